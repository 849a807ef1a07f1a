// A consistent initial state for flexible joints: the motor angle qm = p (q + e) with the
// spring pre-deflected by e so that it carries the torque the link needs at t = 0, i.e. the
// motor and the link side start with the same acceleration (qdd_m = p qdd_q), as a rigid gear
// would have them; qm = p q instead would start the springs relaxed and ring the joint modes.
// Only the model's forward dynamics is used: the accelerations are affine in the
// pre-deflections (M does not depend on the motor angles; the spring forces are linear in
// them), so one linear solve finds them, from N + 1 evaluations.
#pragma once

#include <Eigen/Dense>

#include <stdexcept>
#include <string>
#include <vector>

#include "dynamic_model.hpp"

namespace spacearm {

// Sets the motor coordinates of the flexible joints in (q, qd): qd_m = p qd_q and
// qm = p (q + e) with e from the torques tau (link side, eq. 14) acting at that state. The base
// and the joint slots (link angles of flexible joints, motor angles of rigid gears) are kept.
// Returns e, one entry per joint (0 where not flexible). Throws std::invalid_argument if the
// pre-deflections are not determined by the accelerations (a degenerate model).
inline Eigen::VectorXd consistent_start(const DynamicModel& model, Eigen::VectorXd& q,
                                        Eigen::VectorXd& qd, const Eigen::VectorXd& tau) {
  const int N = model.num_links;
  const std::vector<int>& actuated = model.actuated_coordinates;
  const Eigen::VectorXd& ratios = model.gear_ratios;
  // Joint j's slot follows the base; a flexible joint's torque drives a motor coordinate
  // after all the slots instead (velocity indices; slot_q and motor_q are their places in q).
  auto slot = [&](int j) { return model.joint_v_offsets.at(j); };
  auto slot_q = [&](int j) { return model.joint_q_offsets.at(j); };
  auto motor_q = [&](int j) { return model.q_index(actuated[j]); };
  std::vector<int> flexible;
  for (int j = 0; j < N; ++j)
    if (actuated[j] != slot(j)) flexible.push_back(j);
  Eigen::VectorXd e = Eigen::VectorXd::Zero(N);
  if (flexible.empty()) return e;
  const Eigen::VectorXd Q = model.generalized_forces(tau);
  for (int j : flexible) qd[actuated[j]] = ratios[j] * qd[slot(j)];
  // The mismatch qdd_m - p qdd_q of each flexible joint for deflections d.
  auto mismatch = [&](const Eigen::VectorXd& d) {
    Eigen::VectorXd x = q;
    for (size_t k = 0; k < flexible.size(); ++k) {
      const int j = flexible[k];
      x[motor_q(j)] = ratios[j] * (q[slot_q(j)] + d[k]);
    }
    const Eigen::VectorXd qdd = model.forward_dynamics(x, qd, Q);
    Eigen::VectorXd r(flexible.size());
    for (size_t k = 0; k < flexible.size(); ++k) {
      const int j = flexible[k];
      r[k] = qdd[actuated[j]] - ratios[j] * qdd[slot(j)];
    }
    return r;
  };
  const int F = static_cast<int>(flexible.size());
  const Eigen::VectorXd r0 = mismatch(Eigen::VectorXd::Zero(F));
  Eigen::MatrixXd A(F, F);
  for (int k = 0; k < F; ++k) A.col(k) = mismatch(Eigen::VectorXd::Unit(F, k)) - r0;
  const Eigen::FullPivLU<Eigen::MatrixXd> lu(A);
  if (!lu.isInvertible())
    throw std::invalid_argument(
        "consistent_start: the springs' pre-deflections are not "
        "determined by the accelerations (singular system)");
  const Eigen::VectorXd d = lu.solve(-r0);
  for (int k = 0; k < F; ++k) {
    const int j = flexible[k];
    e[j] = d[k];
    q[motor_q(j)] = ratios[j] * (q[slot_q(j)] + d[k]);
  }
  return e;
}

// The same for a linked model, through its dynamic-size view.
template <class G>
Eigen::VectorXd consistent_start(const Model<G>& model, typename Model<G>::Vector& q,
                                 typename Model<G>::Velocity& qd,
                                 const typename Model<G>::JointVector& tau) {
  Eigen::VectorXd x = q, v = qd;
  const Eigen::VectorXd e = consistent_start(dynamic_model(model), x, v, Eigen::VectorXd(tau));
  q = x;
  qd = v;
  return e;
}

}  // namespace spacearm
