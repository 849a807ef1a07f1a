// `spacearm eval` end to end: its JSON equals the checked-in generated code, --symbolic agrees
// with the compiled path, joint torques drive the motor coordinates, the cache is reused, and bad
// input gets an error naming the option.
#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>

#include <sys/wait.h>

#include "cli_fixtures.hpp"
#include "compiled_model.hpp"
#include "paper_geared.hpp"
#include "support.hpp"

namespace spacearm {
namespace {

namespace fs = std::filesystem;
using test::EvalCli;
using test::expect_json_near;
using test::fresh_cache;
using test::matrix_of;
using test::run;
using test::vector_of;

TEST_F(EvalCli, JsonEqualsGeneratedCodeAndSymbolicAgrees) {
  const std::string q = "0.1,-0.2,0.3,0.5,1.1,-0.7", qd = "0.01,0.02,-0.1,0.3,-0.2,0.4";
  const std::string args = std::string(SPACEARM_SOURCE_DIR) + "/models/paper_geared.yaml --q " + q +
                           " --qd " + qd + " --param p=10 --param Im=2e-5 --json";
  int status = 0;
  const auto compiled = nlohmann::json::parse(run(cli + args, &status));
  ASSERT_EQ(status, 0);
  const auto symbolic = nlohmann::json::parse(run(cli + args + " --symbolic", &status));
  ASSERT_EQ(status, 0);
  // Every output the scene emits, from the registry, in both; and the state and parameters used.
  const Scene scene = load_scene(SPACEARM_SOURCE_DIR "/models/paper_geared.yaml");
  for (const OutputInfo& o : output_registry()) {
    EXPECT_EQ(compiled.contains(o.name), scene.wants(o.id)) << o.name;
    EXPECT_EQ(symbolic.contains(o.name), scene.wants(o.id)) << o.name;
  }
  EXPECT_EQ(compiled["coordinates"], nlohmann::json(scene.coordinate_names()));
  EXPECT_EQ(compiled["parameters"]["p"].get<double>(), 10);
  EXPECT_EQ(compiled["parameters"]["Im"].get<double>(), 2e-5);
  EXPECT_EQ(compiled["qd"][2].get<double>(), -0.1);

  namespace g = models::paper_geared;
  const g::Coordinates<double> qv =
      (g::Coordinates<double>() << 0.1, -0.2, 0.3, 0.5, 1.1, -0.7).finished();
  const g::Coordinates<double> qdv =
      (g::Coordinates<double>() << 0.01, 0.02, -0.1, 0.3, -0.2, 0.4).finished();
  const g::Parameters<double> pv(10, 2e-5);
  g::MassMatrix<double> M, C;
  g::Coordinates<double> b;
  g::Pose<double> h, x;
  g::mass_matrix(qv, pv, M);
  g::coriolis_matrix(qv, qdv, pv, C);
  g::bias_forces(qv, qdv, pv, b);
  g::momentum(qv, qdv, pv, h);
  g::end_effector_pose(qv, pv, x);
  EXPECT_MATRIX_NEAR(matrix_of(compiled["mass_matrix"]), M, 1e-14);
  EXPECT_MATRIX_NEAR(matrix_of(compiled["coriolis_matrix"]), C, 1e-13);
  EXPECT_MATRIX_NEAR(vector_of(compiled["bias_forces"]), b, 1e-13);
  EXPECT_MATRIX_NEAR(vector_of(compiled["momentum"]), h, 1e-14);
  EXPECT_MATRIX_NEAR(vector_of(compiled["end_effector_pose"]), x, 1e-15);
  EXPECT_NEAR(compiled["kinetic_energy"].get<double>(), g::kinetic_energy(qv, qdv, pv), 1e-14);

  for (const OutputInfo& o : output_registry()) {
    if (!scene.wants(o.id)) continue;
    SCOPED_TRACE(o.name);
    expect_json_near(symbolic[o.name], compiled[o.name]);
  }
  // Several results: each under its name.
  for (const char* r : {"qdd", "pivots", "scaled_pivots"})
    EXPECT_TRUE(compiled["forward_dynamics"].contains(r)) << r;
  EXPECT_TRUE(compiled["free_base_inverse_dynamics"].contains("qdd_base"));
}

// Joint torques: --tau puts tau_i / p_i on the motor coordinate each joint drives (after the
// joint slots in a flexible scene), as --forces would with those numbers there; the symbolic
// path agrees, and potential_energy and qdd are in the JSON.
TEST_F(EvalCli, JointTorquesDriveTheMotorCoordinates) {
  const std::string scene = std::string(SPACEARM_SOURCE_DIR) + "/models/paper_flexible.yaml";
  const std::string state = " --q 0,0,0,0.6,1.1,-0.9,6.1,11,-9 --qd 0,0,0,0.1,0.2,0.3,1,2,3.5";
  int status = 0;
  const auto by_tau =
      nlohmann::json::parse(run(cli + scene + state + " --tau 1,-2,3 --json", &status));
  ASSERT_EQ(status, 0);
  const auto by_forces = nlohmann::json::parse(
      run(cli + scene + state + " --forces 0,0,0,0,0,0,0.1,-0.2,0.3 --json", &status));
  ASSERT_EQ(status, 0);
  EXPECT_EQ(by_tau["Q"], by_forces["Q"]);
  EXPECT_EQ(by_tau["tau"], nlohmann::json::parse("[1.0, -2.0, 3.0]"));
  EXPECT_EQ(by_tau["forward_dynamics"]["qdd"], by_forces["forward_dynamics"]["qdd"]);
  EXPECT_GT(by_tau["potential_energy"].get<double>(), 0.0);
  const auto symbolic =
      nlohmann::json::parse(run(cli + scene + state + " --tau 1,-2,3 --json --symbolic", &status));
  ASSERT_EQ(status, 0);
  expect_json_near(symbolic["forward_dynamics"]["qdd"], by_tau["forward_dynamics"]["qdd"]);
  // A run-time ratio divides too; and --tau excludes --forces.
  const auto p20 = nlohmann::json::parse(
      run(cli + scene + state + " --tau 1,-2,3 --param p=20 --json", &status));
  ASSERT_EQ(status, 0);
  EXPECT_DOUBLE_EQ(p20["Q"][6].get<double>(), 0.05);
  const std::string both = run(cli + scene + state + " --tau 1,2,3 --forces 0 2>&1", &status);
  EXPECT_NE(WEXITSTATUS(status), 0);
  EXPECT_NE(both.find("excludes --tau"), std::string::npos) << both;
  const std::string count = run(cli + scene + state + " --tau 1,2 2>&1", &status);
  EXPECT_NE(count.find("--tau: expected 3 comma-separated values, got 2"), std::string::npos)
      << count;
}

// rotor_coupling: c (issue 29): one scene answers "exact or armature?" at run time: c = 1 gives
// paper_geared.yaml's numbers, c = 0 paper_geared_armature.yaml's (compiled, to rounding), and
// c = 1.5 is refused by name. Compiles three models (about 5 s).
TEST_F(EvalCli, RotorCouplingFactorComparesExactAndArmature) {
  const std::string models = std::string(SPACEARM_SOURCE_DIR) + "/models/";
  std::string text = test::read_text_file(models + "paper_geared.yaml");
  text.replace(text.find("name: paper_geared"), 18, "name: paper_geared_coupling");
  text.replace(text.find("  compensate_link_inertia: true"), 31,
               "  compensate_link_inertia: true\n  rotor_coupling: c");
  text.replace(text.find("parameters:"), 11, "parameters:\n  c: 1.0");
  fs::create_directories(cache);
  const fs::path scene = cache / "coupling.yaml";
  std::ofstream(scene) << text;
  const std::string state =
      " --param p=10 --param Im=1e-3 --q 0,0,0.1,2,3,4 --qd 0.1,0.2,0.3,1,2,3 --json";
  auto eval = [&](const std::string& args) {
    int status = 0;
    const std::string out = run(cli + args + state + " 2>/dev/null", &status);
    EXPECT_EQ(status, 0) << args;
    return nlohmann::json::parse(out);
  };
  for (const auto& [c, twin] :
       {std::pair{"1", "paper_geared.yaml"}, std::pair{"0", "paper_geared_armature.yaml"}}) {
    const auto factor = eval(scene.string() + " --param c=" + c), fixed = eval(models + twin);
    for (const char* out : {"mass_matrix", "bias_forces", "kinetic_energy", "momentum"})
      expect_json_near(factor[out], fixed[out]);
  }
  const auto exact = eval(models + "paper_geared.yaml"),
             armature = eval(models + "paper_geared_armature.yaml");
  EXPECT_NE(exact["mass_matrix"][2][3], armature["mass_matrix"][2][3]);  // they do differ
  int status = 0;
  const std::string bad = run(cli + scene.string() + " --param c=1.5" + state + " 2>&1", &status);
  EXPECT_NE(status, 0);
  EXPECT_NE(bad.find("rotor_coupling must be in [0, 1]"), std::string::npos) << bad;
}

// The same in 3D (issue 51): a spatial arm's rotor_coupling: c gives the exact scene's numbers at
// c = 1 and the armature scene's at c = 0, in one compiled model. Compiles three small models.
TEST_F(EvalCli, RotorCouplingFactorComparesExactAndArmatureInSpace) {
  auto scene = [&](const std::string& name, const std::string& coupling) {
    const fs::path path = cache / (name + ".yaml");
    fs::create_directories(cache);
    std::ofstream(path)
        << "name: " << name << "\nspace: spatial\n"
        << "base: {type: free_floating, mass: 200, com: [0.1, 0, 0], inertia: [40, 1, 0, 50, 0, "
           "60]}\n"
        << "links:\n  - {origin: [0.5, 0, 0.2], axis: [0, 0, 1], mass: 5, com: [0.2, 0, 0], "
           "inertia: [0.01, 0, 0, 0.2, 0, 0.2]}\n"
        << "  - {origin: [0.4, 0, 0], rpy: [1.2, 0, 0], axis: [0, 1, 0], mass: 3, com: [0.2, 0, "
           "0], "
           "inertia: [0.01, 0, 0, 0.1, 0, 0.1]}\n"
        << "gears: {ratio: 50, rotor_inertia: [2.0e-4, 1.0e-4], rotor_coupling: " << coupling
        << "}\noutputs: [mass_matrix, bias_forces, momentum]\n"
        << (coupling == "c" ? "parameters: {c: 0.5}\n" : "");
    return path.string();
  };
  const std::string state =
      " --q 0.1,0.2,0.3,0.5,0.5,0.5,0.5,3,-7 --qd 0.1,0.2,0.3,0.4,-0.5,0.6,20,-30 --json";
  auto eval = [&](const std::string& args) {
    int status = 0;
    const std::string out = run(cli + args + state + " 2>/dev/null", &status);
    EXPECT_EQ(status, 0) << args;
    return nlohmann::json::parse(out);
  };
  const std::string coupled = scene("coupled3", "c");
  const auto exact = eval(scene("exact3", "exact")),
             armature = eval(scene("armature3", "armature"));
  for (const auto& [c, twin] : {std::pair{"1", &exact}, std::pair{"0", &armature}}) {
    const auto factor = eval(coupled + " --param c=" + c);
    for (const char* out : {"mass_matrix", "bias_forces", "momentum"})
      expect_json_near(factor[out], (*twin)[out]);
  }
  EXPECT_NE(exact["mass_matrix"][3][6], armature["mass_matrix"][3][6]);  // they do differ
  int status = 0;
  const std::string bad = run(cli + coupled + " --param c=1.5" + state + " 2>&1", &status);
  EXPECT_NE(status, 0);
  EXPECT_NE(
      bad.find(
          "gears.rotor_coupling (every joint) must be in [0, 1] (not above 1) (given c = 1.5)"),
      std::string::npos)
      << bad;
}

// Issue 51: --state-to writes a spatial free base's state in another tool's convention and
// --state-from reads it back: the same state (to 1e-14) and the same numbers, for every tool; the
// joints are link angles there (the geared slots over p = 50); a planar scene is refused.
// The JSON object in output that has stderr's lines around it (2>&1): a model's compile in the
// background is said after the result.
std::string json_in(const std::string& out) {
  const size_t first = out.find('{'), last = out.rfind('}');
  return first == std::string::npos || last == std::string::npos
             ? out
             : out.substr(first, last - first + 1);
}

TEST_F(EvalCli, StatesConvertToAndFromOtherToolsConventions) {
  fs::create_directories(cache);
  const fs::path scene = cache / "arm2c.yaml";
  std::ofstream(scene)
      << "name: arm2c\nspace: spatial\n"
      << "base: {type: free_floating, mass: 200, com: [0.1, -0.2, 0.3], inertia: [40, 1, 0, 50, "
         "0, 60]}\nlinks:\n  - {origin: [0.5, 0, 0.2], axis: [0, 0, 1], mass: 5, com: [0.2, 0, "
         "0], inertia: [0.01, 0, 0, 0.2, 0, 0.2]}\n  - {origin: [0.4, 0, 0], axis: [0, 1, 0], "
         "mass: 3, com: [0.2, 0, 0], inertia: [0.01, 0, 0, 0.1, 0, 0.1]}\n"
      << "gears: [{ratio: 50, rotor_inertia: [2.0e-4, 1.0e-4]}, {ratio: 1}]\n"
      << "outputs: [mass_matrix, momentum]\n";
  auto eval = [&](const std::string& args) {
    int status = 0;
    const std::string out = run(cli + scene.string() + args + " --json 2>&1", &status);
    EXPECT_EQ(status, 0) << out;
    return nlohmann::json::parse(json_in(out));
  };
  auto list = [](const nlohmann::json& v) {
    std::string text;
    char number[32];
    for (double x : v) {
      std::snprintf(number, sizeof number, "%.17g", x);
      text += (text.empty() ? "" : ",") + std::string(number);
    }
    return text;
  };
  const std::string q = "0.1,0.2,0.3,0.5,-0.5,0.5,0.5,3,-0.7",
                    qd = "0.1,-0.2,0.3,0.4,-0.5,0.6,20,-0.3";
  for (const char* tool : {"pinocchio", "spacedyn", "spart"}) {
    SCOPED_TRACE(tool);
    const auto there = eval(" --q " + q + " --qd " + qd + " --state-to " + tool);
    const auto& other = there[std::string("state_") + tool];
    EXPECT_EQ(other["convention"], tool);
    EXPECT_NEAR(other["q"][7].get<double>(), 3.0 / 50, 1e-16);  // a link angle
    EXPECT_NEAR(other["q"][8].get<double>(), -0.7, 1e-16);
    const auto back =
        eval(" --q " + list(other["q"]) + " --qd " + list(other["v"]) + " --state-from " + tool);
    for (int i = 0; i < 9; ++i)
      EXPECT_NEAR(back["q"][i].get<double>(), there["q"][i].get<double>(), 1e-14) << i;
    for (int i = 0; i < 8; ++i)
      EXPECT_NEAR(back["qd"][i].get<double>(), there["qd"][i].get<double>(), 1e-14) << i;
    expect_json_near(back["momentum"], there["momentum"]);
    EXPECT_EQ(back["given_state"]["convention"], tool);
  }
  // SpaceDyn's R0 is the base's centre of mass: at the identity turn, the origin plus its com.
  const auto at_home = eval(" --state-to spacedyn");
  EXPECT_EQ(at_home["state_spacedyn"]["q"][0], 0.1);
  EXPECT_EQ(at_home["state_spacedyn"]["q"][1], -0.2);
  int status = 0;
  const std::string planar = run(cli + std::string(SPACEARM_SOURCE_DIR) +
                                     "/models/paper_geared.yaml --state-to pinocchio 2>&1",
                                 &status);
  EXPECT_NE(status, 0);
  EXPECT_NE(planar.find("--state-to: converts a spatial scene's free base; 'paper_geared' has "
                        "none"),
            std::string::npos)
      << planar;
  // Found in review: the angle bound holds after conversion (p times a link angle), and a zero
  // quaternion names the option.
  const std::string far =
      run(cli + scene.string() + " --state-from spart --q 0,0,0,1,0,0,0,1e5,0 2>&1", &status);
  EXPECT_NE(status, 0);
  EXPECT_NE(far.find("--q[7] (qm1) = 5e+06 rad: angles must lie within +-1e6 rad"),
            std::string::npos)
      << far;
  const std::string zero =
      run(cli + scene.string() + " --state-from spacedyn --q 0,0,0,0,0,0,0,0,0 2>&1", &status);
  EXPECT_NE(zero.find("--q (--state-from spacedyn): the base's quaternion is zero"),
            std::string::npos)
      << zero;
  const std::string bad = run(cli + scene.string() + " --state-from mujoco 2>&1", &status);
  EXPECT_NE(bad.find("--state-from: expected spacearm, pinocchio, spacedyn or spart, got "
                     "'mujoco'"),
            std::string::npos)
      << bad;
}

TEST_F(EvalCli, VerboseReportShowsTheCacheHit) {
  const std::string args = std::string(SPACEARM_SOURCE_DIR) +
                           "/models/paper_reference.yaml --q 0,0,0,0.1,0.2,0.3 --verbose 2>&1";
  const std::string first = run(cli + "--engine compiled " + args);
  const std::string second = run(cli + args);
  EXPECT_NE(first.find("(built)"), std::string::npos) << first;
  EXPECT_NE(second.find("(hit)"), std::string::npos) << second;
  EXPECT_NE(second.find("compile 0.0 ms"), std::string::npos) << second;
  EXPECT_NE(second.find("engine: compiled"), std::string::npos) << second;
}

// --engine auto (the default) on a miss: the interpreter answers while the library compiles in
// the background; the command waits for that compile after its output, so the next run hits the
// cache; the numbers of both runs and of --engine interpreter are the same, to the last digit.
TEST_F(EvalCli, AutomaticEngineAnswersFromTheInterpreterThenTheCacheHits) {
  const fs::path fresh = cache.parent_path() / ("auto-cache-" + std::to_string(getpid()));
  const std::string eval = std::string(SPACEARM_CLI) + " eval " + SPACEARM_SOURCE_DIR +
                           "/models/space_arm7.yaml --json --cache-dir " + fresh.string();
  const std::string log_file = fresh.string() + ".log";
  const std::string first = run(eval + " --verbose 2>" + log_file);
  const std::string log = test::read_text_file(log_file);
  fs::remove(log_file);
  EXPECT_NE(log.find("(missed: the interpreter serves while the library compiles)"),
            std::string::npos)
      << log;
  EXPECT_NE(log.find("engine: the interpreter served"), std::string::npos) << log;
  const std::string second = run(eval + " --verbose 2>&1");
  EXPECT_NE(second.find("(hit)"), std::string::npos) << second;
  const std::string hit = run(eval + " 2>/dev/null"),
                    interpreted = run(eval + " --engine interpreter 2>/dev/null");
  EXPECT_EQ(hit, first);
  EXPECT_EQ(interpreted, first);
  EXPECT_NE(first.find("\"mass_matrix\""), std::string::npos) << first;
  fs::remove_all(fresh);
}

TEST_F(EvalCli, BadInputsGetClearErrors) {
  struct Case {
    std::string args, message;
  };
  const std::string ref = std::string(SPACEARM_SOURCE_DIR) + "/models/paper_reference.yaml";
  const std::string geared = std::string(SPACEARM_SOURCE_DIR) + "/models/paper_geared.yaml";
  for (const Case& c : std::vector<Case>{
           {ref + " --q 1,2,3", "--q: expected 6 comma-separated values, got 3"},
           {ref + " --q 1,2,3,4,5,nan", "--q[5]: 'nan' is not finite"},
           {ref + " --q 1,2,3,4,5,x", "--q[5]: 'x' is not a number"},
           {ref + " --q 1,2,3,4,5,6,",
            "--q[6]: empty item in '1,2,3,4,5,6,' (a stray or trailing comma?)"},
           {ref + " --q 1,2,3,4,5,1e999", "--q[5]: '1e999' is not finite"},
           {ref + " --q 1,2,3,4,5,0x10", "--q[5]: '0x10' is not a number"},
           {ref + " --q 1,2,3,4,5,1e-400",
            "--q[5]: '1e-400' is out of the range of double precision"},
           {ref + " --q 0,0,0,0,0,0 --qd 0,0,0,1e200,0,0", "): the state or parameters overflow"},
           {ref + " --q 0,0,0,0,0,1e100 --symbolic",
            "--q[5] (q3) = 1e+100 rad: angles must lie within +-1e6 rad"},
           {ref + " --q 0,0,-2e6,0,0,0", "--q[2] (q0) = -2e+06 rad: angles must lie within"},
           {geared + " --q 0,0,0,0,0,0 --param p=2 --param p=3",
            "--param: 'p' given more than once"},
           {geared + " --q 0,0,0,0,0,0 --param k=3",
            "--param: unknown parameter 'k' (known: p, Im)"},
           {geared + " --q 0,0,0,0,0,0 --param p=inf", "--param p: 'inf' is not finite"},
           {geared + " --q 0,0,0,0,0,0 --param p=-3",
            "parameters: gears[0].ratio must be positive (given p = -3)"},
           {geared + " --q 0,0,0,0,0,0 --param Im=1",
            "gears[0].motor_inertia must be smaller than the inertia"},
           {unknown_field_scene() + " --q 0", "field 'links[0].colour': unknown field"},
           {unknown_field_scene() + " --q 0 --qdd-joints 1",
            "field 'links[0].colour': unknown field"},
           {std::string(SPACEARM_SOURCE_DIR) + "/tests/scenes/fixed_n1.yaml --q 0 --qdd-joints 1",
            "--qdd-joints: the scene emits no output that takes qdd_joints"},
           {ref + " --q 0,0,0,0,0,0 --forces 1,2,3",
            "--forces: expected 6 comma-separated values, got 3"},
       }) {
    int status = 0;
    const std::string out = run(cli + c.args + " 2>&1", &status);
    EXPECT_EQ(WEXITSTATUS(status), 1) << c.args;
    EXPECT_NE(out.find(c.message), std::string::npos) << "args: " << c.args << "\noutput: " << out;
  }
}

// Issue 51: without --q, eval takes the home state (MuJoCo's qpos0: base at the origin, the
// identity quaternion, joints at 0) and says so.
TEST_F(EvalCli, WithoutQTheHomeStateIsTakenAndSaid) {
  const std::string arm = std::string(SPACEARM_SOURCE_DIR) + "/tests/scenes/spatial_arm2.yaml";
  int status = 0;
  const std::string out = run(cli + arm + " --json 2>&1", &status);
  ASSERT_EQ(WEXITSTATUS(status), 0) << out;
  EXPECT_NE(out.find("spacearm: --q not given: the home state (base at the origin, identity "
                     "quaternion, joints at 0)"),
            std::string::npos)
      << out;
  const nlohmann::json j = nlohmann::json::parse(json_in(out));
  EXPECT_EQ(j["q"], nlohmann::json({0, 0, 0, 1, 0, 0, 0, 0, 0}));
}

TEST_F(EvalCli, LostOutputAndAnEmptyCacheFolderAreErrors) {
  const std::string ref = std::string(SPACEARM_SOURCE_DIR) + "/models/paper_reference.yaml";
  int status = 0;
  std::string out = run(cli + ref + " --q 0,0,0,0,0,0 2>&1 > /dev/full", &status);
  EXPECT_EQ(WEXITSTATUS(status), 1);
  EXPECT_NE(out.find("writing standard output failed"), std::string::npos) << out;
  // Help lost to a full disk is a failure too (issue 28, item 7).
  for (const char* help : {" --help", " simulate --help", " sweep --help"}) {
    out = run(std::string(SPACEARM_CLI) + help + " 2>&1 > /dev/full", &status);
    EXPECT_EQ(WEXITSTATUS(status), 1) << help;
    EXPECT_NE(out.find("writing standard output failed"), std::string::npos) << help << out;
  }
  out = run(std::string(SPACEARM_CLI) + " eval " + ref + " --q 0,0,0,0,0,0 --cache-dir '' 2>&1",
            &status);
  EXPECT_EQ(WEXITSTATUS(status), 1);
  EXPECT_NE(out.find("--cache-dir: an empty value"), std::string::npos) << out;
}

// Issue 49: a model's C++ is measured before the compiler starts; past SPACEARM_MAX_CODE_MB it is
// refused naming its size, time and memory (a 19 MB arm sat at "compiling" for 15 minutes), and
// the cost is said before any compile.
TEST_F(EvalCli, ModelsPastTheCodeBoundAreRefusedBeforeCompiling) {
  const std::string scene = std::string(SPACEARM_SOURCE_DIR) + "/tests/scenes/free_n5.yaml";
  const fs::path fresh = cache.parent_path() / ("bound-cache-" + std::to_string(getpid()));
  const std::string base = std::string(SPACEARM_CLI) + " eval " + scene +
                           " --q 0,0,0,0,0,0,0,0 --cache-dir " + fresh.string(),
                    eval = base + " --engine compiled";
  int status = 0;
  std::string out = run("SPACEARM_MAX_CODE_MB=0.001 " + eval + " 2>&1", &status);
  EXPECT_EQ(WEXITSTATUS(status), 1) << out;
  // --engine auto: the interpreter serves the run, and says why nothing was compiled.
  std::string served = run("SPACEARM_MAX_CODE_MB=0.001 " + base + " 2>&1", &status);
  EXPECT_EQ(WEXITSTATUS(status), 0) << served;
  EXPECT_NE(served.find("the interpreter serves on: model 'free_n5'"), std::string::npos) << served;
  EXPECT_NE(served.find("\"mass_matrix\""), std::string::npos) << served;
  EXPECT_NE(out.find("MB of C++: at least"), std::string::npos) << out;
  EXPECT_NE(out.find("past the bound of 0.001 MB; raise it (SPACEARM_MAX_CODE_MB"),
            std::string::npos)
      << out;
  out = run("SPACEARM_MAX_CODE_MB=many " + base + " 2>&1", &status);  // auto, too
  EXPECT_EQ(WEXITSTATUS(status), 1) << out;
  out = run("SPACEARM_MAX_CODE_MB=many " + eval + " 2>&1", &status);
  EXPECT_EQ(WEXITSTATUS(status), 1) << out;
  EXPECT_NE(out.find("SPACEARM_MAX_CODE_MB: expected a positive number of MB, got 'many'"),
            std::string::npos)
      << out;
  out = run(eval + " 2>&1 >/dev/null", &status);
  EXPECT_EQ(status, 0) << out;
  EXPECT_NE(out.find("compiling with"), std::string::npos) << out;
  EXPECT_NE(out.find("MB of memory"), std::string::npos) << out;
  fs::remove_all(fresh);
}

}  // namespace
}  // namespace spacearm
