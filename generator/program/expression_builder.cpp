#include "expression_builder.hpp"

#include <algorithm>
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

std::string text_of(const ex& e) {
  std::ostringstream s;
  s << e;
  return s.str();
}

void collect_functions(const ex& e, std::vector<std::pair<std::string, ex>>& found) {
  if (is_a<GiNaC::function>(e)) {
    const std::string name = ex_to<GiNaC::function>(e).get_name();
    if (name == "tanh" || name == "exp") {
      found.push_back({canonical_key(e), e});
      return;
    }
  }
  for (size_t i = 0; i < e.nops(); ++i) collect_functions(e.op(i), found);
}

}  // namespace

HornerBuilder::HornerBuilder(InputSymbols inputs) : inputs_(std::move(inputs)) {
  for (size_t i = 0; i < inputs_.parameters.size(); ++i)
    parameter_index_[inputs_.parameters[i]] = static_cast<int>(i);
}

SRef HornerBuilder::build(const ex& e) {
  ex x = function_atoms(e);
  x = x.subs(atom_subs_, GiNaC::subs_options::no_pattern);
  if (!velocity_subs_.empty()) x = x.subs(velocity_subs_, GiNaC::subs_options::no_pattern);
  x = x.expand();
  return horner(terms_of(x));
}

void HornerBuilder::bind(const ex& symbol, SRef node) {
  add_variable(symbol, [node] { return node; });
}

void HornerBuilder::add_variable(const ex& symbol, std::function<SRef()> node) {
  variable_index_[symbol] = static_cast<int>(variable_builders_.size());
  variable_builders_.push_back(std::move(node));
}

void HornerBuilder::substitute_atom(const ex& call, const ex& atom) { atom_subs_[call] = atom; }

void HornerBuilder::substitute_velocity(const ex& qd, const ex& basis) {
  velocity_subs_[qd] = basis;
}

// tanh and exp (smooth friction) become variables whose nodes compute them from their
// arguments; new ones are registered in canonical order, so that the variables' order (and
// the Horner scheme's ties) does not follow GiNaC's address-dependent operand order.
ex HornerBuilder::function_atoms(const ex& e) {
  std::vector<std::pair<std::string, ex>> found;
  collect_functions(e, found);
  std::sort(found.begin(), found.end(),
            [](const auto& a, const auto& b) { return a.first < b.first; });
  for (const auto& [key, f] : found) {
    if (function_subs_.count(f)) continue;
    const bool is_tanh = ex_to<GiNaC::function>(f).get_name() == "tanh";
    GiNaC::symbol a((is_tanh ? "tanh" : "exp") + std::to_string(function_subs_.size()));
    const ex arg = f.op(0);
    add_variable(a, [this, arg, is_tanh] {
      const SRef x = build(arg);
      return is_tanh ? prog_.tanh(x) : prog_.exp(x);
    });
    function_subs_[f] = a;
  }
  return function_subs_.empty() ? e : e.subs(function_subs_, GiNaC::subs_options::no_pattern);
}

SRef HornerBuilder::variable_node(int v) {
  auto it = variable_nodes_.find(v);
  if (it != variable_nodes_.end()) return it->second;
  const auto builder = variable_builders_[v];  // a copy: building may register more variables
  const SRef r = builder();
  variable_nodes_[v] = r;
  return r;
}

bool HornerBuilder::has_variable(const ex& e) const {
  if (is_variable(e)) return true;
  for (size_t i = 0; i < e.nops(); ++i)
    if (has_variable(e.op(i))) return true;
  return false;
}

SRef HornerBuilder::node_of(const ex& e) {
  if (is_a<GiNaC::numeric>(e)) {
    const double v = ex_to<GiNaC::numeric>(e).to_double();
    return v == 0 ? prog_.zero() : prog_.constant(v);
  }
  if (is_variable(e)) return variable_node(variable_index_.at(e));
  if (parameter_index_.count(e)) return prog_.input("params", parameter_index_.at(e));
  for (size_t i = 0; i < inputs_.qd.size(); ++i)  // velocities in another basis (its own nodes)
    if (e.is_equal(inputs_.qd[i])) return prog_.input("qd", static_cast<int>(i));
  if (is_a<GiNaC::add>(e)) {
    std::vector<SRef> terms;
    for (const ex& op : sorted_operands(e)) terms.push_back(node_of(op));
    return prog_.add(terms);
  }
  if (is_a<GiNaC::mul>(e)) {
    std::vector<SRef> factors;
    for (const ex& op : sorted_operands(e)) factors.push_back(node_of(op));
    return prog_.mul(factors);
  }
  if (is_a<GiNaC::power>(e) && is_a<GiNaC::numeric>(e.op(1)) &&
      ex_to<GiNaC::numeric>(e.op(1)).is_integer()) {
    const int k = ex_to<GiNaC::numeric>(e.op(1)).to_int();
    if (k < 0) return prog_.div(prog_.constant(1.0), node_of(GiNaC::pow(e.op(0), -k)));
    return integer_power(node_of(e.op(0)), k);
  }
  throw std::runtime_error("lowering: cannot express '" + text_of(e) + "' in straight-line code");
}

// x^k by repeated squaring: no pow() for integer powers.
SRef HornerBuilder::integer_power(SRef x, int k) {
  if (k == 0) return prog_.constant(1.0);
  if (k == 1) return x;
  const SRef half = integer_power(x, k / 2);
  SRef r = prog_.mul({half, half});
  if (k % 2) r = prog_.mul({r, x});
  return r;
}

// The terms of an expanded expression: each a coefficient (no variables) times a monomial.
std::vector<HornerBuilder::Term> HornerBuilder::terms_of(const ex& e) {
  std::map<std::vector<std::pair<int, int>>, ex> collected;
  auto take = [&](const ex& t) {
    ex coeff = 1;
    std::map<int, int> mono;
    auto factor = [&](const ex& f) {
      if (is_variable(f)) {
        mono[variable_index_.at(f)] += 1;
      } else if (is_a<GiNaC::power>(f) && is_variable(f.op(0)) && is_a<GiNaC::numeric>(f.op(1)) &&
                 ex_to<GiNaC::numeric>(f.op(1)).is_pos_integer()) {
        mono[variable_index_.at(f.op(0))] += ex_to<GiNaC::numeric>(f.op(1)).to_int();
      } else if (!has_variable(f)) {
        coeff *= f;
      } else {
        throw std::runtime_error("lowering: unexpected factor '" + text_of(f) +
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

SRef HornerBuilder::leaf(const Term& t) {
  std::vector<SRef> factors{node_of(t.coeff)};
  for (const auto& [v, k] : t.mono) factors.push_back(integer_power(variable_node(v), k));
  return prog_.mul(factors);
}

// Greedy multivariate Horner scheme: factor out the variable that occurs in most terms.
SRef HornerBuilder::horner(const std::vector<Term>& terms) {
  if (terms.empty()) return prog_.zero();
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
    return prog_.add(parts);
  }
  std::vector<Term> with, without;
  for (const auto& t : terms) {
    auto it =
        std::find_if(t.mono.begin(), t.mono.end(), [&](const auto& p) { return p.first == best; });
    if (it == t.mono.end()) {
      without.push_back(t);
      continue;
    }
    Term reduced = t;
    auto& entry = reduced.mono[it - t.mono.begin()];
    if (--entry.second == 0) reduced.mono.erase(reduced.mono.begin() + (it - t.mono.begin()));
    with.push_back(reduced);
  }
  return prog_.add({prog_.mul({variable_node(best), horner(with)}), horner(without)});
}

namespace {

// The unoptimized baseline: GiNaC's expanded expression node by node, nothing shared, a
// sin/cos call per occurrence and pow for powers (what SymPy's ccode without cse gives).
class PlainBuilder : public ExpressionBuilder {
 public:
  explicit PlainBuilder(const InputSymbols& symbols) {
    for (size_t i = 0; i < symbols.q.size(); ++i) {
      inputs_[symbols.q[i]] = {"q", static_cast<int>(i)};
      inputs_[symbols.qd[i]] = {"qd", static_cast<int>(i)};
    }
    for (size_t i = 0; i < symbols.parameters.size(); ++i)
      inputs_[symbols.parameters[i]] = {"params", static_cast<int>(i)};
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
    throw std::runtime_error("lowering: cannot express '" + text_of(e) + "' in the baseline");
  }

 private:
  std::map<ex, std::pair<std::string, int>, GiNaC::ex_is_less> inputs_;
};

}  // namespace

std::unique_ptr<ExpressionBuilder> plain_builder(const InputSymbols& inputs) {
  return std::make_unique<PlainBuilder>(inputs);
}

}  // namespace spacearm
