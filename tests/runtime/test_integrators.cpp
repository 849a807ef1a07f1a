// runtime/integrators.hpp on the generated geared model: order of convergence, tolerance
// control, and conservation of momentum and energy without torques.
#include <random>

#include "integrators.hpp"

#include "paper_geared.hpp"
#include "simulation.hpp"
#include "torque_signal.hpp"
#include "support.hpp"

namespace spacearm {
namespace {

using G = models::paper_geared::Model;
using Geared = Model<G>;

struct Rollout {
  Geared model;
  Geared::Vector q0 = (Geared::Vector() << 0.1, -0.2, 0.3, 3.0, 12.0, -5.0).finished();
  Geared::Vector qd0 = (Geared::Vector() << 0.05, 0.02, -0.1, 2.0, -3.0, 4.0).finished();
  Rollout() { model.set_parameter("p", 10); }
  // A smooth motor torque, so that the solution is smooth and orders are clean.
  static Geared::JointVector torque(double t) {
    return Geared::JointVector(0.02 * std::sin(2 * t), -0.01 * std::cos(3 * t),
                               0.005 * std::sin(t));
  }
  Geared::Vector final_q(const IntegratorOptions& opt, double t_end = 2.0,
                         long* evaluations = nullptr, double dt_out = 0.2) {
    const auto tr = simulate<G>(model, q0, qd0, &Rollout::torque, t_end, dt_out, opt);
    if (evaluations) *evaluations = tr.stats.rhs_evaluations;
    return tr.q.back();
  }
};

Geared::Vector reference_solution(Rollout& s) {
  IntegratorOptions ref;
  ref.method = Method::rkf78;
  ref.rtol = 1e-13;
  ref.atol = 1e-14;
  return s.final_q(ref);
}

double observed_order(Rollout& s, Method m, double dt) {
  const Geared::Vector exact = reference_solution(s);
  IntegratorOptions opt;
  opt.method = m;
  opt.dt = dt;
  const double e1 = (s.final_q(opt) - exact).norm();
  opt.dt = dt / 2;
  const double e2 = (s.final_q(opt) - exact).norm();
  EXPECT_GT(e2, 1e-13)
      << "error at the finer step is at rounding level: the order would be meaningless";
  return std::log2(e1 / e2);
}

// The error checker of dopri5 and rkf78 (without odeint's copies) gives odeint's default
// checker's error and scaled errors to the bit, at fixed and at dynamic size.
template <class State>
void expect_odeints_error(const State& x_old, const State& dxdt, const State& x_err, double dt) {
  namespace odeint = boost::numeric::odeint;
  odeint::vector_space_algebra algebra;
  const odeint::default_error_checker<double, odeint::vector_space_algebra,
                                      odeint::default_operations>
      odeints(1e-10, 1e-8);
  State theirs = x_err, ours = x_err;
  const double e_theirs = odeints.error(algebra, x_old, dxdt, theirs, dt);
  const double e_ours = detail::ErrorChecker(1e-10, 1e-8).error(algebra, x_old, dxdt, ours, dt);
  EXPECT_EQ(e_ours, e_theirs);
  EXPECT_EQ(ours, theirs);
}
TEST(Integrators, ErrorCheckerIsOdeintsToTheBit) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-3, 3);
  for (int trial = 0; trial < 50; ++trial) {
    Eigen::VectorXd x(13), d(13), e(13);
    for (int i = 0; i < 13; ++i) {
      x[i] = u(rng) * std::pow(10.0, u(rng));
      d[i] = u(rng) * std::pow(10.0, u(rng));
      e[i] = u(rng) * 1e-9;
    }
    const double dt = std::abs(u(rng)) * 1e-2 * (trial % 2 ? 1 : -1);
    expect_odeints_error(x, d, e, dt);
    expect_odeints_error(Eigen::Matrix<double, 13, 1>(x), Eigen::Matrix<double, 13, 1>(d),
                         Eigen::Matrix<double, 13, 1>(e), dt);
  }
}

TEST(Integrators, RK4IsFourthOrder) {
  Rollout s;
  const double order = observed_order(s, Method::rk4, 0.02);
  EXPECT_NEAR(order, 4.0, 0.3);
}

TEST(Integrators, ImplicitMidpointIsSecondOrder) {
  Rollout s;
  const double order = observed_order(s, Method::implicit_midpoint, 0.02);
  EXPECT_NEAR(order, 2.0, 0.2);
}

TEST(Integrators, AdaptiveMethodsMeetTheirTolerance) {
  Rollout s;
  const Geared::Vector exact = reference_solution(s);
  for (Method m : {Method::dopri5, Method::rkf78}) {
    SCOPED_TRACE(to_string(m));
    IntegratorOptions opt;
    opt.method = m;
    opt.rtol = opt.atol = 1e-6;
    long n_loose = 0, n_tight = 0;
    // One output at the end, so the step size is free to grow.
    const double loose = (s.final_q(opt, 2.0, &n_loose, 2.0) - exact).norm();
    opt.rtol = opt.atol = 1e-10;
    const double tight = (s.final_q(opt, 2.0, &n_tight, 2.0) - exact).norm();
    std::printf("%s: error %.2e at tolerance 1e-6 (%ld evaluations), %.2e at 1e-10 (%ld)\n",
                to_string(m).c_str(), loose, n_loose, tight, n_tight);
    EXPECT_LT(loose, 1e-4);         // global error within a few hundred local tolerances
    EXPECT_LT(tight, loose / 100);  // 1e4 tighter tolerance: at least 100x smaller error
    EXPECT_GT(n_tight, n_loose);    // and it costs more evaluations
  }
}

// Prothero and Robinson's stiff test y' = lambda (y - g(t)) + g'(t), y(0) = g(0), whose
// solution is g(t) = sin(t) whatever lambda: with lambda = -1e6 an explicit method must keep
// its step below about 3e-6 s for stability, an L-stable one follows g with steps set by
// accuracy alone. rosenbrock4 meets its tolerance in far fewer evaluations than dopri5, with
// the exact Jacobian and df/dt (non-autonomous).
TEST(Integrators, Rosenbrock4SolvesAStiffProblemWithFewSteps) {
  constexpr double lambda = -1e6;
  using V2 = Eigen::Matrix<double, 2, 1>;  // (y, a second, non-stiff component y2' = cos t)
  auto f = [&](const V2& x, V2& d, double t) {
    d[0] = lambda * (x[0] - std::sin(t)) + std::cos(t);
    d[1] = std::cos(t);
  };
  IntegratorOptions opt;
  opt.rtol = opt.atol = 1e-8;
  opt.jacobian = [&](const Eigen::VectorXd&, double t, Eigen::MatrixXd& J, Eigen::VectorXd& dfdt) {
    J = Eigen::MatrixXd::Zero(2, 2);
    J(0, 0) = lambda;
    dfdt = Eigen::Vector2d(-lambda * std::cos(t) - std::sin(t), -std::sin(t));
  };
  long evaluations[2];
  for (Method m : {Method::rosenbrock4, Method::dopri5}) {
    SCOPED_TRACE(to_string(m));
    opt.method = m;
    V2 x(0, 0);
    const auto stats = integrate(opt, f, x, 0.0, 2.0, 2.0, [](const V2&, double) {});
    EXPECT_NEAR(x[0], std::sin(2.0), 1e-6);
    EXPECT_NEAR(x[1], std::sin(2.0), 1e-6);
    evaluations[m == Method::dopri5] = stats.rhs_evaluations;
    if (m == Method::rosenbrock4) {
      EXPECT_GT(stats.jacobian_evaluations, 0);
    }
  }
  std::printf("right-hand side evaluations: rosenbrock4 %ld, dopri5 %ld\n", evaluations[0],
              evaluations[1]);
  EXPECT_LT(50 * evaluations[0], evaluations[1]);
}

TEST(Integrators, Rosenbrock4NeedsAJacobian) {
  IntegratorOptions opt;
  opt.method = Method::rosenbrock4;
  Eigen::Vector2d x(1, 0);
  auto f = [](const Eigen::Vector2d& s, Eigen::Vector2d& d, double) { d = -s; };
  try {
    integrate(opt, f, x, 0.0, 1.0, 0.5, [](const Eigen::Vector2d&, double) {});
    ADD_FAILURE() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("forward_dynamics_derivatives"), std::string::npos)
        << e.what();
  }
}

// x' = x^2, x(0) = 1 blows up at t = 1: no step size meets the tolerance there. The adaptive
// methods say so, with the time and state of the last accepted step, instead of crawling on
// with steps that no longer advance t.
TEST(Integrators, AdaptiveMethodsReportAToleranceTheyCannotMeet) {
  for (Method m : {Method::dopri5, Method::rkf78}) {
    SCOPED_TRACE(to_string(m));
    IntegratorOptions opt;
    opt.method = m;
    opt.rtol = opt.atol = 1e-10;
    Eigen::Matrix<double, 1, 1> x;
    x << 1.0;
    auto f = [](const Eigen::Matrix<double, 1, 1>& s, Eigen::Matrix<double, 1, 1>& d, double) {
      d = s * s[0];
    };
    int observed = 0;
    try {
      integrate(opt, f, x, 0.0, 2.0, 0.5,
                [&](const Eigen::Matrix<double, 1, 1>&, double) { ++observed; });
      ADD_FAILURE() << "no error";
    } catch (const IntegrationError& e) {
      EXPECT_NE(std::string(e.what()).find(to_string(m) + ": step size "), std::string::npos)
          << e.what();
      EXPECT_NE(std::string(e.what()).find("tolerance cannot be met"), std::string::npos)
          << e.what();
      // It stopped at the blow-up: the numerical solution's blow-up time differs from 1 by
      // the global error (about 1e-10 relative here), so t may lie on either side of 1.
      EXPECT_NEAR(e.t(), 1.0, 1e-6);
      ASSERT_EQ(e.state().size(), 1);
      EXPECT_GT(e.state()[0], 1e9);
      EXPECT_TRUE(std::isfinite(e.state()[0]));
      EXPECT_EQ(Eigen::VectorXd(x), e.state());   // the caller's state is the last accepted one
      EXPECT_EQ(observed, e.t() >= 1.0 ? 3 : 2);  // t = 0, 0.5 (and 1 if reached)
    }
  }
}

// Issue 28, item 5: an explicit method on a very stiff problem (x' = -1e12 (x - cos t), as
// friction with velocity_scale 1e-12) used to run for hours without a word; it stops after
// 10 000 steps that could not reach the end in 1e8, naming the stiffness and rosenbrock4.
TEST(Integrators, NoPracticalProgressOnAStiffProblemIsAnErrorNamingRosenbrock4) {
  using X = Eigen::Matrix<double, 1, 1>;
  auto f = [](const X& s, X& d, double t) { d[0] = -1e12 * (s[0] - std::cos(t)); };
  for (Method m : {Method::dopri5, Method::rkf78}) {
    SCOPED_TRACE(to_string(m));
    IntegratorOptions opt;
    opt.method = m;
    X x;
    x << 1.0;
    const auto t0 = std::chrono::steady_clock::now();
    try {
      integrate(opt, f, x, 0.0, 1.0, 0.5, [](const X&, double) {});
      ADD_FAILURE() << "no error";
    } catch (const IntegrationError& e) {
      EXPECT_NE(std::string(e.what()).find("no practical progress"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("stiff"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("use the integrator rosenbrock4"), std::string::npos)
          << e.what();
      EXPECT_LT(e.t(), 1e-6);
    }
    EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::seconds(20));
  }
  // rosenbrock4 itself: Rosenbrock4SolvesAStiffProblemWithFewSteps (at -1e12, Boost.uBLAS's
  // debug check in its LU refuses the Jacobian in builds without NDEBUG, the sanitizer build).
}

TEST(Integrators, ToleranceBelowRoundingAndBadStepsAreRejected) {
  Eigen::Vector2d x(1, 0);
  auto f = [](const Eigen::Vector2d& s, Eigen::Vector2d& d, double) { d << s[1], -s[0]; };
  auto none = [](const Eigen::Vector2d&, double) {};
  IntegratorOptions opt;
  opt.method = Method::dopri5;
  opt.rtol = 1e-20;
  EXPECT_THROW_MESSAGE(integrate(opt, f, x, 0.0, 1.0, 0.5, none), std::invalid_argument,
                       "rtol = 1e-20 must be at least");
  opt.rtol = 1e-8;
  opt.atol = -1;
  EXPECT_THROW_MESSAGE(integrate(opt, f, x, 0.0, 1.0, 0.5, none), std::invalid_argument,
                       "atol = -1 must be >= 0");
  opt.method = Method::rk4;
  opt.dt = std::nan("");
  EXPECT_THROW_MESSAGE(integrate(opt, f, x, 0.0, 1.0, 0.5, none), std::invalid_argument,
                       "dt = nan must be positive");
  opt.dt = 0.3;
  EXPECT_THROW_MESSAGE(integrate(opt, f, x, 0.0, 1.0, 0.5, none), std::invalid_argument,
                       "must be a multiple of the step");
}

// A failure of the dynamics half way (here a NaN torque from t > 0.55) stops the run with an
// IntegrationError at the last accepted step; the trajectory keeps every earlier sample.
TEST(Integrators, SimulationFailureKeepsTheTrajectorySoFar) {
  for (Method m : {Method::rk4, Method::dopri5, Method::rkf78, Method::implicit_midpoint}) {
    SCOPED_TRACE(to_string(m));
    Rollout s;
    IntegratorOptions opt;
    opt.method = m;
    auto tau = [](double t) {
      return t > 0.55 ? Geared::JointVector::Constant(std::nan("")).eval() : Rollout::torque(t);
    };
    Trajectory<G> tr;
    try {
      simulate<G>(tr, s.model, s.q0, s.qd0, tau, 2.0, 0.1, opt);
      ADD_FAILURE() << "no error";
    } catch (const IntegrationError& e) {
      EXPECT_NE(std::string(e.what()).find("non-finite input Q[3] = nan"), std::string::npos)
          << e.what();
      EXPECT_LE(e.t(), 0.55 + 1e-12);
      EXPECT_GT(e.t(), 0.3);
      ASSERT_EQ(e.state().size(), 12);
      EXPECT_TRUE(e.state().allFinite());
      // Every output up to the last accepted step was taken (t = 0, 0.1, ... <= e.t()).
      const size_t samples = static_cast<size_t>(std::floor(e.t() / 0.1 + 1e-9)) + 1;
      ASSERT_EQ(tr.t.size(), samples);
      EXPECT_NEAR(tr.t.back(), 0.1 * (samples - 1), 1e-12);
      EXPECT_EQ(tr.q.size(), samples);
      EXPECT_EQ(tr.kinetic_energy.size(), samples);
      if (m == Method::rk4) {
        EXPECT_EQ(samples, 6u);
        // The reported state is the state at that time: the same steps, run to it, give it.
        const auto ok = simulate<G>(s.model, s.q0, s.qd0, &Rollout::torque, 0.55, 0.05, opt);
        EXPECT_NEAR(e.t(), 0.55, 1e-12);
        Eigen::VectorXd expected(12);
        expected << ok.q.back(), ok.qd.back();
        EXPECT_EQ(e.state(), expected);
      }
    }
  }
}

// Torques joined by straight lines have a kink at every sample. An adaptive step across one
// loses the method's order, and RKF78's error estimate (stages 1, 11, 12, 13 only) does not
// see it: with rough random samples it ends 4.4e-3 off at a tolerance of 1e-10. With
// breakpoints on the samples no step straddles a kink: measured 5.2e-12 against an RK4
// reference on a 256x finer aligned grid. Expected: below 5e-11, and 100x better than
// without.
TEST(Integrators, BreakpointsKeepTheOrderAcrossTorqueKinks) {
  Rollout s;
  std::mt19937 rng(3);
  std::vector<Geared::JointVector> samples;
  for (int k = 0; k <= 40; ++k) samples.push_back(0.05 * test::random_vector(rng, 3, 1));
  const TorqueSignal<3> tau(0.0, 0.05, samples, Interpolation::linear);
  // As a plain function of t, the integrator knows nothing of the samples; as the signal,
  // simulate() sets the breakpoints itself.
  auto final_state = [&](IntegratorOptions opt) {
    const auto tr = simulate<G>(
        s.model, s.q0, s.qd0, [&](double t) { return tau(t); }, 2.0, 2.0, opt);
    return tr.q.back();
  };
  IntegratorOptions ref;
  ref.method = Method::rk4;
  ref.dt = 0.05 / 256;
  const Geared::Vector exact = final_state(ref);
  IntegratorOptions opt;
  opt.method = Method::rkf78;
  opt.rtol = opt.atol = 1e-10;
  const double without = (final_state(opt) - exact).norm();
  opt.breakpoint_interval = 0.05;
  const double with = (final_state(opt) - exact).norm();
  std::printf("rkf78 across kinks: error %.1e without breakpoints, %.1e with\n", without, with);
  EXPECT_LT(with, 5e-11);
  opt.breakpoint_interval = 0;
  const double automatic =
      (simulate<G>(s.model, s.q0, s.qd0, tau, 2.0, 2.0, opt).q.back() - exact).norm();
  EXPECT_LT(automatic, 5e-11);
  EXPECT_LT(100 * with, without);
  opt.breakpoint_interval = -1;
  EXPECT_THROW_MESSAGE(final_state(opt), std::invalid_argument,
                       "breakpoint_interval = -1 must be >= 0");
}

TEST(Integrators, SimulationsAreBitReproducible) {
  for (Method m : {Method::rk4, Method::dopri5, Method::rkf78, Method::implicit_midpoint}) {
    Rollout a, b;
    IntegratorOptions opt;
    opt.method = m;
    const auto ta = simulate<G>(a.model, a.q0, a.qd0, &Rollout::torque, 2.0, 0.1, opt);
    const auto tb = simulate<G>(b.model, b.q0, b.qd0, &Rollout::torque, 2.0, 0.1, opt);
    ASSERT_EQ(ta.q.size(), tb.q.size());
    for (size_t k = 0; k < ta.q.size(); ++k) {
      EXPECT_EQ(ta.q[k], tb.q[k]) << to_string(m) << " sample " << k;
      EXPECT_EQ(ta.qd[k], tb.qd[k]) << to_string(m) << " sample " << k;
    }
    EXPECT_NE(ta.q.back(), a.q0);
  }
}

TEST(Integrators, ZeroTorqueFromRestNothingMoves) {
  Rollout s;
  for (Method m : {Method::rk4, Method::dopri5, Method::implicit_midpoint}) {
    IntegratorOptions opt;
    opt.method = m;
    const auto tr = simulate<G>(
        s.model, s.q0, Geared::Vector::Zero(),
        [](double) { return Geared::JointVector::Zero().eval(); }, 5.0, 0.5, opt);
    EXPECT_EQ(tr.q.back(), s.q0) << to_string(m);
    EXPECT_EQ(tr.qd.back(), Geared::Vector::Zero()) << to_string(m);
  }
}

// Without torques, momentum and kinetic energy are invariants. Bounds, 100x above what was
// measured (RK4 ~1.5e-12, DOPRI5 ~2e-11, implicit midpoint ~3e-8 / 2e-7): RK4 at 0.01 s
// has a local error O(dt^5); DOPRI5 follows its 1e-10 tolerance; the implicit midpoint rule
// (0.01 s) is second order and, applied to (q, qd), conserves neither exactly.
// (test_extremes runs 1e4 s.)
TEST(Integrators, FreeMotionConservesMomentumAndEnergy) {
  Rollout s;
  struct Case {
    Method m;
    double momentum_tol, energy_tol;
  };
  for (const Case c : {Case{Method::rk4, 1e-10, 1e-10}, Case{Method::dopri5, 1e-9, 1e-9},
                       Case{Method::implicit_midpoint, 1e-6, 1e-5}}) {
    SCOPED_TRACE(to_string(c.m));
    IntegratorOptions opt;
    opt.method = c.m;
    opt.rtol = opt.atol = 1e-10;
    const auto tr = simulate<G>(
        s.model, s.q0, s.qd0, [](double) { return Geared::JointVector::Zero().eval(); }, 20.0, 0.1,
        opt);
    const auto h0 = tr.momentum.front();
    const double T0 = tr.kinetic_energy.front();
    ASSERT_GT(h0.norm(), 0.0);
    double dh = 0, dT = 0;
    for (size_t k = 0; k < tr.t.size(); ++k) {
      dh = std::max(dh, (tr.momentum[k] - h0).norm() / h0.norm());
      dT = std::max(dT, std::abs(tr.kinetic_energy[k] - T0) / T0);
    }
    std::printf("%s: max relative momentum drift %.2e, energy drift %.2e\n", to_string(c.m).c_str(),
                dh, dT);
    EXPECT_LT(dh, c.momentum_tol);
    EXPECT_LT(dT, c.energy_tol);
    // The arm did move.
    EXPECT_GT((tr.q.back() - s.q0).norm(), 1.0);
  }
}

}  // namespace
}  // namespace spacearm
