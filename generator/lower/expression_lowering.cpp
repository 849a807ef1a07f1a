#include "expression_lowering.hpp"

#include <algorithm>
#include <functional>
#include <map>
#include <sstream>
#include <stdexcept>

namespace spacearm {

using GiNaC::ex;
using GiNaC::ex_to;
using GiNaC::is_a;

namespace {

// A text key of an expression that does not depend on GiNaC's internal operand order
// (which follows type-info addresses and so can change between runs): operands of sums
// and products are sorted by their own keys. Used to build nodes in a reproducible order.
std::string canonical_key(const ex& e) {
  std::ostringstream s;
  if (is_a<GiNaC::symbol>(e) || is_a<GiNaC::numeric>(e)) {
    s << e;
    return s.str();
  }
  std::vector<std::string> parts;
  for (size_t i = 0; i < e.nops(); ++i) parts.push_back(canonical_key(e.op(i)));
  const bool commutative = is_a<GiNaC::add>(e) || is_a<GiNaC::mul>(e);
  if (commutative) std::sort(parts.begin(), parts.end());
  std::string name = is_a<GiNaC::add>(e)        ? "+"
                     : is_a<GiNaC::mul>(e)      ? "*"
                     : is_a<GiNaC::power>(e)    ? "^"
                     : is_a<GiNaC::function>(e) ? ex_to<GiNaC::function>(e).get_name()
                                                : "?";
  s << name << "(";
  for (const auto& p : parts) s << p << ",";
  s << ")";
  return s.str();
}

// Operands of a sum or product in canonical order.
std::vector<ex> sorted_operands(const ex& e) {
  std::vector<std::pair<std::string, ex>> keyed;
  for (size_t i = 0; i < e.nops(); ++i) keyed.push_back({canonical_key(e.op(i)), e.op(i)});
  std::stable_sort(keyed.begin(), keyed.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<ex> ops;
  for (auto& k : keyed) ops.push_back(k.second);
  return ops;
}

struct Term {
  ex coeff;                               // numeric or an expression of run-time parameters
  std::vector<std::pair<int, int>> mono;  // (variable, exponent > 0), sorted by variable
};

// Builds the straight-line program of one emitted function. Every quantity the expressions
// use is a "variable" with a lazily built node: velocities (qd, or the absolute body
// rates Omega_k), coordinates, and the trig atoms cos/sin of absolute and relative body
// angles. The relative atoms are formed from the absolute ones with the angle-difference
// identities, so each body angle costs exactly one sin/cos pair.
class FunctionBuilder : public ExpressionBuilder {
 public:
  FunctionBuilder(const ClosedForms& model, const Dimensions& dims, bool free, bool omega_basis)
      : m_(model), omega_basis_(omega_basis) {
    const int n = m_.n();
    const int N = dims.num_links;
    const int first_joint = free ? 3 : 0;
    for (size_t i = 0; i < m_.parameters.size(); ++i)
      param_index_[m_.parameters[i]] = static_cast<int>(i);

    // 1. Velocities.
    if (omega_basis_) {
      if (free) {
        add_var(m_.qd[0], [this] { return prog.input("qd", 0); });
        add_var(m_.qd[1], [this] { return prog.input("qd", 1); });
      }
      for (int k = free ? 0 : 1; k <= N; ++k) {
        GiNaC::symbol w("Omega" + std::to_string(k));
        add_var(w, [this, k] { return omega_node(k); });
        omega_symbols_[k] = w;
      }
      // qd of a joint in terms of body rates: qd_j = (Omega_j - Omega_{j-1}) / gear_map_jj.
      if (free) basis_subs_[m_.qd[2]] = omega_symbols_[0];
      for (int j = 1; j <= N; ++j) {
        const ex prev = (j == 1 && !free) ? ex(0) : ex(omega_symbols_[j - 1]);
        const int c = first_joint + j - 1;
        basis_subs_[m_.qd[c]] = (omega_symbols_[j] - prev) / m_.gear_map(c, c);
      }
      // The motor rates of flexible joints (after the joint slots) are no body's rate.
      for (int i = first_joint + N; i < n; ++i)
        add_var(m_.qd[i], [this, i] { return prog.input("qd", i); });
    } else {
      for (int i = 0; i < n; ++i) add_var(m_.qd[i], [this, i] { return prog.input("qd", i); });
    }
    // 2. Coordinates (only x0, y0 and linear angle sums appear outside trig calls).
    for (int i = 0; i < n; ++i) add_var(m_.q[i], [this, i] { return prog.input("q", i); });
    // 3. Trig atoms, ordered by body.
    std::vector<std::pair<std::pair<int, int>, ex>> angles;
    for (const auto& [arg, pair] : m_.angle_table) angles.push_back({pair, arg});
    std::sort(angles.begin(), angles.end(), [](const auto& a, const auto& b) {
      return std::make_pair(a.first.second, a.first.first) <
             std::make_pair(b.first.second, b.first.first);
    });
    for (const auto& [pair, arg] : angles) {
      if (arg.is_zero()) continue;
      const int from = pair.first, to = pair.second;
      const std::string suffix =
          from < 0 ? std::to_string(to) : std::to_string(from) + "_" + std::to_string(to);
      GiNaC::symbol c("c" + suffix), s("s" + suffix);
      add_var(c, [this, from, to] { return trig_node(true, from, to); });
      add_var(s, [this, from, to] { return trig_node(false, from, to); });
      atom_subs_[GiNaC::cos(arg)] = c;
      atom_subs_[GiNaC::sin(arg)] = s;
    }
  }

  Program prog;
  Program& program() override { return prog; }

  void bind(const ex& symbol, SRef node) override {
    add_var(symbol, [node] { return node; });
  }

  SRef build(const ex& e) override {
    ex x = function_atoms(e);
    x = x.subs(atom_subs_, GiNaC::subs_options::no_pattern);
    if (omega_basis_) x = x.subs(basis_subs_, GiNaC::subs_options::no_pattern);
    x = x.expand();
    return horner(terms_of(x));
  }

 private:
  const ClosedForms& m_;
  bool omega_basis_;
  std::map<ex, int, GiNaC::ex_is_less> var_index_, param_index_;
  std::vector<std::function<SRef()>> var_builders_;
  std::map<int, SRef> var_nodes_, theta_nodes_, omega_nodes_;
  std::map<int, GiNaC::symbol> omega_symbols_;
  GiNaC::exmap atom_subs_, basis_subs_, function_subs_;

  // tanh and exp (smooth friction) become variables whose nodes compute them from their
  // arguments; new ones are registered in canonical order, so that the variables' order (and
  // the Horner scheme's ties) does not follow GiNaC's address-dependent operand order.
  ex function_atoms(const ex& e) {
    std::vector<std::pair<std::string, ex>> found;
    collect_functions(e, found);
    std::sort(found.begin(), found.end(),
              [](const auto& a, const auto& b) { return a.first < b.first; });
    for (const auto& [key, f] : found) {
      if (function_subs_.count(f)) continue;
      const bool is_tanh = ex_to<GiNaC::function>(f).get_name() == "tanh";
      GiNaC::symbol a((is_tanh ? "tanh" : "exp") + std::to_string(function_subs_.size()));
      const ex arg = f.op(0);
      add_var(a, [this, arg, is_tanh] {
        const SRef x = build(arg);
        return is_tanh ? prog.tanh(x) : prog.exp(x);
      });
      function_subs_[f] = a;
    }
    return function_subs_.empty() ? e : e.subs(function_subs_, GiNaC::subs_options::no_pattern);
  }
  static void collect_functions(const ex& e, std::vector<std::pair<std::string, ex>>& found) {
    if (is_a<GiNaC::function>(e)) {
      const std::string name = ex_to<GiNaC::function>(e).get_name();
      if (name == "tanh" || name == "exp") {
        found.push_back({canonical_key(e), e});
        return;
      }
    }
    for (size_t i = 0; i < e.nops(); ++i) collect_functions(e.op(i), found);
  }

  void add_var(const ex& symbol, std::function<SRef()> builder) {
    var_index_[symbol] = static_cast<int>(var_builders_.size());
    var_builders_.push_back(std::move(builder));
  }

  SRef var(int v) {
    auto it = var_nodes_.find(v);
    if (it != var_nodes_.end()) return it->second;
    const auto builder = var_builders_[v];  // a copy: building may register more variables
    const SRef r = builder();
    var_nodes_[v] = r;
    return r;
  }

  // theta_k as partial sums: theta_k = theta_{k-1} + (relative angle of joint k).
  SRef theta_node(int k) {
    if (theta_nodes_.count(k)) return theta_nodes_[k];
    SRef r = k == 0
                 ? from_ex(m_.theta[0])
                 : prog.add({theta_node(k - 1), from_ex((m_.theta[k] - m_.theta[k - 1]).expand())});
    return theta_nodes_[k] = r;
  }

  SRef omega_node(int k) {
    if (omega_nodes_.count(k)) return omega_nodes_[k];
    SRef r = k == 0
                 ? from_ex(m_.omega[0])
                 : prog.add({omega_node(k - 1), from_ex((m_.omega[k] - m_.omega[k - 1]).expand())});
    return omega_nodes_[k] = r;
  }

  SRef trig_node(bool is_cos, int from, int to) {
    if (from < 0) {
      const SRef th = theta_node(to);
      return is_cos ? prog.cos(th) : prog.sin(th);
    }
    const SRef ca = trig_node(true, -1, from), sa = trig_node(false, -1, from);
    const SRef cb = trig_node(true, -1, to), sb = trig_node(false, -1, to);
    // cos(b - a) = cb ca + sb sa,  sin(b - a) = sb ca - cb sa
    if (is_cos) return prog.add({prog.mul({cb, ca}), prog.mul({sb, sa})});
    return prog.add({prog.mul({sb, ca}), -prog.mul({cb, sa})});
  }

  bool is_var(const ex& e) const { return var_index_.count(e) != 0; }

  // Any expression of parameters, numbers and variables, without factoring.
  SRef from_ex(const ex& e) {
    if (is_a<GiNaC::numeric>(e)) {
      const double v = ex_to<GiNaC::numeric>(e).to_double();
      return v == 0 ? prog.zero() : prog.constant(v);
    }
    if (is_var(e)) return var(var_index_.at(e));
    if (param_index_.count(e)) return prog.input("params", param_index_.at(e));
    for (int i = 0; i < m_.n(); ++i)  // velocities, where Omega is the basis (in Omega_k itself)
      if (e.is_equal(m_.qd[i])) return prog.input("qd", i);
    if (is_a<GiNaC::add>(e)) {
      std::vector<SRef> terms;
      for (const ex& op : sorted_operands(e)) terms.push_back(from_ex(op));
      return prog.add(terms);
    }
    if (is_a<GiNaC::mul>(e)) {
      std::vector<SRef> factors;
      for (const ex& op : sorted_operands(e)) factors.push_back(from_ex(op));
      return prog.mul(factors);
    }
    if (is_a<GiNaC::power>(e) && is_a<GiNaC::numeric>(e.op(1)) &&
        ex_to<GiNaC::numeric>(e.op(1)).is_integer()) {
      const int k = ex_to<GiNaC::numeric>(e.op(1)).to_int();
      if (k < 0) return prog.div(prog.constant(1.0), from_ex(GiNaC::pow(e.op(0), -k)));
      return integer_power(from_ex(e.op(0)), k);
    }
    std::ostringstream s;
    s << e;
    throw std::runtime_error("lowering: cannot express '" + s.str() + "' in straight-line code");
  }

  // x^k by repeated squaring: no pow() for integer powers.
  SRef integer_power(SRef x, int k) {
    if (k == 0) return prog.constant(1.0);
    if (k == 1) return x;
    const SRef half = integer_power(x, k / 2);
    SRef r = prog.mul({half, half});
    if (k % 2) r = prog.mul({r, x});
    return r;
  }

  std::vector<Term> terms_of(const ex& e) {
    std::map<std::vector<std::pair<int, int>>, ex> collected;
    auto take = [&](const ex& t) {
      ex coeff = 1;
      std::map<int, int> mono;
      auto factor = [&](const ex& f) {
        if (is_var(f)) {
          mono[var_index_.at(f)] += 1;
        } else if (is_a<GiNaC::power>(f) && is_var(f.op(0)) && is_a<GiNaC::numeric>(f.op(1)) &&
                   ex_to<GiNaC::numeric>(f.op(1)).is_pos_integer()) {
          mono[var_index_.at(f.op(0))] += ex_to<GiNaC::numeric>(f.op(1)).to_int();
        } else if (!has_var(f)) {
          coeff *= f;
        } else {
          std::ostringstream s;
          s << f;
          throw std::runtime_error("lowering: unexpected factor '" + s.str() +
                                   "' (a trig atom not on a body angle?)");
        }
      };
      if (is_a<GiNaC::mul>(t))
        for (size_t i = 0; i < t.nops(); ++i) factor(t.op(i));
      else
        factor(t);
      std::vector<std::pair<int, int>> key(mono.begin(), mono.end());
      collected[key] += coeff;
    };
    if (is_a<GiNaC::add>(e))
      for (size_t i = 0; i < e.nops(); ++i) take(e.op(i));
    else if (!e.is_zero())
      take(e);
    std::vector<Term> terms;
    for (auto& [mono, coeff] : collected)
      if (!coeff.is_zero()) terms.push_back({coeff, mono});
    return terms;
  }

  bool has_var(const ex& e) const {
    if (is_var(e)) return true;
    for (size_t i = 0; i < e.nops(); ++i)
      if (has_var(e.op(i))) return true;
    return false;
  }

  SRef leaf(const Term& t) {
    std::vector<SRef> factors{from_ex(t.coeff)};
    for (const auto& [v, k] : t.mono) factors.push_back(integer_power(var(v), k));
    return prog.mul(factors);
  }

  // Greedy multivariate Horner scheme: factor out the variable that occurs in most terms.
  SRef horner(const std::vector<Term>& terms) {
    if (terms.empty()) return prog.zero();
    std::map<int, int> count;
    for (const auto& t : terms)
      for (const auto& [v, k] : t.mono) ++count[v];
    int best = -1, best_count = 1;
    for (const auto& [v, c] : count)
      if (c > best_count) {
        best = v;
        best_count = c;
      }
    if (best < 0) {
      std::vector<SRef> parts;
      for (const auto& t : terms) parts.push_back(leaf(t));
      return prog.add(parts);
    }
    std::vector<Term> with, without;
    for (const auto& t : terms) {
      auto it = std::find_if(t.mono.begin(), t.mono.end(),
                             [&](const auto& p) { return p.first == best; });
      if (it == t.mono.end()) {
        without.push_back(t);
        continue;
      }
      Term reduced = t;
      auto& entry = reduced.mono[it - t.mono.begin()];
      if (--entry.second == 0) reduced.mono.erase(reduced.mono.begin() + (it - t.mono.begin()));
      with.push_back(reduced);
    }
    return prog.add({prog.mul({var(best), horner(with)}), horner(without)});
  }
};

// The unoptimized baseline: GiNaC's expanded expression node by node, nothing shared, a
// sin/cos call per occurrence and pow for powers (what SymPy's ccode without cse gives).
class PlainBuilder : public ExpressionBuilder {
 public:
  explicit PlainBuilder(const ClosedForms& model) {
    for (int i = 0; i < model.n(); ++i) {
      inputs_[model.q[i]] = {"q", i};
      inputs_[model.qd[i]] = {"qd", i};
    }
    for (size_t i = 0; i < model.parameters.size(); ++i)
      inputs_[model.parameters[i]] = {"params", static_cast<int>(i)};
  }
  Program prog{false};
  Program& program() override { return prog; }
  void bind(const ex&, SRef) override {
    throw std::logic_error("lowering: the baseline binds no variables");
  }

  SRef build(const ex& e) override {
    if (is_a<GiNaC::numeric>(e)) {
      const double v = ex_to<GiNaC::numeric>(e).to_double();
      return v == 0 ? prog.zero() : prog.constant(v);
    }
    if (auto it = inputs_.find(e); it != inputs_.end())
      return prog.input(it->second.first, it->second.second);
    std::vector<SRef> ops;
    if (is_a<GiNaC::add>(e) || is_a<GiNaC::mul>(e)) {
      for (const ex& op : sorted_operands(e)) ops.push_back(build(op));
      return is_a<GiNaC::add>(e) ? prog.add(ops) : prog.mul(ops);
    }
    if (is_a<GiNaC::power>(e) && is_a<GiNaC::numeric>(e.op(1)) &&
        ex_to<GiNaC::numeric>(e.op(1)).is_integer()) {
      const int k = ex_to<GiNaC::numeric>(e.op(1)).to_int();
      const SRef base = build(e.op(0));
      if (k < 0) return prog.div(prog.constant(1.0), k == -1 ? base : prog.pow(base, -k));
      return prog.pow(base, k);
    }
    if (is_a<GiNaC::function>(e) && e.nops() == 1) {
      const std::string name = ex_to<GiNaC::function>(e).get_name();
      if (name == "sin") return prog.sin(build(e.op(0)));
      if (name == "cos") return prog.cos(build(e.op(0)));
      if (name == "tanh") return prog.tanh(build(e.op(0)));
      if (name == "exp") return prog.exp(build(e.op(0)));
    }
    std::ostringstream s;
    s << e;
    throw std::runtime_error("lowering: cannot express '" + s.str() + "' in the baseline");
  }

 private:
  std::map<ex, std::pair<std::string, int>, GiNaC::ex_is_less> inputs_;
};

}  // namespace

std::unique_ptr<ExpressionBuilder> planar_builder(const ClosedForms& forms, const Dimensions& dims,
                                                  bool free_floating, bool omega_basis) {
  return std::make_unique<FunctionBuilder>(forms, dims, free_floating, omega_basis);
}

std::unique_ptr<ExpressionBuilder> plain_builder(const ClosedForms& forms) {
  return std::make_unique<PlainBuilder>(forms);
}

std::vector<ex> entries_of(const GiNaC::matrix& m) {
  std::vector<ex> v;
  for (unsigned i = 0; i < m.rows(); ++i)
    for (unsigned j = 0; j < m.cols(); ++j) v.push_back(m(i, j));
  return v;
}

}  // namespace spacearm
