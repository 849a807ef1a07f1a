// Trajectory planning for a free-floating manipulator by the inverse-dynamics approach
// (Basmadji, Seweryn and Sasiadek 2020, as used in the paper's Section 3): the end-effector
// follows a straight line in the world frame with constant orientation while the total
// momentum stays zero and the base floats freely. Momentum conservation eliminates the
// base velocities (generalized Jacobian): [J_ee; M_base,:] qd = [v_ee; 0]. Joint torques
// then come from eq. 5 of the reference model.
#pragma once

#include <Eigen/LU>

#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "integrators.hpp"
#include "model.hpp"

namespace spacearm {

enum class TimeLaw { quintic, cubic };

inline TimeLaw time_law_from_string(const std::string& s) {
  if (s == "quintic") return TimeLaw::quintic;
  if (s == "cubic") return TimeLaw::cubic;
  throw std::invalid_argument("unknown time law '" + s + "' (known: quintic, cubic)");
}

// Path parameter s(tau) in [0, 1] and its first two derivatives with respect to tau = t/T.
inline Eigen::Vector3d time_law(TimeLaw law, double tau) {
  tau = std::clamp(tau, 0.0, 1.0);
  const double t2 = tau * tau, t3 = t2 * tau;
  if (law == TimeLaw::cubic) return {3 * t2 - 2 * t3, 6 * tau - 6 * t2, 6 - 12 * tau};
  return {10 * t3 - 15 * t3 * tau + 6 * t3 * t2, 30 * t2 - 60 * t3 + 30 * t2 * t2, 60 * tau - 180 * t2 + 120 * t3};
}

struct StraightLineTask {
  Eigen::Vector3d start{1.5, 0.0, M_PI / 6};  // end-effector [x, y, phi] at t = 0
  Eigen::Vector3d goal{1.1, 0.0, M_PI / 6};
  double duration = 10.0;  // s
  double dt = 0.01;        // output grid of the plan
  TimeLaw law = TimeLaw::quintic;
  int elbow = +1;          // sign of the second joint angle at the start
};

template <class G>
struct Plan {
  using M = Model<G>;
  std::vector<double> t;
  std::vector<typename M::Vector> q, qd, qdd;
  std::vector<typename M::JointVector> tau;  // joint torques from eq. 5 (reference model)
  // Forces on the base, max |(M qdd + C qd)_base| along the plan, with qdd taken by central
  // differences of the planned qd over the grid (an independent check of the plan: O(dt^2)).
  double max_base_residual = 0;
  double max_path_error = 0;      // max |x_ee(q(t)) - x_desired(t)| (position and angle)
  double max_momentum = 0;        // max |h(q, qd)| along the plan
};

// Arm joint angles that put the end-effector at `pose` with the base at the origin and
// q0 = 0, by Newton's method on the end-effector pose; `elbow` picks the branch by the
// sign of joint 2.
template <class G>
typename Model<G>::Vector initial_configuration(const Model<G>& model, const Eigen::Vector3d& pose, int elbow) {
  using M = Model<G>;
  static_assert(M::kNumLinks == 3, "the straight-line planner needs a 3-link arm (3 task coordinates)");
  constexpr int j0 = M::kFirstJoint;
  typename M::Vector q = M::Vector::Zero();
  q[j0 + 0] = 0.3 * -elbow;
  q[j0 + 1] = 1.2 * elbow;
  q[j0 + 2] = -0.5 * elbow;
  for (int it = 0; it < 100; ++it) {
    const Eigen::Vector3d err = pose - model.end_effector_pose(q);
    if (err.norm() < 1e-14) break;
    const Eigen::Matrix3d J = model.end_effector_jacobian(q).template block<3, 3>(0, j0);
    q.template segment<3>(j0) += J.fullPivLu().solve(err);
  }
  const Eigen::Vector3d err = pose - model.end_effector_pose(q);
  if (!(err.norm() < 1e-12) || q[j0 + 1] * elbow <= 0)
    throw std::runtime_error("initial_configuration: no solution on elbow branch " + std::to_string(elbow) +
                             " for the end-effector pose (" + std::to_string(pose[0]) + ", " +
                             std::to_string(pose[1]) + ", " + std::to_string(pose[2]) + ")");
  return q;
}

template <class G>
Plan<G> plan_straight_line(const Model<G>& model, const StraightLineTask& task) {
  using M = Model<G>;
  static_assert(M::kFreeFloating && M::kNumLinks == 3, "planner: free-floating base and 3 links");
  constexpr int n = M::kNq;
  using Vector = typename M::Vector;
  using Matrix = typename M::Matrix;
  const double T = task.duration;
  auto desired = [&](double t, Eigen::Vector3d& x, Eigen::Vector3d& v, Eigen::Vector3d& a) {
    const Eigen::Vector3d s = time_law(task.law, t / T);
    const Eigen::Vector3d d = task.goal - task.start;
    x = task.start + s[0] * d;
    v = s[1] / T * d;
    a = s[2] / (T * T) * d;
  };
  // Generalized Jacobian system: A(q) = [J_ee; M_base rows]. Zero base-row momentum
  // M_base qd = 0 is zero linear and angular momentum (L = M_q0,: qd + x0 Py - y0 Px).
  auto system_matrix = [&](const Vector& q) {
    Matrix A;
    A.template topRows<3>() = model.end_effector_jacobian(q);
    A.template bottomRows<3>() = model.mass_matrix(q).template topRows<3>();
    return A;
  };
  auto velocity = [&](const Vector& q, double t) {
    Eigen::Vector3d x, v, a;
    desired(t, x, v, a);
    Vector rhs;
    rhs << v, Eigen::Vector3d::Zero();
    const Eigen::PartialPivLU<Matrix> lu(system_matrix(q));
    // Near a singularity of the generalized Jacobian (e.g. the arm stretched at the edge of
    // the workspace) the joint rates blow up: stop with a reason instead of integrating noise.
    if (!(lu.rcond() > 1e-10))
      throw std::runtime_error("plan_straight_line: generalized Jacobian singular (rcond " +
                               std::to_string(lu.rcond()) + ") at t = " + std::to_string(t) +
                               ": the path leaves the workspace or crosses a singularity");
    return Vector(lu.solve(rhs));
  };

  Vector q = initial_configuration(model, task.start, task.elbow);
  Plan<G> plan;
  IntegratorOptions opt;
  opt.method = Method::rkf78;
  opt.rtol = 1e-13;
  opt.atol = 1e-14;
  auto f = [&](const Vector& s, Vector& dsdt, double t) { dsdt = velocity(s, t); };
  auto observe = [&](const Vector& s, double t) {
    plan.t.push_back(t);
    plan.q.push_back(s);
  };
  try {
    integrate(opt, f, q, 0.0, T, task.dt, observe);
  } catch (const IntegrationError& e) {
    // Say why: the line cannot be followed past a singularity of the generalized Jacobian.
    const Vector q_last = e.state();
    throw std::runtime_error("plan_straight_line: cannot follow the line beyond t = " + std::to_string(e.t()) +
                             " s: the generalized Jacobian becomes singular there (rcond " +
                             std::to_string(system_matrix(q_last).partialPivLu().rcond()) +
                             "; the arm is stretched or folded, or the line leaves the workspace). " + e.what());
  }

  for (size_t k = 0; k < plan.t.size(); ++k) {
    const double t = plan.t[k];
    const Vector& qk = plan.q[k];
    const Vector qd = velocity(qk, t);
    Eigen::Vector3d x, v, a;
    desired(t, x, v, a);
    // d/dt of A qd = [v; 0]: A qdd = [a - Jdot qd; -(Mdot qd)_base]. The base rows are
    // imposed as M_base qdd = -b_base, i.e. no force on the base (eq. 5); this equals
    // -(Mdot qd)_base because b_base - (Mdot qd)_base = -dT/dq_base, which is zero on a
    // zero-momentum motion (dT/dx0 = dT/dy0 = 0, dT/dq0 = -r0d x P). Jdot qd by central
    // differences of J along qd.
    Matrix Mk;
    Vector b;
    model.mass_matrix_and_bias(qk, qd, Mk, b);
    const double eps = 1e-6;
    const Eigen::Vector3d Jdot_qd =
        (model.end_effector_jacobian(qk + eps * qd) - model.end_effector_jacobian(qk - eps * qd)) * qd / (2 * eps);
    Vector rhs;
    rhs << a - Jdot_qd, -b.template head<3>();
    const Vector qdd = system_matrix(qk).partialPivLu().solve(rhs);
    const Vector Q = Mk * qdd + b;  // eq. 5
    plan.qd.push_back(qd);
    plan.qdd.push_back(qdd);
    plan.tau.push_back(Q.template tail<3>());
    plan.max_path_error = std::max(plan.max_path_error, (model.end_effector_pose(qk) - x).cwiseAbs().maxCoeff());
    plan.max_momentum = std::max(plan.max_momentum, model.momentum(qk, qd).cwiseAbs().maxCoeff());
  }
  for (size_t k = 1; k + 1 < plan.t.size(); ++k) {
    const Vector qdd_fd = (plan.qd[k + 1] - plan.qd[k - 1]) / (plan.t[k + 1] - plan.t[k - 1]);
    Matrix Mk;
    Vector b;
    model.mass_matrix_and_bias(plan.q[k], plan.qd[k], Mk, b);
    plan.max_base_residual =
        std::max(plan.max_base_residual, (Mk * qdd_fd + b).template head<3>().cwiseAbs().maxCoeff());
  }
  (void)n;
  return plan;
}

}  // namespace spacearm
