// `spacearm simulate` end to end: runs equal the library's simulation of the linked model, rows
// are kept whatever stops a run (a failure, a signal, --max-wall), the integrator is chosen from
// the stiffest mode and its choice said, and bad input gets an error naming the option.
#include <nlohmann/json.hpp>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>

#include "cli_fixtures.hpp"
#include "compiled_model.hpp"
#include "paper_geared.hpp"
#include "simulation.hpp"
#include "support.hpp"
#include "torque_signal.hpp"

extern char** environ;

namespace spacearm {
namespace {

namespace fs = std::filesystem;
using test::matrix_of;
using test::run;
using test::SimulateCli;
using test::vector_of;

// A spatial arm through eval and simulate: joint torques enter as tau / p on the joint slots
// after the base's six velocities; --symbolic is refused by name; free motion keeps the
// quaternion unit and conserves momentum, with 3D columns (vx0..wz0, the pose's quaternion,
// Px..Lz). Cost: one compile, about 1.5 s.
TEST_F(SimulateCli, SpatialArmEvaluatesAndMoves) {
  const std::string scene = std::string(SPACEARM_SOURCE_DIR) + "/tests/scenes/spatial_arm2.yaml";
  const std::string q = "0.1,0.2,0.3,0.5,0.5,-0.5,0.5,3,-7";
  int status = 0;
  const auto out = nlohmann::json::parse(run(
      cli + scene + " --q " + q + " --qd 0.1,0,0,0.2,-0.1,0.3,5,-2 --tau 2,-3 --json", &status));
  ASSERT_EQ(status, 0);
  const Eigen::MatrixXd M = matrix_of(out["mass_matrix"]);
  const Eigen::VectorXd b = vector_of(out["bias_forces"]),
                        qdd = vector_of(out["forward_dynamics"]["qdd"]);
  Eigen::VectorXd Q = Eigen::VectorXd::Zero(8);
  Q[6] = 2.0 / 50, Q[7] = -3.0 / 20;
  EXPECT_EQ(vector_of(out["Q"]), Q);
  EXPECT_LT((M * qdd + b - Q).norm(), 1e-12 * (1 + b.norm()));
  EXPECT_EQ(out["end_effector_pose"].size(), 7u);
  const std::string symbolic = run(cli + scene + " --q " + q + " --symbolic 2>&1", &status);
  EXPECT_NE(status, 0);
  EXPECT_NE(symbolic.find("--symbolic: model 'spatial_arm2' is a spatial arm"), std::string::npos)
      << symbolic;

  // inspect prints a spatial entry's closed form where it is affordable (M[6][7] depends on
  // joint 2's motor angle), in LaTeX on request; else the statements that compute it, ending in
  // its value, and LaTeX is refused by name.
  const std::string inspect = std::string(SPACEARM_CLI) + " inspect " + scene;
  const std::string closed = run(inspect + " 'M[6][7]' 2>&1", &status);
  EXPECT_EQ(status, 0) << closed;
  EXPECT_NE(closed.find("cos((0.05)*qm2)"), std::string::npos) << closed;
  const std::string latex = run(inspect + " 'M[6][7]' --latex 2>&1", &status);
  EXPECT_EQ(status, 0) << latex;
  EXPECT_NE(latex.find("\\cos({(0.05)}  qm2)"), std::string::npos) << latex;
  const std::string program = run(inspect + " 'qdd[0]' 2>&1", &status);
  EXPECT_EQ(status, 0) << program;
  EXPECT_EQ(
      program.rfind("// qdd[0] of forward_dynamics (recursive (ABA)) in model spatial_arm2", 0), 0u)
      << program;
  EXPECT_NE(program.find("\n  qdd[0] = "), std::string::npos) << program;
  const std::string refused = run(inspect + " 'qdd[0]' --latex 2>&1", &status);
  EXPECT_NE(status, 0);
  EXPECT_NE(refused.find("LaTeX and decimals need a closed form"), std::string::npos) << refused;

  const std::string simulate = std::string(SPACEARM_CLI) + " simulate --cache-dir " +
                               cache.string() + " " + scene +
                               " --zero --t-end 2 --dt-out 0.25 --integrator rkf78 --rtol 1e-11 "
                               "--atol 1e-12 --qd0 0.1,0,0,0.2,-0.1,0.3,5,-2";
  const std::string csv = run(simulate, &status);
  ASSERT_EQ(status, 0) << csv;
  const std::string head = csv.substr(0, csv.find('\n'));
  for (const char* column :
       {",qw0,", ",vx0,", ",wz0,", ",qm2d,", ",q2,", ",ee_z,", ",ee_qw,", ",Pz,", ",Lz"})
    EXPECT_NE(head.find(column), std::string::npos) << column << " in " << head;
  const auto table = rows(csv);
  ASSERT_EQ(table.size(), 9u);
  const size_t momentum = table[0].size() - 6;  // Px .. Lz, the last columns
  for (const auto& r : table) {
    EXPECT_NEAR(Eigen::Vector4d(r[4], r[5], r[6], r[7]).norm(), 1, 1e-14);
    for (size_t k = 0; k < 6; ++k)
      EXPECT_NEAR(r[momentum + k], table[0][momentum + k],
                  1e-9 * (1 + std::abs(table[0][momentum + k])));
  }
}

// A spatial arm with a flexible joint whose ratio is a run-time parameter: eval's --tau puts
// tau / p (the parameter's value, not its nominal one) on the motor coordinate after the joint
// slots, and simulate --consistent-start sets the motor at p q. Cost: one compile, about 1.5 s.
TEST_F(SimulateCli, ASpatialFlexibleJointTakesItsRatioFromTheParametersAndStartsConsistently) {
  std::string text =
      test::read_text_file(std::string(SPACEARM_SOURCE_DIR) + "/tests/scenes/spatial_arm2.yaml");
  text.replace(text.find("name: spatial_arm2"), 18, "name: spatial_arm2_flexible");
  const std::string gear = "{ratio: 50, rotor_inertia: [1.0e-4, 6.0e-5], rotor_coupling: exact}";
  text.replace(text.find(gear), gear.size(),
               "{ratio: p, rotor_inertia: [1.0e-4, 6.0e-5], rotor_coupling: exact, "
               "stiffness: 300, damping: 0.1}");
  text += "parameters: {p: 50}\n";
  const fs::path scene = cache.parent_path() / ("flexible-" + std::to_string(getpid()) + ".yaml");
  std::ofstream(scene) << text;
  int status = 0;
  const std::string q = "0.1,0.2,0.3,0.5,0.5,-0.5,0.5,0.06,-7,3";  // q1, qm2, then qm1
  const std::string evaluated =
      run(cli + scene.string() + " --q " + q + " --tau 2,-3 --param p=25 --json", &status);
  ASSERT_EQ(status, 0) << evaluated;
  const auto out = nlohmann::json::parse(evaluated);
  EXPECT_EQ(out["coordinates"][9], "qm1");
  Eigen::VectorXd Q = Eigen::VectorXd::Zero(9);
  Q[8] = 2.0 / 25, Q[7] = -3.0 / 20;
  EXPECT_EQ(vector_of(out["Q"]), Q);
  const fs::path csv = scene.string() + ".csv";
  const std::string simulated =
      run(std::string(SPACEARM_CLI) + " simulate --cache-dir " + cache.string() + " " +
              scene.string() + " --zero --t-end 0.02 --param p=25 --consistent-start --q0 " + q +
              " -o " + csv.string() + " 2>&1",
          &status);
  ASSERT_EQ(status, 0) << simulated;
  const auto table = rows(test::read_text_file(csv.string()));
  ASSERT_FALSE(table.empty());
  EXPECT_NEAR(table[0][10], 25 * 0.06, 1e-12);  // t, then q: qm1 at index 9
  fs::remove(scene);
  fs::remove(csv);
}

TEST_F(SimulateCli, ZeroTorqueFromRestStaysPutAndTorquesMoveTheArm) {
  int status = 0;
  const auto still =
      rows(run(sim + "--zero --t-end 1 --dt-out 0.25 --q0 0.1,0.2,0.3,1,2,3", &status));
  ASSERT_EQ(status, 0);
  ASSERT_EQ(still.size(), 5u);  // t = 0, 0.25, ..., 1
  for (const auto& r : still)
    EXPECT_EQ(std::vector<double>(r.begin() + 1, r.begin() + 7),
              (std::vector<double>{0.1, 0.2, 0.3, 1, 2, 3}));

  const fs::path torques = cache.parent_path() / ("torques-" + std::to_string(getpid()) + ".csv");
  std::ofstream(torques) << "t,tau1,tau2,tau3\n0,0.1,0,0\n0.5,0.1,0,0\n1,0.1,0,0\n";
  const auto moved =
      rows(run(sim + "--torques " + torques.string() + " --t-end 1 --param p=10", &status));
  ASSERT_EQ(status, 0);
  ASSERT_EQ(moved.size(), 101u);
  EXPECT_GT(std::abs(moved.back()[4]), 1e-3);  // qm1 turned
  // Momentum (last three columns) stays zero: torques are internal. RK4 at 0.01 s keeps it
  // to its truncation error (measured about 1e-12 kg m^2/s here); bound 100x above.
  for (const auto& r : moved)
    for (size_t c = r.size() - 3; c < r.size(); ++c) EXPECT_LT(std::abs(r[c]), 1e-10);
  fs::remove(torques);
}

// A run that fails half way (torques so large that the velocities overflow after t = 0.5)
// reports where, with the state, exits non-zero, and leaves a valid CSV of every sample
// computed before the failure.
TEST_F(SimulateCli, FailureMidRunKeepsTheSamplesComputedSoFar) {
  const fs::path torques =
      cache.parent_path() / ("huge-torques-" + std::to_string(getpid()) + ".csv");
  const fs::path csv = cache.parent_path() / ("partial-" + std::to_string(getpid()) + ".csv");
  std::ofstream(torques) << "t,tau1,tau2,tau3\n0,0,0,0\n0.5,1e300,0,0\n1,1e300,0,0\n";
  int status = 0;
  const std::string err =
      run(sim + "--torques " + torques.string() +
              " --interpolation hold --t-end 1 --dt-out 0.1 -o " + csv.string() + " 2>&1",
          &status);
  EXPECT_NE(status, 0);
  EXPECT_NE(err.find("rk4: "), std::string::npos) << err;
  EXPECT_NE(err.find("not finite"), std::string::npos) << err;
  EXPECT_NE(err.find("last accepted state at t = 0.5"), std::string::npos) << err;
  std::ifstream in(csv);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_FALSE(text.empty());
  EXPECT_EQ(text.back(), '\n');  // no half-written row
  const auto samples = rows(text);
  ASSERT_EQ(samples.size(), 6u);  // t = 0, 0.1, ..., 0.5
  for (size_t k = 0; k < samples.size(); ++k) {
    // t, qm and qm rates, link-side q and rates, tau (link side) and tau / p, end effector,
    // energy, momentum
    EXPECT_EQ(samples[k].size(), 1u + 12 + 6 + 3 + 3 + 3 + 1 + 3);
    EXPECT_NEAR(samples[k][0], 0.1 * k, 1e-12);
  }
  fs::remove(torques);
  fs::remove(csv);
}

// Issue 49: an explicit rk4 step too large for a spatial arm spinning at 100 rad/s diverges
// until the base's quaternion leaves the model's domain. Every row computed up to then stays in
// the CSV (with its header; the domain error had escaped the integrator, and the rows were lost)
// and the message names the cause and the remedy, not just the quaternion.
TEST_F(SimulateCli, ADivergingRunKeepsEveryRowAndNamesTheCause) {
  const std::string scene = std::string(SPACEARM_SOURCE_DIR) + "/tests/scenes/spatial_arm2.yaml";
  const fs::path csv = cache.parent_path() / ("diverged-" + std::to_string(getpid()) + ".csv");
  int status = 0;
  const std::string err =
      run(std::string(SPACEARM_CLI) + " simulate --cache-dir " + cache.string() + " " + scene +
              " --zero --integrator rk4 --dt 1.5 --t-end 300 --qd0 "
              "0,0,0,0,0,0,100,-100 -o " +
              csv.string() + " 2>&1",
          &status);
  EXPECT_NE(status, 0) << err;
  EXPECT_NE(err.find("holds every row up to t = 4.5 s"), std::string::npos) << err;
  EXPECT_NE(err.find("rk4: the state left the model's domain (q[3..6], the base's orientation "
                     "quaternion"),
            std::string::npos)
      << err;
  EXPECT_NE(err.find("rk4 at dt = 1.5 s is unstable for the stiffest mode"), std::string::npos)
      << err;
  const std::string text = test::read_text_file(csv.string());
  ASSERT_EQ(text.rfind("t,x0,", 0), 0u) << text;
  const auto r = rows(text);
  ASSERT_EQ(r.size(), 4u);  // t = 0, 1.5, 3, 4.5
  EXPECT_EQ(r.back()[0], 4.5);
  fs::remove(csv);
}

// An explicit step that does not resolve the stiffest mode at the start is warned, and a
// free-floating run reports how far momentum (and, unforced, energy) drifted: here by half of
// its size, where the resolved step keeps it to rounding.
TEST_F(SimulateCli, AnUnresolvedStepIsWarnedAndTheDriftReported) {
  const std::string scene = std::string(SPACEARM_SOURCE_DIR) + "/tests/scenes/spatial_arm2.yaml";
  const std::string base = std::string(SPACEARM_CLI) + " simulate --cache-dir " + cache.string() +
                           " " + scene +
                           " --zero --t-end 100 --qd0 0,0,0,0,0,0,100,-100 -o /dev/null ";
  auto drift = [](const std::string& err) {
    const auto at = err.find("momentum drift |P - P(0)| <= ");
    return at == std::string::npos ? -1.0 : std::stod(err.substr(at + 29));
  };
  int status = 0;
  const std::string coarse = run(base + "--integrator rk4 --dt 1 2>&1", &status);
  EXPECT_EQ(status, 0) << coarse;
  EXPECT_NE(coarse.find("warning: rk4 at dt = 1 s does not resolve the stiffest mode at the "
                        "start"),
            std::string::npos)
      << coarse;
  EXPECT_GT(drift(coarse), 1.0) << coarse;
  EXPECT_NE(coarse.find("energy drift |E - E(0)| <= "), std::string::npos) << coarse;
  const std::string fine = run(base + "--integrator rk4 --dt 0.001 2>&1", &status);
  EXPECT_EQ(status, 0) << fine;
  EXPECT_EQ(fine.find("warning"), std::string::npos) << fine;
  EXPECT_GE(drift(fine), 0.0) << fine;
  EXPECT_LT(drift(fine), 1e-6) << fine;
}

// A stiff spring (k = 1e12) makes rosenbrock4 take steps of nanoseconds: the run's pace is
// measured, and past --max-wall it stops after 5 s, its rows kept, naming the mode.
TEST_F(SimulateCli, ARunTooSlowForMaxWallStopsNamingTheStiffMode) {
  const std::string scene = std::string(SPACEARM_SOURCE_DIR) + "/models/paper_flexible.yaml";
  const fs::path csv = cache.parent_path() / ("slow-" + std::to_string(getpid()) + ".csv");
  int status = 0;
  const std::string err =
      run(std::string(SPACEARM_CLI) + " simulate --cache-dir " + cache.string() + " " + scene +
              " --param k=1e12 --zero --qd0 0,0,0,0.5,0.5,0.5,0,0,0 --t-end "
              "0.2 --max-wall 2 -o " +
              csv.string() + " 2>&1",
          &status);
  EXPECT_NE(status, 0) << err;
  EXPECT_NE(err.find("past --max-wall 2 s; rosenbrock4 at the start: "), std::string::npos) << err;
  EXPECT_NE(err.find("(a real mode, mostly qm"), std::string::npos) << err;
  EXPECT_NE(err.find("holds every row up to t = 0 s"), std::string::npos) << err;
  EXPECT_EQ(test::read_text_file(csv.string()).rfind("t,x0,", 0), 0u);
  fs::remove(csv);
}

// One runtime interface: the CLI runs the loaded model through the library's integrate_motion,
// so its samples are the library simulate() of the linked model (the same generated code,
// compiled apart: equal to rounding), for a fixed-step and an adaptive method.
TEST_F(SimulateCli, RunEqualsTheLibrarySimulationOfTheLinkedModel) {
  const fs::path torques =
      cache.parent_path() / ("same-torques-" + std::to_string(getpid()) + ".csv");
  std::ofstream(torques) << "t,tau1,tau2,tau3\n0,0.1,0,0\n0.5,0.3,-0.2,0.1\n1,0,0.05,0\n";
  using G = models::paper_geared::Model;
  Model<G> linked;
  linked.set_parameter("p", 10);
  std::vector<Model<G>::JointVector> samples(3);
  samples[0] << 0.1, 0, 0;
  samples[1] << 0.3, -0.2, 0.1;
  samples[2] << 0, 0.05, 0;
  const TorqueSignal<3> tau(0.0, 0.5, samples, Interpolation::linear);
  Model<G>::Vector q0;
  q0 << 0.1, 0.2, 0.3, 1, 2, 3;
  for (const std::string method : {"rk4", "dopri5"}) {
    SCOPED_TRACE(method);
    int status = 0;
    const auto cli = rows(run(sim + "--torques " + torques.string() + " --t-end 1 --dt-out 0.1" +
                                  " --param p=10 --q0 0.1,0.2,0.3,1,2,3 --integrator " + method,
                              &status));
    ASSERT_EQ(status, 0);
    IntegratorOptions opt;
    opt.method = method_from_string(method);
    const auto lib = simulate(linked, q0, Model<G>::Velocity::Zero(), tau, 1.0, 0.1, opt);
    ASSERT_EQ(cli.size(), lib.t.size());
    for (size_t k = 0; k < cli.size(); ++k) {
      Eigen::VectorXd state(12), expected(12);
      for (int i = 0; i < 12; ++i) state[i] = cli[k][1 + i];
      expected << lib.q[k], lib.qd[k];
      EXPECT_MATRIX_NEAR(state, expected, 1e-12);
    }
    EXPECT_GT(std::abs(cli.back()[4] - 1), 1e-3);  // qm1 moved
  }
  fs::remove(torques);
}

TEST_F(SimulateCli, BadInputsGetClearErrors) {
  const fs::path torques =
      cache.parent_path() / ("bad-torques-" + std::to_string(getpid()) + ".csv");
  std::ofstream(torques) << "t,tau1,tau2\n0,0.1,0\n";
  const fs::path grid = cache.parent_path() / ("grid-torques-" + std::to_string(getpid()) + ".csv");
  std::ofstream(grid) << "t,tau1,tau2,tau3\n0,0,0,0\n0.03,0,0,0\n0.06,0,0,0\n";
  struct Case {
    std::string args, message;
  };
  for (const Case& c : std::vector<Case>{
           {"--torques " + torques.string() + " --t-end 1",
            "line 1: missing column 'tau3' (expected t,tau1,tau2,tau3)"},
           {"--torques " + grid.string() + " --t-end 0.06 --dt 0.02 --interpolation hold",
            "needs the torque samples' interval (0.03 s) to be a multiple of --dt (0.02 "
            "s)"},
           {"--zero --t-end 1e999", "--t-end: value: '1e999' is not finite"},
           {"--zero --t-end 1 --dt 0.1 --dt 0.2", "--dt"},
           {"--zero --t-end 1 --extrapolate clamp", "--extrapolate: has no effect with --zero"},
           {"--torques " + grid.string() + " --t-end 0.06 --extrapolate clamp",
            "unknown torque extrapolation 'clamp'"},
           {"--zero --t-end 1 --rtol 1e-3", "--rtol: applies only to the adaptive integrators"},
           {"--torques " + grid.string() + " --t-end 0.06 -o " + grid.string(),
            "is --torques file: it would be overwritten"},
           {"--zero --t-end 1 --q0 0,0,0,0,nan,0", "--q0[4]: 'nan' is not finite"},
           {"--zero --t-end 1 --integrator euler", "unknown integrator 'euler'"},
           {"--zero --t-end 1 --integrator rosenbrock4",
            "rosenbrock4 needs the Jacobian of the right-hand side (for a model: the scene's "
            "output forward_dynamics_derivatives)"},
           {"--t-end 1", "give --torques FILE, --plan FILE or --zero"},
           {"--zero --t-end 1 --rtol 1e-3 --integrator auto", "not to auto"},
           // Issue 49: empty values are not defaults, tolerances are relative errors, one
           // angle rule, run-time parameters in the scene's range, the grid in the options'
           // own names.
           {"--zero --t-end 1 --q0 ''", "--q0: an empty value; give one, or leave the option out"},
           {"--zero --t-end 1 -o ''", "an empty value"},
           {"--zero --t-end 1 --integrator dopri5 --rtol 10", "must be at most 0.1"},
           {"--zero --t-end 1 --q0 0,0,1e100,0,0,0",
            "--q0[2] (q0) = 1e+100 rad: angles must lie within +-1e6 rad"},
           {"--zero --t-end 1 --param p=1e300",
            "'p' = 1e+300 is outside the supported magnitude range 1e-30 .. 1e30 (or 0)"},
           {"--zero --t-end 1 --qd0 0,0,0,1,1,1 --param p=1e-29",
            "rk4 would take 8.76e+50 steps of 1.14e-53 s for each row (--dt 0.01 s): the stiffest "
            "mode at the start is too fast for any run. The run-time parameters widen the "
            "model's span of values to 30 decades, from gears[0].ratio (p) = 1e-29"},
           {"--zero --t-end 1 --integrator rk4 --dt 1e-10 --dt-out 1",
            "--dt 1e-10 s is too small for a row every --dt-out 1 s (1e+10 steps a row)"},
           {"--zero --t-end 1 --dt 0.3 --integrator rk4",
            "--t-end 1 s must be a whole multiple of --dt 0.3 s"},
           {"--zero --t-end 1 --dt 0.1 --dt-out 0.25 --integrator rk4",
            "--dt-out 0.25 s must be a whole multiple of the step --dt 0.1 s"},
       }) {
    int status = 0;
    const std::string out = run(sim + c.args + " 2>&1", &status);
    EXPECT_NE(status, 0) << c.args;
    EXPECT_NE(out.find(c.message), std::string::npos) << "args: " << c.args << "\noutput: " << out;
  }
  fs::remove(torques);
  fs::remove(grid);
}

// A stiff flexible scene: rosenbrock4 (the scene emits the state Jacobian) agrees with a
// tight rkf78 run, and the rows carry the springs' potential energy.
TEST_F(SimulateCli, FlexibleSceneRunsWithRosenbrock4AndWritesPotentialEnergy) {
  const std::string flex = std::string(SPACEARM_CLI) + " simulate --cache-dir " + cache.string() +
                           " " + SPACEARM_SOURCE_DIR + "/models/paper_flexible.yaml --zero " +
                           "--t-end 0.2 --dt-out 0.1 --q0 0,0,0,0.6,1.1,-0.9,6.04,11.08,-8.88 ";
  int status = 0;
  const std::string head =
      run(flex + "--integrator rosenbrock4 --rtol 1e-9 --atol 1e-11 | head -1", &status);
  EXPECT_NE(head.find(",kinetic_energy,potential_energy,Px"), std::string::npos) << head;
  const auto rb = rows(run(flex + "--integrator rosenbrock4 --rtol 1e-9 --atol 1e-11", &status));
  ASSERT_EQ(status, 0);
  const auto ref = rows(run(flex + "--integrator rkf78 --rtol 1e-12 --atol 1e-13", &status));
  ASSERT_EQ(status, 0);
  ASSERT_EQ(rb.size(), 3u);
  ASSERT_EQ(ref.size(), 3u);
  for (size_t c = 1; c < 19; ++c) EXPECT_NEAR(rb.back()[c], ref.back()[c], 1e-6) << "column " << c;
  EXPECT_GT(rb.front()[rb.front().size() - 4], 0.0);  // the twisted springs hold energy at t = 0
}

// --consistent-start pre-deflects the springs for the first torque sample: the motor and link
// sides then move together (twist rate qmd/p - qd stays far smaller than from relaxed springs,
// which ring: measured 1.2e-3 against 0.12 rad/s), and the first row already holds spring
// energy. Refused without a flexible joint.
TEST_F(SimulateCli, ConsistentStartPreDeflectsTheSprings) {
  const fs::path torques =
      cache.parent_path() / ("flex-torques-" + std::to_string(getpid()) + ".csv");
  std::ofstream(torques) << "t,tau1,tau2,tau3\n0,0.5,-0.3,0.2\n0.1,0.5,-0.3,0.2\n";
  const std::string flex = std::string(SPACEARM_CLI) + " simulate --cache-dir " + cache.string() +
                           " " + SPACEARM_SOURCE_DIR + "/models/paper_flexible.yaml --torques " +
                           torques.string() +
                           " --t-end 0.02 --dt-out 0.00025 --integrator rosenbrock4 "
                           "--q0 0,0,0,0.6,1.1,-0.9,6,11,-9 ";
  int status = 0;
  auto worst_twist_rate = [&](const std::vector<std::vector<double>>& r) {
    double worst = 0;  // columns: t, 9 q, 9 qd (qd of q1..q3 at 13..15, of qm1..qm3 at 16..18)
    for (const auto& row : r)
      for (int j = 0; j < 3; ++j) worst = std::max(worst, std::abs(row[16 + j] / 10 - row[13 + j]));
    return worst;
  };
  const auto consistent = rows(run(flex + "--consistent-start", &status));
  ASSERT_EQ(status, 0);
  const auto relaxed = rows(run(flex, &status));
  ASSERT_EQ(status, 0);
  ASSERT_EQ(consistent.size(), 81u);  // every 0.25 ms: the relaxed joints ring at about 3000 rad/s
  EXPECT_NE(consistent[0][7], 6.0);   // qm1 moved off p q1
  EXPECT_GT(consistent[0][consistent[0].size() - 4], 0.0);
  EXPECT_EQ(relaxed[0][relaxed[0].size() - 4], 0.0);
  const double c = worst_twist_rate(consistent), r = worst_twist_rate(relaxed);
  std::printf("worst twist rate: consistent start %.2e rad/s, relaxed springs %.2e rad/s\n", c, r);
  EXPECT_LT(10 * c, r);
  const std::string refused = run(sim + "--zero --t-end 1 --consistent-start 2>&1", &status);
  EXPECT_NE(refused.find("--consistent-start: the scene has no flexible joint"), std::string::npos)
      << refused;
  fs::remove(torques);
}

std::string slurp(const fs::path& p) { return test::read_text_file(p.string()); }

// Columns by name in any order, CRLF and a byte-order mark: the same run as the plain file.
// Link-side columns of a geared scene are q = qm / p, and both torque sides are written.
TEST_F(SimulateCli, TorqueColumnsAreFoundByNameAndBothSidesAreWritten) {
  const fs::path plain = cache.parent_path() / ("plain-" + std::to_string(getpid()) + ".csv");
  const fs::path shuffled = cache.parent_path() / ("shuffled-" + std::to_string(getpid()) + ".csv");
  std::ofstream(plain) << "t,tau1,tau2,tau3\n0,0.1,-0.2,0.3\n0.5,0.2,0.1,0\n1,0,0,0.4\n";
  std::ofstream(shuffled)
      << "\xEF\xBB\xBFtau3, t ,tau2,tau1\r\n0.3,0,-0.2,0.1\r\n0,0.5,0.1,0.2\r\n0.4,1,0,0\r\n";
  int status = 0;
  const std::string a =
      run(sim + "--torques " + plain.string() + " --t-end 1 --param p=10", &status);
  ASSERT_EQ(status, 0);
  EXPECT_EQ(run(sim + "--torques " + shuffled.string() + " --t-end 1 --param p=10", &status), a);
  const std::string header = a.substr(0, a.find('\n'));
  EXPECT_NE(header.find(",q1,q2,q3,q1d,q2d,q3d,tau1,tau2,tau3,tau_motor1,tau_motor2,tau_motor3,"),
            std::string::npos)
      << header;
  const auto r = rows(a);
  const auto& last = r.back();  // t, qm(6), qmd(6), q(3), qd(3), tau(3), tau_motor(3), ...
  for (int j = 0; j < 3; ++j) {
    EXPECT_DOUBLE_EQ(last[13 + j], last[4 + j] / 10);
    EXPECT_DOUBLE_EQ(last[16 + j], last[10 + j] / 10);
    EXPECT_DOUBLE_EQ(last[22 + j], last[19 + j] / 10);
  }
  EXPECT_DOUBLE_EQ(last[21], 0.4);  // tau3 at t = 1

  struct Case {
    std::string text, message;
  };
  for (const Case& c : std::vector<Case>{
           {"t,tau1,tau2,tua3\n0,0,0,0\n1,0,0,0\n",
            "unknown column 'tua3' (expected t,tau1,tau2,tau3)"},
           {"t,tau1,tau1,tau3\n0,0,0,0\n1,0,0,0\n", "column 'tau1' appears twice"},
           {"0,0,0,0\n1,0,0,0\n",
            "starts with data ('0'), not a header; add the header line t,tau1,tau2,tau3"},
           {"t,tau1,tau2,tau3\n0,0,0,0\n0.5,0,x,0\n1,0,0,0\n",
            "line 3, column 'tau2': 'x' is not a number"},
           {"t,tau1,tau2,tau3\n0,0,0,0\n0.5,0,0,0\n",
            "covers t = 0 .. 0.5 s, the run needs 0 .. 1 s"},
           {"t,tau1,tau2,tau3\n0,0,0,0\n0.5,0,0,0\n0.7,0,0,0\n",
            "line 4: time step 0.2 differs from the first step 0.5"},
       }) {
    std::ofstream(plain) << c.text;
    const std::string out = run(sim + "--torques " + plain.string() + " --t-end 1 2>&1", &status);
    EXPECT_NE(status, 0) << c.text;
    EXPECT_NE(out.find(c.message), std::string::npos) << c.text << "\noutput: " << out;
  }
  // Asked for: held after the last sample.
  std::ofstream(plain) << "t,tau1,tau2,tau3\n0,0,0,0\n0.5,0,0,0.25\n";
  const auto held =
      rows(run(sim + "--torques " + plain.string() + " --t-end 1 --extrapolate hold", &status));
  ASSERT_EQ(status, 0);
  EXPECT_DOUBLE_EQ(held.back()[21], 0.25);
  fs::remove(plain);
  fs::remove(shuffled);
}

TEST_F(SimulateCli, WriteFailuresAreErrorsNamingTheFile) {
  int status = 0;
  // A run refused before it starts leaves an existing output file as it was.
  const fs::path previous = cache.parent_path() / ("previous-" + std::to_string(getpid()) + ".csv");
  std::ofstream(previous) << "keep\n";
  run(sim + "--zero --t-end 1 --param Im=0.5 -o " + previous.string() + " 2>&1", &status);
  EXPECT_NE(status, 0);
  EXPECT_EQ(slurp(previous), "keep\n");
  fs::remove(previous);
  std::string out = run(sim + "--zero --t-end 1 -o /dev/full 2>&1", &status);
  EXPECT_EQ(WEXITSTATUS(status), 1) << out;
  EXPECT_NE(out.find("writing '/dev/full' failed: No space left on device"), std::string::npos)
      << out;
  out = run(sim + "--zero --t-end 1 -o /nonexistent-folder/x.csv 2>&1", &status);
  EXPECT_EQ(WEXITSTATUS(status), 1) << out;
  EXPECT_NE(out.find("-o: cannot open '/nonexistent-folder/x.csv' for writing"), std::string::npos)
      << out;
  EXPECT_EQ(rows(run(sim + "--zero --t-end 1 --dt-out 0.5 -o -", &status)).size(), 3u);
  EXPECT_EQ(status, 0);
  // Issue 49: "none" is a file's name like any other, with its provenance beside it.
  const fs::path folder = cache.parent_path() / ("none-" + std::to_string(getpid()));
  fs::create_directories(folder);
  run("cd " + folder.string() + " && " + sim + "--zero --t-end 1 --dt-out 0.5 -o none", &status);
  EXPECT_EQ(status, 0);
  EXPECT_EQ(rows(slurp(folder / "none")).size(), 3u);
  EXPECT_TRUE(fs::is_regular_file(folder / "none.provenance.json"));
  fs::remove_all(folder);
}

// A signal mid-run finishes the row being written, flushes, says where it stopped and exits
// 128 + signal; every row in the file is whole. The run asked for is huge, which is said first.
TEST_F(SimulateCli, SignalsFinishTheRowAndReportTheTimeReached) {
  const fs::path csv = cache.parent_path() / ("signal-" + std::to_string(getpid()) + ".csv");
  const fs::path err = cache.parent_path() / ("signal-" + std::to_string(getpid()) + ".err");
  int status = 0;
  run(sim + "--zero --t-end 0.1 > /dev/null 2>&1", &status);  // compiled before the clock starts
  ASSERT_EQ(status, 0);
  for (const auto& [signal, name] : std::vector<std::pair<int, std::string>>{
           {SIGTERM, "SIGTERM"}, {SIGINT, "SIGINT"}, {SIGHUP, "SIGHUP"}}) {
    fs::remove(csv);
    // Started directly (not as a shell's background job, whose SIGINT is ignored by design).
    const std::string command =
        "exec " + sim + "--zero --t-end 1e7 --dt 1e-3 -o " + csv.string() + " 2> " + err.string();
    pid_t pid = -1;
    const char* argv[] = {"/bin/sh", "-c", command.c_str(), nullptr};
    ASSERT_EQ(posix_spawn(&pid, "/bin/sh", nullptr, nullptr, const_cast<char**>(argv), environ), 0);
    for (int i = 0; i < 600 && !(fs::exists(csv) && fs::file_size(csv) > 200000); ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    ::kill(pid, signal);
    int waited = 0;
    while (::waitpid(pid, &status, WNOHANG) == 0 && waited++ < 400)
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    if (waited > 400) {
      ::kill(pid, SIGKILL);
      ::waitpid(pid, &status, 0);
      FAIL() << name << " did not stop the run";
    }
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 128 + signal)
        << name << " status " << status;
    const std::string e = slurp(err);
    EXPECT_NE(e.find("note: the output will be about"), std::string::npos) << e;
    EXPECT_NE(
        e.find("interrupted by " + name + "; '" + csv.string() + "' holds every row up to t = "),
        std::string::npos)
        << e;
    const std::string text = slurp(csv);
    ASSERT_FALSE(text.empty());
    EXPECT_EQ(text.back(), '\n');
    const auto r = rows(text);  // checks that every row has the same length
    ASSERT_GT(r.size(), 100u);
    const auto at = e.find("up to t = ");
    if (at != std::string::npos) {
      EXPECT_EQ(r.back()[0], std::stod(e.substr(at + 10)));
    }
  }
  fs::remove(csv);
  fs::remove(err);
}

}  // namespace
}  // namespace spacearm
