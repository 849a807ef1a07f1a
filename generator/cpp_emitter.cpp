#include "cpp_emitter.hpp"

#include "emitted_text.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
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
  std::string name = is_a<GiNaC::add>(e) ? "+" : is_a<GiNaC::mul>(e) ? "*" : is_a<GiNaC::power>(e) ? "^"
                     : is_a<GiNaC::function>(e) ? ex_to<GiNaC::function>(e).get_name() : "?";
  s << name << "(";
  for (const auto& p : parts) s << p << ",";
  s << ")";
  return s.str();
}

// Operands of a sum or product in canonical order.
std::vector<ex> sorted_operands(const ex& e) {
  std::vector<std::pair<std::string, ex>> keyed;
  for (size_t i = 0; i < e.nops(); ++i) keyed.push_back({canonical_key(e.op(i)), e.op(i)});
  std::stable_sort(keyed.begin(), keyed.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<ex> ops;
  for (auto& k : keyed) ops.push_back(k.second);
  return ops;
}

struct Term {
  ex coeff;                             // numeric or an expression of run-time parameters
  std::vector<std::pair<int, int>> mono;  // (variable, exponent > 0), sorted by variable
};

// Builds the straight-line program of one emitted function. Every quantity the expressions
// use is a "variable" with a lazily built node: velocities (qd, or the absolute body
// rates Omega_k), coordinates, and the trig atoms cos/sin of absolute and relative body
// angles. The relative atoms are formed from the absolute ones with the angle-difference
// identities, so each body angle costs exactly one sin/cos pair.
class FunctionBuilder {
 public:
  FunctionBuilder(const SymbolicModel& model, bool omega_basis) : m_(model), omega_basis_(omega_basis) {
    const int n = m_.n();
    const int N = m_.scene.num_links();
    const bool free = m_.scene.free_floating();
    const int first_joint = free ? 3 : 0;
    for (size_t i = 0; i < m_.parameters.size(); ++i) param_index_[m_.parameters[i]] = static_cast<int>(i);

    // 1. Velocities.
    if (omega_basis_) {
      if (free) {
        add_var(m_.qd[0], [this] { return prog.input("qd(0)"); });
        add_var(m_.qd[1], [this] { return prog.input("qd(1)"); });
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
    } else {
      for (int i = 0; i < n; ++i) add_var(m_.qd[i], [this, i] { return prog.input("qd(" + std::to_string(i) + ")"); });
    }
    // 2. Coordinates (only x0, y0 and linear angle sums appear outside trig calls).
    for (int i = 0; i < n; ++i) add_var(m_.q[i], [this, i] { return prog.input("q(" + std::to_string(i) + ")"); });
    // 3. Trig atoms, ordered by body.
    std::vector<std::pair<std::pair<int, int>, ex>> angles;
    for (const auto& [arg, pair] : m_.angle_table) angles.push_back({pair, arg});
    std::sort(angles.begin(), angles.end(), [](const auto& a, const auto& b) {
      return std::make_pair(a.first.second, a.first.first) < std::make_pair(b.first.second, b.first.first);
    });
    for (const auto& [pair, arg] : angles) {
      if (arg.is_zero()) continue;
      const int from = pair.first, to = pair.second;
      const std::string suffix = from < 0 ? std::to_string(to) : std::to_string(from) + "_" + std::to_string(to);
      GiNaC::symbol c("c" + suffix), s("s" + suffix);
      add_var(c, [this, from, to] { return trig_node(true, from, to); });
      add_var(s, [this, from, to] { return trig_node(false, from, to); });
      atom_subs_[GiNaC::cos(arg)] = c;
      atom_subs_[GiNaC::sin(arg)] = s;
    }
  }

  Program prog;

  SRef build(const ex& e) {
    ex x = e.subs(atom_subs_, GiNaC::subs_options::no_pattern);
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
  GiNaC::exmap atom_subs_, basis_subs_;

  void add_var(const ex& symbol, std::function<SRef()> builder) {
    var_index_[symbol] = static_cast<int>(var_builders_.size());
    var_builders_.push_back(std::move(builder));
  }

  SRef var(int v) {
    auto it = var_nodes_.find(v);
    if (it != var_nodes_.end()) return it->second;
    const SRef r = var_builders_[v]();
    var_nodes_[v] = r;
    return r;
  }

  // theta_k as partial sums: theta_k = theta_{k-1} + (relative angle of joint k).
  SRef theta_node(int k) {
    if (theta_nodes_.count(k)) return theta_nodes_[k];
    SRef r = k == 0 ? from_ex(m_.theta[0])
                    : prog.add({theta_node(k - 1), from_ex((m_.theta[k] - m_.theta[k - 1]).expand())});
    return theta_nodes_[k] = r;
  }

  SRef omega_node(int k) {
    if (omega_nodes_.count(k)) return omega_nodes_[k];
    SRef r = k == 0 ? from_ex(m_.omega[0])
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
    if (param_index_.count(e)) return prog.input("params(" + std::to_string(param_index_.at(e)) + ")");
    for (int i = 0; i < m_.n(); ++i)  // velocities, where Omega is the basis (in Omega_k itself)
      if (e.is_equal(m_.qd[i])) return prog.input("qd(" + std::to_string(i) + ")");
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
    if (is_a<GiNaC::power>(e) && is_a<GiNaC::numeric>(e.op(1)) && ex_to<GiNaC::numeric>(e.op(1)).is_integer()) {
      const int k = ex_to<GiNaC::numeric>(e.op(1)).to_int();
      if (k < 0) return prog.div(prog.constant(1.0), from_ex(GiNaC::pow(e.op(0), -k)));
      return integer_power(from_ex(e.op(0)), k);
    }
    std::ostringstream s;
    s << e;
    throw std::runtime_error("emitter: cannot express '" + s.str() + "' in straight-line code");
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
          throw std::runtime_error("emitter: unexpected factor '" + s.str() + "' (a trig atom not on a body angle?)");
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
      auto it = std::find_if(t.mono.begin(), t.mono.end(), [&](const auto& p) { return p.first == best; });
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

// ---------------------------------------------------------------------------------------
// Printing.

struct Argument {
  std::string type;  // with T as the scalar type
  std::string name;
};

struct FunctionSpec {
  std::string name;
  std::string doc;
  std::string return_type;  // "void" or "T"
  std::vector<Argument> args;
  std::vector<std::pair<std::string, ex>> outputs;  // target ("M(0, 1)" or "return") and expression
  bool uses_velocity = false;
};

class Printer {
 public:
  Printer(const Program& p, const std::vector<SRef>& roots) : p_(p) {
    order_ = p_.schedule(roots);
    for (int id : order_)
      for (const SRef& a : p_.node(id).args)
        if (a.id >= 0) ++uses_[a.id];
    for (const SRef& r : roots)
      if (r.id >= 0) ++uses_[r.id];
  }

  std::string body(const std::vector<std::pair<std::string, SRef>>& outputs) {
    std::ostringstream out;
    int next = 0;
    for (int id : order_) {
      const auto k = p_.node(id).kind;
      const bool is_op = k != Program::Kind::input && k != Program::Kind::constant;
      const bool trig = k == Program::Kind::sin || k == Program::Kind::cos;
      if (!is_op || (!trig && uses_[id] < 2)) continue;
      const std::string expr = print_node(id);
      names_[id] = "t" + std::to_string(next++);
      out << "  const T " << names_[id] << " = " << expr << ";\n";
    }
    for (const auto& [target, root] : outputs) {
      std::string value = root.id < 0 ? "T(0)" : (root.neg ? "-" + wrap(root.id, 1) : ref(root.id));
      if (target == "return")
        out << "  return " << value << ";\n";
      else
        out << "  " << target << " = " << value << ";\n";
    }
    return out.str();
  }

 private:
  const Program& p_;
  std::vector<int> order_;
  std::map<int, int> uses_;
  std::map<int, std::string> names_;

  std::string ref(int id) const {
    auto it = names_.find(id);
    if (it != names_.end()) return it->second;
    return print_node(id);
  }

  // precedence: 0 sum context, 1 product, 2 divisor/negation
  std::string wrap(int id, int context) const {
    const auto& n = p_.node(id);
    // A sum left with one operand by the CSE pass is that operand, possibly negated.
    if (!names_.count(id) && n.kind == Program::Kind::add && n.args.size() == 1) {
      const SRef a = n.args[0];
      if (!a.neg) return wrap(a.id, context);
      const std::string neg = "-" + wrap(a.id, 2);
      return context >= 1 ? "(" + neg + ")" : neg;
    }
    const std::string s = ref(id);
    if (names_.count(id)) return s;
    const auto k = n.kind;
    const bool needs = (k == Program::Kind::add && n.args.size() > 1 && context >= 1) ||
                       ((k == Program::Kind::mul || k == Program::Kind::div) && context >= 2) ||
                       (context >= 1 && !s.empty() && s[0] == '-');
    return needs ? "(" + s + ")" : s;
  }

  std::string print_node(int id) const {
    const auto& n = p_.node(id);
    switch (n.kind) {
      case Program::Kind::input:
        return n.text;
      case Program::Kind::constant:
        return "T(" + n.text + ")";
      case Program::Kind::sin:
        return "sin(" + ref(n.args[0].id) + ")";
      case Program::Kind::cos:
        return "cos(" + ref(n.args[0].id) + ")";
      case Program::Kind::div:
        return wrap(n.args[0].id, 1) + " / " + wrap(n.args[1].id, 2);
      case Program::Kind::mul: {
        std::string s;
        for (const SRef& a : n.args) s += (s.empty() ? "" : " * ") + wrap(a.id, 1);
        return s;
      }
      case Program::Kind::add: {
        std::vector<SRef> terms = n.args;
        std::stable_partition(terms.begin(), terms.end(), [](const SRef& a) { return !a.neg; });
        std::string s;
        for (const SRef& a : terms) {
          if (s.empty())
            s = (a.neg ? "-" + wrap(a.id, 2) : wrap(a.id, 0));
          else
            s += (a.neg ? " - " + wrap(a.id, 1) : " + " + wrap(a.id, 0));
        }
        return s;
      }
    }
    return "";
  }
};

// with_names: a declaration or definition (definition: inputs may be unused, e.g. a
// constant mass matrix); otherwise the form of an explicit instantiation.
std::string signature(const FunctionSpec& f, const std::string& scalar, bool with_names, bool definition = false) {
  auto subst = [&](std::string s) {
    const std::string with = "<" + scalar + ">";
    for (size_t pos = 0; (pos = s.find("<T>", pos)) != std::string::npos; pos += with.size()) s.replace(pos, 3, with);
    return s;
  };
  std::string s = (f.return_type == "T" ? scalar : f.return_type) + " " + f.name +
                  (with_names ? "" : "<" + scalar + ">") + "(";
  for (size_t i = 0; i < f.args.size(); ++i) {
    if (i) s += ", ";
    const bool input = f.args[i].type.rfind("const ", 0) == 0;
    if (definition && input) s += "[[maybe_unused]] ";
    s += subst(f.args[i].type);
    if (with_names) s += " " + f.args[i].name;
  }
  return s + ")";
}

std::string index_pair(int i, int j) { return "(" + std::to_string(i) + ", " + std::to_string(j) + ")"; }

// The baseline body: named inputs, then each output as one expanded expression.
std::string plain_body(const SymbolicModel& model, const FunctionSpec& f) {
  std::ostringstream out;
  bool has_q = false, has_qd = false, has_params = false;
  for (const auto& a : f.args) {
    has_q |= a.name == "q";
    has_qd |= a.name == "qd";
    has_params |= a.name == "params";
  }
  // Locals named s_<symbol>, so that no symbol (say a parameter p) shadows an argument.
  GiNaC::exmap rename;
  auto local = [&](const GiNaC::symbol& s, const std::string& source) {
    const GiNaC::symbol renamed("s_" + s.get_name());
    rename[s] = renamed;
    out << "  [[maybe_unused]] const T " << renamed.get_name() << " = " << source << ";\n";
  };
  for (int i = 0; i < model.n(); ++i) {
    if (has_q) local(model.q[i], "q(" + std::to_string(i) + ")");
    if (has_qd) local(model.qd[i], "qd(" + std::to_string(i) + ")");
  }
  if (has_params)
    for (size_t i = 0; i < model.parameters.size(); ++i) local(model.parameters[i], "params(" + std::to_string(i) + ")");
  for (const auto& [target, e] : f.outputs) {
    std::ostringstream expr;
    expr << GiNaC::csrc_double << e.subs(rename);
    out << "  " << (target == "return" ? "return" : target + " =") << " T(" << expr.str() << ");\n";
    int r, c;
    if (std::sscanf(target.c_str(), "M(%d, %d)", &r, &c) == 2 && r != c)
      out << "  M" << index_pair(c, r) << " = M" << index_pair(r, c) << ";\n";
  }
  return out.str();
}

std::string banner(const SymbolicModel& model, const EmitOptions& options) {
  // Paths and the command are user text: written only through comment_lines().
  return comment_lines("Generated by spacearm generator " + std::string(kGeneratorVersion) + " from scene '" +
                       options.scene_path + "' (content hash fnv1a64:" + content_hash(model.scene.content) +
                       ").") +
         comment_lines("Regenerate: " + options.command) +
         "// DO NOT EDIT: this file is overwritten when the model is regenerated.\n// clang-format off\n";
}

std::string quoted_list(const std::vector<std::string>& items) {
  std::string s;
  for (const auto& i : items) s += (s.empty() ? "" : ", ") + std::string("\"") + i + "\"";
  return s;
}

// The generator checks itself before it emits: the optimized straight-line program must
// reproduce GiNaC's evaluation of the derived expressions at a fixed pseudo-random state
// (nominal parameters), else it names the entry that fails.
void self_check(const SymbolicModel& model, const std::string& function, const Program& prog,
                const std::vector<SRef>& roots, const std::vector<std::pair<std::string, ex>>& outputs) {
  const int n = model.n();
  std::vector<double> q(n), qd(n), params;
  for (int i = 0; i < n; ++i) {
    q[i] = 0.3 + 0.7 * std::sin(1.3 * i + 0.4);
    qd[i] = 0.5 - 0.9 * std::cos(0.7 * i + 1.1);
  }
  for (const auto& p : model.scene.parameters) params.push_back(p.nominal.value);
  const auto values = prog.evaluate(roots, [&](const std::string& text) {
    int i = 0;
    if (std::sscanf(text.c_str(), "q(%d)", &i) == 1) return q.at(i);
    if (std::sscanf(text.c_str(), "qd(%d)", &i) == 1) return qd.at(i);
    if (std::sscanf(text.c_str(), "params(%d)", &i) == 1) return params.at(i);
    throw std::logic_error("self-check: unknown input " + text);
  });
  double scale = 0;
  std::vector<double> expected;
  for (const auto& [target, e] : outputs) {
    expected.push_back(evaluate(model, e, q, qd, params));
    scale = std::max(scale, std::abs(expected.back()));
  }
  for (size_t i = 0; i < outputs.size(); ++i)
    if (!(std::abs(values[i] - expected[i]) <= 1e-9 * std::max(scale, 1e-300)))
      throw std::logic_error("generator self-check failed in " + function + ", entry " + outputs[i].first + ": " +
                             std::to_string(values[i]) + " emitted vs " + std::to_string(expected[i]) + " derived");
}

// The scene's range checks (positive mass, inertia, length and ratio, non-negative motor
// inertia, positive compensated link inertia) for quantities that depend on run-time
// parameters, as C++ conditions on params(i): the validation the scene parser does for
// literals, repeated at run time for the parameters' actual values.
std::string parameter_checks(const SymbolicModel& model) {
  const Scene& scene = model.scene;
  std::map<std::string, int> index;
  for (size_t i = 0; i < scene.parameters.size(); ++i) index[scene.parameters[i].name] = static_cast<int>(i);
  auto code = [&](const Quantity& q) {
    return q.is_parameter() ? "params(" + std::to_string(index.at(q.parameter)) + ")" : "(" + round_trip(q.value) + ")";
  };
  std::ostringstream s;
  auto check = [&](bool uses_parameter, const std::string& condition, const std::string& what) {
    if (uses_parameter) s << "  if (!(" << condition << ")) return \"" << what << "\";\n";
  };
  for (size_t i = 0; i < scene.parameters.size(); ++i)
    s << "  if (!std::isfinite(params(" << i << "))) return \"parameter '" << scene.parameters[i].name
      << "' is not finite\";\n";
  if (scene.free_floating()) {
    check(scene.base.mass.is_parameter(), code(scene.base.mass) + " > 0", "base.mass must be positive");
    check(scene.base.inertia.is_parameter(), code(scene.base.inertia) + " > 0", "base.inertia must be positive");
  }
  for (int i = 0; i < scene.num_links(); ++i) {
    const Link& l = scene.links[i];
    const std::string f = "links[" + std::to_string(i) + "]";
    check(l.mass.is_parameter(), code(l.mass) + " > 0", f + ".mass must be positive");
    check(l.inertia.is_parameter(), code(l.inertia) + " > 0", f + ".inertia must be positive");
    check(l.length.is_parameter(), code(l.length) + " > 0", f + ".length must be positive");
    if (!scene.geared()) continue;
    const Gear& g = scene.gears[i];
    const std::string gf = "gears[" + std::to_string(i) + "]";
    check(g.ratio.is_parameter(), code(g.ratio) + " > 0", gf + ".ratio must be positive");
    check(g.motor_inertia.is_parameter(), code(g.motor_inertia) + " >= 0", gf + ".motor_inertia must not be negative");
    if (g.compensate_link_inertia)
      check(g.motor_inertia.is_parameter() || l.inertia.is_parameter(),
            code(l.inertia) + " - " + code(g.motor_inertia) + " > 0",
            gf + ".motor_inertia must be smaller than the inertia of link " + std::to_string(i + 1) + " it compensates");
  }
  return s.str();
}

}  // namespace

EmittedModel emit_cpp(const SymbolicModel& model, const EmitOptions& options) {
  const Scene& scene = model.scene;
  const int n = model.n();
  EmittedModel result;
  const std::string model_name = scene.name + (options.plain ? "_plain" : "");
  const std::string stem = options.file_stem.empty() ? model_name : options.file_stem;
  check_file_stem(stem, "file stem");
  result.header_name = stem + ".hpp";
  result.source_name = stem + ".cpp";

  const Argument q{"const Coordinates<T>&", "q"}, qd{"const Coordinates<T>&", "qd"},
      params{"const Parameters<T>&", "params"};
  std::vector<FunctionSpec> functions;
  auto matrix_outputs = [&](const GiNaC::matrix& mat, const std::string& name, bool symmetric) {
    std::vector<std::pair<std::string, ex>> outs;
    for (unsigned i = 0; i < mat.rows(); ++i)
      for (unsigned j = symmetric ? i : 0; j < mat.cols(); ++j)
        outs.push_back({name + (mat.cols() == 1 ? "(" + std::to_string(i) + ")" : index_pair(i, j)), mat(i, j)});
    return outs;
  };
  if (scene.wants(Output::mass_matrix))
    functions.push_back({"mass_matrix", "Mass matrix M(q) (n x n, symmetric positive definite), paper eq. 6.", "void",
                         {q, params, {"MassMatrix<T>&", "M"}}, matrix_outputs(model.mass_matrix, "M", true), false});
  if (scene.wants(Output::coriolis_matrix))
    functions.push_back({"coriolis_matrix",
                         "Coriolis/centrifugal matrix C(q, qd) (n x n) exactly as paper eq. 7; C qd is the bias. "
                         "Not the Christoffel form: Mdot - 2C is not skew-symmetric.",
                         "void",
                         {q, qd, params, {"MassMatrix<T>&", "C"}},
                         matrix_outputs(model.coriolis_matrix, "C", false),
                         true});
  if (scene.wants(Output::bias_forces))
    functions.push_back({"bias_forces", "Bias b = C(q, qd) qd (n), so that M qdd + b = Q (paper eq. 5).", "void",
                         {q, qd, params, {"Coordinates<T>&", "b"}}, matrix_outputs(model.bias_forces, "b", false),
                         true});
  if (scene.wants(Output::mass_matrix) && scene.wants(Output::bias_forces)) {
    auto outs = matrix_outputs(model.mass_matrix, "M", true);
    for (auto& o : matrix_outputs(model.bias_forces, "b", false)) outs.push_back(o);
    functions.push_back({"mass_matrix_and_bias", "M and b together, sharing the sin/cos and common terms.", "void",
                         {q, qd, params, {"MassMatrix<T>&", "M"}, {"Coordinates<T>&", "b"}}, outs, true});
  }
  if (scene.wants(Output::kinetic_energy))
    functions.push_back({"kinetic_energy", "Kinetic energy T = 1/2 qd^T M qd (paper eqs. 3 and 10).", "T",
                         {q, qd, params}, {{"return", model.kinetic_energy}}, true});
  if (scene.wants(Output::momentum))
    functions.push_back({"momentum",
                         "Momentum h = [Px, Py, L]: linear momentum and angular momentum about the world origin.",
                         "void", {q, qd, params, {"Vector3<T>&", "h"}}, matrix_outputs(model.momentum, "h", false),
                         true});
  if (scene.wants(Output::end_effector_pose))
    functions.push_back({"end_effector_pose",
                         "End-effector pose [x, y, phi]: tip of the last link, absolute angle of the last link.",
                         "void", {q, params, {"Vector3<T>&", "x"}},
                         matrix_outputs(model.end_effector_pose, "x", false), false});
  if (scene.wants(Output::end_effector_jacobian))
    functions.push_back({"end_effector_jacobian", "Jacobian of the end-effector pose, d[x, y, phi]/dq (3 x n).",
                         "void", {q, params, {"PoseJacobian<T>&", "J"}},
                         matrix_outputs(model.end_effector_jacobian, "J", false), false});
  if (scene.wants(Output::joint_positions))
    functions.push_back({"joint_positions", "World positions of joints 1..N (columns) and of the tip (last column).",
                         "void", {q, params, {"JointPositions<T>&", "P"}},
                         matrix_outputs(model.joint_positions, "P", false), false});
  {
    // Always emitted: the runtime maps joint torques to generalized forces tau / p (eq. 14).
    GiNaC::matrix ratios(scene.num_links(), 1);
    const int first_joint = scene.free_floating() ? 3 : 0;
    for (int j = 0; j < scene.num_links(); ++j)
      ratios(j, 0) = (1 / model.gear_map(first_joint + j, first_joint + j)).normal();
    functions.push_back({"gear_ratios", "Gear ratio p_i of each joint (1 for the reference model): Q_g = tau / p (eq. 14).",
                         "void", {params, {"JointVector<T>&", "p"}}, matrix_outputs(ratios, "p", false), false});
  }

  // Header.
  const std::string ns = "spacearm::models::" + model_name;
  std::ostringstream h;
  h << banner(model, options) << "#pragma once\n\n#include <Eigen/Core>\n\n#include <array>\n#include <cmath>\n\n";
  h << comment_lines(scene.description.empty() ? scene.name : scene.description);
  h << "// Coordinates q = [" << [&] {
    std::string s;
    for (const auto& c : scene.coordinate_names()) s += (s.empty() ? "" : ", ") + c;
    return s;
  }() << "]" << (scene.geared() ? " (motor angles qm = p q, paper eq. 12)" : "") << ".\n";
  h << "// Instantiated for float, double and long double; constants are double-precision.\n";
  h << "namespace " << ns << " {\n\n";
  h << "inline constexpr int kNq = " << n << ";\n";
  h << "inline constexpr int kNumLinks = " << scene.num_links() << ";\n";
  h << "inline constexpr int kNumParams = " << scene.parameters.size() << ";\n";
  h << "inline constexpr bool kFreeFloating = " << (scene.free_floating() ? "true" : "false") << ";\n";
  h << "inline constexpr bool kGeared = " << (scene.geared() ? "true" : "false") << ";\n";
  h << "inline constexpr std::array<const char*, kNq> kCoordinateNames = {" << quoted_list(scene.coordinate_names())
    << "};\n";
  std::vector<std::string> pnames;
  std::string nominal;
  for (const auto& p : scene.parameters) {
    pnames.push_back(p.name);
    nominal += (nominal.empty() ? "" : ", ") + round_trip(p.nominal.value);
  }
  h << "inline constexpr std::array<const char*, kNumParams> kParameterNames = {" << quoted_list(pnames) << "};\n";
  h << "inline constexpr std::array<double, kNumParams> kNominalParameters = {" << nominal << "};\n";
  h << "inline constexpr const char* kSceneHash = \"fnv1a64:" << content_hash(scene.content) << "\";\n";
  h << "\n// nullptr if the run-time parameters describe a physical system, else what is wrong\n"
    << "// (the scene's range checks, repeated for the parameters' values).\n"
    << "inline const char* parameter_error([[maybe_unused]] const Eigen::Matrix<double, kNumParams, 1>& params) {\n"
    << parameter_checks(model) << "  return nullptr;\n}\n";
  for (Output o : all_outputs())
    h << "inline constexpr bool kHas_" << to_string(o) << " = " << (scene.wants(o) ? "true" : "false") << ";\n";
  h << "\ntemplate <typename T> using Coordinates = Eigen::Matrix<T, kNq, 1>;\n"
    << "template <typename T> using Parameters = Eigen::Matrix<T, kNumParams, 1>;\n"
    << "template <typename T> using MassMatrix = Eigen::Matrix<T, kNq, kNq>;\n"
    << "template <typename T> using Vector3 = Eigen::Matrix<T, 3, 1>;\n"
    << "template <typename T> using PoseJacobian = Eigen::Matrix<T, 3, kNq>;\n"
    << "template <typename T> using JointVector = Eigen::Matrix<T, kNumLinks, 1>;\n"
    << "template <typename T> using JointPositions = Eigen::Matrix<T, 2, kNumLinks + 1>;\n\n";
  h << "// All functions write into caller-provided fixed-size outputs and never allocate.\n";

  // Source.
  std::ostringstream s;
  s << banner(model, options) << "#include \"" << result.header_name << "\"\n\n#include <cmath>\n\n"
    << "namespace " << ns << " {\n";

  for (const auto& f : functions) {
    if (options.plain) {
      result.stats.push_back({f.name, {}, ""});
      h << "\n// " << f.doc << "\ntemplate <typename T>\n" << signature(f, "T", true) << ";\n";
      s << "\n// " << f.doc << "\n// Baseline: expanded expressions, no common-subexpression elimination.\n"
        << "template <typename T>\n"
        << signature(f, "T", true, true) << " {\n  using std::cos;\n  using std::sin;\n  using std::pow;\n"
        << plain_body(model, f) << "}\n";
      continue;
    }
    // Pick the velocity basis (qd or absolute body rates) that needs fewer operations.
    std::string best_body;
    OpCounts best_ops;
    std::string best_basis;
    for (int basis = 0; basis < (f.uses_velocity ? 2 : 1); ++basis) {
      FunctionBuilder fb(model, basis == 1);
      std::vector<SRef> roots;
      for (const auto& [target, e] : f.outputs) roots.push_back(fb.build(e));
      fb.prog.extract_common_pairs(roots);
      self_check(model, f.name, fb.prog, roots, f.outputs);
      const OpCounts ops = fb.prog.count(roots);
      if (!best_body.empty() && ops.total_arithmetic() + ops.trig >= best_ops.total_arithmetic() + best_ops.trig)
        continue;
      std::vector<std::pair<std::string, SRef>> targets;
      for (size_t i = 0; i < roots.size(); ++i) targets.push_back({f.outputs[i].first, roots[i]});
      // Symmetric matrices: also fill the lower triangle.
      if (f.name == "mass_matrix" || f.name == "mass_matrix_and_bias")
        for (size_t i = 0; i < roots.size(); ++i) {
          int r, c;
          if (std::sscanf(f.outputs[i].first.c_str(), "M(%d, %d)", &r, &c) == 2 && r != c)
            targets.push_back({"M" + index_pair(c, r), roots[i]});
        }
      Printer printer(fb.prog, roots);
      best_body = printer.body(targets);
      best_ops = ops;
      best_basis = f.uses_velocity ? (basis == 1 ? "omega" : "qd") : "";
    }
    result.stats.push_back({f.name, best_ops, best_basis});
    h << "\n// " << f.doc << "\ntemplate <typename T>\n" << signature(f, "T", true) << ";\n";
    s << "\n// " << f.doc << "\n// Operations: " << best_ops.adds << " add, " << best_ops.muls << " mul, "
      << best_ops.divs << " div, " << best_ops.trig << " sin/cos.\n"
      << "template <typename T>\n"
      << signature(f, "T", true, true) << " {\n  using std::cos;\n  using std::sin;\n"
      << best_body << "}\n";
  }
  // The model as a type, so generic code (runtime, tests, benchmarks) can take it as a
  // template argument.
  h << "\n// The model as a type for generic code: constants and forwarding functions.\nstruct Model {\n"
    << "  static constexpr const char* kName = \"" << model_name << "\";\n"
    << "  static constexpr int kNq = " << ns << "::kNq;\n"
    << "  static constexpr int kNumLinks = " << ns << "::kNumLinks;\n"
    << "  static constexpr int kNumParams = " << ns << "::kNumParams;\n"
    << "  static constexpr bool kFreeFloating = " << ns << "::kFreeFloating;\n"
    << "  static constexpr bool kGeared = " << ns << "::kGeared;\n";
  for (Output o : all_outputs())
    h << "  static constexpr bool kHas_" << to_string(o) << " = " << ns << "::kHas_" << to_string(o) << ";\n";
  h << "  template <typename T> using Coordinates = " << ns << "::Coordinates<T>;\n"
    << "  template <typename T> using Parameters = " << ns << "::Parameters<T>;\n"
    << "  template <typename T> using MassMatrix = " << ns << "::MassMatrix<T>;\n"
    << "  template <typename T> using Vector3 = " << ns << "::Vector3<T>;\n"
    << "  template <typename T> using PoseJacobian = " << ns << "::PoseJacobian<T>;\n"
    << "  template <typename T> using JointVector = " << ns << "::JointVector<T>;\n"
    << "  template <typename T> using JointPositions = " << ns << "::JointPositions<T>;\n"
    << "  static constexpr const std::array<const char*, kNq>& coordinate_names() { return kCoordinateNames; }\n"
    << "  static constexpr const std::array<const char*, kNumParams>& parameter_names() { return kParameterNames; }\n"
    << "  static constexpr const std::array<double, kNumParams>& nominal_parameters() { return kNominalParameters; }\n"
    << "  static const char* parameter_error(const Eigen::Matrix<double, kNumParams, 1>& params) {\n"
    << "    return " << ns << "::parameter_error(params);\n  }\n";
  for (const auto& f : functions) {
    std::string call;
    for (const auto& a : f.args) call += (call.empty() ? "" : ", ") + a.name;
    h << "  template <typename T>\n  static " << signature(f, "T", true) << " {\n    return " << ns
      << "::" << f.name << "<T>(" << call << ");\n  }\n";
  }
  h << "};\n";
  s << "\n// Explicit instantiations.\n";
  for (const char* scalar : {"float", "double", "long double"})
    for (const auto& f : functions) s << "template " << signature(f, scalar, false) << ";\n";
  s << "\n}  // namespace " << ns << "\n";
  h << "\n}  // namespace " << ns << "\n";
  result.header = h.str();
  result.source = s.str();
  return result;
}

void write_files(const EmittedModel& emitted, const std::string& dir) {
  namespace fs = std::filesystem;
  fs::create_directories(dir);
  const std::vector<std::pair<std::string, const std::string*>> files = {{emitted.header_name, &emitted.header},
                                                                          {emitted.source_name, &emitted.source}};
  std::vector<std::pair<fs::path, fs::path>> staged;
  for (const auto& [name, text] : files) {
    const fs::path final_path = fs::path(dir) / name;
    const fs::path tmp = fs::path(dir) / ("." + name + ".tmp");
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out << *text;
    out.close();
    if (!out) throw std::runtime_error("cannot write '" + tmp.string() + "'");
    staged.push_back({tmp, final_path});
  }
  for (const auto& [tmp, final_path] : staged) fs::rename(tmp, final_path);
}

std::vector<std::string> stale_files(const EmittedModel& emitted, const std::string& dir) {
  std::vector<std::string> stale;
  for (const auto& [name, text] : {std::make_pair(emitted.header_name, &emitted.header),
                                   std::make_pair(emitted.source_name, &emitted.source)}) {
    const std::string path = dir + "/" + name;
    std::ifstream in(path, std::ios::binary);
    std::ostringstream existing;
    existing << in.rdbuf();
    if (!in || existing.str() != *text) stale.push_back(path);
  }
  return stale;
}

}  // namespace spacearm
