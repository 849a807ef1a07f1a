// The table of a simulation, as `spacearm simulate` writes it and Python returns it: one row per
// sample of t, the coordinates and their rates; for a geared model the link-side angles and
// rates of the joints whose slot holds a motor angle; the link-side torques tau1..N and, geared,
// the motor torques tau_motor = tau / p (eq. 14); then what the model emits of the end-effector
// pose, kinetic and potential energy and momentum (in 3D: the pose's position and quaternion,
// linear and angular momentum).
#pragma once

#include <string>
#include <vector>

#include "dynamic_model.hpp"

namespace spacearm {

class SimulationTable {
 public:
  // geared: the scene has a gear in some joint (its torques have a motor side).
  SimulationTable(const DynamicModel& model, bool geared) : m_(model), geared_(geared) {
    names_.push_back("t");
    for (const auto& n : m_.coordinate_names) names_.push_back(n);
    for (const auto& n : m_.velocity_names()) names_.push_back(n);
    const int N = m_.num_links;
    if (geared_) {
      for (int j = 1; j <= N; ++j)
        if (link_side(j - 1)) names_.push_back("q" + std::to_string(j));
      for (int j = 1; j <= N; ++j)
        if (link_side(j - 1)) names_.push_back("q" + std::to_string(j) + "d");
    }
    for (int j = 1; j <= N; ++j) names_.push_back("tau" + std::to_string(j));
    if (geared_)
      for (int j = 1; j <= N; ++j) names_.push_back("tau_motor" + std::to_string(j));
    const std::vector<std::string> pose = end_effector_columns(m_);
    names_.insert(names_.end(), pose.begin(), pose.end());
    if (m_.kinetic_energy) names_.push_back("kinetic_energy");
    if (m_.potential_energy) names_.push_back("potential_energy");
    const std::vector<std::string> momentum = momentum_columns(m_);
    names_.insert(names_.end(), momentum.begin(), momentum.end());
  }

  const std::vector<std::string>& names() const { return names_; }

  // The row of one sample, in the order of names().
  void row(double t, const Eigen::VectorXd& q, const Eigen::VectorXd& qd,
           const Eigen::VectorXd& tau, std::vector<double>& out) const {
    const int N = m_.num_links;
    out.assign(1, t);
    out.insert(out.end(), q.data(), q.data() + q.size());
    out.insert(out.end(), qd.data(), qd.data() + qd.size());
    if (geared_) {
      const Eigen::VectorXd angles = m_.joint_angles(q), rates = m_.joint_rates(qd);
      for (int j = 0; j < N; ++j)
        if (link_side(j)) out.push_back(angles[j]);
      for (int j = 0; j < N; ++j)
        if (link_side(j)) out.push_back(rates[j]);
    }
    out.insert(out.end(), tau.data(), tau.data() + N);
    if (geared_)
      for (int j = 0; j < N; ++j) out.push_back(tau[j] / m_.gear_ratios[j]);
    if (m_.end_effector_pose) {
      const Eigen::VectorXd pose = m_.end_effector_pose(q);
      out.insert(out.end(), pose.data(), pose.data() + pose.size());
    }
    if (m_.kinetic_energy) out.push_back(m_.kinetic_energy(q, qd));
    if (m_.potential_energy) out.push_back(m_.potential_energy(q));
    if (m_.momentum) {
      const Eigen::VectorXd h = m_.momentum(q, qd);
      out.insert(out.end(), h.data(), h.data() + h.size());
    }
  }

 private:
  // Whether joint j gets link-side columns: only where its slot holds the motor angle (a rigid
  // gear); a flexible or ungeared joint's slot is already q_j, and a repeated column name would
  // make the table ambiguous.
  bool link_side(int j) const { return m_.slot_holds_motor(j); }

  const DynamicModel& m_;
  bool geared_;
  std::vector<std::string> names_;
};

}  // namespace spacearm
