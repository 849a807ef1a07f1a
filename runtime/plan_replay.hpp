// A plan replayed into any scene with the same base and joints: the rigid scene plans (the
// planner refuses springs and friction), its geared, flexible or friction twin flies it.
// The plan file is the CSV `spacearm plan` writes; read as untrusted text, its columns found by
// name (t, tau1..N, the link-side angles q1..N and rates q1d..qNd, and for a free base
// x0,y0,q0 and their rates, or in 3D x0,y0,z0,qw0..qz0 and vx0..wz0), every other column ignored.
// The start is mapped to the scene's coordinates (motor angles p q, a flexible joint's spring
// pre-deflected by consistent_start); the torques stay link side and reach a motor as tau/p (eq.
// 14); friction can be fed forward from the scene's own friction law along the planned rates.
#pragma once

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <map>
#include <stdexcept>
#include <sstream>
#include <string>
#include <vector>

#include "consistent_start.hpp"
#include "dynamic_model.hpp"
#include "joint_control.hpp"
#include "torque_csv.hpp"
#include "trajectory_planning.hpp"

namespace spacearm {

struct PlanSamples {
  TorqueTable torques;  // tau1..N, link side, on the plan's grid
  // Per sample: the base pose and its rates (empty for a fixed base), link-side angles, rates.
  std::vector<Eigen::VectorXd> base, base_rate, angles, rates;
  // The end effector's pose the plan wrote at its first and last rows (its ee_ columns; empty
  // for a plan without them): check_plan_kinematics compares them with the replaying scene.
  std::vector<Eigen::VectorXd> end_effector;
};

namespace detail {
// The plan columns a scene with `num_joints` joints and this base needs, in reading order.
inline std::vector<std::string> plan_columns(int num_joints, bool free_floating, bool spatial) {
  std::vector<std::string> names = torque_csv_columns(num_joints);
  if (free_floating && spatial)
    for (const char* n :
         {"x0", "y0", "z0", "qw0", "qx0", "qy0", "qz0", "vx0", "vy0", "vz0", "wx0", "wy0", "wz0"})
      names.push_back(n);
  else if (free_floating)
    for (const char* n : {"x0", "y0", "q0", "x0d", "y0d", "q0d"}) names.push_back(n);
  for (const char* suffix : {"", "d"})
    for (int j = 1; j <= num_joints; ++j) names.push_back("q" + std::to_string(j) + suffix);
  return names;
}
}  // namespace detail

// A plan computed in memory (plan_straight_line on `planner`), as the samples a replay reads.
inline PlanSamples plan_samples(const Plan& plan, const DynamicModel& planner) {
  PlanSamples s;
  const int nb = planner.num_base();
  s.torques.t0 = plan.t.front();
  s.torques.dt = plan.t.size() > 1 ? plan.t[1] - plan.t[0] : 0;
  s.torques.samples = plan.tau;
  for (size_t k = 0; k < plan.t.size(); ++k) {
    s.base.push_back(plan.q[k].head(planner.base_coordinates()));
    s.base_rate.push_back(plan.qd[k].head(nb));
    s.angles.push_back(planner.joint_angles(plan.q[k]));
    s.rates.push_back(planner.joint_rates(plan.qd[k]));
  }
  return s;
}

namespace detail {

// A plan's header (on line `line`): its columns by name, checked against the scene's base and
// joints (a plan made for another base or number of joints is named as such).
inline std::map<std::string, size_t> plan_header(const std::vector<std::string>& header, long line,
                                                 int num_joints, bool free_floating, bool spatial,
                                                 const CsvErrors& fail) {
  std::map<std::string, size_t> column;
  for (size_t c = 0; c < header.size(); ++c)
    if (!column.insert({header[c], c}).second && !header[c].empty())
      throw fail(line, "column " + quoted_text(header[c]) + " appears twice");
  // The plan's base and joints must be the scene's.
  const std::string more = "tau" + std::to_string(num_joints + 1);
  if (column.count(more))
    throw fail(line, "has a column '" + more + "': it was planned for more than " +
                         std::to_string(num_joints) + " joints");
  if (column.count("x0") != static_cast<size_t>(free_floating))
    throw fail(line, free_floating ? "has no column 'x0': it was planned on a fixed base "
                                     "and the scene's base is free_floating"
                                   : "has a column 'x0': it was planned on a "
                                     "free-floating base and the scene's base is fixed");
  if (free_floating && column.count("z0") != static_cast<size_t>(spatial))
    throw fail(line, spatial ? "has no column 'z0': it was planned on a planar arm and "
                               "the scene is spatial"
                             : "has a column 'z0': it was planned on a spatial arm and "
                               "the scene is planar");
  const std::vector<std::string> needed = plan_columns(num_joints, free_floating, spatial);
  for (const auto& n : needed)
    if (!column.count(n))
      throw fail(line, "missing column '" + n + "' (a plan from spacearm plan has it" +
                           (n[0] == 'q' ? "; replan with this version" : "") + ")");
  return column;
}

// The end effector's pose at a plan's first and last rows, where the plan has it (empty if not).
inline std::vector<Eigen::VectorXd> plan_end_effector(
    const std::vector<std::pair<long, std::string>>& lines,
    const std::map<std::string, size_t>& column, bool spatial, const std::string& where) {
  std::vector<Eigen::VectorXd> poses;
  const std::vector<std::string> one = end_effector_columns(spatial);
  std::vector<std::string> ee = one;
  if (!std::all_of(ee.begin(), ee.end(), [&](const auto& n) { return column.count(n); })) {
    // A tree's plan: each end effector's columns (PREFIX_x ... as end_effector_columns names
    // them), in the table's order, stacked as the model's poses are.
    ee.clear();
    std::vector<std::pair<size_t, std::string>> ordered;
    for (const auto& [name, at] : column) ordered.push_back({at, name});
    std::sort(ordered.begin(), ordered.end());
    for (const auto& [at, name] : ordered) {
      if (name.rfind("ee", 0) != 0 || name.size() < 3 || name.substr(name.size() - 2) != "_x")
        continue;
      const std::string prefix = name.substr(0, name.size() - 1);  // up to the "_"
      std::vector<std::string> block;
      for (const std::string& c : one) block.push_back(prefix + c.substr(3));
      if (std::all_of(block.begin(), block.end(), [&](const auto& n) { return column.count(n); }))
        ee.insert(ee.end(), block.begin(), block.end());
    }
    if (ee.empty()) return poses;
  }
  for (const size_t r : {size_t(1), lines.size() - 1}) {
    const auto fields = split_csv_line(lines[r].second);
    Eigen::VectorXd x(static_cast<Eigen::Index>(ee.size()));
    for (size_t c = 0; c < ee.size(); ++c)
      x[static_cast<Eigen::Index>(c)] =
          parse_number(fields[column.at(ee[c])], where + " line " + std::to_string(lines[r].first) +
                                                     ", column '" + ee[c] + "'");
    poses.push_back(x);
  }
  return poses;
}

}  // namespace detail

// Reads a plan for a scene with num_joints joints (spatial: a base floating in 3D); errors name
// the file, line and column, and say when the plan was made for another base or number of joints.
inline PlanSamples read_plan_csv(const std::string& text, int num_joints, bool free_floating,
                                 const std::string& source, bool spatial = false) {
  const std::string where = "plan file '" + source + "'";
  const detail::CsvErrors fail{where};
  const auto lines = detail::csv_lines(text);
  if (lines.empty()) throw fail(0, "empty; write one with spacearm plan");
  const auto header = detail::split_csv_line(lines[0].second);
  const std::map<std::string, size_t> column =
      detail::plan_header(header, lines[0].first, num_joints, free_floating, spatial, fail);
  const std::vector<std::string> needed = detail::plan_columns(num_joints, free_floating, spatial);
  // Rows: the needed columns must be finite numbers; the others are not read.
  PlanSamples plan;
  std::vector<double> times;
  const int pose = !free_floating ? 0
                   : spatial      ? 7
                                  : 3,
            rate = !free_floating ? 0
                   : spatial      ? 6
                                  : 3;
  for (size_t r = 1; r < lines.size(); ++r) {
    const long number = lines[r].first;
    const auto fields = detail::split_csv_line(lines[r].second);
    if (fields.size() != header.size())
      throw fail(number, "expected " + std::to_string(header.size()) + " fields, got " +
                             std::to_string(fields.size()));
    std::vector<double> v;
    for (const auto& n : needed)
      v.push_back(parse_number(fields[column.at(n)],
                               where + " line " + std::to_string(number) + ", column '" + n + "'"));
    times.push_back(v[0]);
    const double* at = v.data() + 1;
    auto take = [&](int n) {
      const Eigen::VectorXd x = Eigen::Map<const Eigen::VectorXd>(at, n);
      at += n;
      return x;
    };
    plan.torques.samples.push_back(take(num_joints));
    plan.base.push_back(take(pose));
    if (spatial && free_floating) {  // the model takes any quaternion whose norm squares safely
      const double norm = plan.base.back().segment<4>(3).norm();
      if (!ConfigurationSpace::takes_quaternion_norm(norm))
        throw fail(number, "columns qw0..qz0, the base's orientation quaternion, have norm " +
                               number_text(norm) + ": expected a unit quaternion");
    }
    plan.base_rate.push_back(take(rate));
    plan.angles.push_back(take(num_joints));
    // Angles within ConfigurationSpace's bound: the joints', and a planar base's q0.
    const Eigen::VectorXd& base_pose = plan.base.back();
    std::vector<std::string> joint_names;
    for (int j = 1; j <= num_joints; ++j) joint_names.push_back("q" + std::to_string(j));
    std::string bad =
        ConfigurationSpace::angle_error(plan.angles.back(), 0, "joint angle", joint_names);
    if (bad.empty())  // a planar base's q0 (a spatial base pose holds no angle)
      bad = ConfigurationSpace::angle_error(base_pose,
                                            ConfigurationSpace::first_angle(free_floating, spatial),
                                            "base pose", {"x0", "y0", "q0"});
    if (!bad.empty()) throw fail(number, bad);
    plan.rates.push_back(take(num_joints));
  }
  if (times.size() < 2)
    throw fail(0, "needs at least two rows of samples, got " + std::to_string(times.size()));
  plan.end_effector = detail::plan_end_effector(lines, column, spatial, where);
  detail::set_uniform_grid(
      plan.torques, times, [&](size_t k) { return lines[k + 1].first; }, fail);
  // The replay starts at t = 0 in the plan's first state: a plan that starts later would pair
  // that state with torques from another time.
  if (!(std::abs(times.front()) <= 1e-9 * std::max(1.0, std::abs(times.back()))))
    throw fail(lines[1].first, "column 't' starts at " + number_text(times.front()) +
                                   " s; a plan starts at t = 0 (its first row is the start)");
  return plan;
}

// Whether the plan was made for this arm (issue 49: a 7-joint plan replayed into another
// 7-joint arm was accepted): the model's end effector from the plan's base and joint angles at
// its first and last rows, against the pose the plan wrote there. Empty when they agree (1e-6 m
// relative, 1e-6 rad), else what differs. *compared: false where either lacks the pose (a plan
// without ee_ columns, a scene without end_effector_pose), and then nothing is said.
inline std::string plan_kinematics_mismatch(const DynamicModel& model, const PlanSamples& plan,
                                            bool* compared = nullptr) {
  const bool can = model.end_effector_pose && plan.end_effector.size() == 2;
  if (compared) *compared = can;
  if (!can) return "";
  const size_t rows[2] = {0, plan.base.size() - 1};
  for (int k = 0; k < 2; ++k) {
    const size_t r = rows[k];
    const Eigen::VectorXd mine =
        model.end_effector_pose(model.from_joint_angles(plan.base[r], plan.angles[r]));
    const Eigen::VectorXd& theirs = plan.end_effector[static_cast<size_t>(k)];
    if (mine.size() != theirs.size())
      return "the plan's end-effector poses have another size (" + std::to_string(theirs.size()) +
             " values, this scene's " + std::to_string(mine.size()) + ")";
    const int np = model.spatial ? 3 : 2, values = model.spatial ? 7 : 3;
    for (Eigen::Index at = 0; at < mine.size(); at += values) {  // each end effector's pose
      const Eigen::VectorXd a = mine.segment(at, values), b = theirs.segment(at, values);
      const double apart = (a.head(np) - b.head(np)).norm();
      double turn = 0;  // the angle between the two orientations
      if (model.spatial) {
        const double dot = std::abs(a.tail(4).normalized().dot(b.tail(4).normalized()));
        turn = 2 * std::acos(std::min(1.0, dot));
      } else {
        turn = std::abs(std::remainder(a[2] - b[2], 2 * M_PI));
      }
      if (apart <= 1e-6 * std::max(1.0, b.head(np).norm()) && turn <= 1e-6) continue;
      std::ostringstream m;
      m.precision(6);
      m << "at t = " << plan.torques.t0 + static_cast<double>(r) * plan.torques.dt
        << " s the plan's "
        << (mine.size() > values ? "end effector " + std::to_string(at / values + 1)
                                 : std::string("end effector"))
        << " is at (";
      for (int i = 0; i < np; ++i) m << (i ? ", " : "") << b[i];
      m << ") and this scene's, from the same base pose and joint angles, at (";
      for (int i = 0; i < np; ++i) m << (i ? ", " : "") << a[i];
      m << "): " << apart << " m apart, orientations " << turn << " rad apart";
      return m.str();
    }
  }
  return "";
}

// The plan's start in the model's coordinates: the base and link-side angles and rates of its
// first sample, a geared joint's motor at p q, a flexible joint's spring pre-deflected to carry
// tau0 (consistent_start; tau0 is the plan's first torque plus any feed-forward). Returns the
// pre-deflections (0 where a joint is not flexible).
inline Eigen::VectorXd replay_start(const DynamicModel& model, const PlanSamples& plan,
                                    const Eigen::VectorXd& tau0, Eigen::VectorXd& q0,
                                    Eigen::VectorXd& qd0) {
  q0 = model.from_joint_angles(plan.base.front(), plan.angles.front());
  qd0 = model.from_joint_rates(plan.base_rate.front(), plan.rates.front());
  return consistent_start(model, q0, qd0, tau0);
}

// The plan's link-side joint motion as a target for a joint controller (joint_control.hpp):
// angles and rates from the plan, accelerations by central differences of the rates (second
// order; one-sided at the ends).
inline SampledJointTrajectory joint_target(const PlanSamples& plan) {
  const size_t n = plan.rates.size();
  const double h = plan.torques.dt;
  std::vector<Eigen::VectorXd> qdd(n);
  for (size_t k = 0; k < n; ++k) {
    const size_t a = k == 0 ? 0 : k - 1, b = k + 1 == n ? n - 1 : k + 1;
    qdd[k] = (plan.rates[b] - plan.rates[a]) / (h * static_cast<double>(b - a));
  }
  return SampledJointTrajectory(plan.torques.t0, h, plan.angles, plan.rates, qdd);
}

// The link-side torque that the model's friction takes at each planned sample: p_j f_j(w) on
// joint j, w its motor rate p q_j' (the scene's own friction law, its output friction_forces).
// Springs and dampers are relaxed along a rigid plan, so friction is all that the planned
// torques lack.
inline std::vector<Eigen::VectorXd> friction_along(const DynamicModel& model,
                                                   const PlanSamples& plan) {
  if (!model.friction_forces)
    throw std::invalid_argument("model " + model.name +
                                " does not emit friction_forces (its scene needs 'friction:', and "
                                "friction_forces in 'outputs' where it lists them)");
  std::vector<Eigen::VectorXd> tau_f;
  for (size_t k = 0; k < plan.rates.size(); ++k) {
    const Eigen::VectorXd f =
        model.friction_forces(model.from_joint_rates(plan.base_rate[k], plan.rates[k]));
    Eigen::VectorXd t(model.num_links);
    for (int j = 0; j < model.num_links; ++j)
      t[j] = model.gear_ratios[j] * f[model.actuated_coordinates.at(j)];
    tau_f.push_back(t);
  }
  return tau_f;
}

// Feeds the model's friction along the plan forward: adds friction_along to its torques.
inline void feed_friction_forward(const DynamicModel& model, PlanSamples& plan) {
  const std::vector<Eigen::VectorXd> tau_f = friction_along(model, plan);
  for (size_t k = 0; k < tau_f.size(); ++k) plan.torques.samples[k] += tau_f[k];
}

// The joints (1-based) where friction along the plan reaches the planned torque's peak: the
// motor stalls or crawls there unless the friction is fed forward.
inline std::vector<int> joints_stalled_by_friction(const PlanSamples& plan,
                                                   const std::vector<Eigen::VectorXd>& tau_f) {
  std::vector<int> joints;
  const long N = plan.torques.samples.front().size();
  for (long j = 0; j < N; ++j) {
    double tau_peak = 0, friction_peak = 0;
    for (size_t k = 0; k < tau_f.size(); ++k) {
      tau_peak = std::max(tau_peak, std::abs(plan.torques.samples[k][j]));
      friction_peak = std::max(friction_peak, std::abs(tau_f[k][j]));
    }
    if (friction_peak > 0 && friction_peak >= tau_peak) joints.push_back(static_cast<int>(j + 1));
  }
  return joints;
}

}  // namespace spacearm
