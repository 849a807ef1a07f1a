// The model recipe (generator/model_recipe.hpp): a scene of either kind as its facts, its code
// and the few scene facts the tools read (gear ratios, the base's inertial), without a caller
// asking which kind it is; its GiNaC work is safe from several threads.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "model_recipe.hpp"

namespace {

using spacearm::ModelRecipe;
using spacearm::Output;
namespace fs = std::filesystem;

std::string source(const char* path) { return std::string(SPACEARM_SOURCE_DIR) + "/" + path; }

// GiNaC's reference counts are plain integers: a planar emit derives and lowers in GiNaC, so
// emits from several threads (Python's load without the GIL, a sweep) must not interleave.
TEST(ModelRecipe, EmitsThePlanarCodeFromSeveralThreadsAtOnce) {
  const ModelRecipe recipe = ModelRecipe::load(source("models/paper_geared.yaml"));
  const spacearm::EmittedModel serial = recipe.emit({});
  std::vector<std::string> sources(4);
  std::vector<std::thread> threads;
  for (auto& s : sources) threads.emplace_back([&recipe, &s] { s = recipe.emit({}).source; });
  for (auto& t : threads) t.join();
  for (const auto& s : sources) EXPECT_EQ(s, serial.source);
}

TEST(ModelRecipe, GearRatiosAreLiteralsOrTheParametersThatGiveThem) {
  const ModelRecipe planar = ModelRecipe::load(source("tests/scenes/fixed_n5_geared_params.yaml"));
  const auto p = planar.gear_ratios();
  ASSERT_EQ(p.size(), 5u);
  const auto& names = planar.facts().parameter_names;
  for (const auto& r : p) {
    ASSERT_TRUE(r.is_parameter());
    ASSERT_GE(r.index, 0);
    EXPECT_EQ(names.at(r.index), "p");
    EXPECT_EQ(r.value, 20);  // the nominal value
  }
  const ModelRecipe spatial = ModelRecipe::load(source("tests/scenes/spatial_arm2.yaml"));
  const auto s = spatial.gear_ratios();
  ASSERT_EQ(s.size(), 2u);
  EXPECT_FALSE(s[0].is_parameter());
  EXPECT_EQ(s[0].value, 50);
  EXPECT_EQ(s[1].value, 20);
  const ModelRecipe reference = ModelRecipe::load(source("models/paper_reference.yaml"));
  ASSERT_FALSE(reference.gear_ratios().empty());
  for (const auto& r : reference.gear_ratios()) {  // no gears
    EXPECT_FALSE(r.is_parameter());
    EXPECT_EQ(r.value, 1);
  }
}

// A fresh folder of this process holding a copy of the project's URDF `urdf`, for scenes that
// name it beside them.
fs::path folder_with_urdf(const std::string& name, const std::string& urdf) {
  const fs::path dir =
      fs::temp_directory_path() / ("sa_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  fs::copy_file(source(urdf.c_str()), dir / fs::path(urdf).filename());
  return dir;
}

// Issue 51: a broken run-time rule names the field, the URDF's joint (or every joint, where one
// mapping gives them all) and the values given.
TEST(ModelRecipe, ParameterErrorsNameTheJointAndTheValue) {
  const fs::path dir = folder_with_urdf("joint_names", "models/identified_arm3.urdf");
  const std::string head =
      "name: named\nspace: spatial\nurdf: identified_arm3.urdf\nbase: {type: "
      "free_floating}\ninertia_check: positive_definite\n";
  std::ofstream(dir / "list.yaml") << head
                                   << "gears: [{ratio: 10}, {ratio: p2}, {ratio: 10}]\n"
                                      "parameters: {p2: 50}\n";
  std::ofstream(dir / "mapping.yaml") << head << "gears: {ratio: p}\nparameters: {p: 50}\n";
  const ModelRecipe list = ModelRecipe::load((dir / "list.yaml").string());
  EXPECT_EQ(list.parameter_error({50}), "");
  EXPECT_EQ(list.parameter_error({-3}),
            "gears[1].ratio (joint 'Joint_2') must be positive (given p2 = -3)");
  const ModelRecipe mapping = ModelRecipe::load((dir / "mapping.yaml").string());
  EXPECT_EQ(mapping.parameter_error({-3}),
            "gears.ratio (every joint) must be positive (given p = -3)");
  fs::remove_all(dir);
}

// Issue 51: snap_right_angles. ETS-VII's published URDF rounds its right angles (1.5708,
// 3.1416), which leaves residue terms in the closed forms; snapped, the entry is the clean one,
// and every right angle turns a frame by exact cosines and sines (the model then differs from the
// rounded one by about the 7e-6 rad moved, no more).
TEST(ModelRecipe, SnappedRightAnglesLeaveNoResidueInTheClosedForms) {
  const fs::path dir = folder_with_urdf("snap", "models/published/ETSVII.urdf");
  const std::string head =
      "name: ets\nspace: spatial\nurdf: ETSVII.urdf\nbase: {type: free_floating}\n"
      "inertia_check: positive_definite\n";
  std::ofstream(dir / "rounded.yaml") << head;
  std::ofstream(dir / "snapped.yaml") << head << "snap_right_angles: true\n";
  const ModelRecipe rounded = ModelRecipe::load((dir / "rounded.yaml").string());
  const ModelRecipe snapped = ModelRecipe::load((dir / "snapped.yaml").string());
  EXPECT_EQ(rounded.inspect_entry("M[9][11]"),
            "3.508033289833957E-12-(0.2599999999964919)*sin(q5)\n");
  EXPECT_EQ(snapped.inspect_entry("M[9][11]"), "-(0.26)*sin(q5)\n");
  EXPECT_EQ(snapped.inspect_entry("M[10][11]"), "0\n");
  EXPECT_NE(rounded.inspect_entry("M[10][11]"), "0\n");
  ASSERT_EQ(snapped.warnings().size(), 2u);
  EXPECT_EQ(snapped.warnings()[0],
            "scene '" + (dir / "snapped.yaml").string() +
                "': snap_right_angles: 7 of the URDF's angles moved to a multiple of pi/2 (at most "
                "7.34641e-06 rad)");
  EXPECT_NE(snapped.emit({}).header.find("inline constexpr bool kRightAnglesSnapped = true;"),
            std::string::npos);
  EXPECT_EQ(rounded.emit({}).header.find("kRightAnglesSnapped"), std::string::npos);
  // The two models at one state: as close as the angles moved.
  std::vector<double> q(13, 0.3);
  q[3] = 1, q[4] = q[5] = q[6] = 0;
  const auto a = rounded.body_poses(q, {}), b = snapped.body_poses(q, {});
  ASSERT_EQ(a.size(), b.size());
  double gap = 0;
  for (size_t k = 0; k < a.size(); ++k)
    for (int i = 0; i < 7; ++i)
      gap = std::max(gap, std::abs(std::abs(a[k][i]) - std::abs(b[k][i])));
  EXPECT_GT(gap, 1e-9);
  EXPECT_LT(gap, 3e-5);
  // Off, true or false; anything else is refused by name.
  std::ofstream(dir / "bad.yaml") << head << "snap_right_angles: yes please\n";
  try {
    ModelRecipe::load((dir / "bad.yaml").string());
    ADD_FAILURE() << "accepted";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find(
                  "field 'snap_right_angles': expected true or false, got 'yes please'"),
              std::string::npos)
        << e.what();
  }
  fs::remove_all(dir);
}

TEST(ModelRecipe, TheBaseInertialIsTheScenes) {
  const auto planar = ModelRecipe::load(source("models/paper_geared.yaml")).base_inertial();
  EXPECT_EQ(planar.mass, 64.859);
  EXPECT_EQ(planar.inertia[5], 2.695);  // izz; the plane has no other entry
  EXPECT_EQ(planar.inertia[0], 0);
  const auto spatial = ModelRecipe::load(source("tests/scenes/spatial_arm2.yaml")).base_inertial();
  EXPECT_GT(spatial.mass, 0);
  EXPECT_GT(spatial.inertia[0] * spatial.inertia[3] * spatial.inertia[5], 0);
}

TEST(ModelRecipe, WithOutputsEmitsMoreUnderAnotherContent) {
  for (const char* path : {"models/paper_geared.yaml", "tests/scenes/spatial_arm2.yaml"}) {
    SCOPED_TRACE(path);
    const ModelRecipe recipe = ModelRecipe::load(source(path));
    const auto& before = recipe.facts().outputs;
    ASSERT_EQ(std::count(before.begin(), before.end(), Output::forward_dynamics_derivatives), 0);
    const ModelRecipe more =
        recipe.with_outputs({Output::forward_dynamics_derivatives, before[0]}, "\n# more");
    const auto& after = more.facts().outputs;
    EXPECT_EQ(after.size(), before.size() + 1);  // the one it had is kept once
    EXPECT_EQ(std::count(after.begin(), after.end(), Output::forward_dynamics_derivatives), 1);
    EXPECT_NE(more.facts().scene_hash, recipe.facts().scene_hash);
    EXPECT_EQ(more.content(), recipe.content() + "\n# more");
  }
}

}  // namespace
