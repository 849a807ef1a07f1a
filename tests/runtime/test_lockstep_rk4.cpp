// LockstepRk4 against Boost.Odeint's runge_kutta4 (integrate()'s rk4): every lane to the bit.
#include <gtest/gtest.h>

#include <boost/numeric/odeint.hpp>
#include <boost/numeric/odeint/external/eigen/eigen.hpp>

#include <cmath>
#include <cstring>

#include "lockstep_rk4.hpp"

namespace {

constexpr int kN = 5;

// A nonlinear system whose terms round: coupled pendulums with a cubic spring and a zero rate
// for the last entry (it starts at -0, which 0 * k turns into +0 in odeint's sum).
void slope(const double* x, double* dxdt, double t, int stride) {
  auto at = [&](int i) { return x[i * stride]; };
  dxdt[0 * stride] = at(1);
  dxdt[1 * stride] = -std::sin(at(0)) + 0.3 * std::cos(1.7 * t) - 0.1 * at(1) * at(3);
  dxdt[2 * stride] = at(3);
  dxdt[3 * stride] = -at(2) * at(2) * at(2) + 0.25 * (at(0) - at(2)) / (1 + t);
  dxdt[4 * stride] = 0.0;
}

Eigen::VectorXd start(int lane) {
  Eigen::VectorXd x(kN);
  x << 0.1 + 0.37 * lane, -0.2 * lane, 1.0 / 3 + lane, 0.7, -0.0;
  return x;
}

// n steps of odeint's runge_kutta4, as integrate() takes them.
Eigen::VectorXd odeint_states(Eigen::VectorXd x, int steps, double h) {
  namespace odeint = boost::numeric::odeint;
  odeint::runge_kutta4<Eigen::VectorXd, double, Eigen::VectorXd, double,
                       odeint::vector_space_algebra>
      stepper;
  auto rhs = [](const Eigen::VectorXd& s, Eigen::VectorXd& d, double t) {
    d.resize(kN);
    slope(s.data(), d.data(), t, 1);
  };
  for (int k = 0; k < steps; ++k) stepper.do_step(rhs, x, k * h, h);
  return x;
}

template <int L>
void expect_lanes_are_odeint() {
  const int steps = 700;
  const double h = 0.013;
  std::vector<double> x(kN * L);
  for (int l = 0; l < L; ++l)
    for (int i = 0; i < kN; ++i) x[i * L + l] = start(l)[i];
  spacearm::LockstepRk4<L> rk4(kN);
  auto rhs = [](const double* s, double* d, double t) {
    for (int l = 0; l < L; ++l) slope(s + l, d + l, t, L);
  };
  for (int k = 0; k < steps; ++k) rk4.step(rhs, x.data(), k * h, h);
  for (int l = 0; l < L; ++l) {
    const Eigen::VectorXd expected = odeint_states(start(l), steps, h);
    for (int i = 0; i < kN; ++i) {
      const double got = x[i * L + l];
      EXPECT_EQ(std::memcmp(&got, &expected[i], sizeof got), 0)
          << "lane " << l << " entry " << i << ": " << got << " vs odeint " << expected[i];
    }
  }
  EXPECT_FALSE(std::signbit(x[4 * L]));  // -0 + 0 * k: odeint's +0
}

TEST(LockstepRk4, OneLaneIsOdeintsRungeKutta4ToTheBit) { expect_lanes_are_odeint<1>(); }
TEST(LockstepRk4, FourLanesAreEachOdeintsRungeKutta4ToTheBit) { expect_lanes_are_odeint<4>(); }

}  // namespace
