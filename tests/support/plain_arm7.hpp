// Tests' models/space_arm7 without its gears, compiled through the cache into a temporary
// folder (about 6 s the first time in a process), as a DynamicModel, and a task on it.
#pragma once

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "compiled_model.hpp"
#include "trajectory_planning.hpp"

namespace spacearm {

// models/space_arm7 compiled through the cache into a temporary folder: without its gears, or
// (geared) as shipped, its harmonic drives (p = 100) with exact rotors.
inline CompiledModel compiled_arm7(bool geared) {
  const std::string dir = std::string(SPACEARM_SOURCE_DIR) + "/models/";
  std::ifstream in(dir + "space_arm7.yaml");
  std::stringstream text;
  text << in.rdbuf();
  std::string scene = text.str();
  if (!geared) scene.erase(scene.find("gears:"));  // the last line
  CompileOptions options;
  options.cache_dir =
      (std::filesystem::temp_directory_path() / ("spacearm-test-plan-" + std::to_string(getpid())))
          .string();
  CompiledModel m = CompiledModel::load(
      ModelRecipe::parse(scene, dir + (geared ? "space_arm7.yaml" : "space_arm7_plain.yaml")),
      options);
  std::filesystem::remove_all(options.cache_dir);
  return m;
}

inline DynamicModel spatial_arm7() {
  static const CompiledModel m = compiled_arm7(false);
  return dynamic_model(m, Eigen::VectorXd(0));
}

inline DynamicModel geared_arm7() {
  static const CompiledModel m = compiled_arm7(true);
  return dynamic_model(m, Eigen::VectorXd(0));
}

// A task both planners' tests take: the tool 0.17 m from a bent start in 4 s, a position (the
// joints' link-side angles: a geared arm's motor angles are p times them).
inline StraightLineTask arm7_task(const DynamicModel& m) {
  StraightLineTask task;
  Eigen::VectorXd angles(7);
  angles << 0.3, 0.5, -0.2, -1.6, 0.4, 0.9, 0.1;
  task.q0 = m.from_joint_angles(m.neutral_configuration().head(7), angles);
  task.start = m.end_effector_pose(task.q0).head<3>();
  task.goal = task.start + Eigen::Vector3d(-0.1, 0.1, 0.1);
  task.duration = 4;
  return task;
}

}  // namespace spacearm
