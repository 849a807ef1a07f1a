// runtime/joint_control.hpp: the quintic Hermite trajectory, the computed-torque controller's
// inverse dynamics against the generated free-base inverse dynamics and, for a flexible
// control model, against the rigid geared model it tends to; closed loops that track with
// the matching model and regulate with PD.
#include "joint_control.hpp"

#include "consistent_start.hpp"
#include "free_n3_base_params.hpp"
#include "paper_flexible.hpp"
#include "paper_geared.hpp"
#include "paper_reference.hpp"
#include "support.hpp"
#include "trajectory_planning.hpp"

namespace spacearm {
namespace {

// A quintic in t is reproduced exactly, with its first and second derivatives.
TEST(JointControl, HermiteTrajectoryReproducesQuintics) {
  auto poly = [](double t, int d) {
    const double c[6] = {0.3, -1.2, 0.7, 2.0, -0.9, 0.25};
    double v = 0;
    for (int k = d; k < 6; ++k) {
      double f = 1;
      for (int i = 0; i < d; ++i) f *= k - i;
      v += f * c[k] * std::pow(t, k - d);
    }
    return Eigen::VectorXd::Constant(2, v);
  };
  std::vector<Eigen::VectorXd> q, qd, qdd;
  for (int k = 0; k <= 10; ++k) {
    q.push_back(poly(0.1 * k, 0));
    qd.push_back(poly(0.1 * k, 1));
    qdd.push_back(poly(0.1 * k, 2));
  }
  const SampledJointTrajectory traj(0.0, 0.1, q, qd, qdd);
  for (double t : {0.0, 0.037, 0.25, 0.5, 0.999, 1.0}) {
    const JointTarget r = traj(t);
    EXPECT_NEAR(r.q[0], poly(t, 0)[0], 1e-13) << t;
    EXPECT_NEAR(r.qd[0], poly(t, 1)[0], 1e-11) << t;
    EXPECT_NEAR(r.qdd[0], poly(t, 2)[0], 1e-9) << t;
  }
}

// On a rigid geared control model the controller's inverse dynamics is the generated
// free_base_inverse_dynamics (a closed form that shares nothing with it but M and b).
TEST(JointControl, InverseDynamicsEqualsTheGeneratedFreeBaseInverseDynamics) {
  using G = models::free_n3_base_params::Model;
  Model<G> m;
  m.set_parameter("p", 7);
  const DynamicModel d = dynamic_model(m);
  const ComputedTorqueController ct(d, JointGains::critically_damped(3, 1));
  std::mt19937 rng(5);
  for (int trial = 0; trial < 5; ++trial) {
    const Eigen::VectorXd q = test::random_vector(rng, 6, 1.0), qd = test::random_vector(rng, 6, 1);
    const Eigen::Vector3d a = test::random_vector(rng, 3, 2.0);
    Eigen::Vector3d tau;
    Eigen::Vector3d base_acc;
    Model<G>::Vector qm = q;
    Model<G>::Velocity qdm = qd;
    qm.tail<3>() *= 7;
    qdm.tail<3>() *= 7;
    G::free_base_inverse_dynamics(qm, qdm, a, m.parameters(), tau, base_acc);
    EXPECT_MATRIX_NEAR(ct.inverse_dynamics(q.head(3), qd.head(3), q.tail(3), qd.tail(3), a), tau,
                       1e-12);
  }
}

// A flexible control model without friction gives the rigid geared model's torques (the
// springs untwisted carry the link rows: the k -> infinity limit), whatever k; with friction
// it adds p f(p qd) per joint.
TEST(JointControl, FlexibleControlModelGivesTheRigidGearedTorquesPlusFriction) {
  Model<models::paper_flexible::Model> flex;
  for (const auto& [name, v] : {std::pair<const char*, double>{"fc", 0}, {"fs", 0}, {"fv", 0}})
    flex.set_parameter(name, v);
  flex.set_parameter("k", 123.0);
  Model<models::paper_geared::Model> rigid;
  rigid.set_parameter("p", 10);
  rigid.set_parameter("Im", 1e-5);
  const DynamicModel df = dynamic_model(flex), dr = dynamic_model(rigid);
  const auto gains = JointGains::critically_damped(3, 1);
  const ComputedTorqueController on_flex(df, gains), on_rigid(dr, gains);
  const Eigen::Vector3d bq(0.1, -0.2, 0.3), bqd(0.01, 0.02, -0.05), qj(0.6, 1.1, -0.9),
      qdj(0.2, -0.3, 0.1), a(0.5, -1, 2);
  const Eigen::VectorXd tau_rigid = on_rigid.inverse_dynamics(bq, bqd, qj, qdj, a);
  EXPECT_MATRIX_NEAR(on_flex.inverse_dynamics(bq, bqd, qj, qdj, a), tau_rigid, 1e-10);
  // Viscous motor friction fv w at w = p qd: p * fv * p qd more on the link side.
  flex.set_parameter("fv", 1e-3);
  const Eigen::VectorXd with_friction = on_flex.inverse_dynamics(bq, bqd, qj, qdj, a);
  EXPECT_MATRIX_NEAR(with_friction - tau_rigid, 100 * 1e-3 * qdj, 1e-9);
}

// Closed loop on the paper's straight line (the plan of the reference model, 2 s) into the
// geared plant at p = 10: the computed torque built on the plant's own model tracks to the
// error of sampling the controller (first order in the period: 4x smaller at 4x the rate);
// the one built on the reference model does worse by the model's error, whatever the rate.
TEST(JointControl, ComputedTorqueOnTheMatchingModelTracksThePlan) {
  Model<models::paper_reference::Model> ref;
  StraightLineTask task;
  task.duration = 2.0;
  const auto plan = plan_straight_line(ref, task);
  std::vector<Eigen::VectorXd> q, qd, qdd;
  for (size_t k = 0; k < plan.q.size(); ++k) {
    q.push_back(plan.q[k].tail<3>());
    qd.push_back(plan.qd[k].tail<3>());
    qdd.push_back(plan.qdd[k].tail<3>());
  }
  const SampledJointTrajectory target(0.0, task.dt, q, qd, qdd);
  Model<models::paper_geared::Model> geared;
  geared.set_parameter("p", 10);
  const DynamicModel plant = dynamic_model(geared), on_ref = dynamic_model(ref);
  auto worst_error = [&](const DynamicModel& control_model, double period) {
    const ComputedTorqueController ct(control_model, JointGains::critically_damped(3, 20));
    Eigen::VectorXd q0 = plan.q.front(), qd0 = Eigen::VectorXd::Zero(6);
    q0.tail(3) *= 10;
    double worst = 0;
    IntegratorOptions opt;
    opt.method = Method::rk4;
    opt.dt = period;
    integrate_closed_loop(
        plant, q0, qd0,
        [&](double t, const Eigen::VectorXd& x, const Eigen::VectorXd& v) {
          return ct.torque(target(t), x.head(3), v.head(3), plant.joint_angles(x),
                           plant.joint_rates(v));
        },
        period, task.duration, opt,
        [&](double t, const Eigen::VectorXd& x, const Eigen::VectorXd&, const Eigen::VectorXd&) {
          worst = std::max(worst, (plant.joint_angles(x) - target(t).q).cwiseAbs().maxCoeff());
        });
    return worst;
  };
  const double matching = worst_error(plant, 1e-3), faster = worst_error(plant, 2.5e-4);
  const double reference = worst_error(on_ref, 1e-3),
               reference_faster = worst_error(on_ref, 2.5e-4);
  std::printf(
      "worst joint error at 1 kHz / 4 kHz: matching model %.2e / %.2e rad, reference "
      "model %.2e / %.2e rad\n",
      matching, faster, reference, reference_faster);
  EXPECT_NEAR(matching / faster, 4.0, 0.4);
  EXPECT_GT(reference, 5 * matching);
  EXPECT_GT(reference_faster, 0.5 * reference);  // the model error does not go with the rate
}

// The held torque changes at every sample, where the adaptive steps land: dopri5 (which reuses
// its last stage as the next step's first) must evaluate the first stage anew there, else it
// integrates the next interval's start with the previous torque. At tolerance 1e-7 its steps
// are the 10 ms period itself, every one landing on a sample. Against RK4 at a tenth of it.
TEST(JointControl, AdaptiveStepsSeeEachNewTorque) {
  Model<models::paper_geared::Model> geared;
  geared.set_parameter("p", 10);
  const DynamicModel plant = dynamic_model(geared);
  const PdController pd({Eigen::Vector3d(20, 10, 2), Eigen::Vector3d(2, 1, 0.2)});
  const JointTarget goal{Eigen::Vector3d(0.7, 1.0, -0.8), Eigen::Vector3d::Zero(),
                         Eigen::Vector3d::Zero()};
  auto final_state = [&](const IntegratorOptions& opt) {
    Eigen::VectorXd q0(6), qd0 = Eigen::VectorXd::Zero(6), end;
    q0 << 0, 0, 0, 6, 11, -9;
    integrate_closed_loop(
        plant, q0, qd0,
        [&](double, const Eigen::VectorXd& x, const Eigen::VectorXd& v) {
          return pd.torque(goal, plant.joint_angles(x), plant.joint_rates(v));
        },
        0.01, 1.0, opt,
        [&](double, const Eigen::VectorXd& x, const Eigen::VectorXd&, const Eigen::VectorXd&) {
          end = x;
        });
    return end;
  };
  IntegratorOptions rk4;
  rk4.method = Method::rk4;
  rk4.dt = 1e-3;
  IntegratorOptions dopri5;
  dopri5.method = Method::dopri5;
  dopri5.rtol = dopri5.atol = 1e-7;
  const Eigen::VectorXd a = final_state(rk4), b = final_state(dopri5);
  EXPECT_MATRIX_NEAR(b, a, 1e-11);  // measured 1.2e-13; 1.8e-9 with the stale first stage
}

TEST(JointControl, PdRegulatesASetPoint) {
  Model<models::paper_geared::Model> geared;
  geared.set_parameter("p", 10);
  const DynamicModel plant = dynamic_model(geared);
  const PdController pd({Eigen::Vector3d(20, 10, 2), Eigen::Vector3d(8, 4, 0.8)});
  const JointTarget goal{Eigen::Vector3d(0.7, 1.0, -0.8), Eigen::Vector3d::Zero(),
                         Eigen::Vector3d::Zero()};
  Eigen::VectorXd q0(6), qd0 = Eigen::VectorXd::Zero(6);
  q0 << 0, 0, 0, 6, 11, -9;  // link side 0.6, 1.1, -0.9
  double first = -1, last = 0;
  IntegratorOptions opt;
  opt.method = Method::rk4;
  opt.dt = 1e-3;
  integrate_closed_loop(
      plant, q0, qd0,
      [&](double, const Eigen::VectorXd& x, const Eigen::VectorXd& v) {
        return pd.torque(goal, plant.joint_angles(x), plant.joint_rates(v));
      },
      1e-3, 10.0, opt,
      [&](double, const Eigen::VectorXd& x, const Eigen::VectorXd&, const Eigen::VectorXd&) {
        last = (plant.joint_angles(x) - goal.q).norm();
        if (first < 0) first = last;
      });
  EXPECT_GT(first, 0.1);
  EXPECT_LT(last, 1e-3 * first);
}

}  // namespace
}  // namespace spacearm
