// Spatial arms against MuJoCo, in one run: forward dynamics and M + bias of models/space_arm7
// (a 7-joint arm on a free base from its URDF, 13 velocities), compiled through the
// compile-and-load cache at -O2 and called through its C interface without checks, against
// MuJoCo 2.2's mj_forward and its M + bias stages on the same MJCF (tests/mujoco_spatial.hpp).
// MuJoCo has armature gears only; the exact rotors run on the same states for their cost.
// Forward dynamics is the articulated-body algorithm. Before anything is timed, the
// armature model's forward dynamics must equal MuJoCo's to 1e-12.
//   scripts/bench.sh --spatial
#include <benchmark/benchmark.h>

#include <Eigen/Geometry>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include "compiled_model.hpp"
#include "mujoco_spatial.hpp"
#include "spatial_scene.hpp"

namespace spacearm {
namespace {

constexpr int kStates = 64;

SpatialScene arm7(bool exact) {
  const std::string path = std::string(SPACEARM_SOURCE_DIR) + "/models/space_arm7.yaml";
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  SpatialScene s = parse_spatial_scene(text.str(), path);
  for (auto& l : s.chain.links) l.gear.exact = exact;
  s.name = exact ? "space_arm7_exact" : "space_arm7_armature";
  s.content += exact ? "\n# exact" : "\n# armature";  // two models, two cache entries
  return s;
}

struct States {
  std::vector<Eigen::VectorXd> q, v, Q;
};
States random_states(const spatial::ChainDescription& c) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  States s;
  for (int k = 0; k < kStates; ++k) {
    Eigen::VectorXd q(c.nq()), v(c.nv()), Q = Eigen::VectorXd::Zero(c.nv());
    for (int i = 0; i < c.nq(); ++i) q[i] = 2 * u(rng);
    const Eigen::Quaterniond r = Eigen::Quaterniond::UnitRandom();
    q.segment<4>(3) << r.w(), r.x(), r.y(), r.z();
    for (int i = 0; i < c.nv(); ++i) v[i] = u(rng);
    for (int i = 6; i < c.nv(); ++i) Q[i] = u(rng);
    s.q.push_back(q), s.v.push_back(v), s.Q.push_back(Q);
  }
  return s;
}

struct Loaded {
  CompiledModel model;
  spatial::ChainDescription chain;
};
Loaded load(bool exact) {
  const SpatialScene s = arm7(exact);
  CompileOptions options;
  options.cache_dir = (std::filesystem::temp_directory_path() / "spacearm-bench-spatial").string();
  options.flags = compile_flags("-O2");
  return {CompiledModel::load(ModelRecipe(s), options), s.chain};
}

// MuJoCo's qacc at the states, in the chain's coordinates (qdd_m = p qdd), against ours.
double worst_disagreement(const Loaded& ours, test::MujocoModel& mj, const States& s) {
  const auto& c = ours.chain;
  double worst = 0;
  for (int k = 0; k < kStates; ++k) {
    Eigen::VectorXd D = Eigen::VectorXd::Ones(c.nv());
    for (size_t j = 0; j < c.links.size(); ++j) D[6 + j] = c.links[j].gear.ratio;
    for (int i = 0; i < c.nq(); ++i) mj.d->qpos[i] = i < 7 ? s.q[k][i] : s.q[k][i] / D[i - 1];
    for (int i = 0; i < c.nv(); ++i) {
      mj.d->qvel[i] = s.v[k][i] / D[i];
      mj.d->qfrc_applied[i] = s.Q[k][i] * D[i];
    }
    mj_forward(mj.m.get(), mj.d.get());
    const Eigen::VectorXd mj_qdd =
        D.cwiseProduct(Eigen::Map<const Eigen::VectorXd>(mj.d->qacc, c.nv()));
    const Eigen::VectorXd qdd =
        ours.model.forward_dynamics(s.q[k], s.v[k], s.Q[k], Eigen::VectorXd());
    worst = std::max(worst, (qdd - mj_qdd).norm() / (1 + mj_qdd.norm()));
  }
  return worst;
}

void register_all() {
  static const Loaded armature = load(false), exact = load(true);
  static test::MujocoModel mj(test::mjcf_of(armature.chain));
  static const States s = random_states(armature.chain);
  const double worst = worst_disagreement(armature, mj, s);
  std::printf("check space_arm7 armature: forward dynamics against MuJoCo, max relative %.1e  %s\n",
              worst, worst < 1e-12 ? "ok" : "DISAGREE");
  if (!(worst < 1e-12)) std::exit(1);
  const int nv = armature.chain.nv();
  for (const Loaded* m : {&armature, &exact}) {
    const std::string name = m->model.name();
    const CompiledModel::Function fd = m->model.function(Output::forward_dynamics);
    benchmark::RegisterBenchmark(("spacearm/FD/" + name).c_str(), [fd, nv](benchmark::State& st) {
      std::vector<double> qdd(nv), pivots(nv), scaled(nv);
      double* results[] = {qdd.data(), pivots.data(), scaled.data()};
      int k = 0;
      for (auto _ : st) {
        const double* inputs[] = {s.q[k].data(), s.v[k].data(), s.Q[k].data()};
        fd(inputs, nullptr, results);
        benchmark::DoNotOptimize(qdd.data());
        k = (k + 1) % kStates;
      }
    });
    const CompiledModel::Function mb = m->model.function(Output::mass_matrix);
    const CompiledModel::Function bias = m->model.function(Output::bias_forces);
    benchmark::RegisterBenchmark(("spacearm/M+bias/" + name).c_str(),
                                 [mb, bias, nv](benchmark::State& st) {
                                   std::vector<double> M(nv * nv), b(nv);
                                   double* rm[] = {M.data()};
                                   double* rb[] = {b.data()};
                                   int k = 0;
                                   for (auto _ : st) {
                                     const double* iq[] = {s.q[k].data()};
                                     const double* iqv[] = {s.q[k].data(), s.v[k].data()};
                                     mb(iq, nullptr, rm);
                                     bias(iqv, nullptr, rb);
                                     benchmark::DoNotOptimize(M.data());
                                     benchmark::DoNotOptimize(b.data());
                                     k = (k + 1) % kStates;
                                   }
                                 });
  }
  auto mujoco = [nv](auto body) {
    return [nv, body](benchmark::State& st) {
      int k = 0;
      for (auto _ : st) {
        for (int i = 0; i < nv + 1; ++i) mj.d->qpos[i] = s.q[k][i];
        for (int i = 0; i < nv; ++i) mj.d->qvel[i] = s.v[k][i];
        body();
        k = (k + 1) % kStates;
      }
    };
  };
  benchmark::RegisterBenchmark("mujoco/FD/space_arm7", mujoco([] {
                                 mj_forward(mj.m.get(), mj.d.get());
                                 benchmark::DoNotOptimize(mj.d->qacc);
                               }));
  static std::vector<mjtNum> full(nv * nv);  // allocated once, outside the timed loop
  benchmark::RegisterBenchmark("mujoco/M+bias/space_arm7", mujoco([] {
                                 mj.mass_matrix_and_bias(full.data());
                                 benchmark::DoNotOptimize(full.data());
                               }));
}

}  // namespace
}  // namespace spacearm

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  spacearm::register_all();
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
