#include "program_algebra.hpp"

#include <stdexcept>

namespace spacearm {

SRef dot(Program& p, const std::vector<SRef>& a, const std::vector<SRef>& b) {
  if (a.size() != b.size()) throw std::logic_error("dot: sizes differ");
  std::vector<SRef> terms;
  for (size_t k = 0; k < a.size(); ++k) terms.push_back(p.mul({a[k], b[k]}));
  return p.add(terms);
}

// Column by column: W_ij = A_ij - sum_{k<j} W_ik L_jk (W = L D), L_ij = W_ij / D_j,
// D_j = A_jj - sum_{k<j} W_jk L_jk.
LdltProgram ldlt(Program& p, const std::vector<SRef>& a, int n) {
  LdltProgram f;
  f.n = n;
  f.l.assign(n * n, p.zero());
  std::vector<SRef> w(n * n, p.zero());
  auto upper = [&](int i, int j) { return i <= j ? a[i * n + j] : a[j * n + i]; };
  for (int j = 0; j < n; ++j) {
    std::vector<SRef> terms{upper(j, j)};
    for (int k = 0; k < j; ++k) terms.push_back(-p.mul({w[j * n + k], f.l[j * n + k]}));
    f.d.push_back(p.add(terms));
    if (f.d.back().id < 0) throw std::logic_error("ldlt: a pivot is identically zero");
    f.inv_d.push_back(p.div(p.constant(1.0), f.d.back()));
    for (int i = j + 1; i < n; ++i) {
      std::vector<SRef> t{upper(j, i)};
      for (int k = 0; k < j; ++k) t.push_back(-p.mul({w[i * n + k], f.l[j * n + k]}));
      w[i * n + j] = p.add(t);
      f.l[i * n + j] = p.mul({w[i * n + j], f.inv_d[j]});
    }
  }
  return f;
}

// L y = rhs, z = D^-1 y, L^T x = z.
std::vector<SRef> ldlt_solve(Program& p, const LdltProgram& f, const std::vector<SRef>& rhs) {
  const int n = f.n;
  std::vector<SRef> y(n), x(n);
  for (int i = 0; i < n; ++i) {
    std::vector<SRef> t{rhs[i]};
    for (int k = 0; k < i; ++k) t.push_back(-p.mul({f.l[i * n + k], y[k]}));
    y[i] = p.add(t);
  }
  for (int i = n - 1; i >= 0; --i) {
    std::vector<SRef> t{p.mul({y[i], f.inv_d[i]})};
    for (int k = i + 1; k < n; ++k) t.push_back(-p.mul({f.l[k * n + i], x[k]}));
    x[i] = p.add(t);
  }
  return x;
}

}  // namespace spacearm
