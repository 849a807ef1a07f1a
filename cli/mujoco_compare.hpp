// `spacearm export --mjcf --compare`: the exported model loaded in MuJoCo and compared with
// spacearm's compiled model at random states, in one command (cli/mujoco_compare.cpp; built where
// MuJoCo is found, else it says so).
#pragma once

#include <Eigen/Core>

#include <string>

#include "model_recipe.hpp"
#include "mjcf_export.hpp"

namespace spacearm::cli {

// Whether this spacearm was built with MuJoCo (libmujoco-dev).
bool mujoco_built();

// Loads `mjcf_path` in MuJoCo and compares it with the scene's model at `states` random states
// (seeded): M and the bias where MuJoCo has no extra bodies (exact rotors), and the forward
// dynamics under random joint torques, MuJoCo's passive forces applied to both. Returns the
// report; throws std::invalid_argument if MuJoCo refuses the file.
std::string compare_in_mujoco(const ModelRecipe& recipe, const MjcfNames& names,
                              const Eigen::VectorXd& params, const std::string& mjcf_path,
                              const std::string& cache_dir, int states = 20);

}  // namespace spacearm::cli
