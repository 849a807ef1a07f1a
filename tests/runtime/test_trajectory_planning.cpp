// runtime/trajectory_planning.hpp and the paper's torque replay: straight line with
// constant orientation and zero momentum; the planned torques replayed into the reference
// model reproduce the line; p = 1 geared replay is the reference; geared replays agree
// with a high-order integration of the same replay.
#include "trajectory_planning.hpp"

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "compiled_model.hpp"
#include "fixed_n5_geared_params.hpp"
#include "free_n8.hpp"
#include "paper_geared.hpp"
#include "paper_reference.hpp"
#include "plain_arm7.hpp"
#include "simulation.hpp"
#include "support.hpp"
#include "torque_signal.hpp"

namespace spacearm {
namespace {

using RG = models::paper_reference::Model;
using GG = models::paper_geared::Model;
using Ref = Model<RG>;
using Geared = Model<GG>;

// f throws an E whose message contains `text`.
template <class E, class F>
void expect_throw_with(F f, const std::string& text) {
  try {
    f();
    ADD_FAILURE() << "no exception; expected one containing: " << text;
  } catch (const E& e) {
    EXPECT_NE(std::string(e.what()).find(text), std::string::npos) << e.what();
  }
}

struct Replay {
  ModelPlan<RG> plan;
  Trajectory<RG> reference;
};

Replay plan_and_replay(const StraightLineTask& task, Interpolation mode = Interpolation::linear) {
  const Ref ref;
  Replay r{plan_straight_line(ref, task), {}};
  const TorqueSignal<3> tau(0.0, task.dt, r.plan.tau, mode);
  IntegratorOptions opt;  // RK4, 0.01 s: the paper's setting
  opt.dt = task.dt;
  r.reference =
      simulate<RG>(ref, r.plan.q.front(), Ref::Vector::Zero(), tau, task.duration, task.dt, opt);
  return r;
}

Trajectory<GG> geared_replay(const Replay& r, const StraightLineTask& task, double p, double Im,
                             const IntegratorOptions& opt) {
  Geared g;
  g.set_parameter("p", p);
  g.set_parameter("Im", Im);
  Geared::Vector qm = r.plan.q.front();
  qm.tail<3>() *= p;  // q_m(0) = p q(0)
  const TorqueSignal<3> tau(0.0, task.dt, r.plan.tau, Interpolation::linear);
  return simulate<GG>(g, qm, Geared::Vector::Zero(), tau, task.duration, task.dt, opt);
}

TEST(TrajectoryPlanning, StraightLineConstantOrientationZeroMomentum) {
  for (int elbow : {+1, -1}) {
    StraightLineTask task;
    task.elbow = elbow;
    const Ref ref;
    const auto plan = plan_straight_line(ref, task);
    ASSERT_EQ(plan.t.size(), 1001u);
    EXPECT_LT(plan.max_path_error, 1e-10);
    EXPECT_LT(plan.max_momentum, 1e-12);
    // Forces on the base from eq. 5 with qdd by central differences: O(dt^2) only
    // (measured 7.0e-7 and 7.6e-7 N for the two branches).
    EXPECT_LT(plan.max_base_residual, 1e-6);
    // The end-effector did travel 0.4 m, the base rotated (13 deg or -6 deg, MODEL-NOTES).
    EXPECT_NEAR(ref.end_effector_pose(plan.q.back())[0], 1.1, 1e-10);
    const double base_turn = plan.q.back()[2] * 180 / M_PI;
    if (elbow > 0)
      EXPECT_NEAR(base_turn, 13, 1.0);
    else
      EXPECT_NEAR(base_turn, -6, 1.0);
    double max_tau = 0;
    for (const auto& t : plan.tau) max_tau = std::max(max_tau, t.cwiseAbs().maxCoeff());
    EXPECT_GT(max_tau, 0.0);
  }
}

// Issue 53: a plan reports how near it passes to a singularity of the generalized Jacobian. The
// paper's line runs inwards, away from the stretched arm: its smallest rcond is at the start. A
// line outwards, towards the stretched arm, has a smaller one at its end; both stay clear of the
// margin at which the planner stops, and the checks' line says so.
TEST(TrajectoryPlanning, APlanReportsHowNearItPassesToASingularity) {
  const Ref ref;
  StraightLineTask inwards, outwards;
  outwards.goal = Eigen::Vector3d(1.55, 0.0, M_PI / 6);
  const auto in = plan_straight_line(ref, inwards), out = plan_straight_line(ref, outwards);
  // The time law rests at both ends, so the extremes are flat there: near the start, near the end.
  EXPECT_LT(in.min_jacobian_rcond_t, 0.1 * inwards.duration);
  EXPECT_GT(out.min_jacobian_rcond_t, 0.9 * outwards.duration);
  EXPECT_LT(out.min_jacobian_rcond, 0.8 * in.min_jacobian_rcond);  // measured 0.14 and 0.26
  EXPECT_GT(out.min_jacobian_rcond, 100 * kMinJacobianRcond);
  const std::string text = plan_checks_text(plan_straight_line(dynamic_model(ref), outwards));
  EXPECT_NE(text.find("generalized Jacobian's rcond at least 1.41e-01 (at t = "), std::string::npos)
      << text;
}

TEST(TrajectoryPlanning, ReplayIntoReferenceReproducesTheLine) {
  StraightLineTask task;
  const auto r = plan_and_replay(task);
  double worst = 0;
  for (size_t k = 0; k < r.plan.t.size(); ++k)
    worst = std::max(worst,
                     (r.reference.end_effector[k] - Ref().end_effector_pose(r.plan.q[k])).norm());
  // Torques linearly interpolated between 0.01 s samples, RK4 at 0.01 s: a few micrometres.
  EXPECT_LT(worst, 1e-5);
  EXPECT_GT(worst, 0.0);
}

TEST(TrajectoryPlanning, GearedReplayAtUnitRatioIsTheReference) {
  StraightLineTask task;
  const auto r = plan_and_replay(task);
  IntegratorOptions opt;
  const auto g = geared_replay(r, task, 1.0, 1e-5, opt);
  EXPECT_LT((g.end_effector.back() - r.reference.end_effector.back()).norm(), 1e-12);
}

TEST(TrajectoryPlanning, GearedReplayAgreesWithHighOrderIntegration) {
  StraightLineTask task;
  const auto r = plan_and_replay(task);
  for (double p : {1.05, 10.0}) {
    SCOPED_TRACE("p = " + std::to_string(p));
    IntegratorOptions rk4;
    IntegratorOptions tight;
    tight.method = Method::rkf78;
    tight.rtol = 1e-12;
    tight.atol = 1e-13;
    const auto a = geared_replay(r, task, p, 1e-5, rk4);
    const auto b = geared_replay(r, task, p, 1e-5, tight);
    const Eigen::Vector3d dev = a.end_effector.back() - r.reference.end_effector.back();
    const Eigen::Vector3d dev_tight = b.end_effector.back() - r.reference.end_effector.back();
    ASSERT_GT(dev.head<2>().norm(), 1e-7);  // the gear does move the end-effector
    // RK4 at 0.01 s and RKF78 at 1e-12 agree on the deviation to 1e-7 m (the linear torque
    // interpolation is continuous, so the RK4 error is tiny compared with the deviation).
    EXPECT_LT((dev - dev_tight).head<2>().norm(), 1e-7);
  }
}

TEST(TrajectoryPlanning, DeviationsDoNotDependOnTheDuration) {
  // No stiffness, damping or gravity: torques scale as 1/T^2 and the final deviations do
  // not depend on T (MODEL-NOTES). Integrated accurately so only the physics is compared.
  Eigen::Vector2d dev[2];
  int i = 0;
  for (double T : {5.0, 20.0}) {
    StraightLineTask task;
    task.duration = T;
    const Ref ref;
    const auto plan = plan_straight_line(ref, task);
    IntegratorOptions tight;
    tight.method = Method::rkf78;
    tight.rtol = 1e-12;
    tight.atol = 1e-13;
    const TorqueSignal<3> tau(0.0, task.dt, plan.tau, Interpolation::linear);
    Replay r{plan, simulate<RG>(ref, plan.q.front(), Ref::Vector::Zero(), tau, T, task.dt, tight)};
    const auto g = geared_replay(r, task, 10.0, 1e-5, tight);
    dev[i++] = (g.end_effector.back() - r.reference.end_effector.back()).head<2>();
  }
  ASSERT_GT(dev[0].norm(), 1e-4);
  EXPECT_LT((dev[0] - dev[1]).norm(), 1e-3 * dev[0].norm());
}

TEST(TrajectoryPlanning, DrivenReplayBalancesEnergyAndKeepsMomentum) {
  StraightLineTask task;
  const auto r = plan_and_replay(task);
  const auto& tr = r.reference;
  // Change of kinetic energy equals the work of the joint torques (trapezoidal in time).
  double peak = 0;
  for (double T : tr.kinetic_energy) peak = std::max(peak, T);
  ASSERT_GT(peak, 0.0);
  EXPECT_LT(std::abs(tr.kinetic_energy.back() - tr.kinetic_energy.front() - tr.work.back()),
            1e-4 * peak);
  for (const auto& h : tr.momentum) EXPECT_LT(h.cwiseAbs().maxCoeff(), 1e-10);
}

// A redundant free-floating arm (8 links for a 3-coordinate pose): the line is followed with
// zero momentum, and the joint rates are the minimum-norm ones, i.e. in the range of A^T for
// A = [J; M_base] (checked with the normal equations, not the planner's QR).
TEST(TrajectoryPlanning, RedundantFreeFloatingArmTakesMinimumNormRates) {
  using G = models::free_n8::Model;
  const Model<G> model;
  StraightLineTask task;
  task.start = Eigen::Vector3d(2.4, 0.5, 0.4);
  task.goal = Eigen::Vector3d(2.0, 0.9, 0.8);
  task.duration = 4;
  const auto plan = plan_straight_line(model, task);
  ASSERT_EQ(plan.t.size(), 401u);
  EXPECT_LT(plan.max_path_error, 1e-10);
  EXPECT_LT(plan.max_momentum, 1e-12);
  double qd_peak = 0, qdd_peak = 0, tau_peak = 0;
  for (size_t k = 0; k < plan.t.size(); ++k) {
    tau_peak = std::max(tau_peak, plan.tau[k].cwiseAbs().maxCoeff());
    qd_peak = std::max(qd_peak, plan.qd[k].cwiseAbs().maxCoeff());
    qdd_peak = std::max(qdd_peak, plan.qdd[k].cwiseAbs().maxCoeff());
  }
  EXPECT_LT(plan.max_acceleration_mismatch, 1e-3 * qdd_peak);  // central differences, O(dt^2)
  // Forces on the base with qdd by central differences: O(dt^2), small against the torques
  // (measured 2.4e-4 N against 3.3 N m).
  EXPECT_LT(plan.max_base_residual, 1e-4 * tau_peak) << "tau peak " << tau_peak;
  std::printf("base residual %.2e, tau peak %.2e\n", plan.max_base_residual, tau_peak);
  // Minimum norm on the link side (p = 1 here): z = J*^T (J* J*^T)^-1 v with the base
  // eliminated numerically, J* = J_j - J_b M_bb^-1 M_bj.
  constexpr int N = Model<G>::kNumLinks;
  for (size_t k = 50; k < plan.t.size(); k += 100) {
    const auto J = model.end_effector_jacobian(plan.q[k]);
    const auto M = model.mass_matrix(plan.q[k]);
    const Eigen::Matrix<double, 3, N> J_star =
        J.rightCols<N>() -
        J.leftCols<3>() * M.topLeftCorner<3, 3>().inverse() * M.topRightCorner<3, N>();
    const Eigen::Vector3d v = J * plan.qd[k];
    const Eigen::Matrix<double, N, 1> z =
        J_star.transpose() * (J_star * J_star.transpose()).ldlt().solve(v);
    EXPECT_LT((z - plan.qd[k].tail<N>()).cwiseAbs().maxCoeff(), 1e-9 * qd_peak)
        << "t = " << plan.t[k];
  }
}

// No stiffness, damping or gravity: a plan T times faster needs T^-2 times the torques and the
// same path. Over 1e-6 s and over 10 s the scaled torques agree (the finite differences inside
// the planner are taken per unit of q, whatever the speed).
TEST(TrajectoryPlanning, TorquesScaleWithTheInverseSquareOfTheDuration) {
  const Ref ref;
  StraightLineTask slow, fast;
  slow.duration = 10;
  slow.dt = 0.01;
  fast.duration = 1e-6;
  fast.dt = 1e-9;
  const auto a = plan_straight_line(ref, slow), b = plan_straight_line(ref, fast);
  ASSERT_EQ(a.t.size(), b.t.size());
  for (size_t k = 0; k < a.t.size(); k += 97) {
    const Eigen::Vector3d ta = a.tau[k] * 100.0, tb = b.tau[k] * 1e-12;
    if (k > 0) EXPECT_MATRIX_NEAR(tb, ta, 1e-6);
    EXPECT_LT((a.q[k] - b.q[k]).cwiseAbs().maxCoeff(), 1e-9);
  }
}

// Issue 28, item 7: spans of one output step, or of 1e-10 s, follow the line too (a first step
// over the whole span, or a loop bound of 1e-12 s absolute, gave plans 0.4-0.6 m off it).
TEST(TrajectoryPlanning, VeryShortPlansFollowTheLine) {
  const Ref ref;
  for (const auto& [duration, dt] : {std::pair{0.01, 0.01}, {1e-10, 1e-10}, {1e-10, 1e-12}}) {
    StraightLineTask task;
    task.duration = duration;
    task.dt = dt;
    const auto plan = plan_straight_line(ref, task);
    EXPECT_LT(plan.max_path_error, 1e-9) << duration << " s in steps of " << dt;
    EXPECT_NEAR(ref.end_effector_pose(plan.q.back())[0], 1.1, 1e-9) << duration;
  }
  // Found by an attacker's review: 1e-300 s gave rows of nan with exit 0.
  StraightLineTask task;
  task.duration = 1e-300;
  task.dt = 1e-301;
  try {
    plan_straight_line(ref, task);
    ADD_FAILURE() << "a plan of 1e-300 s";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("overflow double precision"), std::string::npos)
        << e.what();
  }
}

// A geared fixed-base arm: the planned torques are p times the emitted inverse dynamics'
// joint rows (eq. 14), the start is on the asked elbow branch.
TEST(TrajectoryPlanning, GearedFixedBaseArmTorquesAreInverseDynamics) {
  using G = models::fixed_n5_geared_params::Model;
  const Model<G> model;
  StraightLineTask task;
  task.start = Eigen::Vector3d(1.6, 0.4, 0.5);
  task.goal = Eigen::Vector3d(1.2, 0.8, 1.0);
  task.duration = 3;
  task.law = TimeLaw::cubic;
  task.elbow = -1;
  const auto plan = plan_straight_line(model, task);
  EXPECT_LT(plan.max_path_error, 1e-10);
  EXPECT_TRUE(plan.base_residual.empty());
  EXPECT_LT(plan.q.front()[1], 0.0);
  for (size_t k = 0; k < plan.t.size(); k += 37) {
    Model<G>::Velocity Q;
    G::inverse_dynamics(plan.q[k], plan.qd[k], plan.qdd[k], model.parameters(), Q);
    const Model<G>::JointVector tau = Q.cwiseProduct(model.gear_ratios());
    if (k > 0) EXPECT_MATRIX_NEAR(plan.tau[k], tau, 1e-12);
  }
}

// In 3D: the end effector moves along a line while its orientation turns about one axis
// (slerp) and the momentum stays zero; the base floats (its quaternion stays unit). Replayed
// through forward dynamics, the planned torques move the end effector to the goal.
TEST(TrajectoryPlanning, SpatialArmFollowsALineAndASlerpWithZeroMomentum) {
  const DynamicModel m = spatial_arm7();
  StraightLineTask task;
  task.q0 = m.neutral_configuration();
  task.q0.tail(7) << 0.3, 0.5, -0.2, -1.6, 0.4, 0.9, 0.1;
  const Eigen::VectorXd pose0 = m.end_effector_pose(task.q0);
  const Eigen::Quaterniond q_start(pose0[3], pose0[4], pose0[5], pose0[6]);
  const Eigen::Quaterniond q_goal =
      q_start * Eigen::AngleAxisd(0.5, Eigen::Vector3d(1, 2, -1).normalized());
  task.start = pose0;
  task.goal = pose0;
  task.goal.head<3>() += Eigen::Vector3d(0.1, -0.08, -0.1);
  task.goal.tail<4>() << q_goal.w(), q_goal.x(), q_goal.y(), q_goal.z();
  task.duration = 4;
  task.dt = 0.01;
  const Plan plan = plan_straight_line(m, task);
  ASSERT_EQ(plan.t.size(), 401u);
  EXPECT_LT(plan.max_path_error, 1e-10);
  EXPECT_LT(plan.max_momentum, 1e-12);
  // O(dt^2) checks by central differences of the planned rates (measured 1.7e-5 rad/s^2 and
  // 6.6e-5 N or N m).
  EXPECT_LT(plan.max_acceleration_mismatch, 2e-4);
  EXPECT_LT(plan.max_base_residual, 1e-3);
  const Eigen::VectorXd end = m.end_effector_pose(plan.q.back());
  EXPECT_LT((end.head<3>() - task.goal.head<3>()).norm(), 1e-10);
  EXPECT_LT(Eigen::Quaterniond(end[3], end[4], end[5], end[6]).angularDistance(q_goal), 1e-10);
  double turned = 0;
  for (const Eigen::VectorXd& q : plan.q) {
    EXPECT_NEAR(q.segment<4>(3).norm(), 1, 1e-12);
    turned = std::max(turned, std::abs(q[4]) + std::abs(q[5]) + std::abs(q[6]));
  }
  EXPECT_GT(turned, 1e-3);  // the base reacts

  // Replay: the planned torques (linear between samples) through forward dynamics.
  const TorqueSignal<Eigen::Dynamic> tau(0.0, task.dt, plan.tau, Interpolation::linear);
  IntegratorOptions opt;
  opt.method = Method::rkf78;
  opt.rtol = 1e-10;
  opt.atol = 1e-12;
  Eigen::VectorXd q_end, qd_end;
  integrate_motion(
      m, plan.q.front(), Eigen::VectorXd::Zero(m.nv), tau, task.duration, task.dt, opt,
      [&](double, const Eigen::VectorXd& q, const Eigen::VectorXd& qd) { q_end = q, qd_end = qd; });
  const Eigen::VectorXd replayed = m.end_effector_pose(q_end);
  // Off by the torques' linear interpolation only (measured 4.3e-6 m); the momentum stays zero.
  EXPECT_LT((replayed.head<3>() - task.goal.head<3>()).norm(), 5e-5);
  EXPECT_LT(m.momentum(q_end, qd_end).norm(), 1e-12);
}

// The base's largest rotation from its start when the planned torques are replayed through
// forward dynamics (linear between samples), at rkf78's tolerance.
double replayed_base_rotation(const DynamicModel& m, const Plan& plan, double dt) {
  const TorqueSignal<Eigen::Dynamic> tau(0.0, dt, plan.tau, Interpolation::linear);
  IntegratorOptions opt;
  opt.method = Method::rkf78;
  opt.rtol = 1e-10;
  opt.atol = 1e-12;
  const Eigen::Quaterniond start(plan.q[0][3], plan.q[0][4], plan.q[0][5], plan.q[0][6]);
  double turned = 0;
  integrate_motion(m, plan.q.front(), Eigen::VectorXd::Zero(m.nv), tau, plan.t.back(), dt, opt,
                   [&](double, const Eigen::VectorXd& q, const Eigen::VectorXd&) {
                     const Eigen::Quaterniond now(q[3], q[4], q[5], q[6]);
                     turned = std::max(turned, now.normalized().angularDistance(start));
                   });
  return turned;
}

// Reactionless (the reaction null space, Nenchev and Yoshida): the 7-joint arm follows a line
// with its base's angular velocity held at zero. The plan says the base did not turn, its
// base rates say so independently, and the planned torques replayed through forward dynamics
// turn the base far less than the straight line's on the same task.
TEST(TrajectoryPlanning, AReactionlessPlanLeavesTheBasesAttitudeAlone) {
  const DynamicModel m = spatial_arm7();
  StraightLineTask task = arm7_task(m);
  const Plan line = plan_straight_line(m, task);
  task.objective = Objective::reactionless;
  const Plan plan = plan_straight_line(m, task);
  EXPECT_LT(plan.max_path_error, 1e-10);
  EXPECT_LT(plan.max_momentum, 1e-12);
  EXPECT_LT(plan.max_base_rotation, 1e-12);
  EXPECT_GT(line.max_base_rotation, 1e-3) << "the task must turn a free base to test anything";
  double omega = 0, rate = 0;
  for (size_t k = 0; k < plan.t.size(); ++k) {
    omega = std::max(omega, plan.qd[k].segment<3>(3).cwiseAbs().maxCoeff());
    rate = std::max(rate, plan.qd[k].tail(7).cwiseAbs().maxCoeff());
  }
  EXPECT_LT(omega, 1e-14 * rate) << "joint rates up to " << rate;
  // Replayed open loop, the torques' linear interpolation is all that turns the base.
  const double line_turn = replayed_base_rotation(m, line, task.dt),
               turn = replayed_base_rotation(m, plan, task.dt);
  std::printf("replayed base rotation: line %.3e rad, reactionless %.3e rad\n", line_turn, turn);
  EXPECT_LT(turn, 1e-7);  // measured 2.2e-9 rad against the line's 2.5e-2
  EXPECT_GT(line_turn, 1e-3);
}

// In the plane the base's one attitude row makes a 3-joint position task square; a pose task
// (3 rows + 1) and a fixed base are refused, naming why.
TEST(TrajectoryPlanning, ReactionlessInThePlaneAndItsRefusals) {
  const Ref ref;
  StraightLineTask task;
  task.start = Eigen::Vector2d(1.5, 0.0);
  task.goal = Eigen::Vector2d(1.1, 0.2);
  task.objective = Objective::reactionless;
  const auto plan = plan_straight_line(ref, task);
  EXPECT_LT(plan.max_path_error, 1e-10);
  EXPECT_LT(plan.max_base_rotation, 1e-12);
  for (const auto& qd : plan.qd) EXPECT_LT(std::abs(qd[2]), 1e-13);
  task.objective = Objective::line;
  EXPECT_GT(plan_straight_line(ref, task).max_base_rotation, 1e-3);

  task.objective = Objective::reactionless;
  task.start = Eigen::Vector3d(1.5, 0.0, M_PI / 6);
  task.goal = Eigen::Vector3d(1.1, 0.2, M_PI / 6);
  expect_throw_with<std::invalid_argument>(
      [&] { plan_straight_line(ref, task); },
      "3 task coordinates and the base's 1 angular velocities held at zero (reactionless) are "
      "4 rows, more than its 3 joints can follow");
  const Model<models::fixed_n5_geared_params::Model> fixed;
  task.start = Eigen::Vector2d(1.5, 0.0);
  task.goal = Eigen::Vector2d(1.1, 0.2);
  expect_throw_with<std::invalid_argument>([&] { plan_straight_line(fixed, task); },
                                           "this model's base is fixed");
}

// Where the redundancy does not allow it, the plan stops and names the rank lost: the arm
// upright, joints 1, 3, 5 and 7 on one axis.
TEST(TrajectoryPlanning, AReactionlessPlanNamesTheRankItLoses) {
  const DynamicModel m = spatial_arm7();
  StraightLineTask task;
  task.q0 = m.neutral_configuration();
  task.start = m.end_effector_pose(task.q0).head<3>();
  task.goal = task.start + Eigen::Vector3d(0.1, 0, -0.1);
  task.duration = 4;
  task.objective = Objective::reactionless;
  expect_throw_with<std::runtime_error>(
      [&] { plan_straight_line(m, task); },
      "reaction null space lost: the task's and the base's attitude rows, 6 rows, have rank 5");
}

}  // namespace
}  // namespace spacearm
