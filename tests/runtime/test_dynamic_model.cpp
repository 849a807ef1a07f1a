// runtime/dynamic_model.hpp: a linked Model<G> seen at dynamic size gives what the model
// gives, has only the functions its scene emits, shares the model's checks, and integrates to
// the same samples as the fixed-size model through the one integrate_motion.
#include "dynamic_model.hpp"

#include <random>

#include "fixed_n5_geared_params.hpp"
#include "paper_flexible.hpp"
#include "paper_geared.hpp"
#include "simulation.hpp"
#include "support.hpp"

namespace spacearm {
namespace {

using Geared = Model<models::paper_geared::Model>;
using FixedN5 = Model<models::fixed_n5_geared_params::Model>;

template <class M>
void expect_same_functions(const M& m, std::mt19937& rng) {
  const DynamicModel d = dynamic_model(m);
  ASSERT_EQ(d.nq, M::kNq);
  ASSERT_EQ(d.nv, M::kNv);
  EXPECT_EQ(d.num_links, M::kNumLinks);
  EXPECT_EQ(d.free_floating, M::kFreeFloating);
  ASSERT_EQ(d.coordinate_names.size(), size_t(M::kNq));
  EXPECT_EQ(d.coordinate_names.back(), M::coordinate_names().back());
  EXPECT_EQ(d.gear_ratios, Eigen::VectorXd(m.gear_ratios()));
  const typename M::Vector q = test::random_vector(rng, M::kNq, 2.0);
  const typename M::Velocity qd = test::random_vector(rng, M::kNv, 1.0);
  const typename M::JointVector tau = test::random_vector(rng, M::kNumLinks, 1.0);
  // The same generated functions behind both: equal to the last bit.
  const Eigen::VectorXd Q = d.generalized_forces(tau);
  EXPECT_EQ(Q, Eigen::VectorXd(m.generalized_forces(tau)));
  EXPECT_EQ(d.forward_dynamics(q, qd, Q), Eigen::VectorXd(m.forward_dynamics(q, qd, Q)));
  Eigen::MatrixXd Mq;
  Eigen::VectorXd b;
  d.mass_matrix_and_bias(q, qd, Mq, b);
  typename M::Matrix Mf;
  typename M::Velocity bf;
  m.mass_matrix_and_bias(q, qd, Mf, bf);
  EXPECT_EQ(Mq, Eigen::MatrixXd(Mf));
  EXPECT_EQ(b, Eigen::VectorXd(bf));
  EXPECT_EQ(d.kinetic_energy(q, qd), m.kinetic_energy(q, qd));
  EXPECT_EQ(d.end_effector_pose(q), m.end_effector_pose(q));
  EXPECT_EQ(d.end_effector_jacobian(q), Eigen::MatrixXd(m.end_effector_jacobian(q)));
  EXPECT_EQ(d.configuration_rate(q, qd), Eigen::VectorXd(qd));
}

TEST(DynamicModel, GivesWhatTheLinkedModelGives) {
  std::mt19937 rng(7);
  Geared geared;
  geared.set_parameter("p", 10);
  expect_same_functions(geared, rng);
  FixedN5 fixed;
  expect_same_functions(fixed, rng);
}

// A function the scene does not emit is empty, not a stub returning zeros.
TEST(DynamicModel, HasOnlyWhatTheSceneEmits) {
  const Geared geared;
  EXPECT_TRUE(dynamic_model(geared).momentum);
  const FixedN5 fixed;  // a fixed base: no momentum output
  const DynamicModel d = dynamic_model(fixed);
  EXPECT_FALSE(d.momentum);
  EXPECT_EQ(d.num_base(), 0);
  EXPECT_TRUE(d.forward_dynamics);
}

// The layout is data: a free base's three velocities, then the joint slots in q and in v (the
// same indices in the plane), whatever the coordinates are named.
TEST(DynamicModel, StatesItsLayout) {
  const Geared geared;  // a free base with three joints
  const DynamicModel d = dynamic_model(geared);
  EXPECT_EQ(d.num_base(), 3);
  EXPECT_EQ(d.joint_q_offsets, (std::vector<int>{3, 4, 5}));
  EXPECT_EQ(d.joint_v_offsets, (std::vector<int>{3, 4, 5}));
  const FixedN5 fixed;
  EXPECT_EQ(dynamic_model(fixed).joint_v_offsets, (std::vector<int>{0, 1, 2, 3, 4}));
}

// Joint angles and rates in, the state out and back: each slot holds what its fact says (qm = p q
// for a rigid gear, q for a flexible joint, whose motor angle p q is a coordinate of its own),
// the motor encoders read the joint angle, and a vector of the wrong size is an error.
TEST(DynamicModel, JointAnglesAndRatesGoBothWays) {
  Geared geared;
  geared.set_parameter("p", 10);
  const Model<models::paper_flexible::Model> flexible;
  const Eigen::Vector3d base(0.1, -0.2, 0.3), angles(0.4, -0.5, 0.6), rates(1.0, 2.0, -3.0);
  for (const DynamicModel& d : {dynamic_model(geared), dynamic_model(flexible)}) {
    SCOPED_TRACE(d.name);
    const Eigen::VectorXd q = d.from_joint_angles(base, angles);
    const Eigen::VectorXd qd = d.from_joint_rates(base, rates);
    ASSERT_EQ(q.size(), d.nq);
    ASSERT_EQ(qd.size(), d.nv);
    EXPECT_MATRIX_NEAR(d.joint_angles(q), angles, 1e-15);
    EXPECT_MATRIX_NEAR(d.joint_rates(qd), rates, 1e-15);
    EXPECT_MATRIX_NEAR(d.motor_side(q), angles, 1e-15);
    EXPECT_MATRIX_NEAR(d.motor_side_rates(qd), rates, 1e-15);
    for (int j = 0; j < d.num_links; ++j) {
      const double p = d.gear_ratios[j], slot = q[d.joint_q_offsets[j]];
      EXPECT_EQ(slot, d.slot_holds_motor(j) ? p * angles[j] : angles[j]);
      EXPECT_EQ(q[d.actuated_coordinates[j]], p * angles[j]);
    }
    EXPECT_THROW_MESSAGE(d.joint_angles(q.head(d.nq - 1)), std::invalid_argument,
                         "model " + d.name + ": expected " + std::to_string(d.nq) + " values");
    EXPECT_THROW_MESSAGE(d.from_joint_angles(base.head(2), angles), std::invalid_argument,
                         "expected 3 base and 3 joint values, got 2 and 3");
  }
  EXPECT_TRUE(dynamic_model(geared).slot_holds_motor(0));
  EXPECT_FALSE(dynamic_model(flexible).slot_holds_motor(0));
}

// A model without forward dynamics is refused up front, naming what its scene must emit.
TEST(DynamicModel, NamesWhatForwardDynamicsNeeds) {
  DynamicModel d;
  EXPECT_THROW_MESSAGE(d.require_forward_dynamics("simulate"), std::invalid_argument,
                       "simulate: the scene must emit forward_dynamics, or mass_matrix and "
                       "bias_forces (field 'outputs')");
  d.passive_forces = true;
  EXPECT_THROW_MESSAGE(d.require_forward_dynamics("closed_loop"), std::invalid_argument,
                       "closed_loop: a scene with springs, dampers or friction must emit "
                       "forward_dynamics (field 'outputs')");
  EXPECT_NO_THROW(dynamic_model(Geared()).require_forward_dynamics("simulate"));
}

// The checks are the model's: a NaN is a DynamicsError naming the coordinate, whichever form.
TEST(DynamicModel, SharesTheModelsChecks) {
  const Geared geared;
  const DynamicModel d = dynamic_model(geared);
  Eigen::VectorXd q = Eigen::VectorXd::Zero(6), qd = q, Q = q;
  q[3] = std::nan("");
  EXPECT_THROW_MESSAGE(d.forward_dynamics(q, qd, Q), DynamicsError,
                       "model paper_geared: non-finite input q[3] (qm1) = nan");
  EXPECT_THROW_MESSAGE(geared.forward_dynamics(q, qd, Q), DynamicsError,
                       "model paper_geared: non-finite input q[3] (qm1) = nan");
}

// integrate_motion runs the fixed-size state of a Model<G> and the dynamic one of a
// DynamicModel through the same steps: the samples agree to rounding (Eigen may vectorize the
// two state sizes differently), for a fixed-step and an adaptive method.
TEST(DynamicModel, IntegratesToTheSameSamplesAsTheFixedSizeModel) {
  Geared geared;
  geared.set_parameter("p", 10);
  const DynamicModel d = dynamic_model(geared);
  Geared::Vector q0;
  q0 << 0.1, -0.2, 0.3, 3.0, 12.0, -5.0;
  Geared::Velocity qd0;
  qd0 << 0.05, 0.02, -0.1, 2.0, -3.0, 4.0;
  auto tau = [](double t) {
    return Geared::JointVector(0.02 * std::sin(2 * t), -0.01 * std::cos(3 * t), 0.005 * t);
  };
  for (Method m : {Method::rk4, Method::dopri5}) {
    SCOPED_TRACE(to_string(m));
    IntegratorOptions opt;
    opt.method = m;
    std::vector<Eigen::VectorXd> fixed_q, dynamic_q;
    const auto fixed_stats = integrate_motion(
        geared, q0, qd0, tau, 1.0, 0.1, opt,
        [&](double, const Geared::Vector& q, const Geared::Velocity&) { fixed_q.push_back(q); });
    const auto dynamic_stats = integrate_motion(
        d, Eigen::VectorXd(q0), Eigen::VectorXd(qd0),
        [&](double t) { return Eigen::VectorXd(tau(t)); }, 1.0, 0.1, opt,
        [&](double, const Eigen::VectorXd& q, const Eigen::VectorXd&) { dynamic_q.push_back(q); });
    EXPECT_EQ(fixed_stats.rhs_evaluations, dynamic_stats.rhs_evaluations);
    ASSERT_EQ(fixed_q.size(), 11u);
    ASSERT_EQ(dynamic_q.size(), fixed_q.size());
    EXPECT_GT((fixed_q.back() - q0).norm(), 0.1);  // it moved
    for (size_t k = 0; k < fixed_q.size(); ++k) EXPECT_MATRIX_NEAR(dynamic_q[k], fixed_q[k], 1e-13);
  }
}

}  // namespace
}  // namespace spacearm
