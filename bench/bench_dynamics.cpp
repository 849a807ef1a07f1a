// Per-call cost of the generated code against its peers, over a fixed set of random states,
// for the paper's models and chains of N = 2 .. 30 links: MuJoCo, the same chains derived and
// printed by SymPy with cse (bench/sympy_chain.py), and the same Lagrangian emitted without
// common-subexpression elimination (the baseline). Before any timing, MuJoCo's and SymPy's M
// and bias are checked against ours. After the runs it prints the ratios peer time / our
// time, all measured in this process.
//   build-bench/bench/bench_dynamics [--benchmark_filter=...] [--benchmark_repetitions=...]
#include <benchmark/benchmark.h>

#include <boost/numeric/odeint.hpp>
#include <boost/numeric/odeint/external/eigen/eigen.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <functional>
#include <map>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "machine_context.hpp"
#include "model.hpp"
#include "mujoco_chain.hpp"
#include "recording_reporter.hpp"
#include "planar_scene.hpp"

#include "paper_geared.hpp"
#include "paper_reference.hpp"
// The chains of the sizes CMake generated (SPACEARM_BENCH_SIZES defines SPACEARM_BENCH_WITH_N<k>),
// each registered in main().
#ifdef SPACEARM_BENCH_WITH_N2
#include "chain_n2.hpp"
#include "chain_n2_armature.hpp"
#include "chain_n2_geared.hpp"
#define SPACEARM_BENCH_N2 SPACEARM_CHAIN(2)
#else
#define SPACEARM_BENCH_N2
#endif
#ifdef SPACEARM_BENCH_WITH_N3
#include "chain_n3.hpp"
#include "chain_n3_armature.hpp"
#include "chain_n3_geared.hpp"
#define SPACEARM_BENCH_N3 SPACEARM_CHAIN(3)
#else
#define SPACEARM_BENCH_N3
#endif
#ifdef SPACEARM_BENCH_WITH_N4
#include "chain_n4.hpp"
#include "chain_n4_armature.hpp"
#include "chain_n4_geared.hpp"
#define SPACEARM_BENCH_N4 SPACEARM_CHAIN(4)
#else
#define SPACEARM_BENCH_N4
#endif
#ifdef SPACEARM_BENCH_WITH_N6
#include "chain_n6.hpp"
#include "chain_n6_armature.hpp"
#include "chain_n6_geared.hpp"
#define SPACEARM_BENCH_N6 SPACEARM_CHAIN(6)
#else
#define SPACEARM_BENCH_N6
#endif
#ifdef SPACEARM_BENCH_WITH_N8
#include "chain_n8.hpp"
#include "chain_n8_armature.hpp"
#include "chain_n8_geared.hpp"
#define SPACEARM_BENCH_N8 SPACEARM_CHAIN(8)
#else
#define SPACEARM_BENCH_N8
#endif
#ifdef SPACEARM_BENCH_WITH_N10
#include "chain_n10.hpp"
#include "chain_n10_armature.hpp"
#include "chain_n10_geared.hpp"
#define SPACEARM_BENCH_N10 SPACEARM_CHAIN(10)
#else
#define SPACEARM_BENCH_N10
#endif
#ifdef SPACEARM_BENCH_WITH_N12
#include "chain_n12.hpp"
#include "chain_n12_armature.hpp"
#include "chain_n12_geared.hpp"
#define SPACEARM_BENCH_N12 SPACEARM_CHAIN(12)
#else
#define SPACEARM_BENCH_N12
#endif
#ifdef SPACEARM_BENCH_WITH_N16
#include "chain_n16.hpp"
#include "chain_n16_armature.hpp"
#include "chain_n16_geared.hpp"
#define SPACEARM_BENCH_N16 SPACEARM_MUJOCO_CHAIN(16)
#else
#define SPACEARM_BENCH_N16
#endif
#ifdef SPACEARM_BENCH_WITH_N20
#include "chain_n20.hpp"
#include "chain_n20_armature.hpp"
#include "chain_n20_geared.hpp"
#define SPACEARM_BENCH_N20 SPACEARM_MUJOCO_CHAIN(20)
#else
#define SPACEARM_BENCH_N20
#endif
#ifdef SPACEARM_BENCH_WITH_N30
#include "chain_n30.hpp"
#include "chain_n30_armature.hpp"
#include "chain_n30_geared.hpp"
#define SPACEARM_BENCH_N30 SPACEARM_MUJOCO_CHAIN(30)
#else
#define SPACEARM_BENCH_N30
#endif
// The full run adds the CSE-free baseline and the SymPy peer (N <= 12).
#ifndef SPACEARM_BENCH_QUICK
#include "paper_geared_folded.hpp"
#include "paper_geared_plain.hpp"
#include "paper_reference_plain.hpp"
#include "chain_n2_geared_plain.hpp"
#include "chain_n2_plain.hpp"
#include "chain_n3_geared_plain.hpp"
#include "chain_n3_plain.hpp"
#include "chain_n4_geared_plain.hpp"
#include "chain_n4_plain.hpp"
#include "chain_n6_geared_plain.hpp"
#include "chain_n6_plain.hpp"
#include "chain_n2_sympy.hpp"
#include "chain_n2_geared_sympy.hpp"
#include "chain_n3_sympy.hpp"
#include "chain_n3_geared_sympy.hpp"
#include "chain_n4_sympy.hpp"
#include "chain_n4_geared_sympy.hpp"
#include "chain_n6_sympy.hpp"
#include "chain_n6_geared_sympy.hpp"
#include "chain_n8_sympy.hpp"
#include "chain_n8_geared_sympy.hpp"
#include "chain_n10_sympy.hpp"
#include "chain_n10_geared_sympy.hpp"
#include "chain_n12_sympy.hpp"
#include "chain_n12_geared_sympy.hpp"
#endif

namespace spacearm::bench {
namespace {

constexpr int kStates = 64;  // fixed random states, cycled through by every benchmark
constexpr double kStep = 1e-3;

std::map<std::string, double> g_seconds;  // fastest repetition per benchmark name

template <class G>
struct States {
  using M = Model<G>;
  std::vector<typename M::Vector> q, qd;
  // Joint angles in [-pi, pi], rates in [-1, 1] rad/s (motor coordinates: times the ratio).
  explicit States(const M& model) {
    std::mt19937 rng(2024);
    std::uniform_real_distribution<double> angle(-M_PI, M_PI), rate(-1, 1);
    for (int k = 0; k < kStates; ++k) {
      typename M::Vector a, r;
      for (int i = 0; i < M::kNq; ++i) a[i] = angle(rng), r[i] = rate(rng);
      if constexpr (M::kFreeFloating) {
        for (int i = 0; i < 3; ++i) r[i] *= 0.1;
      }
      for (int j = 0; j < M::kNumLinks; ++j) {
        a[M::kNumBase + j] *= model.gear_ratios()[j];
        r[M::kNumBase + j] *= model.gear_ratios()[j];
      }
      q.push_back(a);
      qd.push_back(r);
    }
  }
};

template <class G>
Model<G> make_model() {
  Model<G> m;
  for (int i = 0; i < Model<G>::kNumParams; ++i) {
    const std::string name = G::parameter_names()[i];
    if (name == "p") m.set_parameter("p", 10);  // every geared benchmark at p = 10, I_m = 1e-5
    if (name == "Im") m.set_parameter("Im", 1e-5);
  }
  return m;
}

// Our functions: M, C, bias, M + bias, forward dynamics, one RK4 step.
template <class G>
void register_ours(const std::string& prefix, const std::string& name, bool everything) {
  using M = Model<G>;
  auto run = [](auto&& body) {
    return [body](benchmark::State& st) {
      const M model = make_model<G>();
      const States<G> s(model);
      int k = 0;
      for (auto _ : st) {
        body(model, s, k);
        k = (k + 1) % kStates;
      }
    };
  };
  benchmark::RegisterBenchmark((prefix + "/M+bias/" + name).c_str(),
                               run([](const M& m, const States<G>& s, int k) {
                                 typename M::Matrix Mq;
                                 typename M::Vector b;
                                 m.mass_matrix_and_bias(s.q[k], s.qd[k], Mq, b);
                                 benchmark::DoNotOptimize(Mq);
                                 benchmark::DoNotOptimize(b);
                               }));
  benchmark::RegisterBenchmark((prefix + "/FD/" + name).c_str(),
                               run([](const M& m, const States<G>& s, int k) {
                                 auto qdd = m.forward_dynamics(s.q[k], s.qd[k], M::Vector::Zero());
                                 benchmark::DoNotOptimize(qdd);
                               }));
  if (!everything) return;
  benchmark::RegisterBenchmark((prefix + "/M/" + name).c_str(),
                               run([](const M& m, const States<G>& s, int k) {
                                 auto Mq = m.mass_matrix(s.q[k]);
                                 benchmark::DoNotOptimize(Mq);
                               }));
  benchmark::RegisterBenchmark((prefix + "/bias/" + name).c_str(),
                               run([](const M& m, const States<G>& s, int k) {
                                 auto b = m.bias_forces(s.q[k], s.qd[k]);
                                 benchmark::DoNotOptimize(b);
                               }));
  if constexpr (G::kHas_coriolis_matrix) {
    benchmark::RegisterBenchmark((prefix + "/C/" + name).c_str(),
                                 run([](const M& m, const States<G>& s, int k) {
                                   typename M::Matrix C;
                                   G::coriolis_matrix(s.q[k], s.qd[k], m.parameters(), C);
                                   benchmark::DoNotOptimize(C);
                                 }));
    // Pruning: the bias through the full C (eq. 7) and a product, instead of emitted directly.
    benchmark::RegisterBenchmark((prefix + "/C*qd/" + name).c_str(),
                                 run([](const M& m, const States<G>& s, int k) {
                                   typename M::Matrix C;
                                   G::coriolis_matrix(s.q[k], s.qd[k], m.parameters(), C);
                                   typename M::Vector b = C * s.qd[k];
                                   benchmark::DoNotOptimize(b);
                                 }));
  }
  benchmark::RegisterBenchmark((prefix + "/RK4/" + name).c_str(), [](benchmark::State& st) {
    namespace odeint = boost::numeric::odeint;
    const M model = make_model<G>();
    const States<G> s(model);
    using State = Eigen::Matrix<double, 2 * M::kNq, 1>;
    odeint::runge_kutta4<State, double, State, double, odeint::vector_space_algebra> stepper;
    auto f = [&](const State& x, State& dx, double) {
      dx.template head<M::kNq>() = x.template tail<M::kNq>();
      dx.template tail<M::kNq>() = model.forward_dynamics(
          x.template head<M::kNq>(), x.template tail<M::kNq>(), M::Vector::Zero());
    };
    int k = 0;
    for (auto _ : st) {
      State x;
      x << s.q[k], s.qd[k];
      stepper.do_step(f, x, 0.0, kStep);
      benchmark::DoNotOptimize(x);
      k = (k + 1) % kStates;
    }
  });
}

// MuJoCo on the same scene and states (armature for geared scenes), in joint coordinates.
template <class G>
void register_mujoco(const std::string& scene_file, const std::string& name) {
  using M = Model<G>;
  const Scene scene = load_scene(scene_file);
  auto states = [] {
    const M model = make_model<G>();
    States<G> s(model);
    for (int k = 0; k < kStates; ++k)  // to joint coordinates
      for (int j = 0; j < M::kNumLinks; ++j) {
        s.q[k][M::kNumBase + j] /= model.gear_ratios()[j];
        s.qd[k][M::kNumBase + j] /= model.gear_ratios()[j];
      }
    return s;
  };
  // Each benchmark loads the k-th state into MuJoCo's data, then runs body(mj).
  auto run = [scene, states](auto&& body) {
    return [scene, states, body](benchmark::State& st) {
      MujocoModel mj(mjcf_of(scene));
      const States<G> s = states();
      int k = 0;
      for (auto _ : st) {
        for (int i = 0; i < M::kNq; ++i) mj.d->qpos[i] = s.q[k][i], mj.d->qvel[i] = s.qd[k][i];
        body(mj);
        k = (k + 1) % kStates;
      }
    };
  };
  benchmark::RegisterBenchmark(("mujoco/M+bias/" + name).c_str(), run([](MujocoModel& mj) {
                                 std::array<mjtNum, M::kNq * M::kNq> full;
                                 mj.mass_matrix_and_bias(full.data());
                                 benchmark::DoNotOptimize(full.data());
                                 benchmark::DoNotOptimize(mj.d->qfrc_bias);
                               }));
  benchmark::RegisterBenchmark(("mujoco/FD/" + name).c_str(), run([](MujocoModel& mj) {
                                 mj_forward(mj.m.get(), mj.d.get());
                                 benchmark::DoNotOptimize(mj.d->qacc);
                               }));
  benchmark::RegisterBenchmark(("mujoco/RK4/" + name).c_str(), run([](MujocoModel& mj) {
                                 mj.d->time = 0;
                                 mj_step(mj.m.get(), mj.d.get());
                                 benchmark::DoNotOptimize(mj.d->qpos);
                               }));
}

// MuJoCo's M and bias must be ours (mapped to motor coordinates for geared scenes:
// M_g = G M G, b_g = G b with G = diag(1, 1, 1, 1/p, ...)) before any of it is timed.
template <class G>
bool agrees_with_mujoco(const std::string& scene_file, const std::string& name) {
  using M = Model<G>;
  const M model = make_model<G>();
  const States<G> s(model);
  MujocoModel mj(mjcf_of(load_scene(scene_file)));
  typename M::Vector g = M::Vector::Ones();
  for (int j = 0; j < M::kNumLinks; ++j) g[M::kNumBase + j] = 1 / model.gear_ratios()[j];
  double worst_M = 0, worst_b = 0;
  for (int k = 0; k < kStates; ++k) {
    const typename M::Vector q = g.cwiseProduct(s.q[k]), qd = g.cwiseProduct(s.qd[k]);
    for (int i = 0; i < M::kNq; ++i) mj.d->qpos[i] = q[i], mj.d->qvel[i] = qd[i];
    mj_forward(mj.m.get(), mj.d.get());
    Eigen::Matrix<double, M::kNq, M::kNq, Eigen::RowMajor> full;
    mj_fullM(mj.m.get(), full.data(), mj.d->qM);
    const typename M::Matrix M_mj = g.asDiagonal() * typename M::Matrix(full) * g.asDiagonal();
    const typename M::Vector b_mj =
        g.cwiseProduct(Eigen::Map<const typename M::Vector>(mj.d->qfrc_bias));
    typename M::Matrix Mq;
    typename M::Vector b;
    model.mass_matrix_and_bias(s.q[k], s.qd[k], Mq, b);
    worst_M = std::max(worst_M, (Mq - M_mj).cwiseAbs().maxCoeff() / Mq.cwiseAbs().maxCoeff());
    worst_b = std::max(worst_b, (b - b_mj).cwiseAbs().maxCoeff() / b.cwiseAbs().maxCoeff());
  }
  const bool ok = worst_M < 1e-12 && worst_b < 1e-10;
  std::printf("check %-22s MuJoCo vs ours: max relative difference M %.1e, bias %.1e  %s\n",
              name.c_str(), worst_M, worst_b, ok ? "ok" : "DISAGREE");
  return ok;
}

// The SymPy peer (bench/sympy_chain.py): M and bias derived and printed by SymPy with cse.
using SympyFunction = void (*)(const double* q, const double* qd, const double* params, double* M,
                               double* bias);
template <class G>
struct SympyPeer {
  using M = Model<G>;
  using RowMatrix = Eigen::Matrix<double, M::kNq, M::kNq, Eigen::RowMajor>;
  SympyFunction f;
  typename M::Params params;
  SympyPeer(SympyFunction fn, const char* const* names, int n_names, const M& model) : f(fn) {
    // Parameters by name, so that a different order in the two derivations cannot go unseen.
    if (n_names != M::kNumParams)
      throw std::runtime_error("SymPy peer: number of parameters differs");
    for (int i = 0; i < n_names; ++i)
      for (int k = 0; k <= M::kNumParams; ++k) {
        if (k == M::kNumParams)
          throw std::runtime_error(std::string("SymPy peer: unknown parameter ") + names[i]);
        if (std::string(names[i]) == G::parameter_names()[k]) {
          params[i] = model.parameters()[k];
          break;
        }
      }
  }
  void operator()(const typename M::Vector& q, const typename M::Vector& qd, RowMatrix& Mq,
                  typename M::Vector& b) const {
    f(q.data(), qd.data(), params.data(), Mq.data(), b.data());
  }
};

// SymPy's M and bias must be ours (an independent derivation of the same scene, the exact
// rotor coupling included) before either is timed.
template <class G>
bool agrees_with_sympy(SympyFunction f, const char* const* names, int n_names,
                       const std::string& name) {
  using M = Model<G>;
  const M model = make_model<G>();
  const States<G> s(model);
  const SympyPeer<G> peer(f, names, n_names, model);
  double worst_M = 0, worst_b = 0;
  for (int k = 0; k < kStates; ++k) {
    typename SympyPeer<G>::RowMatrix M_sp;
    typename M::Vector b_sp, b;
    typename M::Matrix Mq;
    peer(s.q[k], s.qd[k], M_sp, b_sp);
    model.mass_matrix_and_bias(s.q[k], s.qd[k], Mq, b);
    worst_M = std::max(
        worst_M, (Mq - typename M::Matrix(M_sp)).cwiseAbs().maxCoeff() / Mq.cwiseAbs().maxCoeff());
    worst_b = std::max(worst_b, (b - b_sp).cwiseAbs().maxCoeff() / b.cwiseAbs().maxCoeff());
  }
  const bool ok = worst_M < 1e-12 && worst_b < 1e-10;
  std::printf("check %-22s SymPy vs ours: max relative difference M %.1e, bias %.1e  %s\n",
              name.c_str(), worst_M, worst_b, ok ? "ok" : "DISAGREE");
  return ok;
}

template <class G>
void register_sympy(SympyFunction f, const char* const* names, int n_names,
                    const std::string& name) {
  using M = Model<G>;
  auto run = [=](auto&& body) {
    return [=](benchmark::State& st) {
      const M model = make_model<G>();
      const States<G> s(model);
      const SympyPeer<G> peer(f, names, n_names, model);
      int k = 0;
      for (auto _ : st) {
        typename SympyPeer<G>::RowMatrix Mq;
        typename M::Vector b;
        peer(s.q[k], s.qd[k], Mq, b);
        body(Mq, b);
        k = (k + 1) % kStates;
      }
    };
  };
  benchmark::RegisterBenchmark(("sympy/M+bias/" + name).c_str(), run([](auto& Mq, auto& b) {
                                 benchmark::DoNotOptimize(Mq);
                                 benchmark::DoNotOptimize(b);
                               }));
  // Forward dynamics as a SymPy user would write it: M, bias, Eigen's Cholesky (no checks).
  benchmark::RegisterBenchmark(("sympy/FD/" + name).c_str(), run([](auto& Mq, auto& b) {
                                 typename M::Vector qdd = Mq.llt().solve(-b);
                                 benchmark::DoNotOptimize(qdd);
                               }));
}

std::string scene_path(const std::string& name) {
  return std::string(SPACEARM_SOURCE_DIR) + "/bench/scenes/" + name + ".yaml";
}

double seconds(const std::string& name) {
  auto it = g_seconds.find(name);
  return it == g_seconds.end() ? NAN : it->second;
}

void print_ratio_table() {
  std::printf(
      "\nRatios, peer time / our time (same process, same states, fastest repetition; > 1: ours is "
      "faster)\n");
  std::printf("%-20s %8s %8s %7s %8s %7s %8s %7s | %8s %8s %7s %8s %7s | %8s %8s %7s\n", "model",
              "M+b ns", "MuJoCo", "ratio", "plain", "ratio", "SymPy", "ratio", "FD ns", "MuJoCo",
              "ratio", "SymPy", "ratio", "RK4 ns", "MuJoCo", "ratio");
  for (const auto& [key, t] : g_seconds) {
    if (key.rfind("ours/M+bias/", 0) != 0) continue;
    const std::string model = key.substr(12);
    std::string peer = model;  // geared exact: MuJoCo's closest model is the armature one
    const auto geared = peer.find("_geared");
    if (geared != std::string::npos) peer.replace(geared, 7, "_armature");
    if (model == "paper_geared") peer = "";
    auto ns = [](double s) { return s * 1e9; };
    const double ours_mb = t, mj_mb = seconds("mujoco/M+bias/" + peer),
                 plain_mb = seconds("plain/M+bias/" + model);
    const double sympy_mb = seconds("sympy/M+bias/" + model),
                 sympy_fd = seconds("sympy/FD/" + model);
    const double ours_fd = seconds("ours/FD/" + model), mj_fd = seconds("mujoco/FD/" + peer);
    const double ours_rk = seconds("ours/RK4/" + model), mj_rk = seconds("mujoco/RK4/" + peer);
    std::printf(
        "%-20s %8.0f %8.0f %7.2f %8.0f %7.2f %8.0f %7.2f | %8.0f %8.0f %7.2f %8.0f %7.2f | %8.0f "
        "%8.0f %7.2f\n",
        model.c_str(), ns(ours_mb), ns(mj_mb), mj_mb / ours_mb, ns(plain_mb), plain_mb / ours_mb,
        ns(sympy_mb), sympy_mb / ours_mb, ns(ours_fd), ns(mj_fd), mj_fd / ours_fd, ns(sympy_fd),
        sympy_fd / ours_fd, ns(ours_rk), ns(mj_rk), mj_rk / ours_rk);
  }
  std::printf("\nPruning (our time / pruned time):\n");
  for (const auto& [key, t] : g_seconds) {
    if (key.rfind("ours/C*qd/", 0) != 0) continue;
    const std::string model = key.substr(10);
    std::printf("  %-20s bias through the full C %.0f ns, emitted bias %.0f ns: %.2fx\n",
                model.c_str(), t * 1e9, seconds("ours/bias/" + model) * 1e9,
                t / seconds("ours/bias/" + model));
  }
  const double params = seconds("ours/M+bias/paper_geared"),
               folded = seconds("ours/M+bias/paper_geared_folded");
  if (std::isfinite(params) && std::isfinite(folded))  // both ran (not filtered out)
    std::printf(
        "  paper_geared M+bias with p, Im at run time %.0f ns, folded as constants %.0f ns: "
        "%.2fx\n",
        params * 1e9, folded * 1e9, params / folded);
}

}  // namespace
}  // namespace spacearm::bench

int main(int argc, char** argv) {
  using namespace spacearm;
  using namespace spacearm::bench;
  namespace m = spacearm::models;
  bool ok = true;
  ok &= agrees_with_mujoco<m::paper_reference::Model>(
      SPACEARM_SOURCE_DIR "/models/paper_reference.yaml", "paper_reference");
#define SPACEARM_MUJOCO_CHAIN(N)                                                                  \
  ok &= agrees_with_mujoco<m::chain_n##N::Model>(scene_path("chain_n" #N), "chain_n" #N);         \
  ok &= agrees_with_mujoco<m::chain_n##N##_armature::Model>(scene_path("chain_n" #N "_armature"), \
                                                            "chain_n" #N "_armature");            \
  register_ours<m::chain_n##N::Model>("ours", "chain_n" #N, true);                                \
  register_ours<m::chain_n##N##_geared::Model>("ours", "chain_n" #N "_geared", true);             \
  register_ours<m::chain_n##N##_armature::Model>("ours", "chain_n" #N "_armature", false);        \
  register_mujoco<m::chain_n##N::Model>(scene_path("chain_n" #N), "chain_n" #N);                  \
  register_mujoco<m::chain_n##N##_armature::Model>(scene_path("chain_n" #N "_armature"),          \
                                                   "chain_n" #N "_armature");
#define SPACEARM_CHAIN(N)                  \
  SPACEARM_MUJOCO_CHAIN(N)                 \
  SPACEARM_SYMPY(chain_n##N, "chain_n" #N) \
  SPACEARM_SYMPY(chain_n##N##_geared, "chain_n" #N "_geared")
#ifdef SPACEARM_BENCH_QUICK
#define SPACEARM_SYMPY(MODEL, NAME)
#else
#define SPACEARM_SYMPY(MODEL, NAME)                                                                \
  {                                                                                                \
    namespace sp = spacearm::bench::MODEL##_sympy;                                                 \
    constexpr int n_names = sizeof(sp::kParameterNames) / sizeof(sp::kParameterNames[0]) -         \
                            (sp::kParameterNames[0] == nullptr);                                   \
    ok &= agrees_with_sympy<m::MODEL::Model>(sp::mass_matrix_and_bias, sp::kParameterNames,        \
                                             n_names, NAME);                                       \
    register_sympy<m::MODEL::Model>(sp::mass_matrix_and_bias, sp::kParameterNames, n_names, NAME); \
  }
#endif
#define SPACEARM_PLAIN(N)                                                    \
  register_ours<m::chain_n##N##_plain::Model>("plain", "chain_n" #N, false); \
  register_ours<m::chain_n##N##_geared_plain::Model>("plain", "chain_n" #N "_geared", false);
  register_ours<m::paper_reference::Model>("ours", "paper_reference", true);
  register_ours<m::paper_geared::Model>("ours", "paper_geared", true);
  register_mujoco<m::paper_reference::Model>(SPACEARM_SOURCE_DIR "/models/paper_reference.yaml",
                                             "paper_reference");
  SPACEARM_BENCH_N2
  SPACEARM_BENCH_N3
  SPACEARM_BENCH_N4
  SPACEARM_BENCH_N6
  SPACEARM_BENCH_N8
  SPACEARM_BENCH_N10
  SPACEARM_BENCH_N12
  SPACEARM_BENCH_N16
  SPACEARM_BENCH_N20
  SPACEARM_BENCH_N30
#ifndef SPACEARM_BENCH_QUICK
  register_ours<m::paper_geared_folded::Model>("ours", "paper_geared_folded", false);
  register_ours<m::paper_reference_plain::Model>("plain", "paper_reference", false);
  register_ours<m::paper_geared_plain::Model>("plain", "paper_geared", false);
  SPACEARM_PLAIN(2)
  SPACEARM_PLAIN(3)
  SPACEARM_PLAIN(4)
  SPACEARM_PLAIN(6)
#endif
  if (!ok) {
    std::fprintf(stderr,
                 "bench_dynamics: a peer and spacearm disagree; not timing different models\n");
    return 1;
  }
  benchmark::Initialize(&argc, argv);
  spacearm::bench::add_machine_context();
  RecordingReporter reporter(g_seconds);
  benchmark::RunSpecifiedBenchmarks(&reporter);
  print_ratio_table();
  benchmark::Shutdown();
  return 0;
}
