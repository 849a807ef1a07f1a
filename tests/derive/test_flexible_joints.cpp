// Flexible joints and friction (the paper's future work): the generated models against the
// independent numeric Lagrangian (M, bias, potential energy, spring/damper and friction
// forces), forward dynamics balancing every force, and rollouts: T + V conserved without
// dissipation, the dissipated power equal to the loss of T + V, momentum conserved under any
// torques, springs and friction, and stiff springs approaching the rigid geared model at
// first order in 1/k.
#include <Eigen/Dense>

#include <cmath>
#include <map>

#include "free_n4_mixed.hpp"
#include "paper_flexible.hpp"
#include "paper_geared.hpp"
#include "simulation.hpp"
#include "support.hpp"

namespace spacearm {
namespace {

using FlexModel = Model<models::paper_flexible::Model>;
using MixedModel = Model<models::free_n4_mixed::Model>;

// The paper's flexible system with the given parameters (nominal for the others).
FlexModel flexible(const std::vector<std::pair<std::string, double>>& values) {
  FlexModel m;
  for (const auto& [name, v] : values) m.set_parameter(name, v);
  return m;
}

std::map<std::string, double> named(const Scene& scene, const Eigen::VectorXd& params) {
  std::map<std::string, double> v;
  for (size_t i = 0; i < scene.parameters.size(); ++i) v[scene.parameters[i].name] = params[i];
  return v;
}

// Every generated quantity of model m against the oracle at random states.
template <class G>
void check_against_oracle(const Model<G>& m, const std::string& scene_path, unsigned seed) {
  using Mdl = Model<G>;
  const Scene scene = load_scene(scene_path);
  const NumericLagrangian oracle(test::chain_parameters(scene, named(scene, m.parameters())));
  ASSERT_EQ(oracle.n(), Mdl::kNv);
  std::mt19937 rng(seed);
  for (int k = 0; k < 20; ++k) {
    const typename Mdl::Vector q = test::random_vector(rng, Mdl::kNq, 1.5);
    const typename Mdl::Velocity qd = test::random_vector(rng, Mdl::kNv, 2.0);
    typename Mdl::Matrix M;
    typename Mdl::Velocity b, fk, ff;
    m.mass_matrix_and_bias(q, qd, M, b);
    G::spring_damper_forces(q, qd, m.parameters(), fk);
    G::friction_forces(qd, m.parameters(), ff);
    const double V = G::potential_energy(q, m.parameters());
    // Non-vacuity: the springs are twisted and the motors turn.
    ASSERT_GT(oracle.potential_energy(q), 1e-3);
    ASSERT_GT(oracle.friction_forces(qd).norm(), 1e-4);
    EXPECT_MATRIX_NEAR(M, oracle.mass_matrix(q), 1e-12);
    EXPECT_MATRIX_NEAR(b, oracle.bias_forces(q, qd), 1e-7);
    EXPECT_MATRIX_NEAR(fk, oracle.spring_damper_forces(q, qd), 1e-9);
    EXPECT_MATRIX_NEAR(ff, oracle.friction_forces(qd), 1e-13);
    EXPECT_NEAR(V, oracle.potential_energy(q), 1e-12 * std::abs(V));
    EXPECT_NEAR(m.kinetic_energy(q, qd), oracle.kinetic_energy(q, qd), 1e-12 * (1 + std::abs(V)));
    EXPECT_MATRIX_NEAR(m.momentum(q, qd), oracle.momentum(q, qd), 1e-12);
  }
}

TEST(FlexibleJoints, PaperSystemAgreesWithTheNumericLagrangian) {
  check_against_oracle(flexible({}), SPACEARM_SOURCE_DIR "/models/paper_flexible.yaml", 1);
  // Another operating point: low ratio, soft springs, a Stribeck hump.
  check_against_oracle(flexible({{"p", 1.5}, {"k", 50}, {"d", 0.2}, {"fs", 0.01}, {"vst", 0.3}}),
                       SPACEARM_SOURCE_DIR "/models/paper_flexible.yaml", 2);
}

TEST(FlexibleJoints, MixedJointKindsAgreeWithTheNumericLagrangian) {
  // Flexible, ungeared, rigid armature-coupled and flexible undamped joints in one arm.
  EXPECT_EQ(MixedModel::actuated_coordinates(), (std::array<int, 4>{7, 4, 5, 8}));
  check_against_oracle(MixedModel(), SPACEARM_SOURCE_DIR "/tests/scenes/free_n4_mixed.yaml", 3);
}

// M qdd + b + fk + ff = Q with Q = tau / p on each motor coordinate and nothing on the link
// side of a flexible joint; inverse dynamics gives Q back.
template <class G>
void check_force_balance(const Model<G>& m, unsigned seed) {
  using Mdl = Model<G>;
  std::mt19937 rng(seed);
  const typename Mdl::Vector q = test::random_vector(rng, Mdl::kNq, 1.0);
  const typename Mdl::Velocity qd = test::random_vector(rng, Mdl::kNv, 1.0);
  const typename Mdl::JointVector tau = test::random_vector(rng, Mdl::kNumLinks, 5.0);
  const typename Mdl::Velocity Q = m.generalized_forces(tau);
  for (int j = 0; j < Mdl::kNumLinks; ++j)
    EXPECT_DOUBLE_EQ(Q[Mdl::actuated_coordinates()[j]], tau[j] / m.gear_ratios()[j]);
  EXPECT_DOUBLE_EQ(Q.norm(), (tau.array() / m.gear_ratios().array()).matrix().norm());
  const typename Mdl::Velocity qdd = m.forward_dynamics(q, qd, Q);
  typename Mdl::Matrix M;
  typename Mdl::Velocity b, fk, ff, Q_back;
  m.mass_matrix_and_bias(q, qd, M, b);
  G::spring_damper_forces(q, qd, m.parameters(), fk);
  G::friction_forces(qd, m.parameters(), ff);
  EXPECT_MATRIX_NEAR((M * qdd + b + fk + ff).eval(), Q, 1e-9);
  G::inverse_dynamics(q, qd, qdd, m.parameters(), Q_back);
  EXPECT_MATRIX_NEAR(Q_back, Q, 1e-9);
}

TEST(FlexibleJoints, ForwardDynamicsBalancesEveryForce) {
  check_force_balance(flexible({}), 4);
  check_force_balance(MixedModel(), 5);
}

// A rollout of model m from (q0, qd0) under tau(t), sampled every dt_out.
template <class G, class Torque>
void roll_out(const Model<G>& m, const typename Model<G>::Vector& q0,
              const typename Model<G>::Velocity& qd0, const Torque& tau, double t_end,
              double dt_out,
              const std::function<void(double, const typename Model<G>::Vector&,
                                       const typename Model<G>::Velocity&)>& obs) {
  IntegratorOptions opt;
  opt.method = Method::dopri5;
  opt.rtol = 1e-12;
  opt.atol = 1e-13;
  integrate_motion(m, q0, qd0, tau, t_end, dt_out, opt, obs);
}

double total_energy(const FlexModel& m, const FlexModel::Vector& q, const FlexModel::Velocity& qd) {
  return m.kinetic_energy(q, qd) +
         models::paper_flexible::Model::potential_energy(q, m.parameters());
}

// A twisted, moving start: link angles of the paper's pose, motors ahead by a few mrad.
void twisted_start(const FlexModel& m, FlexModel::Vector& q, FlexModel::Velocity& qd) {
  q << 0.1, -0.05, 0.2, 0.6, 1.1, -0.9, 0, 0, 0;
  const double p = m.gear_ratios()[0];
  for (int j = 0; j < 3; ++j) q[6 + j] = p * (q[3 + j] + 0.004 * (j + 1));
  qd << 0.01, -0.02, 0.03, 0.2, -0.3, 0.1, 0, 0, 0;
  for (int j = 0; j < 3; ++j) qd[6 + j] = p * qd[3 + j] * 1.05;
}

// The stiff case: the paper's flexible system at its nominal k = 1e4 N m/rad with damping and
// steep friction, from a twisted start under smooth motor torques. rosenbrock4 (with the
// emitted state Jacobian) meets its tolerance against a tight rkf78 reference; dopri5 at the
// same tolerance needs many more right-hand sides, its steps held down by stability.
TEST(FlexibleJoints, Rosenbrock4IntegratesTheStiffModel) {
  const FlexModel m;
  FlexModel::Vector q0;
  FlexModel::Velocity qd0;
  twisted_start(m, q0, qd0);
  qd0.setZero();  // at rest, springs relaxed (qm = p q): only the torques excite the modes
  for (int j = 0; j < 3; ++j) q0[6 + j] = m.gear_ratios()[j] * q0[3 + j];
  auto tau = [](double t) {
    return FlexModel::JointVector(0.5 * std::sin(3 * t), -0.3 * std::sin(2 * t), 0.1 * std::sin(t));
  };
  auto final_state = [&](Method method, double tol, IntegrationStats* stats) {
    IntegratorOptions opt;
    opt.method = method;
    opt.rtol = opt.atol = tol;
    Eigen::VectorXd x;
    const auto s =
        integrate_motion(m, q0, qd0, tau, 0.5, 0.5, opt,
                         [&](double, const FlexModel::Vector& q, const FlexModel::Velocity& qd) {
                           x = (Eigen::VectorXd(18) << q, qd).finished();
                         });
    if (stats) *stats = s;
    return x;
  };
  const Eigen::VectorXd ref = final_state(Method::rkf78, 1e-12, nullptr);
  IntegrationStats rb, dp;
  const Eigen::VectorXd x_rb = final_state(Method::rosenbrock4, 1e-7, &rb);
  const Eigen::VectorXd x_dp = final_state(Method::dopri5, 1e-7, &dp);
  std::printf("rosenbrock4: %ld rhs, %ld Jacobians, error %.2e; dopri5: %ld rhs, error %.2e\n",
              rb.rhs_evaluations, rb.jacobian_evaluations, (x_rb - ref).norm(), dp.rhs_evaluations,
              (x_dp - ref).norm());
  EXPECT_LT((x_rb - ref).norm(), 1e-4 * ref.norm());
  EXPECT_GT(rb.jacobian_evaluations, 0);
  EXPECT_LT(2 * rb.rhs_evaluations, dp.rhs_evaluations);
}

// The Jacobian that integrate_motion hands to rosenbrock4: [[0, I], [dqdd/dq, dqdd/dqd]] and
// df/dt from the torque's slope, against central differences of f(x, t) = (qd, qdd) in x and t.
TEST(FlexibleJoints, MotionJacobianMatchesFiniteDifferences) {
  const FlexModel m;
  auto tau = [](double t) {
    return FlexModel::JointVector(0.5 * std::sin(3 * t), -0.3 * t, 0.2 * std::cos(2 * t));
  };
  const auto jacobian = detail::motion_jacobian(m, tau, 9, 9, 0);
  auto f = [&](const Eigen::VectorXd& x, double t) {
    Eigen::VectorXd d(18);
    d << x.tail(9), m.forward_dynamics(x.head(9), x.tail(9), m.generalized_forces(tau(t)));
    return d;
  };
  FlexModel::Vector q;
  FlexModel::Velocity qd;
  twisted_start(m, q, qd);
  const Eigen::VectorXd x = (Eigen::VectorXd(18) << q, qd).finished();
  const double t = 0.7;
  Eigen::MatrixXd J;
  Eigen::VectorXd dfdt;
  jacobian(x, t, J, dfdt);
  Eigen::MatrixXd fd_J(18, 18);
  for (int k = 0; k < 18; ++k) {
    const double h = 1e-6;
    const Eigen::VectorXd e = Eigen::VectorXd::Unit(18, k) * h;
    fd_J.col(k) = (f(x + e, t) - f(x - e, t)) / (2 * h);
  }
  const Eigen::VectorXd fd_dfdt = (f(x, t + 1e-5) - f(x, t - 1e-5)) / 2e-5;
  for (int i = 9; i < 18; ++i) {
    SCOPED_TRACE("row " + std::to_string(i));
    EXPECT_MATRIX_NEAR(J.row(i), fd_J.row(i), 1e-5);
  }
  EXPECT_EQ(J.topLeftCorner(9, 9), Eigen::MatrixXd::Zero(9, 9));
  EXPECT_EQ(J.topRightCorner(9, 9), Eigen::MatrixXd::Identity(9, 9));
  EXPECT_TRUE(dfdt.head(9).isZero(0));
  EXPECT_MATRIX_NEAR(dfdt, fd_dfdt, 1e-5);
}

TEST(FlexibleJoints, EnergyIsConservedWithoutDampingOrFriction) {
  const FlexModel m = flexible({{"d", 0}, {"fv", 0}, {"fc", 0}, {"fs", 0}});
  FlexModel::Vector q0;
  FlexModel::Velocity qd0;
  twisted_start(m, q0, qd0);
  const double E0 = total_energy(m, q0, qd0);
  const double V0 = models::paper_flexible::Model::potential_energy(q0, m.parameters());
  ASSERT_GT(V0, 0.1 * E0);  // the springs hold a good share of the energy
  double worst = 0;
  auto zero = [](double) { return FlexModel::JointVector::Zero().eval(); };
  roll_out<models::paper_flexible::Model>(
      m, q0, qd0, zero, 0.5, 0.01,
      [&](double, const FlexModel::Vector& q, const FlexModel::Velocity& qd) {
        worst = std::max(worst, std::abs(total_energy(m, q, qd) - E0));
      });
  EXPECT_LT(worst, 1e-9 * E0) << "E0 = " << E0;
}

TEST(FlexibleJoints, DissipatedPowerEqualsTheLossOfEnergy) {
  // Damping and friction with a Stribeck hump; the loss of T + V against the integral of the
  // dissipated power qd . (dD/dqd + f) = 2 D + qd . f (Simpson's rule on a fine grid).
  const FlexModel m = flexible({{"d", 0.5}, {"fv", 1e-4}, {"fs", 3e-3}, {"fc", 2e-3}});
  using G = models::paper_flexible::Model;
  FlexModel::Vector q0;
  FlexModel::Velocity qd0;
  twisted_start(m, q0, qd0);
  std::vector<double> power, energy;
  auto zero = [](double) { return FlexModel::JointVector::Zero().eval(); };
  const double dt = 1e-5;
  roll_out<G>(m, q0, qd0, zero, 0.1, dt,
              [&](double, const FlexModel::Vector& q, const FlexModel::Velocity& qd) {
                FlexModel::Velocity fk, ff, fk_spring;
                G::spring_damper_forces(q, qd, m.parameters(), fk);
                G::spring_damper_forces(q, FlexModel::Velocity::Zero().eval(), m.parameters(),
                                        fk_spring);
                G::friction_forces(qd, m.parameters(), ff);
                power.push_back(qd.dot(fk - fk_spring + ff));  // damper and friction only
                energy.push_back(total_energy(m, q, qd));
              });
  ASSERT_EQ(power.size() % 2, 1u);
  double dissipated = 0;
  for (size_t i = 0; i + 2 < power.size(); i += 2)
    dissipated += dt / 3 * (power[i] + 4 * power[i + 1] + power[i + 2]);
  const double loss = energy.front() - energy.back();
  ASSERT_GT(loss, 0.05 * energy.front());  // non-vacuity: a real share is dissipated
  EXPECT_NEAR(loss, dissipated, 1e-7 * energy.front()) << "loss " << loss;
}

TEST(FlexibleJoints, MomentumIsConservedUnderTorquesSpringsAndFriction) {
  const FlexModel m = flexible({{"fs", 3e-3}, {"fc", 2e-3}});
  FlexModel::Vector q0;
  FlexModel::Velocity qd0;
  twisted_start(m, q0, qd0);
  const Eigen::Vector3d h0 = m.momentum(q0, qd0);
  auto tau = [](double t) {
    return FlexModel::JointVector(0.8 * std::sin(9 * t), -0.5 * std::cos(7 * t), 0.3 * t).eval();
  };
  double worst = 0;
  roll_out<models::paper_flexible::Model>(
      m, q0, qd0, tau, 0.5, 0.01,
      [&](double, const FlexModel::Vector& q, const FlexModel::Velocity& qd) {
        worst = std::max(worst, (m.momentum(q, qd) - h0).norm());
      });
  ASSERT_GT(h0.norm(), 0.1);
  EXPECT_LT(worst, 1e-10 * h0.norm());
}

// The rigid geared model (motor coordinates) and the flexible one with springs of stiffness k,
// both at rest with the springs relaxed, driven by the same torques that start at zero with a
// zero rate (so no static twist is needed at t = 0): the end-effector paths differ by O(1/k),
// the springs' quasi-static twist tau / k.
double rigid_flexible_gap(double k) {
  using Rigid = Model<models::paper_geared::Model>;
  Rigid rigid;
  rigid.set_parameter("p", 10);
  rigid.set_parameter("Im", 1e-5);
  const FlexModel flex =
      flexible({{"p", 10}, {"Im", 1e-5}, {"k", k}, {"d", 0}, {"fv", 0}, {"fc", 0}, {"fs", 0}});
  const Eigen::Vector3d link(0.6, 1.1, -0.9);
  Rigid::Vector qr = Rigid::Vector::Zero();
  qr.tail<3>() = 10 * link;
  FlexModel::Vector qf = FlexModel::Vector::Zero();
  qf.segment<3>(3) = link;
  qf.tail<3>() = 10 * link;
  const double T = 1.0;
  auto tau = [T](double t) {
    const double s = std::sin(M_PI * t / T);
    return Eigen::Vector3d(2.0 * s * s, -1.2 * s * s, 0.4 * s * s * std::cos(3 * t));
  };
  std::vector<Eigen::Vector2d> path_rigid, path_flex;
  roll_out<models::paper_geared::Model>(
      rigid, qr, Rigid::Velocity::Zero(), tau, T, T / 20,
      [&](double, const Rigid::Vector& q, const Rigid::Velocity&) {
        path_rigid.push_back(rigid.end_effector_pose(q).head<2>());
      });
  roll_out<models::paper_flexible::Model>(
      flex, qf, FlexModel::Velocity::Zero(), tau, T, T / 20,
      [&](double, const FlexModel::Vector& q, const FlexModel::Velocity&) {
        path_flex.push_back(flex.end_effector_pose(q).head<2>());
      });
  double gap = 0;
  for (size_t i = 0; i < path_rigid.size(); ++i)
    gap = std::max(gap, (path_flex.at(i) - path_rigid[i]).norm());
  return gap;
}

TEST(FlexibleJoints, StiffSpringsApproachTheRigidGearedModelAtFirstOrder) {
  const double e3 = rigid_flexible_gap(1e3), e4 = rigid_flexible_gap(1e4),
               e5 = rigid_flexible_gap(1e5);
  // Observed order in 1/k between successive decades.
  const double order_34 = std::log10(e3 / e4), order_45 = std::log10(e4 / e5);
  EXPECT_GT(e3, 1e-7);  // non-vacuity: the soft arm is measurably off
  std::printf("end-effector gap: %.3e m (k = 1e3), %.3e (1e4), %.3e (1e5)\n", e3, e4, e5);
  EXPECT_NEAR(order_34, 1.0, 0.2) << e3 << " " << e4;
  EXPECT_NEAR(order_45, 1.0, 0.2) << e4 << " " << e5;
}

}  // namespace
}  // namespace spacearm
