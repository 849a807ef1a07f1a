#include "planar_lowering.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <sstream>
#include <stdexcept>

#include <Eigen/Dense>

#include "emitted_text.hpp"
#include "numeric_outputs.hpp"
#include "program_algebra.hpp"
#include "planar_chain.hpp"

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
class FunctionBuilder {
 public:
  FunctionBuilder(const SymbolicModel& model, bool omega_basis)
      : m_(model), omega_basis_(omega_basis) {
    const int n = m_.n();
    const int N = m_.scene.num_links();
    const bool free = m_.scene.free_floating();
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

  // Makes `symbol` a variable whose value is an existing node (the solved qdd of a
  // composed output, which the state Jacobian's expressions then use).
  void bind(const ex& symbol, SRef node) {
    add_var(symbol, [node] { return node; });
  }

  SRef build(const ex& e) {
    ex x = function_atoms(e);
    x = x.subs(atom_subs_, GiNaC::subs_options::no_pattern);
    if (omega_basis_) x = x.subs(basis_subs_, GiNaC::subs_options::no_pattern);
    x = x.expand();
    return horner(terms_of(x));
  }

 private:
  const SymbolicModel& m_;
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
class PlainBuilder {
 public:
  explicit PlainBuilder(const SymbolicModel& model) {
    for (int i = 0; i < model.n(); ++i) {
      inputs_[model.q[i]] = {"q", i};
      inputs_[model.qd[i]] = {"qd", i};
    }
    for (size_t i = 0; i < model.parameters.size(); ++i)
      inputs_[model.parameters[i]] = {"params", static_cast<int>(i)};
  }
  Program prog{false};

  SRef build(const ex& e) {
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

// A fixed pseudo-random state and the nominal parameters, where lowering checks itself.
struct CheckPoint {
  std::vector<double> q, qd, params;
  explicit CheckPoint(const SymbolicModel& model) {
    for (int i = 0; i < model.n(); ++i) {
      q.push_back(0.3 + 0.7 * std::sin(1.3 * i + 0.4));
      qd.push_back(0.5 - 0.9 * std::cos(0.7 * i + 1.1));
    }
    for (const auto& p : model.scene.parameters) params.push_back(p.nominal.value);
  }
  // Entry `index` of an input array; the composed outputs' other inputs (qdd, Q, qdd_joints)
  // get fixed values of their own.
  double input(const std::string& array, int index) const {
    if (array == "q") return q.at(index);
    if (array == "qd") return qd.at(index);
    if (array == "params") return params.at(index);
    return 0.2 + 0.3 * std::cos(1.7 * index + array.size());
  }
};

// The smallest and largest non-zero magnitudes among the scene's masses, inertias, lengths,
// gear ratios, motor inertias and stiffnesses (nominal values), by field; empty when they span
// less than six decades. Double precision cannot hold a model whose numbers span too far.
std::string value_span(const Scene& scene) {
  std::vector<std::pair<std::string, double>> values;
  auto add = [&](const std::string& field, const Quantity& q) {
    if (q.value != 0) values.push_back({field, std::abs(q.value)});
  };
  if (scene.free_floating())
    add("base.mass", scene.base.mass), add("base.inertia", scene.base.inertia);
  for (int i = 0; i < scene.num_links(); ++i) {
    const std::string l = "links[" + std::to_string(i) + "]",
                      g = "gears[" + std::to_string(i) + "]";
    add(l + ".mass", scene.links[i].mass);
    add(l + ".inertia", scene.links[i].inertia);
    add(l + ".length", scene.links[i].length);
    if (!scene.has_gear(i)) continue;
    add(g + ".ratio", scene.gears[i]->ratio);
    add(g + ".motor_inertia", scene.gears[i]->motor_inertia);
    if (scene.gears[i]->stiffness) add(g + ".stiffness", *scene.gears[i]->stiffness);
  }
  if (values.empty()) return "";
  const auto [lo, hi] =
      std::minmax_element(values.begin(), values.end(),
                          [](const auto& a, const auto& b) { return a.second < b.second; });
  if (hi->second / lo->second < 1e6) return "";
  char text[200];
  std::snprintf(text, sizeof text, "%.0f decades, from %s = %g to %s = %g",
                std::floor(std::log10(hi->second / lo->second)), lo->first.c_str(), lo->second,
                hi->first.c_str(), hi->second);
  return text;
}

// The generator checks itself before it emits: the optimized straight-line program must
// reproduce, at the check point, the values computed from the derivation alone (want: per
// result, its entries row by row), else it names the entry that fails.
void self_check(const SymbolicModel& model, const FunctionSpec& f,
                const std::vector<std::vector<double>>& want) {
  const CheckPoint at(model);
  for (size_t k = 0; k < f.results.size(); ++k) {
    const auto got = f.program.evaluate(
        f.entries[k], [&](const std::string& a, int i) { return at.input(a, i); });
    if (got.size() != want[k].size())
      throw std::logic_error("self-check: " + f.name + " has a wrong entry count");
    double scale = 1e-300;
    for (double w : want[k]) {
      // Not a generator bug but a scene whose numbers make the model degenerate in double.
      if (!std::isfinite(w)) {
        const std::string span = value_span(model.scene);
        throw std::runtime_error(
            "scene '" + model.scene.name + "': " + f.name +
            " is not finite at the generator's check point (nominal parameters): the masses, "
            "inertias or lengths make the model numerically degenerate" +
            (span.empty() ? "" : " (its values span " + span + ")"));
      }
      scale = std::max(scale, std::abs(w));
    }
    for (size_t i = 0; i < want[k].size(); ++i) {
      if (std::abs(got[i] - want[k][i]) <= 1e-9 * scale) continue;
      char values[120];
      std::snprintf(values, sizeof values, "%.17g emitted vs %.17g derived", got[i], want[k][i]);
      const std::string where =
          f.name + ", " + f.results[k].name + " entry " + std::to_string(i) + ": " + values;
      // Numbers too far apart for double are the scene's, named by field; else a generator bug.
      if (const std::string span = value_span(model.scene); !span.empty())
        throw std::runtime_error(
            "scene '" + model.scene.name +
            "': double precision cannot hold this model at its nominal values (" + where +
            "): its values span " + span +
            "; choose units or nominal values that bring them closer");
      throw std::logic_error("generator self-check failed in " + where);
    }
  }
}

// What lowering minimizes: arithmetic operations plus calls of sin/cos, tanh and exp.
int cost(const FunctionSpec& f) {
  const OpCounts ops = f.program.count(f.roots());
  return ops.total_arithmetic() + ops.trig + ops.functions;
}

// Lowers f in each velocity basis (both when it uses velocities): `build` makes the entries
// in the builder's program; CSE, the self-check against `want`, and the cheaper one is kept.
FunctionSpec cheapest_lowering(
    const SymbolicModel& model, const FunctionSpec& f,
    const std::function<std::vector<std::vector<SRef>>(FunctionBuilder&)>& build,
    const std::vector<std::vector<double>>& want) {
  const bool uses_velocity = std::any_of(f.inputs.begin(), f.inputs.end(), [](const ArraySpec& a) {
    return a.name == info(Input::qd).name;
  });
  FunctionSpec best;
  int best_cost = -1;
  for (int basis = 0; basis < (uses_velocity ? 2 : 1); ++basis) {
    FunctionBuilder fb(model, basis == 1);
    FunctionSpec candidate = f;
    candidate.entries = build(fb);
    fb.prog.extract_common_pairs(candidate.roots());
    candidate.program = std::move(fb.prog);
    self_check(model, candidate, want);
    const int candidate_cost = cost(candidate);
    if (best_cost >= 0 && candidate_cost >= best_cost) continue;
    candidate.variant = uses_velocity ? (basis == 1 ? "omega" : "qd") : "";
    best = std::move(candidate);
    best_cost = candidate_cost;
  }
  return best;
}

// The arrays of an output as the registry gives them.
void describe(FunctionSpec& f, const OutputInfo& o) {
  f.name = o.name;
  f.doc = o.doc;
  f.equation = o.equation;
  for (Input i : o.inputs) f.inputs.push_back({info(i).name, info(i).size, Size::one});
  for (const auto& r : o.results) f.results.push_back({r.name, r.rows, r.cols, r.symmetric});
}

// A function whose results are closed-form expressions (row by row per result): lowered
// with both velocity bases when it uses velocities, keeping the cheaper program.
FunctionSpec lower_closed_form(const SymbolicModel& model, FunctionSpec f,
                               const std::vector<std::vector<ex>>& results, bool plain) {
  if (plain) {
    PlainBuilder pb(model);
    for (const auto& r : results) {
      f.entries.emplace_back();
      for (const ex& e : r) f.entries.back().push_back(pb.build(e.expand()));
    }
    f.program = std::move(pb.prog);
    f.plain = true;
    f.formulation = "closed form";
    return f;
  }
  const CheckPoint at(model);
  std::vector<std::vector<double>> want;
  for (const auto& r : results) {
    auto& w = want.emplace_back();
    for (const ex& e : r) w.push_back(evaluate(model, e, at.q, at.qd, at.params));
  }
  auto build = [&](FunctionBuilder& fb) {
    std::vector<std::vector<SRef>> entries;
    for (size_t k = 0; k < results.size(); ++k) {
      auto& out = entries.emplace_back();
      const int cols = model.scene.dimensions()(f.results[k].cols);
      for (size_t e = 0; e < results[k].size(); ++e) {
        // A symmetric result's lower triangle repeats its upper one (built once).
        const int i = static_cast<int>(e) / cols, j = static_cast<int>(e) % cols;
        out.push_back(f.results[k].symmetric && j < i ? out[j * cols + i]
                                                      : fb.build(results[k][e]));
      }
    }
    return entries;
  };
  FunctionSpec lowered = cheapest_lowering(model, f, build, want);
  lowered.formulation = "closed form";
  return lowered;
}

std::vector<ex> entries_of(const GiNaC::matrix& m) {
  std::vector<ex> v;
  for (unsigned i = 0; i < m.rows(); ++i)
    for (unsigned j = 0; j < m.cols(); ++j) v.push_back(m(i, j));
  return v;
}

// The composed output's values at the check point, from the derivation alone.
std::vector<Eigen::MatrixXd> composed_reference(const SymbolicModel& model, Output o,
                                                const CheckPoint& at) {
  std::vector<Eigen::VectorXd> inputs;
  for (Input i : info(o).inputs) {
    Eigen::VectorXd v(model.scene.dimensions()(info(i).size));
    for (int k = 0; k < v.size(); ++k) v[k] = at.input(info(i).name, k);
    inputs.push_back(v);
  }
  const Eigen::VectorXd params =
      Eigen::Map<const Eigen::VectorXd>(at.params.data(), at.params.size());
  return evaluate_output(model, o, inputs, params);
}

// The closed forms of M and b in a builder's program, and the block and row views the
// compositions below take of them (row-major vectors of node references).
struct Composer {
  const SymbolicModel& model;
  FunctionBuilder& fb;
  Program& p = fb.prog;
  const int n = model.n(), N = model.scene.num_links(), nb = n - N;
  std::vector<SRef> M;

  Composer(const SymbolicModel& m, FunctionBuilder& builder) : model(m), fb(builder), M(n * n) {
    if (!model.outputs.count(Output::mass_matrix)) {  // derived only recursively
      M = record_recursive(model.scene, Output::mass_matrix, p)[0];
      return;
    }
    const GiNaC::matrix& Me = model.expression(Output::mass_matrix);
    for (int i = 0; i < n; ++i)
      for (int j = i; j < n; ++j) M[i * n + j] = M[j * n + i] = fb.build(Me(i, j));
  }
  std::vector<SRef> block(int r0, int c0, int rows, int cols) const {
    std::vector<SRef> m;
    for (int i = 0; i < rows; ++i)
      for (int j = 0; j < cols; ++j) m.push_back(M[(r0 + i) * n + c0 + j]);
    return m;
  }
  static std::vector<SRef> row(const std::vector<SRef>& m, int cols, int i) {
    return std::vector<SRef>(m.begin() + i * cols, m.begin() + (i + 1) * cols);
  }
  std::vector<SRef> inputs(const char* name, int size) {
    std::vector<SRef> v;
    for (int i = 0; i < size; ++i) v.push_back(p.input(name, i));
    return v;
  }
  std::vector<SRef> bias() {
    if (!model.outputs.count(Output::bias_forces))
      return record_recursive(model.scene, Output::bias_forces, p)[0];
    std::vector<SRef> b;
    for (int i = 0; i < n; ++i) b.push_back(fb.build(model.expression(Output::bias_forces)(i, 0)));
    return b;
  }
  // Everything on the left of M qdd + ... = Q besides M qdd: the bias, and the spring, damper
  // and friction forces where the scene has them.
  std::vector<SRef> forces() {
    std::vector<SRef> h = bias();
    if (model.has_passive_forces())
      for (int i = 0; i < n; ++i) h[i] = p.add({h[i], fb.build(model.passive_forces(i, 0))});
    return h;
  }
  SRef gear_ratio(int j) { return fb.build((1 / model.gear_map(nb + j, nb + j)).normal()); }

  // J* = J_m - J_b X with M_bb X = M_bm, column by column.
  std::vector<std::vector<SRef>> generalized_jacobian() {
    const GiNaC::matrix& Je = model.expression(Output::end_effector_jacobian);
    const LdltProgram f = ldlt(p, block(0, 0, nb, nb), nb);
    const std::vector<SRef> Mbm = block(0, nb, nb, N);
    std::vector<std::vector<SRef>> X;  // columns
    for (int c = 0; c < N; ++c) {
      std::vector<SRef> col;
      for (int k = 0; k < nb; ++k) col.push_back(Mbm[k * N + c]);
      X.push_back(ldlt_solve(p, f, col));
    }
    std::vector<SRef> Jg;
    for (int r = 0; r < 3; ++r) {
      std::vector<SRef> Jb;
      for (int k = 0; k < nb; ++k) Jb.push_back(fb.build(Je(r, k)));
      for (int c = 0; c < N; ++c) Jg.push_back(p.add({fb.build(Je(r, nb + c)), -dot(p, Jb, X[c])}));
    }
    return {Jg};
  }

  // Q = M qdd + b (+ spring, damper and friction forces).
  std::vector<std::vector<SRef>> inverse_dynamics() {
    const std::vector<SRef> qdd = inputs("qdd", n), b = forces();
    std::vector<SRef> Q;
    for (int i = 0; i < n; ++i) Q.push_back(p.add({dot(p, row(M, n, i), qdd), b[i]}));
    return {Q};
  }

  // The right-hand side Q - b (- spring, damper, friction) of M qdd = ..., and M = L D L^T.
  LdltProgram factored(std::vector<SRef>& rhs) {
    const std::vector<SRef> Q = inputs("Q", n), b = forces();
    for (int i = 0; i < n; ++i) rhs.push_back(p.add({Q[i], -b[i]}));
    return ldlt(p, M, n);
  }

  // qdd = M^-1 (Q - b (- spring, damper, friction)), the pivots D and D_i / M_ii.
  std::vector<std::vector<SRef>> forward_dynamics() {
    std::vector<SRef> rhs, scaled;
    const LdltProgram f = factored(rhs);
    for (int i = 0; i < n; ++i) scaled.push_back(p.div(f.d[i], M[i * n + i]));
    return {ldlt_solve(p, f, rhs), f.d, scaled};
  }

  // qdd as forward_dynamics; then each column of dqdd/dq and dqdd/dqd by the same LDL^T
  // factors: M dqdd/dx_k = -dR/dx_k, with R's qdd symbols bound to the solved qdd.
  std::vector<std::vector<SRef>> forward_dynamics_derivatives() {
    std::vector<SRef> rhs;
    const LdltProgram f = factored(rhs);
    const std::vector<SRef> qdd = ldlt_solve(p, f, rhs);
    for (int j = 0; j < n; ++j) fb.bind(model.qdd[j], qdd[j]);
    auto jacobian = [&](const GiNaC::matrix& dR) {
      std::vector<SRef> J(n * n);
      for (int k = 0; k < n; ++k) {
        std::vector<SRef> minus_col;
        for (int i = 0; i < n; ++i) minus_col.push_back(fb.build(-dR(i, k)));
        const std::vector<SRef> col = ldlt_solve(p, f, minus_col);
        for (int i = 0; i < n; ++i) J[i * n + k] = col[i];
      }
      return J;
    };
    return {jacobian(model.residual_dq), jacobian(model.residual_dqd), qdd};
  }

  // M_bb a_b = -(M_bm a + b_b); Q_m = M_mb a_b + M_mm a + b_m, with a the joint rows of qdd
  // (motor accelerations p qdd_joints) and tau = p Q_m.
  std::vector<std::vector<SRef>> free_base_inverse_dynamics() {
    const std::vector<SRef> b = bias();
    std::vector<SRef> ratio, a;
    for (int j = 0; j < N; ++j) ratio.push_back(gear_ratio(j));
    for (int j = 0; j < N; ++j) a.push_back(p.mul({p.input("qdd_joints", j), ratio[j]}));
    const std::vector<SRef> Mbm = block(0, nb, nb, N), Mmb = block(nb, 0, N, nb),
                            Mmm = block(nb, nb, N, N);
    std::vector<SRef> rhs;
    for (int k = 0; k < nb; ++k) rhs.push_back(-p.add({dot(p, row(Mbm, N, k), a), b[k]}));
    const std::vector<SRef> base = ldlt_solve(p, ldlt(p, block(0, 0, nb, nb), nb), rhs);
    std::vector<SRef> tau;
    for (int j = 0; j < N; ++j) {
      const SRef Qj = p.add({dot(p, row(Mmb, nb, j), base), dot(p, row(Mmm, N, j), a), b[nb + j]});
      tau.push_back(p.mul({Qj, ratio[j]}));
    }
    return {tau, base};
  }
};

// Builds one composed output in fb's program from M, b and J.
std::vector<std::vector<SRef>> compose(const SymbolicModel& model, FunctionBuilder& fb, Output o) {
  Composer c(model, fb);
  switch (o) {
    case Output::generalized_jacobian:
      return c.generalized_jacobian();
    case Output::inverse_dynamics:
      return c.inverse_dynamics();
    case Output::forward_dynamics:
      return c.forward_dynamics();
    case Output::free_base_inverse_dynamics:
      return c.free_base_inverse_dynamics();
    case Output::forward_dynamics_derivatives:
      return c.forward_dynamics_derivatives();
    default:
      throw std::logic_error("compose: " + to_string(o) + " is not a composed output");
  }
}

// A composed output, checked against Eigen's solves of GiNaC's values.
FunctionSpec lower_composed(const SymbolicModel& model, const FunctionSpec& f, Output o) {
  std::vector<std::vector<double>> want;
  for (const Eigen::MatrixXd& m : composed_reference(model, o, CheckPoint(model))) {
    const Eigen::MatrixXd rows = m.transpose();  // entries row by row
    want.emplace_back(rows.data(), rows.data() + rows.size());
  }
  FunctionSpec composed = cheapest_lowering(
      model, f, [&](FunctionBuilder& fb) { return compose(model, fb, o); }, want);
  composed.formulation =
      model.outputs.count(Output::mass_matrix) ? "closed form" : "recursive (CRBA, RNEA)";
  return composed;
}

// A function whose results come from the recursive algorithms (planar_chain.hpp), recorded
// in one program and checked against the same algorithms run in double.
FunctionSpec lower_recursive(const SymbolicModel& model, FunctionSpec f,
                             const std::vector<Output>& parts) {
  const CheckPoint at(model);
  auto input = [&](const std::string& a, int i) { return at.input(a, i); };
  std::vector<std::vector<double>> want;
  std::string algorithms;
  for (Output o : parts) {
    for (auto& r : record_recursive(model.scene, o, f.program)) f.entries.push_back(std::move(r));
    for (auto& w : evaluate_recursive(model.scene, o, input)) want.push_back(std::move(w));
    algorithms += (algorithms.empty() ? "" : " + ") + std::string(recursive_algorithm(o));
  }
  f.program.extract_common_pairs(f.roots());
  self_check(model, f, want);
  f.formulation = "recursive (" + algorithms + ")";
  return f;
}

// The scene's range checks for quantities that depend on run-time parameters (positive
// mass, inertia, length, ratio and stiffness, non-negative motor inertia, damping and friction,
// positive compensated link inertia): the validation the scene parser does for literals,
// repeated at run time.
class ParameterChecks {
 public:
  ParameterChecks(const Scene& scene, ModelFacts& facts) : facts_(facts), p_(facts.checks_program) {
    for (size_t i = 0; i < scene.parameters.size(); ++i)
      index_[scene.parameters[i].name] = static_cast<int>(i);
    if (scene.free_floating()) {
      check(scene.base.mass, true, "base.mass must be positive");
      check(scene.base.inertia, true, "base.inertia must be positive");
    }
    for (int i = 0; i < scene.num_links(); ++i) {
      const Link& l = scene.links[i];
      const std::string f = "links[" + std::to_string(i) + "]";
      check(l.mass, true, f + ".mass must be positive");
      check(l.inertia, true, f + ".inertia must be positive");
      check(l.length, true, f + ".length must be positive");
      if (scene.has_gear(i)) gear(*scene.gears[i], l, i);
      if (scene.has_friction() && scene.friction[i]) friction(*scene.friction[i], i);
    }
  }

 private:
  ModelFacts& facts_;
  Program& p_;
  std::map<std::string, int> index_;

  SRef value(const Quantity& q) {
    if (q.is_parameter()) return p_.input("params", index_.at(q.parameter));
    return q.value == 0 ? p_.zero() : p_.constant(q.value);
  }
  void check(bool uses_parameter, SRef v, bool strict, const std::string& what) {
    if (uses_parameter) facts_.checks.push_back({v, strict, what});
  }
  void check(const Quantity& q, bool strict, const std::string& what) {
    check(q.is_parameter(), value(q), strict, what);
  }

  void gear(const Gear& g, const Link& l, int i) {
    const std::string gf = "gears[" + std::to_string(i) + "]";
    check(g.ratio, true, gf + ".ratio must be positive");
    check(g.motor_inertia, g.flexible(),
          gf + (g.flexible() ? ".motor_inertia must be positive (a flexible joint)"
                             : ".motor_inertia must not be negative"));
    if (g.compensate_link_inertia)
      check(g.motor_inertia.is_parameter() || l.inertia.is_parameter(),
            p_.add({value(l.inertia), -value(g.motor_inertia)}), true,
            gf + ".motor_inertia must be smaller than the inertia of link " +
                std::to_string(i + 1) + " it compensates");
    if (g.stiffness) check(*g.stiffness, true, gf + ".stiffness must be positive");
    if (g.coupling) {
      check(*g.coupling, false, gf + ".rotor_coupling must be in [0, 1] (not negative)");
      check(g.coupling->is_parameter(), p_.add({p_.constant(1), -value(*g.coupling)}), false,
            gf + ".rotor_coupling must be in [0, 1] (not above 1)");
    }
    if (g.damping) check(*g.damping, false, gf + ".damping must not be negative");
  }

  void friction(const Friction& f, int i) {
    const std::string ff = "friction[" + std::to_string(i) + "]";
    check(f.viscous, false, ff + ".viscous must not be negative");
    check(f.coulomb, false, ff + ".coulomb must not be negative");
    auto at_least = [&](const Quantity& q, const std::string& what) {
      check(q.is_parameter(), p_.add({value(q), p_.constant(-kMinFrictionVelocity)}), false, what);
    };
    if (f.has_coulomb)
      at_least(f.velocity_scale, ff + ".velocity_scale must be at least 1e-9 rad/s");
    if (!f.has_stribeck) return;
    at_least(f.stribeck_velocity, ff + ".stribeck_velocity must be at least 1e-9 rad/s");
    check(f.stribeck_static.is_parameter() || f.coulomb.is_parameter(),
          p_.add({value(f.stribeck_static), -value(f.coulomb)}), false,
          ff + ".stribeck_static must not be below coulomb");
  }
};

ModelFacts model_facts(const SymbolicModel& model, bool plain) {
  const Scene& scene = model.scene;
  ModelFacts facts;
  facts.name = scene.name + (plain ? "_plain" : "");
  facts.description = scene.description;
  facts.coordinates_note =
      scene.num_flexible() ? " (q: link angles; qm: motor angles, qm = p q for a rigid gear, paper "
                             "eq. 12; a flexible joint's qm follows the joint slots)"
      : scene.geared()     ? " (motor angles qm = p q, paper eq. 12)"
                           : "";
  facts.features = scene.features();
  if (scene.num_flexible())
    for (int j = 0; j < scene.num_links(); ++j)
      facts.actuated_coordinates.push_back(scene.motor_coordinate(j));
  facts.dims = model.scene.dimensions();
  facts.free_floating = scene.free_floating();
  facts.geared = scene.geared();
  facts.coordinate_names = scene.coordinate_names();
  for (const auto& p : scene.parameters) {
    facts.parameter_names.push_back(p.name);
    facts.nominal_parameters.push_back(p.nominal.value);
  }
  facts.scene_hash = "fnv1a64:" + content_hash(scene.content);
  facts.formulation = to_string(scene.formulation);
  for (const auto& o : output_registry())
    if (scene.wants(o.id) && !(plain && !o.composed_of.empty())) facts.outputs.push_back(o.id);
  ParameterChecks{scene, facts};
  return facts;
}

// Whether `parts` (outputs, or what a composed one is made of) were all derived in closed form.
bool has_closed_forms(const SymbolicModel& model, const std::vector<Output>& parts) {
  return std::all_of(parts.begin(), parts.end(),
                     [&](Output o) { return model.outputs.count(o) != 0; });
}

// One function of the outputs `parts` (one output, or M and b together): its closed form where
// it was derived, its recursive form where the scene tries it, the cheaper of the two.
FunctionSpec lower_function(const SymbolicModel& model, const FunctionSpec& f,
                            const std::vector<Output>& parts, bool plain) {
  const Scene& scene = model.scene;
  const bool recursive =
      !plain && scene.tries_recursive() &&
      std::all_of(parts.begin(), parts.end(), [](Output o) { return has_recursive_form(o); });
  const OutputInfo& first = info(parts[0]);
  std::vector<FunctionSpec> candidates;
  if (!first.composed_of.empty()) {
    // Composed of M and b: from their closed forms, or from their recursive ones when only
    // those were derived (no candidate of its own where a recursive algorithm covers it).
    if (has_closed_forms(model, first.composed_of) || !recursive)
      candidates.push_back(lower_composed(model, f, parts[0]));
  } else if (has_closed_forms(model, parts)) {
    std::vector<std::vector<ex>> results;
    for (Output o : parts) results.push_back(entries_of(model.expression(o)));
    candidates.push_back(lower_closed_form(model, f, results, plain));
  }
  if (recursive) candidates.push_back(lower_recursive(model, f, parts));
  if (candidates.empty()) throw std::logic_error("lowering: no formulation derived for " + f.name);
  auto cheaper = [](const FunctionSpec& a, const FunctionSpec& b) { return cost(a) < cost(b); };
  return std::move(*std::min_element(candidates.begin(), candidates.end(), cheaper));
}

}  // namespace

LoweredModel lower(const SymbolicModel& model, const LowerOptions& options) {
  const Scene& scene = model.scene;
  LoweredModel lowered;
  lowered.facts = model_facts(model, options.plain);
  for (const OutputInfo& o : output_registry()) {
    if (!scene.wants(o.id)) continue;
    FunctionSpec f;
    describe(f, o);
    if (!o.composed_of.empty() && options.plain) continue;  // the baseline has closed forms only
    lowered.functions.push_back(lower_function(model, f, {o.id}, options.plain));
    // M and b together, sharing the sin/cos and common terms (what forward dynamics needs).
    if (o.id == Output::bias_forces && scene.wants(Output::mass_matrix)) {
      FunctionSpec mb;
      mb.name = "mass_matrix_and_bias";
      mb.doc = "M and b together, sharing the sin/cos and common terms.";
      mb.inputs = {{"q", Size::nq, Size::one}, {"qd", Size::nv, Size::one}};
      mb.results = {{"M", Size::nv, Size::nv, true}, {"b", Size::nv, Size::one, false}};
      lowered.functions.push_back(
          lower_function(model, mb, {Output::mass_matrix, Output::bias_forces}, options.plain));
    }
  }
  // Always emitted: the runtime maps joint torques to generalized forces tau / p (eq. 14).
  FunctionSpec ratios;
  ratios.name = "gear_ratios";
  ratios.doc = "Gear ratio p_i of each joint (1 for the reference model): Q_g = tau / p.";
  ratios.equation = "14";
  ratios.results = {{"p", Size::num_links, Size::one, false}};
  lowered.functions.push_back(lower_closed_form(model, ratios, {model.ratios}, options.plain));
  return lowered;
}

}  // namespace spacearm
