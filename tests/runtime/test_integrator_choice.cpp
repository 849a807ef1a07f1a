// runtime/integrator_choice.hpp: the stiffest linearised mode of the flexible paper system is
// its motor-spring mode, about sqrt(k / (p^2 I_m)); central differences find the same mode as
// the state Jacobian; `auto` keeps rk4 at dt for the rigid arm, shortens the step for a soft
// spring and switches to rosenbrock4 for a stiff one, and what it chose integrates stably.
// Cost: well under 1 s.
#include "integrator_choice.hpp"

#include "paper_flexible.hpp"
#include "paper_geared.hpp"
#include "simulation.hpp"
#include "support.hpp"

namespace spacearm {
namespace {

using Flex = Model<models::paper_flexible::Model>;
using Geared = Model<models::paper_geared::Model>;

StiffestMode at_rest(const DynamicModel& d) {
  Eigen::VectorXd q = Eigen::VectorXd::Zero(d.nq);
  q.segment(3, 3) << 0.3, 0.8, -0.5;
  q.tail(d.nq - 3 - 3) = d.gear_ratios.head(d.nq - 6).cwiseProduct(q.segment(3, d.nq - 6));
  return stiffest_mode(d, q, Eigen::VectorXd::Zero(d.nv), Eigen::VectorXd::Zero(d.nv));
}

TEST(IntegratorChoice, StiffestModeIsTheMotorSpring) {
  Flex flex;
  for (const char* f : {"fv", "fc", "fs"}) flex.set_parameter(f, 0);  // the spring alone
  const DynamicModel d = dynamic_model(flex);
  const StiffestMode mode = at_rest(d);
  const double p = flex.parameters()[0], Im = flex.parameters()[1], k = flex.parameters()[2];
  const double spring = std::sqrt(k / (p * p * Im));
  std::printf("stiffest mode %.1f 1/s (frequency %.1f, %s); sqrt(k/(p^2 Im)) = %.1f\n", mode.rate,
              mode.frequency, mode.coordinate.c_str(), spring);
  EXPECT_NEAR(mode.rate, spring, 0.05 * spring);
  EXPECT_GT(mode.frequency, 0.9 * mode.rate);  // an oscillation, lightly damped
  EXPECT_EQ(mode.coordinate.substr(0, 2), "qm");
  // Central differences of forward dynamics (a model without the state Jacobian) agree.
  DynamicModel no_jacobian = d;
  no_jacobian.forward_dynamics_derivatives = nullptr;
  EXPECT_NEAR(at_rest(no_jacobian).rate, mode.rate, 1e-6 * mode.rate);
}

TEST(IntegratorChoice, AutoKeepsRk4ShortensItsStepOrSwitchesToRosenbrock4) {
  const Geared rigid;
  const DynamicModel dr = dynamic_model(rigid);
  Eigen::VectorXd q = Eigen::VectorXd::Zero(dr.nq), qd = Eigen::VectorXd::Zero(dr.nv);
  qd.tail(3) << 1, -2, 0.5;  // moving, so the modes are not all zero
  const IntegratorChoice keep =
      choose_integrator(stiffest_mode(dr, q, qd, qd * 0), 0.01, 0.01, false);
  EXPECT_EQ(keep.method, Method::rk4);
  EXPECT_EQ(keep.dt, 0.01) << keep.why;

  Flex soft;
  soft.set_parameter("k", 5);  // sqrt(5 / (100 1e-5)) = 71 1/s: rk4 at a somewhat shorter step
  soft.set_parameter("d", 0);  // (d / (p^2 I_m) would be a real mode of 1000 1/s)
  for (const char* f : {"fv", "fc", "fs"}) soft.set_parameter(f, 0);
  const IntegratorChoice shorter = choose_integrator(at_rest(dynamic_model(soft)), 0.1, 0.1, true);
  EXPECT_EQ(shorter.method, Method::rk4) << shorter.why;
  EXPECT_LT(shorter.dt, 0.1);
  EXPECT_GT(shorter.dt, 0.01);
  EXPECT_NEAR(0.1 / shorter.dt, std::round(0.1 / shorter.dt), 1e-9);  // divides dt_out

  const Flex stiff;  // k = 1e4: about 3200 1/s, 30 times the step rk4 could take at 0.01 s
  const StiffestMode mode = at_rest(dynamic_model(stiff));
  const IntegratorChoice implicit = choose_integrator(mode, 0.01, 0.01, true);
  EXPECT_EQ(implicit.method, Method::rosenbrock4);
  EXPECT_NE(implicit.why.find("rosenbrock4"), std::string::npos);
  EXPECT_TRUE(unstable_for_rk4(mode, 0.01));
  // Without the state Jacobian: rk4 at a resolving step, and the advice to add it.
  const IntegratorChoice small = choose_integrator(mode, 0.01, 0.01, false);
  EXPECT_EQ(small.method, Method::rk4);
  EXPECT_LE(small.dt * mode.rate, 1.0);
  EXPECT_NE(small.why.find("forward_dynamics_derivatives"), std::string::npos) << small.why;
}

TEST(IntegratorChoice, WhatAutoChoosesIntegratesTheStiffModelStably) {
  const Flex stiff;
  const DynamicModel d = dynamic_model(stiff);
  Eigen::VectorXd q = Eigen::VectorXd::Zero(d.nq), qd = Eigen::VectorXd::Zero(d.nv);
  q.segment(3, 3) << 0.3, 0.8, -0.5;
  q.tail(3) = 10 * q.segment(3, 3) + Eigen::Vector3d(1e-3, -1e-3, 2e-3);  // springs twisted
  const auto tau = [](double) { return Eigen::VectorXd(Eigen::Vector3d(0.1, -0.05, 0.02)); };
  for (bool small_steps : {false, true}) {
    const StiffestMode mode = stiffest_mode(d, q, qd, d.generalized_forces(tau(0)));
    const IntegratorChoice c = choose_integrator(mode, 0.01, 0.01, !small_steps);
    IntegratorOptions opt;
    c.apply(opt);
    double energy = 0;
    EXPECT_NO_THROW(
        integrate_motion(d, q, qd, tau, 0.2, 0.01, opt,
                         [&](double, const Eigen::VectorXd& x, const Eigen::VectorXd& v) {
                           energy = d.kinetic_energy(x, v) + d.potential_energy(x);
                         }))
        << c.why;
    EXPECT_TRUE(std::isfinite(energy) && energy < 1.0) << c.why << " energy " << energy;
  }
}

}  // namespace
}  // namespace spacearm
