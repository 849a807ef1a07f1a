// runtime/step_jacobian.hpp: one rk4 step's state is the runtime's own rk4 step (integrate_motion
// with the torques held), and A, B equal central differences of that step on the tangent spaces
// (q ⊕ delta, configuration_space.hpp): the flexible paper model (exact state Jacobian) and the
// spatial test arm (a free base's quaternion; its state Jacobian by differences). Cost: well
// under 1 s.
#include "step_jacobian.hpp"

#include <random>

#include "paper_flexible.hpp"
#include "simulation.hpp"
#include "spatial_arm2.hpp"
#include "support.hpp"

namespace spacearm {
namespace {

// The runtime's own step: integrate_motion over one rk4 step of dt with tau held.
void runtime_step(const DynamicModel& m, const Eigen::VectorXd& q, const Eigen::VectorXd& v,
                  const Eigen::VectorXd& tau, double dt, Eigen::VectorXd& q1, Eigen::VectorXd& v1) {
  IntegratorOptions options;
  options.method = Method::rk4;
  options.dt = dt;
  integrate_motion(
      m, q, v, [&tau](double) { return tau; }, dt, dt, options,
      [&](double t, const Eigen::VectorXd& qs, const Eigen::VectorXd& vs) {
        if (t > 0) q1 = qs, v1 = vs;
      });
}

// A and B against central differences of runtime_step, each column along one tangent direction
// of (q, v) or one joint torque; the state after the step as the runtime's.
void check(const DynamicModel& m, const Eigen::VectorXd& q, const Eigen::VectorXd& v,
           const Eigen::VectorXd& tau, double dt, double tolerance) {
  SCOPED_TRACE(m.name);
  const ConfigurationSpace space = m.configuration_space();
  const int nv = m.nv, N = m.num_links;
  const StepJacobians J = rk4_step_jacobians(m, q, v, tau, dt);
  Eigen::VectorXd q1, v1;
  runtime_step(m, q, v, tau, dt, q1, v1);
  EXPECT_LT((J.q - q1).norm(), 1e-14 * (1 + q1.norm()));
  EXPECT_LT((J.v - v1).norm(), 1e-13 * (1 + v1.norm()));
  ASSERT_EQ(J.A.rows(), 2 * nv);
  ASSERT_EQ(J.A.cols(), 2 * nv);
  ASSERT_EQ(J.B.cols(), N);
  // The step's result as a tangent from (q1, v1).
  auto moved = [&](const Eigen::VectorXd& qs, const Eigen::VectorXd& vs,
                   const Eigen::VectorXd& taus) {
    Eigen::VectorXd qa, va;
    runtime_step(m, qs, vs, taus, dt, qa, va);
    Eigen::VectorXd d(2 * nv);
    d << space.difference(q1, qa), va - v1;
    return d;
  };
  const double h = 1e-6;
  for (int k = 0; k < 2 * nv; ++k) {
    Eigen::VectorXd delta = Eigen::VectorXd::Zero(2 * nv);
    delta[k] = h;
    const Eigen::VectorXd plus = moved(space.integrate(q, delta.head(nv)), v + delta.tail(nv), tau);
    const Eigen::VectorXd minus =
        moved(space.integrate(q, -delta.head(nv)), v - delta.tail(nv), tau);
    const Eigen::VectorXd column = (plus - minus) / (2 * h);
    EXPECT_LT((J.A.col(k) - column).norm(), tolerance * (1 + column.norm())) << "x " << k;
  }
  for (int j = 0; j < N; ++j) {
    const Eigen::VectorXd e = 1e-5 * Eigen::VectorXd::Unit(N, j);  // the stages bend the step
    const Eigen::VectorXd column = (moved(q, v, tau + e) - moved(q, v, tau - e)) / 2e-5;
    EXPECT_LT((J.B.col(j) - column).norm(), tolerance * (1 + column.norm())) << "tau " << j;
  }
}

TEST(StepJacobian, FlexiblePaperModelAgreesWithDifferencesOfTheRuntimeStep) {
  const Model<models::paper_flexible::Model> model;  // dynamic_model() refers to it
  const DynamicModel m = dynamic_model(model);
  ASSERT_TRUE(m.has_state_jacobian());
  std::mt19937 rng(5);
  // The motors near their links' angles times p (the springs a little deflected), as a run has
  // them; a step the spring's mode resolves (|lambda| dt about 0.3).
  Eigen::VectorXd q = test::random_vector(rng, m.nq, 0.5);
  const int N = m.num_links;
  q.tail(N) = m.gear_ratios.cwiseProduct(q.segment(3, N)) + test::random_vector(rng, N, 1e-3);
  const Eigen::VectorXd v = test::random_vector(rng, m.nv, 0.3),
                        tau = test::random_vector(rng, N, 2.0);
  check(m, q, v, tau, 1e-4, 1e-6);
}

TEST(StepJacobian, SpatialArmAgreesOnTheQuaternionsTangentSpace) {
  const Model<models::spatial_arm2::Model> model;  // dynamic_model() refers to it
  const DynamicModel m = dynamic_model(model);
  ASSERT_EQ(m.configuration_space().quaternion_offset, 3);
  Eigen::VectorXd q(m.nq), v(m.nv), tau(m.num_links);
  q << 0.1, 0.2, 0.3, 0.5, 0.5, -0.5, 0.5, 3.0, -7.0;
  v << 0.1, -0.2, 0.3, 0.4, -0.5, 0.6, 7.0, -8.0;
  tau << 0.5, -0.3;
  check(m, q, v, tau, 0.01, 1e-6);
  // Wrong sizes and steps are refused by name.
  EXPECT_THROW(rk4_step_jacobians(m, v, v, tau, 0.01), std::invalid_argument);
  EXPECT_THROW(rk4_step_jacobians(m, q, v, tau, 0), std::invalid_argument);
}

}  // namespace
}  // namespace spacearm
