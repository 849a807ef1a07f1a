// Spatial arms against MuJoCo, in one run: forward dynamics and M + bias of models/space_arm7
// (a 7-joint arm on a free base from its URDF, 13 velocities), of the trees models/dual_arm7 (two
// 7-joint arms, 20 velocities) and bench/scenes/quad_arm6 (four 6-joint arms, 30 velocities),
// each without gears, with armature gears and with exact rotors, compiled through the
// compile-and-load cache with its default flags and called through its C interface without
// checks, against MuJoCo 2.2's mj_forward and its M + bias stages on the same MJCF (spacearm
// export --mjcf: a tree's bodies nested depth-first, MuJoCo's dofs in spacearm's order), without
// gears and with armature.
// MuJoCo has armature gears only; the exact rotors run on the same states for their cost against
// the ungeared arm's. Forward dynamics is the articulated-body algorithm. Before anything is timed,
// the ungeared and the armature model's forward dynamics must equal MuJoCo's to 1e-12. The first/
// rows time the URDF to a first result through an empty cache, with one compiler, with one per
// CPU and under --engine auto (the interpreter's answer), for space_arm7 and the dual arm.
// space_arm7's models also give their state Jacobian (forward_dynamics_derivatives; also four
// states per call, its 4-lane version) and one rk4 step's Jacobians (runtime/step_jacobian.hpp),
// timed against MuJoCo's mjd_transitionFD. One row calls two single-arm models in turn: an
// instruction working set the size of the dual arm's, without a tree. The plan/ rows time `plan
// --objective`'s planners on one task of space_arm7 (the tool 0.17 m in 4 s) against the straight
// line's, with each plan's base rotation, effort and distance from the goal as counters
// (optimal_plan.hpp). Built with -DPINOCCHIO_DIR=an install of Pinocchio
// (bench/peers/pinocchio.sh), space_arm7's ungeared and armature models are also timed against
// Pinocchio's aba and computeABADerivatives (pinocchio_peer.hpp), and with
// -DPINOCCHIO_CPPADCG_DIR (bench/peers/cppadcg.sh) its generated ABA derivatives too.
//   scripts/bench.sh --spatial
#include <benchmark/benchmark.h>

#include <Eigen/Geometry>

#include <unistd.h>

#include <array>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <random>
#include <sstream>
#include <stdexcept>

#include "machine_context.hpp"
#include "compiled_model.hpp"
#include "lane_layout.hpp"
#include "mjcf_export.hpp"
#include "mujoco_model.hpp"
#include "optimal_plan.hpp"
#include "spatial_scene.hpp"
#include "step_jacobian.hpp"
#ifdef SPACEARM_BENCH_WITH_PINOCCHIO
#include "pinocchio_peer.hpp"
#endif

namespace spacearm {
namespace {

constexpr int kStates = 64;

// The robots, by scene path relative to the source folder.
const char* const kRobots[] = {"models/space_arm7.yaml", "models/dual_arm7.yaml",
                               "bench/scenes/quad_arm6.yaml"};

// The robot whose state Jacobian (forward_dynamics_derivatives) is timed.
const std::string kDerivativesRobot = "models/space_arm7.yaml";

// The robot without gears, with armature gears (MuJoCo's model of a rotor) or with exact rotors.
enum class Gears { none, armature, exact };
SpatialScene robot(const std::string& relative, Gears gears) {
  const std::string path = std::string(SPACEARM_SOURCE_DIR) + "/" + relative;
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  SpatialScene s = parse_spatial_scene(text.str(), path);
  const char* kind[] = {"ungeared", "armature", "exact"};
  for (auto& l : s.chain.links) {
    l.gear.exact = gears == Gears::exact;
    l.gear.present = gears != Gears::none;
  }
  s.name += std::string("_") + kind[static_cast<int>(gears)];
  s.content += std::string("\n# ") + kind[static_cast<int>(gears)];  // one cache entry each
  if (relative == kDerivativesRobot) {  // the state Jacobian too, for its rows
    s.outputs = spatial_outputs(s);
    s.outputs.push_back(Output::forward_dynamics_derivatives);
    s.lanes.push_back(Output::forward_dynamics_derivatives);  // and its 4-lane version
    s.content += "\n# with forward_dynamics_derivatives, on four lanes too";
  }
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
  std::string mjcf;  // spacearm export --mjcf of the same scene
  States states;     // the timed states, the same for each robot's models
};
Loaded load(const std::string& relative, Gears gears) {
  const SpatialScene s = robot(relative, gears);
  CompileOptions options;
  options.cache_dir = (std::filesystem::temp_directory_path() / "spacearm-bench-spatial").string();
  options.flags = compile_flags();  // the default, what eval, simulate and Python get
  return {CompiledModel::load(ModelRecipe(s), options), s.chain, export_mjcf(s),
          random_states(s.chain)};
}

// MuJoCo's qacc at the states, in the chain's coordinates (qdd_m = p qdd), against ours.
double worst_disagreement(const Loaded& ours, test::MujocoModel& mj) {
  const States& s = ours.states;
  const auto& c = ours.chain;
  double worst = 0;
  for (int k = 0; k < kStates; ++k) {
    Eigen::VectorXd D = Eigen::VectorXd::Ones(c.nv());
    for (size_t j = 0; j < c.links.size(); ++j)
      D[6 + j] = c.links[j].gear.present ? c.links[j].gear.ratio.value : 1;
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

// Calls the C functions `calls` in turn at one timed state after another (inputs q, v, Q: a
// function reads those it takes), their results into buffers of the given sizes; with several
// calls the time is that of all of them, and items count the calls.
void register_calls(const std::string& name, const std::vector<CompiledModel::Function>& calls,
                    const std::vector<int>& result_sizes, const States& states) {
  benchmark::RegisterBenchmark(name.c_str(), [calls, result_sizes, &states](benchmark::State& st) {
    std::vector<std::vector<double>> buffers;
    std::vector<double*> results;
    for (int size : result_sizes) buffers.emplace_back(size);
    for (auto& buffer : buffers) results.push_back(buffer.data());
    int k = 0;
    for (auto _ : st) {
      const double* inputs[] = {states.q[k].data(), states.v[k].data(), states.Q[k].data()};
      for (const auto& call : calls) {
        call(inputs, nullptr, results.data());
        benchmark::DoNotOptimize(results.data());
      }
      k = (k + 1) % kStates;
    }
    if (calls.size() > 1)
      st.SetItemsProcessed(static_cast<int64_t>(calls.size()) * st.iterations());
  });
}

// Forward dynamics and M + b (mass_matrix_and_bias, one call as MuJoCo's stages are) of a
// model, under its name.
void register_ours(const Loaded& m) {
  const int nv = m.chain.nv();
  register_calls("spacearm/FD/" + m.model.name(), {m.model.function(Output::forward_dynamics)},
                 {nv, nv, nv}, m.states);
  register_calls("spacearm/M+bias/" + m.model.name(), {m.model.function(kMassMatrixAndBias)},
                 {nv * nv, nv}, m.states);
}

// Forward dynamics of two models called in turn (the time of both calls): together their code is
// about the dual arm's size (space_arm7's forward dynamics is 23 KB, the dual arm's 45 KB, this
// CPU's L1 instruction cache 32 KB on the machines measured), so this row against the two models
// alone shows what an instruction working set over the cache costs, apart from the tree.
void register_alternated(const Loaded& a, const Loaded& b) {
  const int nv = a.chain.nv();
  register_calls(
      "spacearm/FD/" + a.model.name() + " and " + b.model.name() + " in turn (two calls)",
      {a.model.function(Output::forward_dynamics), b.model.function(Output::forward_dynamics)},
      {nv, nv, nv}, a.states);
}

// The state Jacobian (dqdd/dq on the tangent space, dqdd/dqd, qdd and dqdd/dtau: one call),
// under the model's name.
void register_derivatives(const Loaded& m) {
  const int nv = m.chain.nv(), N = static_cast<int>(m.chain.links.size());
  register_calls("spacearm/FD derivatives/" + m.model.name(),
                 {m.model.function(Output::forward_dynamics_derivatives)},
                 {nv * nv, nv * nv, nv, nv * N}, m.states);
}

// The state Jacobian's 4-lane version (the scene's `lanes:`), four of the timed states per
// call, interleaved (entry i of lane l at [4 i + l]); the counter per_state is the time per
// state, against the scalar row's time per call.
void register_derivatives_lanes(const Loaded& m) {
  const int nv = m.chain.nv(), N = static_cast<int>(m.chain.links.size());
  const auto four = m.model.lanes_function(Output::forward_dynamics_derivatives);
  if (!four) throw std::logic_error("the derivatives model lacks its 4-lane state Jacobian");
  const std::vector<Eigen::VectorXd>* inputs[] = {&m.states.q, &m.states.v, &m.states.Q};
  std::vector<std::array<std::vector<double>, 3>> groups(kStates / 4);
  for (int g = 0; g < kStates / 4; ++g)
    for (int a = 0; a < 3; ++a) {
      const auto& x = *inputs[a];
      const int n = static_cast<int>(x[4 * g].size());
      std::vector<double> four;  // the group's states one after the other
      for (int l = 0; l < 4; ++l) four.insert(four.end(), x[4 * g + l].begin(), x[4 * g + l].end());
      groups[g][a].resize(four.size());
      if (!lanes::interleave(four.data(), n, groups[g][a].data()))
        throw std::logic_error("a timed state is not finite");
    }
  benchmark::RegisterBenchmark(
      ("spacearm/FD derivatives, 4 lanes/" + m.model.name()).c_str(),
      [four, groups, nv, N](benchmark::State& st) {
        std::vector<std::vector<double>> buffers;
        for (int size : {nv * nv, nv * nv, nv, nv * N}) buffers.emplace_back(4 * size);
        double* results[] = {buffers[0].data(), buffers[1].data(), buffers[2].data(),
                             buffers[3].data()};
        size_t g = 0;
        for (auto _ : st) {
          const double* inputs[] = {groups[g][0].data(), groups[g][1].data(), groups[g][2].data()};
          four(inputs, nullptr, results);
          benchmark::DoNotOptimize(results[0]);
          g = (g + 1) % groups.size();
        }
        st.counters["per_state"] = benchmark::Counter(
            4, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
      });
}

// One rk4 step's A and B (runtime/step_jacobian.hpp, 1 ms: the peer's default step) through the
// DynamicModel the tools use, at the model's parameters: the quantity mjd_transitionFD gives.
void register_step_jacobians(const Loaded& m) {
  const States& states = m.states;
  const Eigen::VectorXd params = Eigen::Map<const Eigen::VectorXd>(
      m.model.nominal_parameters().data(),
      static_cast<Eigen::Index>(m.model.nominal_parameters().size()));
  const auto model = std::make_shared<DynamicModel>(dynamic_model(m.model, params));
  benchmark::RegisterBenchmark(
      ("spacearm/step Jacobians/" + m.model.name()).c_str(),
      [model, &states](benchmark::State& st) {
        const Eigen::VectorXd tau = Eigen::VectorXd::Zero(model->num_links);
        int k = 0;
        for (auto _ : st) {
          StepJacobians J = rk4_step_jacobians(*model, states.q[k], states.v[k], tau, 1e-3);
          benchmark::DoNotOptimize(J.A.data());
          k = (k + 1) % kStates;
        }
      });
}

// The planners on one task (scripts/plans.sh's, README): the time to a plan, once each, and its
// quality: the base's largest rotation [rad], the integral of |tau|^2 and the distance from the
// goal at the end.
void register_plans(const Loaded& m) {
  const Eigen::VectorXd params = Eigen::Map<const Eigen::VectorXd>(
      m.model.nominal_parameters().data(),
      static_cast<Eigen::Index>(m.model.nominal_parameters().size()));
  const auto model = std::make_shared<DynamicModel>(dynamic_model(m.model, params));
  StraightLineTask task;
  Eigen::VectorXd angles(7);
  angles << 0.3, 0.5, -0.2, -1.6, 0.4, 0.9, 0.1;
  task.q0 = model->from_joint_angles(model->neutral_configuration().head(7), angles);
  task.start = model->end_effector_pose(task.q0).head<3>();
  task.goal = task.start + Eigen::Vector3d(-0.1, 0.1, 0.1);
  task.duration = 4;
  for (Objective o : {Objective::line, Objective::reactionless, Objective::min_base_rotation,
                      Objective::min_effort}) {
    const char* names[] = {"line", "reactionless", "min_base_rotation", "min_effort"};
    task.objective = o;
    benchmark::RegisterBenchmark(
        ("spacearm/plan " + std::string(names[static_cast<int>(o)]) + "/" + m.model.name()).c_str(),
        [model, task](benchmark::State& st) {
          Plan plan;
          for (auto _ : st) plan = plan_task(*model, task);
          const Eigen::Vector3d end = model->end_effector_pose(plan.q.back()).head<3>();
          st.counters["base_rotation"] = plan.max_base_rotation;
          st.counters["effort"] = plan_effort(plan);
          st.counters["goal_error"] = (end - task.goal).norm();
          st.counters["iterations"] = plan.iterations;
        })
        ->Iterations(1)
        ->Unit(benchmark::kMillisecond);
  }
}

// MuJoCo's step Jacobian by forward differences (mjd_transitionFD, eps 1e-6, not centered: its
// cheapest), A (2 nv x 2 nv) at the same states.
void register_mujoco_derivatives(test::MujocoModel& mj, const std::string& name, const Loaded& m) {
  const int nv = m.chain.nv();
  const States& states = m.states;
  auto A = std::make_shared<std::vector<mjtNum>>(4 * nv * nv);
  benchmark::RegisterBenchmark(
      ("mujoco/transitionFD/" + name).c_str(), [&mj, nv, A, &states](benchmark::State& st) {
        int k = 0;
        for (auto _ : st) {
          for (int i = 0; i < nv + 1; ++i) mj.d->qpos[i] = states.q[k][i];
          for (int i = 0; i < nv; ++i) mj.d->qvel[i] = states.v[k][i];
          mjd_transitionFD(mj.m.get(), mj.d.get(), 1e-6, 0, A->data(), nullptr, nullptr, nullptr);
          benchmark::DoNotOptimize(A->data());
          k = (k + 1) % kStates;
        }
      });
}

#ifdef SPACEARM_BENCH_WITH_PINOCCHIO
// Pinocchio's model of the same MJCF: its forward dynamics must equal ours to 1e-12 and the
// joint blocks of its ABA derivatives ours to 1e-9 (relative) before anything is timed; then
// aba and computeABADerivatives at the same states.
void register_pinocchio(const Loaded& m) {
  const int nv = m.chain.nv(), N = static_cast<int>(m.chain.links.size());
  Eigen::VectorXd ratios = Eigen::VectorXd::Ones(N);
  for (int j = 0; j < N; ++j)
    if (m.chain.links[j].gear.present) ratios[j] = m.chain.links[j].gear.ratio.value;
  auto peer = std::make_shared<bench::PinocchioPeer>(m.mjcf, ratios);
  const States& s = m.states;
  peer->set_states(s.q, s.v, s.Q);
  const auto derivatives = m.model.function(Output::forward_dynamics_derivatives);
  std::vector<double> dq(nv * nv), dv(nv * nv), qdd(nv), dtau(nv * N);
  double worst = 0, worst_derivative = 0;
  using Matrix = Eigen::MatrixXd;  // the C interface's results are column-major
  for (int k = 0; k < kStates; ++k) {
    const double* inputs[] = {s.q[k].data(), s.v[k].data(), s.Q[k].data()};
    double* results[] = {dq.data(), dv.data(), qdd.data(), dtau.data()};
    derivatives(inputs, nullptr, results);
    const Eigen::VectorXd theirs = peer->forward_dynamics(k);
    worst = std::max(
        worst, (Eigen::Map<Eigen::VectorXd>(qdd.data(), nv) - theirs).norm() / (1 + theirs.norm()));
    Eigen::MatrixXd P_dq, P_dv, P_dtau;
    peer->joint_blocks(k, P_dq, P_dv, P_dtau);
    const Matrix O_dq = Eigen::Map<Matrix>(dq.data(), nv, nv).bottomRightCorner(N, N),
                 O_dv = Eigen::Map<Matrix>(dv.data(), nv, nv).bottomRightCorner(N, N),
                 O_dtau = Eigen::Map<Matrix>(dtau.data(), nv, N).bottomRows(N);
    for (const auto& [a, b] : {std::pair{&O_dq, &P_dq}, {&O_dv, &P_dv}, {&O_dtau, &P_dtau}})
      worst_derivative = std::max(worst_derivative, (*a - *b).norm() / (1 + b->norm()));
  }
  std::printf(
      "check %s: against Pinocchio, forward dynamics max relative %.1e, the derivatives' "
      "joint blocks %.1e  %s\n",
      m.model.name().c_str(), worst, worst_derivative,
      worst < 1e-12 && worst_derivative < 1e-9 ? "ok" : "DISAGREE");
  if (!(worst < 1e-12 && worst_derivative < 1e-9)) std::exit(1);
  // One of the peer's calls, timed over the states in turn.
  auto timed = [peer](void (bench::PinocchioPeer::*call)(int)) {
    return [peer, call](benchmark::State& st) {
      int k = 0;
      for (auto _ : st) {
        ((*peer).*call)(k);
        k = (k + 1) % kStates;
      }
    };
  };
  using Peer = bench::PinocchioPeer;
  benchmark::RegisterBenchmark(("pinocchio/FD/" + m.model.name()).c_str(), timed(&Peer::aba));
  benchmark::RegisterBenchmark(("pinocchio/FD derivatives/" + m.model.name()).c_str(),
                               timed(&Peer::aba_derivatives));
  // Its generated derivatives (CppADCodeGen), where built with them: equal to its analytical
  // ones to 1e-9 (relative) first.
  if (!peer->build_codegen()) return;
  double worst_generated = 0;
  for (int k = 0; k < kStates; ++k)
    worst_generated = std::max(worst_generated, peer->codegen_difference(k));
  std::printf(
      "check %s: Pinocchio's generated ABA derivatives against its analytical ones, max "
      "relative %.1e  %s\n",
      m.model.name().c_str(), worst_generated, worst_generated < 1e-9 ? "ok" : "DISAGREE");
  if (!(worst_generated < 1e-9)) std::exit(1);
  benchmark::RegisterBenchmark(("pinocchio/FD derivatives, generated/" + m.model.name()).c_str(),
                               timed(&Peer::aba_derivatives_codegen));
}
#endif

// mj_forward and M + bias of MuJoCo's model of the arm, under its name.
void register_mujoco(test::MujocoModel& mj, const std::string& name, const Loaded& m) {
  const int nv = m.chain.nv();
  const States& states = m.states;
  auto timed = [&mj, nv, &states](auto body) {
    return [&mj, nv, body, &states](benchmark::State& st) {
      int k = 0;
      for (auto _ : st) {
        for (int i = 0; i < nv + 1; ++i) mj.d->qpos[i] = states.q[k][i];
        for (int i = 0; i < nv; ++i) mj.d->qvel[i] = states.v[k][i];
        body();
        k = (k + 1) % kStates;
      }
    };
  };
  benchmark::RegisterBenchmark(("mujoco/FD/" + name).c_str(), timed([&mj] {
                                 mj_forward(mj.m.get(), mj.d.get());
                                 benchmark::DoNotOptimize(mj.d->qacc);
                               }));
  auto full = std::make_shared<std::vector<mjtNum>>(nv * nv);  // allocated outside the loop
  benchmark::RegisterBenchmark(("mujoco/M+bias/" + name).c_str(), timed([&mj, full] {
                                 mj.mass_matrix_and_bias(full->data());
                                 benchmark::DoNotOptimize(full->data());
                               }));
}

// From the URDF to a first forward-dynamics result with a fresh cache: read the scene and the
// URDF, generate (the default outputs), compile, load, one call; with one compiler and with one
// per CPU (the cache's default, at most 4). A peer-free row: the goal is 2 s.
void register_first_use(const std::string& relative, const std::string& robot,
                        const States& states) {
  for (int jobs : {1, 0, -1}) {  // -1: --engine auto (the interpreter answers first)
    const std::string label = jobs == 1   ? "1 compiler"
                              : jobs == 0 ? "compilers per CPU"
                                          : "auto, interpreted first";
    benchmark::RegisterBenchmark(
        ("first/URDF to result/" + robot + "/" + label).c_str(),
        [jobs, relative, &states](benchmark::State& st) {
          const auto folder = std::filesystem::temp_directory_path() /
                              ("spacearm-bench-first-" + std::to_string(::getpid()));
          for (auto _ : st) {
            std::filesystem::remove_all(folder);
            const auto t0 = std::chrono::steady_clock::now();
            CompileOptions options;
            options.cache_dir = folder.string();
            options.jobs = std::max(jobs, 0);
            if (jobs < 0) options.engine = Engine::automatic;
            const ModelRecipe recipe =
                ModelRecipe::load(std::string(SPACEARM_SOURCE_DIR) + "/" + relative);
            const CompiledModel m = CompiledModel::load(recipe, options);
            auto qdd = m.forward_dynamics(states.q[0], states.v[0], states.Q[0], Eigen::VectorXd());
            benchmark::DoNotOptimize(qdd);
            st.SetIterationTime(
                std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
            finish_background_compiles();  // auto: the library's compile, untimed
          }
          std::filesystem::remove_all(folder);
        })
        ->UseManualTime()
        ->Iterations(1)
        ->Unit(benchmark::kMillisecond);
  }
}

// One robot's models, checked against MuJoCo before anything is timed; kept for the run.
void register_robot(const std::string& relative) {
  static std::vector<std::unique_ptr<Loaded>> loaded;
  static std::vector<std::unique_ptr<test::MujocoModel>> mujoco;
  const size_t first = loaded.size();
  for (Gears g : {Gears::none, Gears::armature, Gears::exact})
    loaded.push_back(std::make_unique<Loaded>(load(relative, g)));
  for (size_t k = first; k < first + 2; ++k) {  // ungeared and armature: MuJoCo has both
    mujoco.push_back(std::make_unique<test::MujocoModel>(loaded[k]->mjcf));
    const double worst = worst_disagreement(*loaded[k], *mujoco.back());
    std::printf("check %s: forward dynamics against MuJoCo, max relative %.1e  %s\n",
                loaded[k]->model.name().c_str(), worst, worst < 1e-12 ? "ok" : "DISAGREE");
    if (!(worst < 1e-12)) std::exit(1);
    register_mujoco(*mujoco.back(), loaded[k]->model.name(), *loaded[k]);
    if (relative == kDerivativesRobot) {
      register_mujoco_derivatives(*mujoco.back(), loaded[k]->model.name(), *loaded[k]);
#ifdef SPACEARM_BENCH_WITH_PINOCCHIO
      register_pinocchio(*loaded[k]);
#endif
    }
  }
  for (size_t k = first; k < first + 3; ++k) register_ours(*loaded[k]);
  for (size_t k = first; k < first + 3 && relative == kDerivativesRobot; ++k) {
    register_derivatives(*loaded[k]);
    register_derivatives_lanes(*loaded[k]);
    register_step_jacobians(*loaded[k]);
    if (k != first + 1) register_plans(*loaded[k]);  // ungeared and exact rotors
  }
  if (first == 0) register_alternated(*loaded[0], *loaded[1]);  // space_arm7 ungeared, armature
  if (relative.rfind("models/", 0) == 0)                        // the URDF robots
    register_first_use(relative, std::filesystem::path(relative).stem().string(),
                       loaded[first]->states);
}

void register_all() {
  for (const char* relative : kRobots) register_robot(relative);
}

}  // namespace
}  // namespace spacearm

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  spacearm::bench::add_machine_context();
  spacearm::register_all();
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
