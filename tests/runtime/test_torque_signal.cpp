// runtime/torque_signal.hpp: held and linearly interpolated torque samples, what happens
// outside them, and a true zero-order hold under the integrators (against the exact
// solution of a body under piecewise-constant torque).
#include "torque_signal.hpp"

#include <gtest/gtest.h>

#include "integrators.hpp"

namespace spacearm {
namespace {

using J = Eigen::Matrix<double, 2, 1>;
const std::vector<J> kSamples{J(0, 10), J(1, 20), J(3, 20)};

TEST(TorqueSignal, HoldAndLinear) {
  const TorqueSignal<2> hold(0.0, 0.5, kSamples, Interpolation::hold);
  const TorqueSignal<2> linear(0.0, 0.5, kSamples, Interpolation::linear);
  EXPECT_EQ(hold(0.25), J(0, 10));
  EXPECT_EQ(linear(0.25), J(0.5, 15));
  EXPECT_EQ(hold(0.5), J(1, 20));
  EXPECT_EQ(linear(0.75), J(2, 20));
  EXPECT_EQ(linear(1.0), J(3, 20));
  // A whole step [0.25, 0.5] that ends on a sample belongs to the interval it lies in.
  EXPECT_EQ(hold.held_over(0.25, 0.5), J(0, 10));
  EXPECT_EQ(hold.held_over(0.5, 1.0), J(1, 20));
  EXPECT_THROW(interpolation_from_string("cubic"), std::invalid_argument);
}

TEST(TorqueSignal, OutsideTheSamplesIsAnErrorUnlessAskedFor) {
  const TorqueSignal<2> strict(0.0, 0.5, kSamples, Interpolation::linear);
  EXPECT_THROW(strict(1.5), std::runtime_error);
  EXPECT_THROW(strict(-0.1), std::runtime_error);
  EXPECT_EQ(TorqueSignal<2>(0.0, 0.5, kSamples, Interpolation::linear, Extrapolation::zero)(1.5),
            J(0, 0));
  EXPECT_EQ(TorqueSignal<2>(0.0, 0.5, kSamples, Interpolation::linear, Extrapolation::hold)(1.5),
            J(3, 20));
  EXPECT_EQ(TorqueSignal<2>(0.0, 0.5, kSamples, Interpolation::hold, Extrapolation::hold)(-1),
            J(0, 10));
  EXPECT_EQ(extrapolation_from_string("zero"), Extrapolation::zero);
  EXPECT_THROW(extrapolation_from_string("clamp"), std::invalid_argument);
}

// x'' = u(t) / m with u held on each interval: exact piecewise quadratic.
struct HeldBody {
  static constexpr double m = 2.0, dt_samples = 0.1;
  std::vector<Eigen::Matrix<double, 1, 1>> u;
  HeldBody() {
    for (int k = 0; k <= 20; ++k)
      u.push_back(Eigen::Matrix<double, 1, 1>(std::sin(1.7 * k) + 0.3 * k));
  }
  Eigen::VectorXd exact(double T) const {
    Eigen::VectorXd x = Eigen::Vector2d(0.1, -0.2);
    for (int k = 0; k * dt_samples < T - 1e-12; ++k) {
      const double a = u[k][0] / m, h = std::min(dt_samples, T - k * dt_samples);
      x = Eigen::Vector2d(x[0] + x[1] * h + 0.5 * a * h * h, x[1] + a * h);
    }
    return x;
  }
  Eigen::VectorXd run(IntegratorOptions opt, bool use_held_over, double T = 2.0) const {
    const TorqueSignal<1> tau(0.0, dt_samples, u, Interpolation::hold);
    double t_a = 0, t_b = 0;
    opt.step_begin = [&](double a, double b) {
      t_a = a;
      t_b = b;
    };
    auto f = [&](const Eigen::VectorXd& x, Eigen::VectorXd& dxdt, double t) {
      const double torque = use_held_over ? tau.held_over(t_a, t_b)[0] : tau(t)[0];
      dxdt = Eigen::Vector2d(x[1], torque / m);
    };
    Eigen::VectorXd x = Eigen::Vector2d(0.1, -0.2);
    integrate(opt, f, x, 0.0, T, 0.5, [](const Eigen::VectorXd&, double) {});
    return x;
  }
};

TEST(TorqueSignal, HoldIsATrueZeroOrderHoldInEveryIntegrator) {
  const HeldBody body;
  const Eigen::VectorXd exact = body.exact(2.0);
  IntegratorOptions rk4;
  rk4.dt = 0.05;
  // RK4 is exact for a quadratic when every stage of a step sees one sample.
  EXPECT_LT((body.run(rk4, true) - exact).norm(), 1e-13);
  // The defect this replaced: stages at t_b took the next sample, a first-order error.
  EXPECT_GT((body.run(rk4, false) - exact).norm(), 1e-3);
  IntegratorOptions midpoint = rk4;
  midpoint.method = Method::implicit_midpoint;
  EXPECT_LT((body.run(midpoint, true) - exact).norm(), 1e-12);
  for (Method m : {Method::dopri5, Method::rkf78}) {
    IntegratorOptions adaptive;
    adaptive.method = m;
    adaptive.rtol = 1e-10;
    adaptive.atol = 1e-12;
    adaptive.breakpoint_interval = HeldBody::dt_samples;
    EXPECT_LT((body.run(adaptive, true) - exact).norm(), 1e-9) << to_string(m);
  }
}

TEST(TorqueSignal, BreakpointsStopAfterTheLastSampleAndTooFineGridsAreRefused) {
  IntegratorOptions opt;
  opt.method = Method::dopri5;
  opt.rtol = 1e-6;
  opt.breakpoint_interval = 0.01;
  opt.breakpoint_end = 0.5;
  int steps_after_end = 0;
  opt.step_begin = [&](double a, double) { steps_after_end += a >= 0.5; };
  auto decay = [](const Eigen::VectorXd& x, Eigen::VectorXd& dxdt, double) { dxdt = -x; };
  Eigen::VectorXd x = Eigen::Vector2d(1, 2);
  integrate(opt, decay, x, 0.0, 2.0, 0.5, [](const Eigen::VectorXd&, double) {});
  EXPECT_LT(steps_after_end, 50) << "steps still land every 0.01 s after the last sample";
  EXPECT_NEAR(x[0], std::exp(-2.0), 1e-5);

  // A grid step that rounds to nothing at these times used to loop forever.
  for (Method m : {Method::dopri5, Method::rkf78}) {
    opt.method = m;
    opt.breakpoint_interval = 1e-12;
    opt.breakpoint_origin = 1e6;
    opt.breakpoint_end = 2e6;
    x = Eigen::Vector2d(1, 2);
    EXPECT_THROW(integrate(opt, decay, x, 1e6, 1e6 + 1, 0.5, [](const Eigen::VectorXd&, double) {}),
                 std::invalid_argument);
  }
}

}  // namespace
}  // namespace spacearm
