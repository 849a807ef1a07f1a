// runtime/configuration_space.hpp: dq/dt of MuJoCo's free-joint layout (the quaternion's rate
// 1/2 q (0, omega), omega in the base frame) against the exact rotation at a constant omega, its
// Jacobians against differences, q ⊕ delta and the tangent map, the projection, and every
// integrator keeping the quaternion on the unit sphere while it follows the exact rotation.
#include "configuration_space.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include "integrators.hpp"

namespace spacearm {
namespace {

// A base (origin, quaternion) and two joints: nq = 9, nv = 8.
const ConfigurationSpace kSpace{9, 8, 3};

Eigen::VectorXd start() {
  Eigen::VectorXd q(9);
  const Eigen::Quaterniond r = Eigen::Quaterniond(0.9, 0.1, -0.3, 0.2).normalized();
  q << 0.5, -1.0, 2.0, r.w(), r.x(), r.y(), r.z(), 0.3, -0.4;
  return q;
}
Eigen::VectorXd velocity() {
  Eigen::VectorXd v(8);
  v << 0.1, 0.2, -0.3, 0.7, -0.4, 1.1, 2.0, -3.0;
  return v;
}

// The quaternion after turning at the constant body rate omega for t: q0 exp(omega t / 2).
Eigen::Vector4d turned(const Eigen::VectorXd& q0, const Eigen::Vector3d& omega, double t) {
  const Eigen::Quaterniond r0(q0[3], q0[4], q0[5], q0[6]);
  const Eigen::Quaterniond r =
      r0 * Eigen::Quaterniond(Eigen::AngleAxisd(omega.norm() * t, omega.normalized()));
  return {r.w(), r.x(), r.y(), r.z()};
}

TEST(ConfigurationSpace, RateIsTheDerivativeOfTheExactRotation) {
  const Eigen::VectorXd q = start(), v = velocity();
  const Eigen::VectorXd rate = kSpace.rate(q, v);
  const double h = 1e-6;
  const Eigen::Vector4d quat_rate =
      (turned(q, v.segment<3>(3), h) - turned(q, v.segment<3>(3), -h)) / (2 * h);
  EXPECT_LT((rate.segment<4>(3) - quat_rate).norm(), 1e-9);
  EXPECT_EQ(rate.head(3), v.head(3));  // the origin moves at the world velocity
  EXPECT_EQ(rate.tail(2), v.tail(2));  // the joints at their rates
  // Tangent to the sphere: the norm does not change to first order.
  EXPECT_NEAR(rate.segment<4>(3).dot(q.segment<4>(3)), 0, 1e-15);
  // Without a quaternion dq/dt = v.
  const ConfigurationSpace planar{8, 8, -1};
  EXPECT_EQ(planar.rate(v, v), v);
}

// q ⊕ delta (the derivatives' tangent space) is the exact turn in the base's own frame, and
// tangent_map W undoes the rate's G: W G = 1, for a quaternion of any norm; its rows turn a
// change of q into the tangent that a norm-blind function sees (differences of integrate);
// difference (q1 ⊖ q0) undoes integrate, the shorter way round.
TEST(ConfigurationSpace, IntegrateTurnsInTheBaseFrameAndTangentMapInvertsTheRate) {
  const Eigen::VectorXd q = start(), v = velocity();
  const Eigen::VectorXd moved = kSpace.integrate(q, 0.3 * v);
  EXPECT_LT((moved.segment<4>(3) - turned(q, v.segment<3>(3), 0.3)).norm(), 1e-15);
  EXPECT_EQ(moved.head(3), q.head(3) + 0.3 * v.head(3));
  EXPECT_EQ(moved.tail(2), q.tail(2) + 0.3 * v.tail(2));
  EXPECT_EQ(kSpace.integrate(q, Eigen::VectorXd::Zero(8)), q);
  Eigen::MatrixXd by_q, G;
  for (const double scale : {1.0, 3.0, 0.01}) {
    Eigen::VectorXd x = q;
    x.segment<4>(3) *= scale;
    kSpace.rate_jacobians(x, v, by_q, G);
    EXPECT_LT((kSpace.tangent_map(x) * G - Eigen::MatrixXd::Identity(8, 8)).norm(), 1e-13) << scale;
  }
  // A change dq of the quaternion: the turn it makes is W dq, as q ⊕ (W dq) is q + dq normalized.
  const Eigen::Vector4d dq(0.3, -0.2, 0.5, 0.1);
  Eigen::VectorXd change = Eigen::VectorXd::Zero(9);
  change.segment<4>(3) = 1e-7 * dq;
  Eigen::VectorXd nudged = q + change;
  kSpace.project(nudged);
  const Eigen::VectorXd via_tangent = kSpace.integrate(q, kSpace.tangent_map(q) * change);
  EXPECT_LT((via_tangent - nudged).norm(), 1e-13);
  // difference undoes integrate for turns below pi (the shorter turn), whatever the norms.
  for (const double scale : {0.3, 2.0, 4.0}) {
    const Eigen::VectorXd delta = scale * v;  // turns of 0.3 to 4 times |omega| = 1.37 rad
    Eigen::VectorXd there = kSpace.integrate(q, delta), from = q;
    from.segment<4>(3) *= scale;
    there.segment<4>(3) *= 7;
    const Eigen::VectorXd back = kSpace.difference(from, there);
    if (scale * v.segment<3>(3).norm() < M_PI) {
      EXPECT_LT((back - delta).norm(), 1e-13) << scale;
    } else {  // the other way round, by 2 pi - angle
      EXPECT_NEAR(back.segment<3>(3).norm(), 2 * M_PI - scale * v.segment<3>(3).norm(), 1e-12);
      EXPECT_LT((kSpace.integrate(q, back).segment<4>(3) + kSpace.integrate(q, delta).segment<4>(3))
                    .norm(),
                1e-13);  // the same rotation: q and -q
    }
  }
  const ConfigurationSpace planar{8, 8, -1};
  EXPECT_EQ(planar.integrate(v, v), 2 * v);
  EXPECT_EQ(planar.difference(v, 2 * v), v);
  EXPECT_EQ(planar.tangent_map(v), Eigen::MatrixXd::Identity(8, 8));
}

TEST(ConfigurationSpace, JacobiansEqualCentralDifferences) {
  const Eigen::VectorXd q = start(), v = velocity();
  Eigen::MatrixXd by_q, by_v;
  kSpace.rate_jacobians(q, v, by_q, by_v);
  ASSERT_EQ(by_q.rows(), 9);
  ASSERT_EQ(by_q.cols(), 9);
  ASSERT_EQ(by_v.cols(), 8);
  const double h = 1e-6;
  for (int i = 0; i < 9; ++i) {
    Eigen::VectorXd a = q, b = q;
    a[i] += h, b[i] -= h;
    EXPECT_LT((by_q.col(i) - (kSpace.rate(a, v) - kSpace.rate(b, v)) / (2 * h)).norm(), 1e-9) << i;
  }
  for (int i = 0; i < 8; ++i) {
    Eigen::VectorXd a = v, b = v;
    a[i] += h, b[i] -= h;
    EXPECT_LT((by_v.col(i) - (kSpace.rate(q, a) - kSpace.rate(q, b)) / (2 * h)).norm(), 1e-9) << i;
  }
}

TEST(ConfigurationSpace, ProjectionScalesOnlyTheQuaternion) {
  Eigen::VectorXd q = start();
  Eigen::VectorXd scaled = q;
  scaled.segment<4>(3) *= 1.7;
  kSpace.project(scaled);
  EXPECT_LT((scaled - q).norm(), 1e-15);
}

// dq/dt integrated at a constant omega by each method follows the exact rotation, with the
// quaternion's norm 1 to rounding after every step (the projection).
TEST(ConfigurationSpace, EveryIntegratorKeepsTheQuaternionUnitAndExact) {
  const Eigen::VectorXd q0 = start(), v = velocity();
  for (Method m : {Method::rk4, Method::dopri5, Method::rkf78, Method::implicit_midpoint,
                   Method::rosenbrock4}) {
    SCOPED_TRACE(to_string(m));
    IntegratorOptions opt;
    opt.method = m;
    opt.dt = 1e-3;
    opt.rtol = opt.atol = 1e-11;
    opt.project = [](Eigen::Ref<Eigen::VectorXd> x) { kSpace.project(x); };
    opt.jacobian = [&](const Eigen::VectorXd& x, double, Eigen::MatrixXd& J,
                       Eigen::VectorXd& dfdt) {
      Eigen::MatrixXd by_v;
      kSpace.rate_jacobians(x, v, J, by_v);
      dfdt = Eigen::VectorXd::Zero(9);
    };
    Eigen::VectorXd x = q0;
    double worst_norm = 0;
    integrate(
        opt,
        [&](const Eigen::VectorXd& s, Eigen::VectorXd& dsdt, double) { dsdt = kSpace.rate(s, v); },
        x, 0.0, 2.0, 0.1,
        [&](const Eigen::VectorXd& s, double) {
          worst_norm = std::max(worst_norm, std::abs(s.segment<4>(3).norm() - 1));
        });
    EXPECT_LT(worst_norm, 1e-14);
    const Eigen::Vector4d exact = turned(q0, v.segment<3>(3), 2.0);
    EXPECT_LT((x.segment<4>(3) - exact).norm(), m == Method::implicit_midpoint ? 1e-6 : 1e-8);
    EXPECT_LT((x.head(3) - (q0.head(3) + 2.0 * v.head(3))).norm(), 1e-10);
  }
}

}  // namespace
}  // namespace spacearm
