// runtime/simulation.hpp's integrate_motion: after its set-up an integration allocates nothing
// per step. Every allocation of the process is counted (counting_malloc.hpp) and a run three
// times as long must allocate exactly as often as the short one: a loaded model (planar, and
// spatial, whose quaternion is projected after every step) with each explicit method, and a
// linked model at fixed size. Without the forward-dynamics call on a workspace of its own the
// same run allocates on every evaluation, which shows that the count sees them; its samples and
// errors are the workspace's, to the bit and to the letter.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "compiled_model.hpp"
#include "counting_malloc.hpp"
#include "model_recipe.hpp"
#include "paper_geared.hpp"
#include "simulation.hpp"

namespace spacearm {
namespace {

using Geared = Model<models::paper_geared::Model>;

CompiledModel loaded(const std::string& scene) {
  CompileOptions options;
  options.cache_dir = SPACEARM_TEST_CACHE_DIR;
  return CompiledModel::load(ModelRecipe::load(SPACEARM_SOURCE_DIR + scene), options);
}

// Smooth joint torques of N joints sampled every 0.1 s over [0, 3] s.
TorqueSignal<Eigen::Dynamic> torques(int N) {
  std::vector<Eigen::VectorXd> samples;
  for (int k = 0; k <= 30; ++k) {
    Eigen::VectorXd tau(N);
    for (int j = 0; j < N; ++j) tau[j] = 0.02 * std::sin(0.1 * k * (j + 1) + j);
    samples.push_back(tau);
  }
  return TorqueSignal<Eigen::Dynamic>(0.0, 0.1, samples, Interpolation::linear);
}

// An integration to t_end from (q0, qd0), sampled every 0.01 s: the samples of q end to end,
// and the allocations it made. With breakpoints at the torque samples dopri5 takes controlled
// steps, without them dense output. (One integrate_motion per model type: each instantiates
// every method, the test's compile time.)
struct Integration {
  std::vector<double> q;
  long allocations = 0;
};
template <class Mdl, class Vector, class Velocity>
Integration run(const Mdl& model, const Vector& q0, const Velocity& qd0, int num_links,
                Method method, bool breakpoints, double t_end) {
  const TorqueSignal<Eigen::Dynamic> tau = torques(num_links);
  IntegratorOptions opt;
  opt.method = method;
  const TorqueReplay<Eigen::Dynamic> replay(tau, opt, "dt");
  if (!breakpoints) {  // linear interpolation: the replay is then the signal itself
    opt.breakpoint_interval = 0;
    opt.step_begin = nullptr;
  }
  Integration r;
  r.q.reserve(400 * q0.size());  // the observer allocates nothing either
  auto observe = [&r](double, const auto& q, const auto&) {
    r.q.insert(r.q.end(), q.data(), q.data() + q.size());
  };
  counting_malloc::start();
  integrate_motion(model, q0, qd0, replay, t_end, 0.01, opt, observe);
  r.allocations = counting_malloc::stop();
  EXPECT_EQ(r.q.size(), (std::lround(t_end / 0.01) + 1) * q0.size());
  return r;
}

// The same model without its workspace call: forward_dynamics, which allocates on every call.
DynamicModel without_workspace(DynamicModel d) {
  d.make_forward_dynamics_call = nullptr;
  return d;
}

void expect_no_allocation_per_step(const DynamicModel& d, const Eigen::VectorXd& q0) {
  const Eigen::VectorXd qd0 = Eigen::VectorXd::Constant(d.nv, 0.01);
  for (const auto& [method, breakpoints] : {std::pair{Method::rk4, true},
                                            {Method::dopri5, true},
                                            {Method::dopri5, false},
                                            {Method::rkf78, true}}) {
    SCOPED_TRACE(to_string(method) + (breakpoints ? " with breakpoints" : " dense"));
    const Integration once = run(d, q0, qd0, d.num_links, method, breakpoints, 1.0);
    const Integration thrice = run(d, q0, qd0, d.num_links, method, breakpoints, 3.0);
    EXPECT_EQ(thrice.allocations, once.allocations);
    EXPECT_GT(once.allocations, 0);  // the count sees the set-up's
    // Without the workspace: an allocation on every evaluation, and the same samples.
    const Integration checked =
        run(without_workspace(d), q0, qd0, d.num_links, method, breakpoints, 3.0);
    EXPECT_GT(checked.allocations, thrice.allocations + 300);
    EXPECT_EQ(checked.q, thrice.q);
  }
}

TEST(Simulation, AllocatesNothingPerStepOnALoadedPlanarModel) {
  if (!counting_malloc::enabled()) GTEST_SKIP() << "AddressSanitizer replaces malloc";
  const CompiledModel m = loaded("/models/paper_geared.yaml");
  Eigen::VectorXd q0(6);
  q0 << 0.1, -0.2, 0.3, 3.0, 12.0, -5.0;
  expect_no_allocation_per_step(
      dynamic_model(m, Eigen::Map<const Eigen::VectorXd>(m.nominal_parameters().data(),
                                                         m.nominal_parameters().size())),
      q0);
}

TEST(Simulation, AllocatesNothingPerStepOnALoadedSpatialModel) {
  if (!counting_malloc::enabled()) GTEST_SKIP() << "AddressSanitizer replaces malloc";
  const CompiledModel m = loaded("/tests/scenes/spatial_arm2.yaml");
  const DynamicModel d =
      dynamic_model(m, Eigen::Map<const Eigen::VectorXd>(m.nominal_parameters().data(),
                                                         m.nominal_parameters().size()));
  ASSERT_GE(d.quaternion_offset, 0);
  Eigen::VectorXd q0 = d.neutral_configuration();
  q0.tail(2) << 0.3, -0.4;
  expect_no_allocation_per_step(d, q0);
}

TEST(Simulation, AllocatesNothingPerStepOnALinkedModel) {
  if (!counting_malloc::enabled()) GTEST_SKIP() << "AddressSanitizer replaces malloc";
  Geared geared;
  geared.set_parameter("p", 10);
  Geared::Vector q0;
  q0 << 0.1, -0.2, 0.3, 3.0, 12.0, -5.0;
  const Geared::Velocity qd0 = Geared::Velocity::Constant(0.01);
  const Integration once = run(geared, q0, qd0, 3, Method::rk4, true, 1.0);
  const Integration thrice = run(geared, q0, qd0, 3, Method::rk4, true, 3.0);
  EXPECT_EQ(thrice.allocations, once.allocations);
  // Its DynamicModel, through the linked source's call at fixed size: the same.
  const DynamicModel d = dynamic_model(geared);
  const Eigen::VectorXd x0 = q0, v0 = qd0;
  EXPECT_EQ(run(d, x0, v0, 3, Method::rk4, true, 3.0).allocations,
            run(d, x0, v0, 3, Method::rk4, true, 1.0).allocations);
}

// A failure of the dynamics reads the same through the workspace as through forward_dynamics.
TEST(Simulation, AFailureOnTheWorkspaceNamesWhatForwardDynamicsNames) {
  const CompiledModel m = loaded("/models/paper_geared.yaml");
  const DynamicModel d =
      dynamic_model(m, Eigen::Map<const Eigen::VectorXd>(m.nominal_parameters().data(),
                                                         m.nominal_parameters().size()));
  Eigen::VectorXd q0(6);
  q0 << 0.1, -0.2, 0.3, 3.0, 12.0, -5.0;
  const Eigen::VectorXd qd0 = Eigen::VectorXd::Constant(6, 0.01);
  auto failure = [&](const DynamicModel& model) {
    IntegratorOptions opt;
    // A torque that is not a number after 0.5 s: a non-finite input of the dynamics.
    auto broken = [](double t) -> Eigen::VectorXd {
      return Eigen::VectorXd::Constant(3, t > 0.5 ? std::nan("") : 0.0);
    };
    try {
      integrate_motion(model, q0, qd0, broken, 1.0, 0.01, opt,
                       [](double, const Eigen::VectorXd&, const Eigen::VectorXd&) {});
    } catch (const IntegrationError& e) {
      return std::string(e.what());
    }
    return std::string("no failure");
  };
  const std::string workspace = failure(d), checked = failure(without_workspace(d));
  EXPECT_EQ(workspace, checked);
  EXPECT_NE(workspace.find("model paper_geared: non-finite input Q[3] = nan"), std::string::npos)
      << workspace;
  EXPECT_NE(workspace.find(" at t = 0.505"), std::string::npos) << workspace;
}

}  // namespace
}  // namespace spacearm
