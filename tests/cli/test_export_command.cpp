// `spacearm export --mjcf` end to end (cli/export_command.hpp): the file it writes for the
// YAML arm of tests/scenes/spatial_arm2 loads in MuJoCo, and --compare finds it equal to
// spacearm's compiled model to rounding with armature gears, to the soft equality's tolerance
// with an exact rotor; run-time parameters take --param's values,
// checked by the scene's rules; a planar scene, identified bodies and an input as -o are refused
// by name. Cost: about 2 s (one compile).
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <regex>
#include <string>

#include "cli_fixtures.hpp"

namespace spacearm {
namespace {

namespace fs = std::filesystem;

std::string cli() { return std::string(SPACEARM_CLI) + " export --mjcf "; }
std::string source(const std::string& path) {
  return std::string(SPACEARM_SOURCE_DIR) + "/" + path;
}

// The numbers after each of `labels` in a --compare report.
double after(const std::string& report, const std::string& label) {
  std::smatch m;
  if (!std::regex_search(report, m, std::regex(label + " within ([0-9.e+-]+)")))
    ADD_FAILURE() << "no '" << label << "' in: " << report;
  return m.empty() ? 1.0 : std::stod(m[1]);
}

TEST(ExportCommand, WritesAModelThatMujocoAgreesWith) {
  const fs::path dir = test::fresh_cache("export");
  fs::create_directories(dir);
  const std::string xml = (dir / "arm2.xml").string(), cache = " --cache-dir " + dir.string();
  // The arm with both gears armature: MuJoCo's model is spacearm's to rounding.
  const std::string armature = (dir / "arm2_armature.yaml").string();
  {
    std::string text = test::read_text_file(source("tests/scenes/spatial_arm2.yaml"));
    text.replace(text.find("rotor_coupling: exact"), 21, "rotor_coupling: armature");
    std::ofstream(armature) << text;
  }
  int status = 0;
  std::string out =
      test::run(cli() + armature + " -o " + xml + " --compare" + cache + " 2>&1", &status);
  ASSERT_EQ(status, 0) << out;
  EXPECT_NE(out.find("spacearm: wrote " + xml + " (MuJoCo model of scene 'spatial_arm2')"),
            std::string::npos)
      << out;
  EXPECT_LT(after(out, "M"), 1e-12) << out;
  EXPECT_LT(after(out, "the bias"), 1e-12) << out;
  EXPECT_LT(after(out, "forward dynamics"), 1e-12) << out;
  // As it is, one rotor exact: to the soft equality's tolerance.
  out = test::run(cli() + source("tests/scenes/spatial_arm2.yaml") + " -o " + xml + " --compare" +
                      cache + " 2>&1",
                  &status);
  ASSERT_EQ(status, 0) << out;
  EXPECT_LT(after(out, "forward dynamics"), 2e-4) << out;
  EXPECT_NE(out.find("exact rotors: MuJoCo holds them by soft joint equalities"),
            std::string::npos);
  const std::string text = test::read_text_file(xml);
  EXPECT_NE(text.find("<freejoint name=\"base\"/>"), std::string::npos);
  EXPECT_NE(text.find("armature=\""), std::string::npos);
  // Refusals name what is wrong.
  const std::vector<std::pair<std::string, std::string>> refused = {
      {source("models/paper_geared.yaml") + " -o " + xml + " --compare",
       "--compare: compares a spatial scene's model; a planar scene's MuJoCo model moves in 3D"},
      {source("models/paper_flexible.yaml") + " -o " + xml,
       "joint 'joint1' is flexible (gears: stiffness)"},
      {source("models/identified_arm3.yaml") + " -o " + xml,
       "MuJoCo takes only physical inertias (each principal moment at most the sum of the other "
       "two), and these bodies' are not: 'Link_1', 'Link_2', 'Link_3'"},
      {source("tests/scenes/spatial_arm2.yaml") + " -o " + source("tests/scenes/spatial_arm2.yaml"),
       "-o '" + source("tests/scenes/spatial_arm2.yaml") + "' is the scene file"},
      {source("tests/scenes/spatial_arm2.yaml"), "--output is required"},
  };
  for (const auto& [args, message] : refused) {
    const std::string r = test::run(cli() + args + " 2>&1", &status);
    EXPECT_NE(status, 0) << args;
    EXPECT_NE(r.find(message), std::string::npos) << r;
  }
  EXPECT_NE(test::read_text_file(source("tests/scenes/spatial_arm2.yaml")).find("space: spatial"),
            std::string::npos);
  // A planar scene exports as the arm moving in its plane (MjcfExport tests its numbers).
  const std::string planar =
      test::run(cli() + source("models/paper_geared.yaml") + " -o " + xml + " 2>&1", &status);
  EXPECT_EQ(status, 0) << planar;
  EXPECT_NE(test::read_text_file(xml).find("<mujoco model=\"paper_geared\">"), std::string::npos);
  fs::remove_all(dir);
}

TEST(ExportCommand, ParametersTakeTheirValuesAndRules) {
  const fs::path dir = test::fresh_cache("export-params");
  fs::create_directories(dir);
  const std::string xml = (dir / "p.xml").string();
  const std::string scene = (dir / "p.yaml").string();
  std::ofstream(scene) << R"(name: p
space: spatial
base: {type: free_floating, mass: mb, inertia: [10, 0, 0, 12, 0, 14]}
links: [{origin: [0.5, 0, 0], axis: [0, 0, 1], mass: 5, inertia: [0.2, 0, 0, 0.2, 0, 0.3]}]
parameters: {mb: 100}
)";
  int status = 0;
  std::string out = test::run(cli() + scene + " -o " + xml + " --param mb=250 2>&1", &status);
  ASSERT_EQ(status, 0) << out;
  EXPECT_NE(test::read_text_file(xml).find("mass=\"250\""), std::string::npos);
  out = test::run(cli() + scene + " -o " + xml + " --param mb=-1 2>&1", &status);
  EXPECT_NE(status, 0);
  EXPECT_NE(out.find("--param: base.mass must be positive"), std::string::npos) << out;
  fs::remove_all(dir);
}

}  // namespace
}  // namespace spacearm
