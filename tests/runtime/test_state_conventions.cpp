// runtime/state_conventions.hpp: a free base's state in Pinocchio's, SpaceDyn's and SPART's
// conventions. Each pair round-trips to 1e-14, and each converted quantity means what its tool
// says: the centre of mass's velocity is the time derivative of its position (central
// differences along spacearm's own motion), Pinocchio's linear velocity is the world one seen
// from the base, the joints are link angles (a motor slot divided by its ratio).
#include "state_conventions.hpp"

#include <gtest/gtest.h>

#include <random>

namespace spacearm {
namespace {

const Eigen::Vector3d kCom(0.12, -0.05, 0.3);

Eigen::VectorXd ratios() { return Eigen::Vector3d(100, 1, 50); }

BaseState random_state(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1, 1);
  BaseState s{Eigen::VectorXd(10), Eigen::VectorXd(9)};
  for (int i = 0; i < 10; ++i) s.q[i] = 2 * u(rng);
  for (int i = 0; i < 9; ++i) s.v[i] = u(rng);
  s.q.segment<4>(3) = Eigen::Quaterniond::UnitRandom().coeffs();  // x y z w: as w x y z, a turn
  return s;
}

// spacearm's state after h along its own velocity: the origin by dp h, the quaternion turned by
// omega (base frame) over h, the joints by their rates.
Eigen::VectorXd moved(const BaseState& s, double h) {
  Eigen::VectorXd q =
      s.q + h * (Eigen::VectorXd(10) << s.v.head<3>(), 0, 0, 0, 0, s.v.tail<3>()).finished();
  const Eigen::Quaterniond r(s.q[3], s.q[4], s.q[5], s.q[6]);
  const Eigen::Vector3d w = s.v.segment<3>(3);
  const Eigen::Quaterniond turned =
      r * Eigen::Quaterniond(Eigen::AngleAxisd(w.norm() * h, w.normalized()));
  q.segment<4>(3) << turned.w(), turned.x(), turned.y(), turned.z();
  return q;
}

TEST(StateConventions, EachPairRoundTrips) {
  std::mt19937 rng(5);
  for (StateConvention c : {StateConvention::spacearm, StateConvention::pinocchio,
                            StateConvention::spacedyn, StateConvention::spart})
    for (int trial = 0; trial < 20; ++trial) {
      BaseState s = random_state(rng);
      s.q.segment<4>(3).normalize();
      const BaseState other = to_convention(c, s.q, s.v, kCom, ratios());
      const BaseState back = from_convention(c, other.q, other.v, kCom, ratios());
      EXPECT_LT((back.q - s.q).norm(), 1e-14 * (1 + s.q.norm()));
      EXPECT_LT((back.v - s.v).norm(), 1e-14 * (1 + s.v.norm()));
    }
}

TEST(StateConventions, EachQuantityMeansWhatItsToolSays) {
  std::mt19937 rng(6);
  const double h = 1e-6;
  for (int trial = 0; trial < 5; ++trial) {
    BaseState s = random_state(rng);
    s.q.segment<4>(3).normalize();
    const Eigen::Matrix3d R = Eigen::Quaterniond(s.q[3], s.q[4], s.q[5], s.q[6]).toRotationMatrix();
    // SpaceDyn: R0 the centre of mass, v0 its rate, w0 omega in the world; link angles.
    const BaseState d = to_convention(StateConvention::spacedyn, s.q, s.v, kCom, ratios());
    auto com_at = [&](const Eigen::VectorXd& q) {
      return to_convention(StateConvention::spacedyn, q, s.v, kCom, ratios()).q.head<3>().eval();
    };
    EXPECT_LT((d.q.head<3>() - (s.q.head<3>() + R * kCom)).norm(), 1e-14);
    const Eigen::Vector3d rate = (com_at(moved(s, h)) - com_at(moved(s, -h))) / (2 * h);
    EXPECT_LT((d.v.head<3>() - rate).norm(), 1e-8);
    EXPECT_LT((d.v.segment<3>(3) - R * s.v.segment<3>(3)).norm(), 1e-14);
    EXPECT_DOUBLE_EQ(d.q[7], s.q[7] / 100);
    EXPECT_DOUBLE_EQ(d.v[8], s.v[8] / 50);
    // SPART: the same centre and its rate, after omega in the base frame.
    const BaseState p = to_convention(StateConvention::spart, s.q, s.v, kCom, ratios());
    EXPECT_LT((p.v.head<3>() - s.v.segment<3>(3)).norm(), 1e-15);
    EXPECT_LT((p.v.segment<3>(3) - rate).norm(), 1e-8);
    // Pinocchio: x y z w, the linear velocity in the base frame.
    const BaseState f = to_convention(StateConvention::pinocchio, s.q, s.v, kCom, ratios());
    EXPECT_EQ(f.q.segment<4>(3), Eigen::Vector4d(s.q[4], s.q[5], s.q[6], s.q[3]));
    EXPECT_LT((R * f.v.head<3>() - s.v.head<3>()).norm(), 1e-14);
  }
}

TEST(StateConventions, BadNamesAndSizesAreRefused) {
  EXPECT_THROW(state_convention("mujoco", "--state-to"), std::invalid_argument);
  try {
    state_convention("drake", "--state-from");
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(),
                 "--state-from: expected spacearm, pinocchio, spacedyn or spart, got 'drake'");
  }
  EXPECT_THROW(to_convention(StateConvention::spart, Eigen::VectorXd::Zero(9),
                             Eigen::VectorXd::Zero(8), kCom, ratios()),
               std::invalid_argument);
  Eigen::VectorXd q = Eigen::VectorXd::Zero(10);  // a zero quaternion is no turn
  EXPECT_THROW(
      to_convention(StateConvention::spacedyn, q, Eigen::VectorXd::Zero(9), kCom, ratios()),
      std::invalid_argument);
}

}  // namespace
}  // namespace spacearm
