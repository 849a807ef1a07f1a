#include "symbolic_model.hpp"

#include <cctype>
#include <cmath>
#include <regex>
#include <set>
#include <sstream>
#include <stdexcept>

namespace spacearm {

using GiNaC::ex;
using GiNaC::lst;
using GiNaC::matrix;
using GiNaC::numeric;
using GiNaC::symbol;

numeric exact_decimal(const std::string& literal) {
  static const std::regex re(R"(([+-]?)(\d*)(?:\.(\d*))?(?:[eE]([+-]?\d+))?)");
  std::smatch m;
  if (!std::regex_match(literal, m, re)) throw std::invalid_argument("not a decimal: " + literal);
  std::string digits = m[2].str() + m[3].str();
  if (digits.empty()) digits = "0";
  const long exponent =
      (m[4].matched ? std::stol(m[4].str()) : 0) - static_cast<long>(m[3].length());
  numeric value(digits.c_str());
  value = value * GiNaC::pow(numeric(10), numeric(exponent));
  return m[1].str() == "-" ? -value : value;
}

namespace {

// Everything the derivation needs about one scene, as GiNaC expressions.
struct Builder {
  const Scene& scene;
  SymbolicModel& model;
  std::map<std::string, ex> parameter_symbols;

  ex value(const Quantity& q) const {
    if (q.is_parameter()) return parameter_symbols.at(q.parameter);
    return exact_decimal(q.literal);
  }

  // d/dt of an expression of q along qd (qdd = 0 is all we ever need it for).
  ex time_derivative(const ex& e) const {
    ex result = 0;
    for (int i = 0; i < model.n(); ++i) result += e.diff(model.q[i]) * model.qd[i];
    return result;
  }
};

struct Vec2 {
  ex x, y;
};

// R(theta) J u with J the rotation by +90 degrees: d/dtheta of R(theta) u.
Vec2 rotated_perp(const ex& theta, const Vec2& u) {
  return {-GiNaC::cos(theta) * u.y - GiNaC::sin(theta) * u.x,
          GiNaC::cos(theta) * u.x - GiNaC::sin(theta) * u.y};
}

Vec2 rotated(const ex& theta, const Vec2& u) {
  return {GiNaC::cos(theta) * u.x - GiNaC::sin(theta) * u.y,
          GiNaC::sin(theta) * u.x + GiNaC::cos(theta) * u.y};
}

}  // namespace

namespace {

// One derivation, stage by stage: symbols, angles, kinetic energy, then the outputs asked for.
// The stages share the scene's sizes and the intermediate expressions below.
class Derivation {
 public:
  Derivation(const Scene& scene, const DeriveOptions& options, SymbolicModel& model)
      : scene_(scene),
        model_(model),
        b_{scene, model, {}},
        N_(scene.num_links()),
        free_(scene.free_floating()),
        geared_(scene.geared()) {
    // What the scene asks for, and what its composed outputs are composed of.
    wanted_ = scene.outputs;
    for (Output o : scene.outputs)
      wanted_.insert(info(o).composed_of.begin(), info(o).composed_of.end());
    // Where only the recursive forms are tried, nothing is derived from T.
    if (!scene.tries_closed_form())
      for (const OutputInfo& o : output_registry())
        if (from_kinetic_energy(o.id)) wanted_.erase(o.id);
    all_ = options.all_outputs;
  }

  // Whether the scene can have output o at all (what it needs, outputs.hpp).
  bool defined(Output o) const { return missing_feature(info(o).needs, scene_.features()).empty(); }

  void run() {
    symbols();
    angles();
    kinetic_energy();
    mass_matrix_forms();
    joint_state();
    bias_and_momentum();
    end_effector();
    passive_forces();
    residual_derivatives();
  }

 private:
  const Scene& scene_;
  SymbolicModel& model_;
  Builder b_;
  const int N_;
  const bool free_, geared_;
  bool all_ = false;
  std::set<Output> wanted_;
  // The Lagrangian's generalized coordinates and their rates: one count, nq = nv by
  // construction (a base with a quaternion takes the recursive chain, recursive_algorithms.hpp).
  int n_ = 0, first_joint_ = 0;
  Vec2 r0_{0, 0}, r0d_{0, 0}, mount_{0, 0};
  std::vector<ex> p_, Im_, dT_dqd_;
  matrix M_;

  bool wants(Output o) const {
    return (all_ && defined(o) && info(o).composed_of.empty()) || wanted_.count(o);
  }

  // Symbols in a fixed order: coordinates, velocities, parameters.
  void symbols() {
    for (const auto& name : scene_.coordinate_names()) model_.q.emplace_back(name);
    for (const auto& name : scene_.coordinate_names()) model_.qd.emplace_back(name + "d");
    for (const auto& p : scene_.parameters) {
      model_.parameters.emplace_back(p.name);
      model_.nominal_parameters.push_back(p.nominal.value);
      b_.parameter_symbols[p.name] = model_.parameters.back();
    }
    n_ = model_.n();
    first_joint_ = free_ ? 3 : 0;
  }

  // Base pose and absolute angles theta_k = q0 + sum_{j<=k} q_j (eq. 4); in motor
  // coordinates q_j = q_m_j / p_j (eq. 9 integrated with q_m(0) = p q(0)).
  void angles() {
    ex theta0 = 0;
    if (free_) {
      r0_ = {model_.q[0], model_.q[1]};
      r0d_ = {model_.qd[0], model_.qd[1]};
      theta0 = model_.q[2];
    }
    mount_ = {b_.value(scene_.base.mount[0]), b_.value(scene_.base.mount[1])};
    model_.gear_map = matrix(n_, n_);
    for (int i = 0; i < n_; ++i) model_.gear_map(i, i) = 1;
    p_.assign(N_ + 1, 1);
    Im_.assign(N_ + 1, 0);
    for (int j = 1; j <= N_; ++j) {
      if (!scene_.has_gear(j - 1)) continue;
      p_[j] = b_.value(scene_.gears[j - 1]->ratio);
      Im_[j] = b_.value(scene_.gears[j - 1]->motor_inertia);
      // A rigid gear's slot holds the motor angle; a flexible joint's slot the link angle.
      if (!scene_.is_flexible(j - 1))
        model_.gear_map(first_joint_ + j - 1, first_joint_ + j - 1) = 1 / p_[j];
    }
    model_.ratios.assign(p_.begin() + 1, p_.end());
    model_.theta.push_back(theta0);
    for (int j = 1; j <= N_; ++j) {
      const int c = first_joint_ + j - 1;
      model_.theta.push_back(model_.theta.back() + model_.q[c] * model_.gear_map(c, c));
    }
    for (const ex& th : model_.theta) model_.omega.push_back(b_.time_derivative(th).expand());
    for (int k = 0; k <= N_; ++k) {
      model_.angle_table[model_.theta[k].expand()] = {-1, k};
      for (int l = k + 1; l <= N_; ++l)
        model_.angle_table[(model_.theta[l] - model_.theta[k]).expand()] = {k, l};
    }
  }

  // |v_i|^2 of link i's CoM. With d_i = CoM_i - r0 = sum_k R(theta_k) u_ki, the CoM velocity
  // is v_i = r0d + sum_k Omega_k R(theta_k) J u_ki and
  // |v_i|^2 = |r0d|^2 + 2 sum_k Omega_k r0d.(R_k J u_k) + sum_kl Omega_k Omega_l u_k^T R(theta_l -
  // theta_k) u_l, written with the relative angles so the closed form stays compact (no trig
  // identities are needed afterwards).
  ex com_speed_squared(int i) const {
    const auto& theta = model_.theta;
    const auto& Omega = model_.omega;
    std::vector<Vec2> u;  // u_ki, k = 0..i
    u.push_back(mount_);
    for (int k = 1; k < i; ++k) u.push_back({b_.value(scene_.links[k - 1].length), 0});
    u.push_back({b_.value(scene_.links[i - 1].com[0]), b_.value(scene_.links[i - 1].com[1])});
    ex v2 = r0d_.x * r0d_.x + r0d_.y * r0d_.y;
    for (int k = 0; k <= i; ++k) {
      const Vec2 w = rotated_perp(theta[k], u[k]);
      v2 += 2 * Omega[k] * (r0d_.x * w.x + r0d_.y * w.y);
      v2 += Omega[k] * Omega[k] * (u[k].x * u[k].x + u[k].y * u[k].y);
      for (int l = k + 1; l <= i; ++l) {
        const ex delta = theta[l] - theta[k];
        // u_k^T R(delta) u_l = (u_k . u_l) cos(delta) + (u_ky u_lx - u_kx u_ly) sin(delta)
        const ex dot = u[k].x * u[l].x + u[k].y * u[l].y;
        const ex cross = u[k].y * u[l].x - u[k].x * u[l].y;
        v2 += 2 * Omega[k] * Omega[l] * (dot * GiNaC::cos(delta) + cross * GiNaC::sin(delta));
      }
    }
    return v2;
  }

  // Whether output o's closed form is derived from T (at N = 30 expanding T and its gradient
  // takes a minute: the recursive forms do without it).
  static bool from_kinetic_energy(Output o) {
    switch (o) {
      case Output::mass_matrix:
      case Output::coriolis_matrix:
      case Output::bias_forces:
      case Output::kinetic_energy:
      case Output::momentum:
      case Output::mass_matrix_derivative:
      case Output::christoffel_coriolis_matrix:
      case Output::forward_dynamics_derivatives:
        return true;
      default:
        return false;
    }
  }
  bool needs_kinetic_energy() const {
    for (const OutputInfo& o : output_registry())
      if (wants(o.id) && from_kinetic_energy(o.id)) return true;
    return false;
  }

  // Kinetic energy, eq. 3, plus the motors' (eq. 10).
  void kinetic_energy() {
    if (!needs_kinetic_energy()) return;
    const auto& Omega = model_.omega;
    const ex m0 = free_ ? b_.value(scene_.base.mass) : ex(0);
    const ex I0 = free_ ? b_.value(scene_.base.inertia) : ex(0);
    ex T = m0 * (r0d_.x * r0d_.x + r0d_.y * r0d_.y) / 2 + I0 * Omega[0] * Omega[0] / 2;
    for (int i = 1; i <= N_; ++i) {
      const Link& link = scene_.links[i - 1];
      const std::optional<Gear>& gear = scene_.gears.empty() ? std::nullopt : scene_.gears[i - 1];
      ex I_link = b_.value(link.inertia);
      if (gear && gear->compensate_link_inertia) I_link -= Im_[i];
      T += b_.value(link.mass) * com_speed_squared(i) / 2 + I_link * Omega[i] * Omega[i] / 2;
      if (gear) {
        // Motor i turns with the previous body plus its own rate (eq. 11), 1/2 I_m w^2 (eq. 10);
        // the armature approximation keeps only the motor's own rate.
        const ex& qd_m = model_.qd[scene_.motor_coordinate(i - 1)];
        const ex carried = gear->coupling ? b_.value(*gear->coupling) * Omega[i - 1] : Omega[i - 1];
        const ex omega_m = gear->armature ? qd_m : carried + qd_m;
        T += Im_[i] * omega_m * omega_m / 2;
      }
    }
    model_.kinetic_energy = T.expand();
    if (wants(Output::kinetic_energy))
      model_.outputs[Output::kinetic_energy] = matrix{{model_.kinetic_energy}};
    dT_dqd_.resize(n_);
    for (int i = 0; i < n_; ++i) dT_dqd_[i] = model_.kinetic_energy.diff(model_.qd[i]);
  }

  // Mass matrix, eq. 6: M_ij = d^2 T / dqd_i dqd_j; and the outputs made from it.
  void mass_matrix_forms() {
    if (!(wants(Output::mass_matrix) || wants(Output::coriolis_matrix) ||
          wants(Output::mass_matrix_derivative) || wants(Output::christoffel_coriolis_matrix)))
      return;
    M_ = matrix(n_, n_);
    for (int i = 0; i < n_; ++i)
      for (int j = i; j < n_; ++j) M_(i, j) = M_(j, i) = dT_dqd_[i].diff(model_.qd[j]).expand();
    if (wants(Output::mass_matrix)) model_.outputs[Output::mass_matrix] = M_;
    if (wants(Output::coriolis_matrix)) model_.outputs[Output::coriolis_matrix] = coriolis_eq7();
    // Mdot = sum_k dM/dq_k qd_k.
    if (wants(Output::mass_matrix_derivative)) {
      matrix Mdot(n_, n_);
      for (int i = 0; i < n_; ++i)
        for (int j = i; j < n_; ++j)
          Mdot(i, j) = Mdot(j, i) = b_.time_derivative(M_(i, j)).expand();
      model_.outputs[Output::mass_matrix_derivative] = Mdot;
    }
    if (wants(Output::christoffel_coriolis_matrix))
      model_.outputs[Output::christoffel_coriolis_matrix] = christoffel_coriolis();
  }

  // Coriolis matrix exactly as eq. 7: C = (Mdot - 1/2 d(M qd)/dq)^T, i.e.
  // C_ij = sum_k dM_ij/dq_k qd_k - 1/2 sum_k dM_jk/dq_i qd_k.
  matrix coriolis_eq7() const {
    matrix C(n_, n_);
    std::vector<ex> M_qd(n_);  // (M qd)_j
    for (int j = 0; j < n_; ++j) {
      ex s = 0;
      for (int k = 0; k < n_; ++k) s += M_(j, k) * model_.qd[k];
      M_qd[j] = s.expand();
    }
    for (int i = 0; i < n_; ++i)
      for (int j = 0; j < n_; ++j)
        C(i, j) = (b_.time_derivative(M_(i, j)) - M_qd[j].diff(model_.q[i]) / 2).expand();
    return C;
  }

  // The Christoffel form Cc_ij = sum_k Gamma_ijk qd_k with
  // Gamma_ijk = 1/2 (dM_ij/dq_k + dM_ik/dq_j - dM_jk/dq_i).
  matrix christoffel_coriolis() const {
    const auto& q = model_.q;
    matrix Cc(n_, n_);
    for (int i = 0; i < n_; ++i)
      for (int j = 0; j < n_; ++j) {
        ex s = 0;
        for (int k = 0; k < n_; ++k)
          s += (M_(i, j).diff(q[k]) + M_(i, k).diff(q[j]) - M_(j, k).diff(q[i])) * model_.qd[k] / 2;
        Cc(i, j) = s.expand();
      }
    return Cc;
  }

  // Link-side joint angles and rates: q_link = gear_map q (eq. 12), qd_link = gear_map qd.
  void joint_state() {
    if (!wants(Output::joint_angles) && !wants(Output::joint_rates)) return;
    matrix angles(N_, 1), rates(N_, 1);
    for (int j = 0; j < N_; ++j) {
      const ex& g = model_.gear_map(first_joint_ + j, first_joint_ + j);
      angles(j, 0) = g * model_.q[first_joint_ + j];
      rates(j, 0) = g * model_.qd[first_joint_ + j];
    }
    if (wants(Output::joint_angles)) model_.outputs[Output::joint_angles] = angles;
    if (wants(Output::joint_rates)) model_.outputs[Output::joint_rates] = rates;
  }

  void bias_and_momentum() {
    // Bias C qd, emitted directly from the Euler-Lagrange terms at qdd = 0 (cheaper than C).
    if (wants(Output::bias_forces)) {
      matrix bias(n_, 1);
      for (int i = 0; i < n_; ++i)
        bias(i, 0) =
            (b_.time_derivative(dT_dqd_[i]) - model_.kinetic_energy.diff(model_.q[i])).expand();
      model_.outputs[Output::bias_forces] = bias;
    }
    // Momentum: P = dT/d(r0d); angular momentum about the world origin
    // L = dT/dq0d + r0 x P (dT/dq0d is the angular momentum about the base CoM).
    if (wants(Output::momentum) && free_)
      model_.outputs[Output::momentum] =
          matrix{{dT_dqd_[0].expand()},
                 {dT_dqd_[1].expand()},
                 {(dT_dqd_[2] + r0_.x * dT_dqd_[1] - r0_.y * dT_dqd_[0]).expand()}};
  }

  // Springs and dampers of flexible joints: V = sum 1/2 k (qm/p - q)^2, Rayleigh's
  // D = sum 1/2 d (qmd/p - qd)^2, generalized forces dV/dq + dD/dqd; friction f(w) on each
  // motor coordinate (the joint's own for a rigid gear or no gear). M qdd + b + these = Q.
  void passive_forces() {
    ex V = 0, D = 0;
    for (int j = 0; j < N_ && geared_; ++j) {
      if (!scene_.is_flexible(j)) continue;
      const Gear& g = *scene_.gears[j];
      const int c = scene_.joint_coordinate(j), m = scene_.motor_coordinate(j);
      const ex twist = model_.q[m] / p_[j + 1] - model_.q[c];
      V += b_.value(*g.stiffness) * twist * twist / 2;
      const ex twist_rate = model_.qd[m] / p_[j + 1] - model_.qd[c];
      if (g.damping) D += b_.value(*g.damping) * twist_rate * twist_rate / 2;
    }
    model_.potential_energy = V.expand();
    matrix fk(n_, 1), ff(n_, 1);
    for (int i = 0; i < n_; ++i) fk(i, 0) = (V.diff(model_.q[i]) + D.diff(model_.qd[i])).expand();
    for (int j = 0; j < N_ && scene_.has_friction(); ++j)
      if (scene_.friction[j]) {
        const int m = scene_.motor_coordinate(j);
        ff(m, 0) = friction_force(*scene_.friction[j], model_.qd[m]);
      }
    model_.passive_forces = fk.add(ff);
    if (wants(Output::potential_energy))
      model_.outputs[Output::potential_energy] = matrix{{V.expand()}};
    if (wants(Output::spring_damper_forces)) model_.outputs[Output::spring_damper_forces] = fk;
    if (wants(Output::friction_forces)) model_.outputs[Output::friction_forces] = ff;
  }

  // The residual R = M qdd + b + passive forces with symbolic qdd, and its exact partial
  // derivatives, from which the state Jacobian of qdd = M^-1 (Q - b - passive) follows:
  // dqdd/dq = -M^-1 dR/dq, dqdd/dqd = -M^-1 dR/dqd (Q does not depend on the state).
  void residual_derivatives() {
    if (!wants(Output::forward_dynamics_derivatives)) return;
    for (const auto& name : scene_.coordinate_names()) model_.qdd.emplace_back(name + "dd");
    const matrix& bias = model_.outputs.at(Output::bias_forces);
    model_.residual_dq = matrix(n_, n_);
    model_.residual_dqd = matrix(n_, n_);
    for (int i = 0; i < n_; ++i) {
      ex R = bias(i, 0) + model_.passive_forces(i, 0);
      for (int j = 0; j < n_; ++j) R += M_(i, j) * model_.qdd[j];
      for (int k = 0; k < n_; ++k) {
        model_.residual_dq(i, k) = R.diff(model_.q[k]).expand();
        model_.residual_dqd(i, k) = R.diff(model_.qd[k]).expand();
      }
    }
  }

  // f(w) = b w + Fc tanh(w/vs) + (Fs - Fc) exp(-(w/vst)^2) tanh(w/vs) (Scene::Friction).
  ex friction_force(const Friction& f, const ex& w) const {
    ex force = b_.value(f.viscous) * w;
    if (f.has_coulomb) {
      const ex smooth_sign = GiNaC::tanh(w / b_.value(f.velocity_scale));
      force += b_.value(f.coulomb) * smooth_sign;
      if (f.has_stribeck) {
        const ex r = w / b_.value(f.stribeck_velocity);
        force +=
            (b_.value(f.stribeck_static) - b_.value(f.coulomb)) * GiNaC::exp(-r * r) * smooth_sign;
      }
    }
    return force.expand();
  }

  // End-effector: tip of the last link, orientation of the last link; the joints' positions.
  void end_effector() {
    if (!wants(Output::end_effector_pose) && !wants(Output::end_effector_jacobian) &&
        !wants(Output::joint_positions))
      return;
    const auto& theta = model_.theta;
    const Vec2 m0vec = rotated(theta[0], mount_);
    Vec2 tip = {r0_.x + m0vec.x, r0_.y + m0vec.y};
    matrix P(2, N_ + 1);
    for (int k = 1; k <= N_; ++k) {
      P(0, k - 1) = tip.x.expand();
      P(1, k - 1) = tip.y.expand();
      const Vec2 seg = rotated(theta[k], {b_.value(scene_.links[k - 1].length), 0});
      tip = {tip.x + seg.x, tip.y + seg.y};
    }
    P(0, N_) = tip.x.expand();
    P(1, N_) = tip.y.expand();
    const matrix pose{{tip.x.expand()}, {tip.y.expand()}, {theta[N_].expand()}};
    matrix J(3, n_);
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < n_; ++c) J(r, c) = pose(r, 0).diff(model_.q[c]).expand();
    if (wants(Output::joint_positions)) model_.outputs[Output::joint_positions] = P;
    if (wants(Output::end_effector_pose)) model_.outputs[Output::end_effector_pose] = pose;
    if (wants(Output::end_effector_jacobian)) model_.outputs[Output::end_effector_jacobian] = J;
  }
};

}  // namespace

SymbolicModel derive(const Scene& scene, const DeriveOptions& options) {
  // Every closed form (for inspect) only within the closed form's reach: past it, expanding T
  // alone takes minutes and gigabytes (issue 14 measured 6.8 GB at N = 30).
  if (options.all_outputs && !scene.closed_form_affordable())
    throw std::invalid_argument(
        "scene '" + scene.name + "' has " + std::to_string(scene.num_links()) +
        " links: the closed form's entries are printed up to " + std::to_string(kClosedFormLinks) +
        " links; beyond, the closed form takes minutes and gigabytes to expand and the generated "
        "functions come from the recursive algorithms, which have no entries to print. Evaluate "
        "the quantity with 'spacearm eval'" +
        (scene.num_links() <= kMaxClosedFormLinks
             ? std::string(", or add 'formulation: closed' to the scene to expand it anyway")
             : std::string()));
  SymbolicModel model;
  model.scene = scene;
  Derivation(model.scene, options, model).run();
  return model;
}

GiNaC::ex symbolic_entry(const SymbolicModel& model, const std::string& entry) {
  const EntryText e = parse_entry(entry);
  std::string known;
  for (const auto& o : output_registry()) {
    known += (known.empty() ? "" : ", ") + std::string(o.symbol);
    if (e.name != o.symbol) continue;
    if (!o.composed_of.empty()) {
      std::string parts;
      for (Output c : o.composed_of)
        parts +=
            (parts.empty() ? "" : ", ") + std::string(info(c).symbol) + " (" + to_string(c) + ")";
      throw std::invalid_argument(
          "entry '" + entry + "': " + o.name +
          " is composed in the emitted program (a solve or a product), not a closed form; "
          "inspect what it is made of: " +
          parts);
    }
    if (const std::string why = missing_feature(o.needs, model.scene.features()); !why.empty())
      throw std::invalid_argument("entry '" + entry + "': " + o.name + " " + why);
    const matrix& m = model.expression(o.id);
    const auto [row, col] = entry_position(e, o, static_cast<int>(m.rows()),
                                           static_cast<int>(m.cols()), "entry '" + entry + "'");
    return m(row, col);
  }
  throw std::invalid_argument("entry '" + entry + "': unknown quantity '" + e.name +
                              "' (known: " + known + ")");
}

std::string entry_text(const SymbolicModel& model, const std::string& entry, bool latex,
                       bool decimal) {
  GiNaC::ex e = symbolic_entry(model, entry);
  GiNaC::lst group_by;
  for (const auto& v : model.qd) group_by.append(v);
  for (const auto& p : model.parameters) group_by.append(p);
  if (decimal) e = GiNaC::evalf(e);
  e = GiNaC::collect(e, group_by, true);
  std::ostringstream out;
  if (latex) out << GiNaC::latex;
  out << e;
  return out.str();
}

}  // namespace spacearm
