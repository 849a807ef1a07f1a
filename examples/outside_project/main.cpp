// Your own arm from C++, against an installed spacearm (docs/cpp-api.md walks through it):
//   1. the rigid model (my_arm.yaml): sizes, the mass matrix, the dynamic-size view;
//   2. a zero-momentum straight-line plan on it;
//   3. the plan replayed open loop into the flexible twin with friction (my_arm_flexible.yaml),
//      with and without the friction fed forward, the integrator chosen from the stiffest mode;
//   4. a PD loop around the plan's torques, sampled at 1 kHz, on the flexible twin.
// Prints the end-effector error of each; exits 1 if the closed loop does not beat open loop.
#include <spacearm/dynamic_model.hpp>
#include <spacearm/integrator_choice.hpp>
#include <spacearm/joint_control.hpp>
#include <spacearm/model.hpp>
#include <spacearm/plan_replay.hpp>
#include <spacearm/simulation.hpp>
#include <spacearm/trajectory_planning.hpp>

#include <cstdio>

#include "my_arm.hpp"
#include "my_arm_flexible.hpp"

using namespace spacearm;
using Arm = Model<models::my_arm::Model>;
using FlexibleArm = Model<models::my_arm_flexible::Model>;

// The flexible twin flies the plan open loop; returns the end-effector pose at the end.
Eigen::Vector3d replay(const DynamicModel& plant, PlanSamples plan, bool feed_friction) {
  if (feed_friction) feed_friction_forward(plant, plan);
  Eigen::VectorXd q0, qd0;
  replay_start(plant, plan, plan.torques.samples.front(), q0, qd0);  // springs pre-deflected
  const TorqueSignal<Eigen::Dynamic> tau(plan.torques.t0, plan.torques.dt, plan.torques.samples,
                                         Interpolation::linear);
  IntegratorOptions opt;  // rk4 at a step that resolves the stiffest mode, or rosenbrock4
  const StiffestMode mode = stiffest_mode(plant, q0, qd0, plant.generalized_forces(tau(0)));
  const IntegratorChoice choice = choose_integrator(mode, 0.01, 0.01, plant.has_state_jacobian());
  choice.apply(opt);
  const TorqueReplay<Eigen::Dynamic> samples(tau, opt, "dt");
  const double t_end = plan.torques.t_last();
  Eigen::Vector3d pose;
  integrate_motion(
      plant, q0, qd0, [&](double t) { return samples(t); }, t_end, 0.01, opt,
      [&](double, const Eigen::VectorXd& q, const Eigen::VectorXd&) {
        pose = plant.end_effector_pose(q);
      });
  if (!feed_friction) std::printf("integrator: %s\n", choice.why.c_str());
  return pose;
}

// A PD loop on the motor-side joint errors (the encoders' qm / p: feedback collocated with the
// motor torque stays stable with flexible joints; from the link side of the springs it did
// not) around the plan's torques and friction, at 1 kHz.
Eigen::Vector3d closed_loop(const DynamicModel& plant, PlanSamples plan) {
  const SampledJointTrajectory target = joint_target(plan);
  feed_friction_forward(plant, plan);
  const std::vector<Eigen::VectorXd>& feedforward = plan.torques.samples;
  const TorqueSignal<Eigen::Dynamic> tau_ff(0.0, plan.torques.dt, feedforward,
                                            Interpolation::linear, Extrapolation::hold);
  // kp = 400 N m/rad, kd = 40 N m s/rad (link side): against the reflected rotor inertia
  // p^2 I_m = 0.1 kg m^2, a joint bandwidth of about 60 rad/s, well below the springs' modes.
  const PdController pd(JointGains::critically_damped(plant.num_links, 20.0));
  auto control = [&](double t, const Eigen::VectorXd& q, const Eigen::VectorXd& qd) {
    const Eigen::VectorXd tau_pd =
        pd.torque(target(t), plant.motor_side(q), plant.motor_side_rates(qd));
    return Eigen::VectorXd(tau_ff(t) + tau_pd);
  };
  Eigen::VectorXd q0, qd0;
  replay_start(plant, plan, feedforward.front(), q0, qd0);
  IntegratorOptions opt;
  opt.method = Method::rosenbrock4;  // the twin is stiff: its fastest mode is about 820 1/s
  Eigen::Vector3d pose;
  integrate_closed_loop(plant, q0, qd0, control, 1e-3, plan.torques.t_last(), opt,
                        [&](double, const Eigen::VectorXd& q, const Eigen::VectorXd&,
                            const Eigen::VectorXd&) { pose = plant.end_effector_pose(q); });
  return pose;
}

int main() {
  // 1. The rigid model, at fixed size and through the dynamic-size view.
  Arm arm;
  const Arm::Vector q = Arm::Vector::Zero(), qd = Arm::Vector::Zero();
  const Arm::JointVector tau = Arm::JointVector::Constant(0.5);
  const Arm::Vector qdd = arm.forward_dynamics(q, qd, arm.generalized_forces(tau));
  std::printf("coordinates %d, total mass %.6g kg\n", Arm::kNq, arm.mass_matrix(q)(0, 0));
  const DynamicModel rigid = dynamic_model(arm);
  const bool same =
      rigid.forward_dynamics(q, qd, rigid.generalized_forces(tau)) == Eigen::VectorXd(qdd);
  std::printf("dynamic-size model %s\n", same ? "agrees" : "DIFFERS");

  // 2. The plan: a straight line of the end effector, zero momentum, on the rigid model.
  StraightLineTask task;
  task.start = Eigen::Vector3d(0.9, 0.3, 0.3);
  task.goal = Eigen::Vector3d(0.8, 0.5, 0.6);
  task.duration = 4;
  const Plan plan = plan_straight_line(rigid, task);
  const PlanSamples samples = plan_samples(plan, rigid);
  std::printf("plan: %zu samples, path error %.2g m\n", plan.t.size(), plan.max_path_error);

  // 3. and 4. The flexible twin flies it: open loop, then closed loop.
  const FlexibleArm flexible_arm;
  const DynamicModel plant = dynamic_model(flexible_arm);
  const double bare = (replay(plant, samples, false) - task.goal).norm(),
               fed = (replay(plant, samples, true) - task.goal).norm(),
               loop = (closed_loop(plant, samples) - task.goal).norm();
  std::printf(
      "end-effector error: open loop %.3g m, with friction fed forward %.3g m, "
      "closed loop %.3g m\n",
      bare, fed, loop);
  return same && loop < bare && loop < 1e-3 ? 0 : 1;
}
