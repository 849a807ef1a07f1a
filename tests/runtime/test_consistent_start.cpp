// runtime/consistent_start.hpp: the pre-deflected springs make the motor and link sides start
// with the same acceleration (qdd_m = p qdd_q) and carry about the torque (k e close to tau);
// only flexible joints' motor coordinates change, through either runtime model.
#include "consistent_start.hpp"

#include "free_n4_mixed.hpp"
#include "paper_flexible.hpp"
#include "paper_geared.hpp"
#include "simulation.hpp"
#include "support.hpp"

namespace spacearm {
namespace {

using Flex = Model<models::paper_flexible::Model>;

TEST(ConsistentStart, MotorAndLinkStartWithTheSameAcceleration) {
  Flex m;
  Flex::Vector q = Flex::Vector::Zero();
  Flex::Velocity qd = Flex::Velocity::Zero();
  q.segment<3>(3) << 0.6, 1.1, -0.9;
  qd.segment<3>(3) << 0.1, -0.2, 0.05;
  const Flex::JointVector tau(0.8, -0.5, 0.2);
  const Eigen::VectorXd e = consistent_start(m, q, qd, tau);
  const double p = m.gear_ratios()[0];
  const Flex::Velocity qdd = m.forward_dynamics(q, qd, m.generalized_forces(tau));
  for (int j = 0; j < 3; ++j) {
    EXPECT_NEAR(qd[6 + j], p * qd[3 + j], 1e-15);
    EXPECT_NEAR(q[6 + j], p * (q[3 + j] + e[j]), 1e-14);
    EXPECT_NEAR(qdd[6 + j], p * qdd[3 + j], 1e-9 * std::abs(qdd[6 + j]) + 1e-9) << j;
  }
  // The springs carry about the torque (tau less what the motor's own inertia takes): k e
  // within a few percent of tau, and the deflection is not zero.
  const double k = m.parameters()[2];
  for (int j = 0; j < 3; ++j) {
    EXPECT_GT(std::abs(e[j]), 1e-6);
    EXPECT_NEAR(k * e[j], tau[j], 0.05 * std::abs(tau[j]) + 0.02) << j;
  }
}

TEST(ConsistentStart, MixedJointsOnlyMoveTheFlexibleMotors) {
  Model<models::free_n4_mixed::Model> m;
  using M = decltype(m);
  std::mt19937 rng(3);
  M::Vector q = test::random_vector(rng, M::kNq, 0.5);
  M::Velocity qd = M::Velocity::Zero();
  const M::Vector before = q;
  const M::JointVector tau(0.3, -0.2, 0.1, 0.05);
  const Eigen::VectorXd e = consistent_start(m, q, qd, tau);
  EXPECT_EQ(e[1], 0.0);  // no gear
  EXPECT_EQ(e[2], 0.0);  // rigid gear
  EXPECT_NE(e[0], 0.0);
  EXPECT_NE(e[3], 0.0);
  EXPECT_EQ(q.head<7>(), before.head<7>());  // base and joint slots kept
  const M::Velocity qdd = m.forward_dynamics(q, qd, m.generalized_forces(tau));
  const auto p = m.gear_ratios();
  EXPECT_NEAR(qdd[7], p[0] * qdd[3], 1e-9 * std::abs(qdd[7]));
  EXPECT_NEAR(qdd[8], p[3] * qdd[6], 1e-9 * std::abs(qdd[8]));
  // The same through the dynamic-size model.
  M::Vector q2 = before;
  M::Velocity qd2 = M::Velocity::Zero();
  const DynamicModel d = dynamic_model(m);
  Eigen::VectorXd qx = q2, qdx = qd2;
  const Eigen::VectorXd e2 = consistent_start(d, qx, qdx, Eigen::VectorXd(tau));
  EXPECT_MATRIX_NEAR(e2, e, 1e-12);
}

TEST(ConsistentStart, RigidModelsAreLeftAlone) {
  Model<models::paper_geared::Model> m;
  using M = decltype(m);
  M::Vector q = M::Vector::Constant(0.3);
  M::Velocity qd = M::Velocity::Constant(0.1);
  const Eigen::VectorXd e = consistent_start(m, q, qd, M::JointVector(1, 2, 3));
  EXPECT_TRUE(e.isZero(0));
  EXPECT_EQ(q, M::Vector::Constant(0.3));
}

}  // namespace
}  // namespace spacearm
