#include "planar_expressions.hpp"

#include <algorithm>
#include <string>

namespace spacearm {

using GiNaC::ex;

namespace {

// Every quantity the expressions use is a variable with a lazily built node, declared in this
// order: velocities (qd, or the absolute body rates Omega_k), coordinates, and the trig atoms
// cos/sin of absolute and relative body angles, ordered by body.
class PlanarBuilder : public HornerBuilder {
 public:
  PlanarBuilder(const SymbolicModel& model, const Dimensions& dims, bool free, bool body_rates)
      : HornerBuilder({model.q, model.qd, model.parameters}), m_(model) {
    if (body_rates)
      declare_body_rates(dims.num_links, free);
    else
      for (int i = 0; i < m_.n(); ++i)
        add_variable(m_.qd[i], [this, i] { return program().input("qd", i); });
    // Only x0, y0 and linear angle sums appear outside trig calls.
    for (int i = 0; i < m_.n(); ++i)
      add_variable(m_.q[i], [this, i] { return program().input("q", i); });
    declare_trig_atoms();
  }

 private:
  const SymbolicModel& m_;
  std::map<int, SRef> theta_nodes_, omega_nodes_;

  // The base's linear rates stay inputs; each body's rate is Omega_k, and each joint rate
  // qd_j = (Omega_j - Omega_{j-1}) / gear_map_jj.
  void declare_body_rates(int N, bool free) {
    const int n = m_.n(), first_joint = free ? 3 : 0;
    std::map<int, GiNaC::symbol> omega;
    if (free) {
      add_variable(m_.qd[0], [this] { return program().input("qd", 0); });
      add_variable(m_.qd[1], [this] { return program().input("qd", 1); });
    }
    for (int k = free ? 0 : 1; k <= N; ++k) {
      GiNaC::symbol w("Omega" + std::to_string(k));
      add_variable(w, [this, k] { return omega_node(k); });
      omega[k] = w;
    }
    if (free) substitute_velocity(m_.qd[2], omega[0]);
    for (int j = 1; j <= N; ++j) {
      const ex prev = (j == 1 && !free) ? ex(0) : ex(omega[j - 1]);
      const int c = first_joint + j - 1;
      substitute_velocity(m_.qd[c], (omega[j] - prev) / m_.gear_map(c, c));
    }
    // The motor rates of flexible joints (after the joint slots) are no body's rate.
    for (int i = first_joint + N; i < n; ++i)
      add_variable(m_.qd[i], [this, i] { return program().input("qd", i); });
  }

  void declare_trig_atoms() {
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
      add_variable(c, [this, from, to] { return trig_node(true, from, to); });
      add_variable(s, [this, from, to] { return trig_node(false, from, to); });
      substitute_atom(GiNaC::cos(arg), c);
      substitute_atom(GiNaC::sin(arg), s);
    }
  }

  // Body k's angle theta_k or rate Omega_k as a partial sum: x_k = x_{k-1} + (joint k's share).
  SRef partial_sum(const std::vector<ex>& x, std::map<int, SRef>& nodes, int k) {
    if (nodes.count(k)) return nodes[k];
    SRef r =
        k == 0 ? node_of(x[0])
               : program().add({partial_sum(x, nodes, k - 1), node_of((x[k] - x[k - 1]).expand())});
    return nodes[k] = r;
  }
  SRef theta_node(int k) { return partial_sum(m_.theta, theta_nodes_, k); }
  SRef omega_node(int k) { return partial_sum(m_.omega, omega_nodes_, k); }

  SRef trig_node(bool is_cos, int from, int to) {
    Program& p = program();
    if (from < 0) {
      const SRef th = theta_node(to);
      return is_cos ? p.cos(th) : p.sin(th);
    }
    const SRef ca = trig_node(true, -1, from), sa = trig_node(false, -1, from);
    const SRef cb = trig_node(true, -1, to), sb = trig_node(false, -1, to);
    // cos(b - a) = cb ca + sb sa,  sin(b - a) = sb ca - cb sa
    if (is_cos) return p.add({p.mul({cb, ca}), p.mul({sb, sa})});
    return p.add({p.mul({sb, ca}), -p.mul({cb, sa})});
  }
};

}  // namespace

std::unique_ptr<ExpressionBuilder> planar_builder(const SymbolicModel& model,
                                                  const Dimensions& dims, bool free_floating,
                                                  bool body_rates) {
  return std::make_unique<PlanarBuilder>(model, dims, free_floating, body_rates);
}

}  // namespace spacearm
