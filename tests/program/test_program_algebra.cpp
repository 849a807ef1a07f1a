// generator/program/program_algebra.hpp: the unrolled LDL^T solve that forward dynamics and the
// base-block solves are composed of, tested directly against Eigen's LLT on random symmetric
// positive definite matrices (n = 1 to 9); structural zeros of the matrix add no operation; the
// factors satisfy A = L D L^T.
#include "program_algebra.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <gtest/gtest.h>

#include <random>
#include <string>
#include <vector>

namespace spacearm {
namespace {

// A's entries and b's as program inputs "A" (row-major) and "b"; zero where A's pattern is.
struct SolveProgram {
  Program p;
  std::vector<SRef> a, rhs, x;
  LdltProgram f;
  SolveProgram(int n, const Eigen::MatrixXd& pattern) {
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j)
        a.push_back(pattern(i, j) == 0 ? p.zero() : p.input("A", i * n + j));
    for (int i = 0; i < n; ++i) rhs.push_back(p.input("b", i));
    f = ldlt(p, a, n);
    x = ldlt_solve(p, f, rhs);
  }
  std::vector<double> run(const std::vector<SRef>& roots, const Eigen::MatrixXd& A,
                          const Eigen::VectorXd& b) const {
    const int n = int(b.size());
    return p.evaluate(roots, [&](const std::string& name, int i) {
      return name == "A" ? A(i / n, i % n) : b[i];
    });
  }
};

Eigen::MatrixXd random_spd(int n, std::mt19937& rng, bool banded) {
  std::uniform_real_distribution<double> u(-1, 1);
  Eigen::MatrixXd B(n, n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) B(i, j) = u(rng);
  Eigen::MatrixXd A = B * B.transpose() + n * Eigen::MatrixXd::Identity(n, n);
  if (banded)  // tridiagonal, still positive definite (diagonally dominant)
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j)
        if (std::abs(i - j) > 1) A(i, j) = 0;
  return A;
}

TEST(ProgramAlgebra, TheUnrolledSolveIsEigensSolve) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int n = 1; n <= 9; ++n)
    for (bool banded : {false, true}) {
      SCOPED_TRACE("n = " + std::to_string(n) + (banded ? ", tridiagonal" : ""));
      const Eigen::MatrixXd A = random_spd(n, rng, banded);
      Eigen::VectorXd b(n);
      for (int i = 0; i < n; ++i) b[i] = u(rng);
      const SolveProgram s(n, A);
      const std::vector<double> x = s.run(s.x, A, b);
      const Eigen::VectorXd want = A.llt().solve(b);
      for (int i = 0; i < n; ++i) EXPECT_NEAR(x[size_t(i)], want[i], 1e-12 * want.norm()) << i;
      // The factors: A = L D L^T, L unit lower triangular.
      const std::vector<double> d = s.run(s.f.d, A, b);
      Eigen::MatrixXd L = Eigen::MatrixXd::Identity(n, n);
      for (int i = 0; i < n; ++i)
        for (int j = 0; j < i; ++j)
          if (s.f.l[size_t(i * n + j)].id >= 0)
            L(i, j) = s.run({s.f.l[size_t(i * n + j)]}, A, b)[0];
      const Eigen::MatrixXd D = Eigen::Map<const Eigen::VectorXd>(d.data(), n).asDiagonal();
      EXPECT_LT((L * D * L.transpose() - A).norm(), 1e-12 * A.norm());
    }
}

TEST(ProgramAlgebra, StructuralZerosCostNothing) {
  const int n = 8;
  std::mt19937 rng(5);
  const SolveProgram full(n, random_spd(n, rng, false)), tridiagonal(n, random_spd(n, rng, true));
  const OpCounts f = full.p.count(full.x), t = tridiagonal.p.count(tridiagonal.x);
  // A tridiagonal factor has no fill-in: the solve is linear in n, the full one cubic.
  EXPECT_LT(t.total_arithmetic() * 4, f.total_arithmetic());
  EXPECT_LE(t.muls, 8 * n);
}

}  // namespace
}  // namespace spacearm
