// Model interface over any generated model (`spacearm::models::<name>::Model`): dimensions,
// run-time parameters, mass matrix, bias, energy, momentum, end-effector pose/Jacobian,
// generalized forces from joint torques (eq. 14) and forward dynamics (eq. 8) through a
// fixed-size Cholesky factorization. Eigen only; no allocation after construction.
#pragma once

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/Eigenvalues>

#include <array>
#include <cmath>
#include <stdexcept>
#include <string>
#include <type_traits>

#include "configuration_space.hpp"
#include "dynamics_checks.hpp"

namespace spacearm {

// The end effectors of generated code: a tree's header states several (kNumEndEffectors), a
// chain's one.
template <class G, class = void>
struct end_effectors_of {
  static constexpr int value = 1;
};
template <class G>
struct end_effectors_of<G, std::void_t<decltype(G::kNumEndEffectors)>> {
  static constexpr int value = G::kNumEndEffectors;
};

template <class Generated>
class Model {
 public:
  // Configuration and velocity sizes, kept apart (nq = nv + 1 on a base floating in 3D).
  static constexpr int kNq = Generated::kNq;
  static constexpr int kNv = Generated::kNv;
  static constexpr int kNumLinks = Generated::kNumLinks;
  static constexpr int kNumParams = Generated::kNumParams;
  static constexpr bool kFreeFloating = Generated::kFreeFloating;
  // Springs, dampers or friction: forces besides M qdd + b (forward_dynamics includes them).
  static constexpr bool kHasPassiveForces = Generated::kPassiveForces;
  using Vector = Eigen::Matrix<double, kNq, 1>;    // configuration q
  using Velocity = Eigen::Matrix<double, kNv, 1>;  // qd, qdd, generalized forces Q, bias b
  using Matrix = Eigen::Matrix<double, kNv, kNv>;
  using Params = Eigen::Matrix<double, kNumParams, 1>;
  using JointVector = Eigen::Matrix<double, kNumLinks, 1>;
  // The pose and its Jacobian as the generated header shapes them (the registry's pose and
  // twist sizes: 3 in the plane; in 3D a pose [x, y, z, w, qx, qy, qz] and a 6-row Jacobian).
  using Pose = typename Generated::template Pose<double>;
  using Vector3 = Pose;  // its former name
  using PoseJacobian = typename Generated::template PoseJacobian<double>;
  // A spatial arm (a base floating in 3D, or fixed): its pose has 7 entries per end effector
  // (a tree's poses follow one another).
  static constexpr int kNumEndEffectors = end_effectors_of<Generated>::value;
  static constexpr bool kSpatial = Pose::RowsAtCompileTime == 7 * kNumEndEffectors;
  // The base's momentum: [px, py, L] in the plane; [P (3), L (3)] in 3D, L about the world origin.
  using Momentum = Eigen::Matrix<double, kSpatial ? 6 : 3, 1>;
  // d(velocity-sized)/dq on q's tangent space (configuration_space.hpp's integrate): nv x nv.
  using TangentJacobian = Eigen::Matrix<double, kNv, kNv>;
  using TorqueJacobian = Eigen::Matrix<double, kNv, kNumLinks>;  // d(velocity-sized)/dtau
  // The base's velocities (x0, y0, q0 in the plane; none for a fixed base); joint 1's slot
  // follows them (a flexible joint's motor coordinates follow the joint slots:
  // actuated_coordinates()). Where a quaternion sits in q (-1: none).
  static constexpr int kNumBase = Generated::kNumBase;
  static constexpr int kQuaternionOffset = Generated::kQuaternionOffset;
  // The scene emits forward_dynamics_derivatives (the state Jacobian).
  static constexpr bool kHasStateJacobian = Generated::kHas_forward_dynamics_derivatives;
  static constexpr bool has_state_jacobian() { return kHasStateJacobian; }

  Model() {
    for (int i = 0; i < kNumParams; ++i) params_[i] = Generated::nominal_parameters()[i];
    update();
  }

  static const char* name() { return Generated::kName; }
  static const std::array<const char*, kNq>& coordinate_names() {
    return Generated::coordinate_names();
  }

  const Params& parameters() const { return params_; }
  void set_parameter(const std::string& name, double value) {
    for (int i = 0; i < kNumParams; ++i)
      if (name == Generated::parameter_names()[i]) {
        if (!std::isfinite(value))
          throw std::invalid_argument(std::string("model ") + Generated::kName + ": parameter '" +
                                      name + "' must be finite, got " + number_text(value));
        const double previous = params_[i];
        params_[i] = value;
        try {
          update();
        } catch (const std::invalid_argument& e) {
          params_[i] = previous;  // the model stays valid
          throw std::invalid_argument(std::string(e.what()) + " (after setting " + name + " = " +
                                      number_text(value) + ")");
        }
        return;
      }
    std::string known;
    for (int i = 0; i < kNumParams; ++i)
      known += (i ? ", " : "") + std::string(Generated::parameter_names()[i]);
    throw std::invalid_argument(std::string("model ") + Generated::kName + ": unknown parameter '" +
                                name + "' (known: " + (known.empty() ? "none" : known) + ")");
  }

  // The configuration space (configuration_space.hpp): dq/dt from v, and the quaternion's
  // projection onto the unit sphere where the base has one.
  static ConfigurationSpace configuration_space() {
    return {kNq, kNv, Generated::kQuaternionOffset};
  }
  static Vector configuration_rate(const Vector& q, const Velocity& qd) {
    if constexpr (kNq == kNv)
      return qd;
    else
      return configuration_space().rate(q, qd);
  }

  // Gear ratio per joint (1 for the reference model), eq. 9.
  const JointVector& gear_ratios() const { return ratios_; }

  // Velocity index that joint torque tau_i drives (as tau_i / p_i): the joint's own slot, or
  // the motor coordinate of a flexible joint.
  static const std::array<int, kNumLinks>& actuated_coordinates() {
    return Generated::actuated_coordinates();
  }
  // Per joint, whether its slot in q holds the motor angle qm = p q (a rigid gear, eq. 12).
  static const std::array<bool, kNumLinks>& motor_angle_slots() {
    return Generated::motor_angle_slots();
  }

  Matrix mass_matrix(const Vector& q) const {
    Matrix M;
    Generated::mass_matrix(q, params_, M);
    return M;
  }
  Velocity bias_forces(const Vector& q, const Velocity& qd) const {
    Velocity b;
    Generated::bias_forces(q, qd, params_, b);
    return b;
  }
  void mass_matrix_and_bias(const Vector& q, const Velocity& qd, Matrix& M, Velocity& b) const {
    Generated::mass_matrix_and_bias(q, qd, params_, M, b);
  }
  double kinetic_energy(const Vector& q, const Velocity& qd) const {
    return Generated::kinetic_energy(q, qd, params_);
  }
  // V(q) of the joint springs, where the scene emits potential_energy.
  template <class G2 = Generated, std::enable_if_t<G2::kHas_potential_energy, int> = 0>
  double potential_energy(const Vector& q) const {
    return Generated::potential_energy(q, params_);
  }
  static constexpr bool kHasPotentialEnergy = Generated::kHas_potential_energy;
  // The joint friction f(w) on each velocity (motor side), where the scene emits friction_forces.
  template <class G2 = Generated, std::enable_if_t<G2::kHas_friction_forces, int> = 0>
  Velocity friction_forces(const Velocity& qd) const {
    Velocity ff;
    Generated::friction_forces(qd, params_, ff);
    return ff;
  }
  static constexpr bool kHasFrictionForces = Generated::kHas_friction_forces;
  // forward_dynamics exists: emitted, or from M and b where nothing acts besides them.
  static constexpr bool kHasForwardDynamics =
      Generated::kHas_forward_dynamics ||
      (Generated::kHas_mass_matrix && Generated::kHas_bias_forces && !kHasPassiveForces);
  Momentum momentum(const Vector& q, const Velocity& qd) const {
    Momentum h;
    Generated::momentum(q, qd, params_, h);
    return h;
  }
  Pose end_effector_pose(const Vector& q) const {
    Pose x;
    Generated::end_effector_pose(q, params_, x);
    return x;
  }
  PoseJacobian end_effector_jacobian(const Vector& q) const {
    PoseJacobian J;
    Generated::end_effector_jacobian(q, params_, J);
    return J;
  }

  // Generalized forces for joint torques tau applied at the joints (the reference model)
  // or at the motors (the geared model, Q_g = tau / p, eq. 14); no force on the base.
  Velocity generalized_forces(const JointVector& tau) const {
    Velocity Q = Velocity::Zero();
    for (int i = 0; i < kNumLinks; ++i) Q[actuated_[i]] = tau[i] / ratios_[i];
    return Q;
  }
  void generalized_forces(const JointVector& tau, Velocity& Q) const {
    Q = generalized_forces(tau);
  }

  // qdd = M^-1 (Q - C qd), eq. 8 (eq. 15 with the sign corrected): the emitted unrolled
  // LDL^T solve where the model has one, else a fixed-size Cholesky factorization. Throws
  // DynamicsError on non-finite input, a mass matrix that is not positive definite or one
  // too ill-conditioned to solve (check_forward_dynamics).
  Velocity forward_dynamics(const Vector& q, const Velocity& qd, const Velocity& Q) const {
    check_finite_inputs(q, qd, Q, Generated::kName, Generated::coordinate_names());
    Velocity qdd, pivots, scaled_pivots;
    if constexpr (Generated::kHas_forward_dynamics) {
      Generated::forward_dynamics(q, qd, Q, params_, qdd, pivots, scaled_pivots);
    } else {
      static_assert(!kHasPassiveForces,
                    "a model with springs, dampers or friction needs the forward_dynamics output");
      Matrix M;
      Velocity b;
      Generated::mass_matrix_and_bias(q, qd, params_, M, b);
      qdd = cholesky_forward_dynamics(M, Velocity(Q - b), Generated::kName, pivots, scaled_pivots);
    }
    check_forward_dynamics(pivots, scaled_pivots, qdd, Generated::kName);
    return qdd;
  }

  // The state Jacobian of forward dynamics at constant Q: dqdd/dq (on q's tangent space: q moves
  // as q ⊕ delta, configuration_space.hpp) and dqdd/dqd, exact (from the symbolic derivatives);
  // returns qdd. Exists where the scene emits forward_dynamics_derivatives. Throws DynamicsError
  // as forward_dynamics does.
  // With dqdd_dtau: by the link-side joint torques (Q = tau / p on each actuated coordinate).
  template <class G2 = Generated, std::enable_if_t<G2::kHas_forward_dynamics_derivatives, int> = 0>
  Velocity forward_dynamics_derivatives(const Vector& q, const Velocity& qd, const Velocity& Q,
                                        TangentJacobian& dqdd_dq, Matrix& dqdd_dqd,
                                        TorqueJacobian& dqdd_dtau) const {
    check_finite_inputs(q, qd, Q, Generated::kName, Generated::coordinate_names());
    Velocity qdd;
    Generated::forward_dynamics_derivatives(q, qd, Q, params_, dqdd_dq, dqdd_dqd, qdd, dqdd_dtau);
    if (!dqdd_dq.allFinite() || !dqdd_dqd.allFinite() || !qdd.allFinite() || !dqdd_dtau.allFinite())
      throw DynamicsError(std::string("model ") + Generated::kName +
                          ": the state Jacobian is not finite (mass matrix singular?)");
    return qdd;
  }
  template <class G2 = Generated, std::enable_if_t<G2::kHas_forward_dynamics_derivatives, int> = 0>
  Velocity forward_dynamics_derivatives(const Vector& q, const Velocity& qd, const Velocity& Q,
                                        TangentJacobian& dqdd_dq, Matrix& dqdd_dqd) const {
    TorqueJacobian dqdd_dtau;
    return forward_dynamics_derivatives(q, qd, Q, dqdd_dq, dqdd_dqd, dqdd_dtau);
  }

  // 2-norm condition number of M(q) (symmetric positive definite: ratio of eigenvalues).
  double condition_number(const Vector& q) const { return spd_condition_number(mass_matrix(q)); }
  // The same for diag(M)^-1/2 M diag(M)^-1/2, which is what bounds the accuracy of
  // forward_dynamics (see there); it does not grow with the units or the gear ratios.
  double scaled_condition_number(const Vector& q) const {
    const Matrix M = mass_matrix(q);
    const Velocity s = M.diagonal().cwiseSqrt().cwiseInverse();
    return spd_condition_number(s.asDiagonal() * M * s.asDiagonal());
  }

 private:
  static double spd_condition_number(const Matrix& A) {
    const Eigen::SelfAdjointEigenSolver<Matrix> eig(A, Eigen::EigenvaluesOnly);
    return eig.eigenvalues().maxCoeff() / eig.eigenvalues().minCoeff();
  }

  Params params_;
  JointVector ratios_;
  std::array<int, kNumLinks> actuated_ = actuated_coordinates();

  void update() {
    if (const char* error = Generated::parameter_error(params_))
      throw std::invalid_argument(std::string("model ") + Generated::kName + ": " + error);
    // The ratios' range is the scene's rule (parameter_rules.hpp), checked above at run time.
    Generated::gear_ratios(params_, ratios_);
  }
};

}  // namespace spacearm
