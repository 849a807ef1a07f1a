// The extremes: huge gear ratios, zero motor inertia, singular arm poses, heavy and light
// bases, fast joint rates and long horizons. Each check states the tolerance it expects and
// why; the measured values are printed so that the margins stay visible.
#include <Eigen/Cholesky>
#include <Eigen/SVD>

#include <limits>

#include "free_n3_base_params.hpp"
#include "integrator_options.hpp"
#include "model.hpp"
#include "paper_geared.hpp"
#include "paper_reference.hpp"
#include "simulation.hpp"
#include "support.hpp"
#include "trajectory_planning.hpp"

namespace spacearm {
namespace {

using Ref = Model<models::paper_reference::Model>;
using Geared = Model<models::paper_geared::Model>;
using Arm = Model<models::free_n3_base_params::Model>;
constexpr double kEps = std::numeric_limits<double>::epsilon();

// The accelerations of the geared model in long double (the generated code is instantiated
// for it, with the same double constants), as the reference for the forward error.
Geared::Vector accelerations_long_double(const Geared& g, const Geared::Vector& q,
                                         const Geared::Vector& qd, const Geared::Vector& Q) {
  namespace m = models::paper_geared;
  using LD = long double;
  m::MassMatrix<LD> M;
  m::Coordinates<LD> b;
  m::mass_matrix_and_bias<LD>(q.cast<LD>(), qd.cast<LD>(), g.parameters().cast<LD>(), M, b);
  return Eigen::LLT<m::MassMatrix<LD>>(M).solve(Q.cast<LD>() - b).cast<double>();
}

// Gear ratios up to 1e4 with I_m = 1e-5: the rotor bounds cond(M) (about I_base / I_m).
// Expected: the forward error of qdd against a long double evaluation is at most
// 100 eps cond(S M S), S = diag(M)^-1/2 (perturbation bound of a Cholesky solve, which is
// invariant under diagonal scaling, with M and b evaluated to a few ulps: the factor 100
// covers those and the norms' slack).
TEST(Extremes, HugeGearRatiosWithMotorInertiaStayAccurate) {
  std::mt19937 rng(7);
  for (double p : {1.0, 10.0, 100.0, 1e3, 1e4}) {
    Geared g;
    g.set_parameter("p", p);
    g.set_parameter("Im", 1e-5);
    for (int trial = 0; trial < 5; ++trial) {
      Geared::Vector q = test::random_vector(rng, 6, 3), qd = test::random_vector(rng, 6, 1);
      q.tail<3>() *= p;  // motor angles and rates are p times the joint's
      qd.tail<3>() *= p;
      const Geared::Vector Q = g.generalized_forces(test::random_vector(rng, 3, 1));
      const Geared::Vector qdd = g.forward_dynamics(q, qd, Q);
      ASSERT_TRUE(qdd.allFinite());
      const Geared::Vector exact = accelerations_long_double(g, q, qd, Q);
      const double cond = g.condition_number(q), scaled = g.scaled_condition_number(q);
      const double error = (qdd - exact).norm() / exact.norm();
      if (trial == 0)
        std::printf("p = %g: cond(M) = %.2e, scaled %.2e, relative error of qdd %.1e\n", p, cond,
                    scaled, error);
      EXPECT_LT(error, 100 * scaled * kEps) << "p = " << p;
      EXPECT_LT(cond, 1e8) << "p = " << p;  // the rotor bounds it
    }
  }
}

// I_m = 0 and a growing ratio: cond(M_g) grows as p^2 (the link inertia is divided by p^2
// in motor coordinates and nothing else is left on the motor's diagonal), but that is only
// a scaling, which Cholesky does not see: the condition number of the diagonally scaled M
// stays flat. Expected: the accelerations, mapped back to joints, equal the reference
// model's (the geared model at I_m = 0 is the reference in other coordinates) to
// 100 eps cond(scaled M), for p up to 1e10 where cond(M) passes 1e23 - no refusal, no noise.
TEST(Extremes, ZeroMotorInertiaAtLargeRatiosStaysAccurate) {
  Ref ref;
  const Ref::Vector q_joint = (Ref::Vector() << 0.1, -0.2, 0.4, 0.3, 1.2, -0.5).finished();
  const Ref::Vector qd_joint = (Ref::Vector() << 0.01, 0.02, -0.03, 0.2, -0.1, 0.3).finished();
  const Ref::JointVector tau(0.05, -0.02, 0.01);
  const Ref::Vector qdd_ref = ref.forward_dynamics(q_joint, qd_joint, ref.generalized_forces(tau));
  for (double p = 10; p <= 1e10; p *= 10) {
    Geared g;
    g.set_parameter("Im", 0);
    g.set_parameter("p", p);
    Geared::Vector q = q_joint, qd = qd_joint;
    q.tail<3>() *= p;
    qd.tail<3>() *= p;
    const double cond = g.condition_number(q), scaled = g.scaled_condition_number(q);
    Geared::Vector qdd = g.forward_dynamics(q, qd, g.generalized_forces(tau));
    qdd.tail<3>() /= p;  // back to joint accelerations
    const double error = (qdd - qdd_ref).norm() / qdd_ref.norm();
    std::printf("p = %g: cond(M) = %.2e, scaled %.2e, relative error %.1e\n", p, cond, scaled,
                error);
    EXPECT_LT(error, 100 * scaled * kEps) << "p = " << p;
    EXPECT_LT(scaled, 1e4) << "p = " << p;
    if (p == 1e10) {
      EXPECT_GT(cond, 1e20);
    }
  }
}

// Fully stretched and folded arms are kinematic singularities (the arm Jacobian loses rank)
// but not dynamic ones: every body keeps its mass and inertia, so M stays positive definite
// and well conditioned there. Expected: cond(M) below 1e4 (measured about 2e3) and the
// forward dynamics residual at rounding level (1e-12 relative); the arm Jacobian's smallest
// singular value is zero to rounding (1e-12) stretched and not at a generic pose.
TEST(Extremes, SingularArmPosesAreKinematicNotDynamic) {
  Ref model;
  const Ref::Vector stretched = Ref::Vector::Zero();
  const Ref::Vector folded = (Ref::Vector() << 0, 0, 0, 0, M_PI, 0).finished();
  const Ref::Vector generic = (Ref::Vector() << 0, 0, 0, 0.3, 1.2, -0.5).finished();
  const Ref::Vector qd = (Ref::Vector() << 0.1, -0.1, 0.2, 1.0, -2.0, 3.0).finished();
  const Ref::Vector Q = model.generalized_forces(Ref::JointVector(0.1, 0.2, -0.1));
  const std::vector<Ref::Vector> poses = {stretched, folded, generic};
  for (size_t pose = 0; pose < poses.size(); ++pose) {
    const Ref::Vector& q = poses[pose];
    const double cond = model.condition_number(q);
    const Ref::Vector qdd = model.forward_dynamics(q, qd, Q);
    const Ref::Matrix M = model.mass_matrix(q);
    EXPECT_LT(cond, 1e4);
    EXPECT_LT((M * qdd + model.bias_forces(q, qd) - Q).norm(),
              1e-12 * (M.norm() * qdd.norm() + Q.norm()));
    const Eigen::Matrix3d J_arm = model.end_effector_jacobian(q).rightCols<3>();
    const double sigma_min = Eigen::JacobiSVD<Eigen::Matrix3d>(J_arm).singularValues()[2];
    std::printf("q_arm = (%g, %g, %g): cond(M) = %.2e, smallest singular value of J_arm %.1e\n",
                q[3], q[4], q[5], cond, sigma_min);
    if (pose < 2) {
      EXPECT_LT(sigma_min, 1e-12);
    } else {
      EXPECT_GT(sigma_min, 1e-2);
    }
  }
}

// A straight line out of the workspace drives the planner into the stretched-arm
// singularity: it must stop with an error that says so, not return NaN torques.
TEST(Extremes, PlannerStopsAtTheWorkspaceBoundary) {
  Ref model;
  StraightLineTask task;
  task.start = Eigen::Vector3d(1.2, 0.3, 0.3);
  task.goal = Eigen::Vector3d(1.9, 0.3, 0.0);  // beyond the reach of about 1.62 m
  task.duration = 5;
  try {
    const auto plan = plan_straight_line(model, task);
    ADD_FAILURE() << "planned " << plan.t.size() << " samples through the boundary; last q "
                  << plan.q.back().transpose();
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("singular"), std::string::npos) << e.what();
  }
}

// Heavy (1e4 kg) and light (1 kg) bases, the same arm and torques for 2 s from rest.
// Expected: momentum stays at its initial zero to 1e-9 of the largest generalized momentum
// |M qd| (RK4 at 1 ms: an O(dt^4) truncation error, measured 3e-11 and 1.1e-10), the
// torques' work equals the change of kinetic energy to 1e-6 relative (the work is a
// trapezoidal sum on the 1 ms output grid, O(dt^2): measured about 1e-7), and the base turns
// in proportion to the arm/base inertia ratio.
TEST(Extremes, HeavyAndLightBases) {
  double base_turn[2];
  int k = 0;
  for (double m0 : {1e4, 1.0}) {
    Arm arm;
    arm.set_parameter("m0", m0);
    arm.set_parameter("I0", 2.695 * m0 / 64.859);  // same radius of gyration as the paper's base
    arm.set_parameter("p", 10);
    IntegratorOptions opt;
    opt.method = Method::rk4;
    opt.dt = 0.001;
    auto tau = [](double t) {
      return Arm::JointVector(0.2 * std::sin(3 * t), -0.1 * std::cos(2 * t), 0.05).eval();
    };
    const auto tr = simulate<models::free_n3_base_params::Model>(
        arm, Arm::Vector::Zero(), Arm::Vector::Zero(), tau, 2.0, 0.001, opt);
    double h_max = 0, scale = 0, cond_max = 0;
    for (size_t i = 0; i < tr.t.size(); ++i) {
      h_max = std::max(h_max, tr.momentum[i].norm());
      scale = std::max(scale, (arm.mass_matrix(tr.q[i]) * tr.qd[i]).norm());
      cond_max = std::max(cond_max, tr.condition_number[i]);
    }
    const double energy_error =
        std::abs(tr.work.back() - tr.kinetic_energy.back()) / tr.kinetic_energy.back();
    base_turn[k++] = std::abs(tr.q.back()[2]);
    std::printf(
        "m0 = %g kg: max |h| %.1e (scale %.1e), work vs energy %.1e, base turn %.2e rad, max "
        "cond(M) %.1e\n",
        m0, h_max, scale, energy_error, std::abs(tr.q.back()[2]), cond_max);
    EXPECT_LT(h_max, 1e-9 * scale);
    EXPECT_LT(energy_error, 1e-6);
    EXPECT_GT((tr.q.back().tail<3>()).norm(), 0.1);  // the arm moved
  }
  // Base rotation scales about as the arm's inertia over the base's: 1e4 times less on the
  // heavy base; at least 100x less keeps the check robust to the geometry.
  EXPECT_LT(base_turn[0], base_turn[1] / 100);
}

// Fast joint rates: the bias is exactly quadratic in qd, T too, so scaling qd by 1e3 scales
// them by 1e6 to rounding (1e-13 relative); forward dynamics stay finite and solve eq. 5.
TEST(Extremes, FastJointRatesScaleQuadratically) {
  Geared g;
  g.set_parameter("p", 100);
  const Geared::Vector q = (Geared::Vector() << 0.1, 0.2, 0.3, 30, 120, -50).finished();
  const Geared::Vector qd = (Geared::Vector() << 0.05, 0.02, -0.1, 2.0, -3.0, 4.0).finished();
  for (double s : {1e2, 1e3, 1e4}) {
    const Geared::Vector b = g.bias_forces(q, qd), bs = g.bias_forces(q, s * qd);
    EXPECT_MATRIX_NEAR(bs, s * s * b, 1e-13);
    EXPECT_NEAR(g.kinetic_energy(q, s * qd), s * s * g.kinetic_energy(q, qd),
                1e-13 * s * s * g.kinetic_energy(q, qd));
    const Geared::Vector qdd = g.forward_dynamics(q, s * qd, Geared::Vector::Zero());
    ASSERT_TRUE(qdd.allFinite());
    EXPECT_LT((g.mass_matrix(q) * qdd + bs).norm(), 1e-12 * bs.norm());
  }
}

// 1e4 s of free motion of the geared model (p = 10, motor rates up to 4 rad/s; the base
// drifts about 250 m, so the angular momentum about the origin carries a large r0 x P).
// Bounds on the largest relative error of momentum and kinetic energy over the run, 10x
// above what was measured here (momentum / energy):
//  - rk4 at 0.01 s: O(dt^4) errors that accumulate; measured 3.2e-9 / 3.2e-11;
//  - dopri5 at 1e-10: local errors held to the tolerance, accumulating; 4.2e-8 / 3.9e-10;
//  - implicit midpoint at 0.05 s: second order at 5x the step, so 1e4-1e5 times larger;
//    in (q, qd) it is neither symplectic nor momentum-conserving; 6.2e-4 / 6.0e-6.
TEST(Extremes, LongHorizonDriftStaysWithinStatedBounds) {
  Geared g;
  g.set_parameter("p", 10);
  const Geared::Vector q0 = (Geared::Vector() << 0.1, -0.2, 0.3, 3.0, 12.0, -5.0).finished();
  const Geared::Vector qd0 = (Geared::Vector() << 0.05, 0.02, -0.1, 2.0, -3.0, 4.0).finished();
  struct Case {
    Method method;
    double dt, momentum_bound, energy_bound;
  };
  for (const Case c : {Case{Method::rk4, 0.01, 3e-8, 3e-10}, Case{Method::dopri5, 0, 4e-7, 4e-9},
                       Case{Method::implicit_midpoint, 0.05, 6e-3, 6e-5}}) {
    IntegratorOptions opt;
    opt.method = c.method;
    opt.dt = c.dt ? c.dt : 0.01;
    opt.rtol = opt.atol = 1e-10;
    const auto tr = simulate<models::paper_geared::Model>(
        g, q0, qd0, [](double) { return Geared::JointVector::Zero().eval(); }, 1e4, 100.0, opt);
    const Eigen::Vector3d h0 = tr.momentum.front();
    const double T0 = tr.kinetic_energy.front();
    double dh = 0, dT = 0;
    for (size_t k = 0; k < tr.t.size(); ++k) {
      dh = std::max(dh, (tr.momentum[k] - h0).norm() / h0.norm());
      dT = std::max(dT, std::abs(tr.kinetic_energy[k] - T0) / T0);
    }
    std::printf("%s over 1e4 s: %ld evaluations, momentum drift %.1e, energy drift %.1e\n",
                to_string(c.method).c_str(), tr.stats.rhs_evaluations, dh, dT);
    EXPECT_LT(dh, c.momentum_bound) << to_string(c.method);
    EXPECT_LT(dT, c.energy_bound) << to_string(c.method);
  }
}

}  // namespace
}  // namespace spacearm
