// An independent numeric reference for the symbolic models: forward kinematics and the
// kinetic energy of eq. 3 (+ eq. 10 for motors) evaluated body by body in plain floating
// point, with M by polarization of T and the Euler-Lagrange bias by finite differences; the
// joint springs' potential energy, the dampers' Rayleigh function and the friction law joint by
// joint, their generalized forces by central differences. It shares no code with the
// generator: tests use it as an oracle.
#pragma once

#include <Eigen/Core>

#include <cmath>
#include <optional>
#include <stdexcept>
#include <vector>

namespace spacearm {

struct ChainParameters {
  struct Link {
    double mass, inertia, length;
    Eigen::Vector2d com;
  };
  struct Gear {
    double ratio, motor_inertia;
    bool compensate_link_inertia;
    bool armature = false;  // rotor energy 1/2 I_m qd_m^2 only (no coupling to the previous body)
    double stiffness = 0;   // > 0: a flexible joint, spring between qm / p and the link angle
    double damping = 0;     // damper beside the spring
  };
  // f(w) = b w + Fc tanh(w/vs) + (Fs - Fc) exp(-(w/vst)^2) tanh(w/vs) on the motor rate w.
  struct Friction {
    double viscous = 0, coulomb = 0, velocity_scale = 1, stribeck_static = 0, stribeck_velocity = 1;
  };
  bool free_floating = true;
  double base_mass = 0, base_inertia = 0;
  Eigen::Vector2d mount = Eigen::Vector2d::Zero();
  std::vector<Link> links;
  std::vector<std::optional<Gear>> gears;         // empty: reference model; empty entry: no gear
  std::vector<std::optional<Friction>> friction;  // empty: none

  const Gear* gear(size_t joint) const {
    return joint < gears.size() && gears[joint] ? &*gears[joint] : nullptr;
  }
  bool flexible(size_t joint) const { return gear(joint) && gear(joint)->stiffness > 0; }
  int num_coordinates() const {
    int n = (free_floating ? 3 : 0) + static_cast<int>(links.size());
    for (size_t j = 0; j < links.size(); ++j) n += flexible(j);
    return n;
  }
  // Coordinate of joint j's motor: its own slot, or after all joint slots if it is flexible.
  int motor_coordinate(size_t joint) const {
    int c = (free_floating ? 3 : 0) + static_cast<int>(links.size());
    if (!flexible(joint)) return (free_floating ? 3 : 0) + static_cast<int>(joint);
    for (size_t j = 0; j < joint; ++j) c += flexible(j);
    return c;
  }
};

class NumericLagrangian {
 public:
  using Vector = Eigen::VectorXd;
  using Matrix = Eigen::MatrixXd;

  explicit NumericLagrangian(ChainParameters chain) : c_(std::move(chain)) {}

  int n() const { return c_.num_coordinates(); }

  struct BodyState {
    std::vector<Eigen::Vector2d> com, com_velocity;  // base first, then links
    std::vector<double> angle, rate;                 // absolute angle and rate per body
    std::vector<double> motor_rate;                  // absolute motor rate per joint
    Eigen::Vector2d tip;
  };

  // Forward kinematics and velocities, propagated joint by joint.
  BodyState bodies(const Vector& q, const Vector& qd) const {
    check(q, qd);
    const int N = static_cast<int>(c_.links.size());
    const int j0 = c_.free_floating ? 3 : 0;
    BodyState s;
    Eigen::Vector2d r0 = Eigen::Vector2d::Zero(), v0 = Eigen::Vector2d::Zero();
    double theta = 0, omega = 0;
    if (c_.free_floating) {
      r0 = {q[0], q[1]};
      v0 = {qd[0], qd[1]};
      theta = q[2];
      omega = qd[2];
    }
    s.com.push_back(r0);
    s.com_velocity.push_back(v0);
    s.angle.push_back(theta);
    s.rate.push_back(omega);
    Eigen::Vector2d joint = r0 + rotate(theta, c_.mount);
    Eigen::Vector2d joint_velocity = v0 + cross(omega, joint - r0);
    for (int i = 0; i < N; ++i) {
      const auto* gear = c_.gear(i);
      // In motor coordinates the link angle is qm / p and its rate qmd / p (eq. 9); a flexible
      // joint's slot holds the link angle itself.
      const double p = gear && !c_.flexible(i) ? gear->ratio : 1.0;
      const double previous_rate = omega;
      theta += q[j0 + i] / p;
      omega += qd[j0 + i] / p;
      const bool armature = gear && gear->armature;
      const double qd_motor = qd[c_.motor_coordinate(i)];
      s.motor_rate.push_back((armature ? 0.0 : previous_rate) + qd_motor);  // eq. 11
      const auto& link = c_.links[i];
      const Eigen::Vector2d com = joint + rotate(theta, link.com);
      s.com.push_back(com);
      s.com_velocity.push_back(joint_velocity + cross(omega, com - joint));
      s.angle.push_back(theta);
      s.rate.push_back(omega);
      const Eigen::Vector2d next = joint + rotate(theta, {link.length, 0});
      joint_velocity = joint_velocity + cross(omega, next - joint);
      joint = next;
    }
    s.tip = joint;
    return s;
  }

  double kinetic_energy(const Vector& q, const Vector& qd) const {
    const BodyState s = bodies(q, qd);
    double T = 0;
    if (c_.free_floating)
      T += 0.5 * c_.base_mass * s.com_velocity[0].squaredNorm() +
           0.5 * c_.base_inertia * s.rate[0] * s.rate[0];
    for (size_t i = 0; i < c_.links.size(); ++i) {
      const auto& link = c_.links[i];
      const auto* gear = c_.gear(i);
      double inertia = link.inertia;
      if (gear && gear->compensate_link_inertia) inertia -= gear->motor_inertia;
      T += 0.5 * link.mass * s.com_velocity[i + 1].squaredNorm() +
           0.5 * inertia * s.rate[i + 1] * s.rate[i + 1];
      if (gear) T += 0.5 * gear->motor_inertia * s.motor_rate[i] * s.motor_rate[i];
    }
    return T;
  }

  // T is a quadratic form in qd, so M_ij = T(e_i + e_j) - T(e_i) - T(e_j) exactly.
  Matrix mass_matrix(const Vector& q) const {
    const int n = this->n();
    Matrix M(n, n);
    Vector e = Vector::Zero(n);
    Vector diag(n);
    for (int i = 0; i < n; ++i) {
      e.setZero();
      e[i] = 1;
      diag[i] = kinetic_energy(q, e);
      M(i, i) = 2 * diag[i];
    }
    for (int i = 0; i < n; ++i)
      for (int j = i + 1; j < n; ++j) {
        e.setZero();
        e[i] = e[j] = 1;
        M(i, j) = M(j, i) = kinetic_energy(q, e) - diag[i] - diag[j];
      }
    return M;
  }

  // Euler-Lagrange terms at qdd = 0: d/dt dT/dqd - dT/dq = (dM/dt) qd - dT/dq, both by
  // central differences (step h relative to the scale of q).
  Vector bias_forces(const Vector& q, const Vector& qd, double h = 1e-6) const {
    const int n = this->n();
    const Vector Mdot_qd = (mass_matrix(q + h * qd) * qd - mass_matrix(q - h * qd) * qd) / (2 * h);
    Vector dT_dq(n);
    for (int i = 0; i < n; ++i) {
      Vector dq = Vector::Zero(n);
      dq[i] = h;
      dT_dq[i] = (kinetic_energy(q + dq, qd) - kinetic_energy(q - dq, qd)) / (2 * h);
    }
    return Mdot_qd - dT_dq;
  }

  // [Px, Py, L]: sum of m v, and of r x m v + I omega (+ motors) about the world origin.
  Eigen::Vector3d momentum(const Vector& q, const Vector& qd) const {
    const BodyState s = bodies(q, qd);
    Eigen::Vector3d h = Eigen::Vector3d::Zero();
    for (size_t b = 0; b < s.com.size(); ++b) {
      const bool base = b == 0;
      if (base && !c_.free_floating) continue;
      const double m = base ? c_.base_mass : c_.links[b - 1].mass;
      double inertia = base ? c_.base_inertia : c_.links[b - 1].inertia;
      if (!base && c_.gear(b - 1) && c_.gear(b - 1)->compensate_link_inertia)
        inertia -= c_.gear(b - 1)->motor_inertia;
      const Eigen::Vector2d p = m * s.com_velocity[b];
      h.head<2>() += p;
      h[2] += s.com[b].x() * p.y() - s.com[b].y() * p.x() + inertia * s.rate[b];
    }
    // A rotor adds I_m w_m to the angular momentum; with the armature approximation its
    // energy does not depend on the base rate, so it adds nothing to the conserved momentum.
    for (size_t i = 0; i < c_.links.size(); ++i)
      if (c_.gear(i) && !c_.gear(i)->armature) h[2] += c_.gear(i)->motor_inertia * s.motor_rate[i];
    return h;
  }

  // The springs' twist qm / p - q of each flexible joint (0 for the others), at q or, for its
  // rate, at qd.
  std::vector<double> twists(const Vector& x) const {
    const int j0 = c_.free_floating ? 3 : 0;
    std::vector<double> twist(c_.links.size(), 0.0);
    for (size_t j = 0; j < c_.links.size(); ++j)
      if (c_.flexible(j)) twist[j] = x[c_.motor_coordinate(j)] / c_.gear(j)->ratio - x[j0 + j];
    return twist;
  }

  // V = sum 1/2 k (qm/p - q)^2.
  double potential_energy(const Vector& q) const {
    const std::vector<double> twist = twists(q);
    double V = 0;
    for (size_t j = 0; j < twist.size(); ++j)
      if (c_.flexible(j)) V += 0.5 * c_.gear(j)->stiffness * twist[j] * twist[j];
    return V;
  }

  // Rayleigh's dissipation function D = sum 1/2 d (qmd/p - qd)^2: the dampers dissipate 2 D.
  double dissipation_function(const Vector& qd) const {
    const std::vector<double> rate = twists(qd);
    double D = 0;
    for (size_t j = 0; j < rate.size(); ++j)
      if (c_.flexible(j)) D += 0.5 * c_.gear(j)->damping * rate[j] * rate[j];
    return D;
  }

  // dV/dq + dD/dqd by central differences (exact but for rounding: both are quadratic).
  Vector spring_damper_forces(const Vector& q, const Vector& qd, double h = 1e-3) const {
    Vector f(n());
    for (int i = 0; i < n(); ++i) {
      Vector e = Vector::Zero(n());
      e[i] = h;
      f[i] = (potential_energy(q + e) - potential_energy(q - e)) / (2 * h) +
             (dissipation_function(qd + e) - dissipation_function(qd - e)) / (2 * h);
    }
    return f;
  }

  // Friction on each joint's motor rate w (the joint's own rate without a gear).
  Vector friction_forces(const Vector& qd) const {
    Vector f = Vector::Zero(n());
    for (size_t j = 0; j < c_.friction.size(); ++j) {
      if (!c_.friction[j]) continue;
      const auto& fr = *c_.friction[j];
      const double w = qd[c_.motor_coordinate(j)];
      const double smooth_sign = std::tanh(w / fr.velocity_scale);
      const double hump = std::exp(-std::pow(w / fr.stribeck_velocity, 2));
      f[c_.motor_coordinate(j)] = fr.viscous * w + fr.coulomb * smooth_sign +
                                  (fr.stribeck_static - fr.coulomb) * hump * smooth_sign;
    }
    return f;
  }

  Eigen::Vector3d end_effector_pose(const Vector& q) const {
    const BodyState s = bodies(q, Vector::Zero(n()));
    return {s.tip.x(), s.tip.y(), s.angle.back()};
  }

 private:
  ChainParameters c_;

  static Eigen::Vector2d rotate(double angle, const Eigen::Vector2d& v) {
    const double c = std::cos(angle), s = std::sin(angle);
    return {c * v.x() - s * v.y(), s * v.x() + c * v.y()};
  }
  static Eigen::Vector2d cross(double omega, const Eigen::Vector2d& r) {
    return {-omega * r.y(), omega * r.x()};
  }

  void check(const Vector& q, const Vector& qd) const {
    if (q.size() != n() || qd.size() != n())
      throw std::invalid_argument("NumericLagrangian: expected q and qd of size " +
                                  std::to_string(n()) + ", got " + std::to_string(q.size()) +
                                  " and " + std::to_string(qd.size()));
  }
};

}  // namespace spacearm
