// Command-line input shared by the subcommands: number lists and run-time parameters,
// parsed strictly (runtime/text_numbers.hpp), errors naming the option.
#pragma once

#include <Eigen/Core>

#include <algorithm>
#include <cstdio>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "model_recipe.hpp"
#include "planar_scene.hpp"
#include "text_numbers.hpp"

namespace spacearm::cli {

// The files a command read a scene from, as (what, path) pairs for refuse_input_as_output: the
// scene and what it names (a spatial scene's URDF).
inline std::vector<std::pair<std::string, std::string>> scene_inputs(const std::string& scene_path,
                                                                     const ModelRecipe& recipe) {
  std::vector<std::pair<std::string, std::string>> inputs = {{"the scene", scene_path}};
  for (const std::string& path : recipe.read_files()) inputs.push_back({"the scene's URDF", path});
  return inputs;
}

// Says a scene's warnings once, on stderr (the command's output stays clean).
inline void say_warnings(const std::vector<std::string>& warnings) {
  for (const std::string& w : warnings) std::fprintf(stderr, "spacearm: warning: %s\n", w.c_str());
}

// A scene file as a recipe (SceneError naming the file), its warnings said.
inline ModelRecipe load_scene(const std::string& path) {
  ModelRecipe recipe = ModelRecipe::load(path);
  say_warnings(recipe.warnings());
  return recipe;
}

// Parses "a,b,c" for option `name` into exactly n finite numbers (strictly: no empty
// items, nothing out of the range of double).
inline Eigen::VectorXd parse_vector(const std::string& text, const std::string& name, int n) {
  std::vector<double> values = parse_number_list(text, name, n);
  return Eigen::Map<Eigen::VectorXd>(values.data(), n);
}

// --param name=value pairs over the scene's nominal parameter values; each name once.
inline Eigen::VectorXd parse_parameters(const std::vector<std::string>& assignments,
                                        const ModelFacts& facts) {
  const std::vector<std::string>& names = facts.parameter_names;
  Eigen::VectorXd p = Eigen::Map<const Eigen::VectorXd>(
      facts.nominal_parameters.data(), static_cast<Eigen::Index>(facts.nominal_parameters.size()));
  std::set<std::string> given;
  for (const auto& a : assignments) {
    const auto eq = a.find('=');
    if (eq == std::string::npos)
      throw std::invalid_argument("--param " + quoted_text(a) + ": expected name=value");
    const std::string name = a.substr(0, eq);
    const auto it = std::find(names.begin(), names.end(), name);
    if (it == names.end()) {
      std::string known;
      for (const auto& n : names) known += (known.empty() ? "" : ", ") + n;
      throw std::invalid_argument("--param: unknown parameter " + quoted_text(name) +
                                  " (known: " + (known.empty() ? "none" : known) + ")");
    }
    if (!given.insert(name).second)
      throw std::invalid_argument("--param: '" + name + "' given more than once");
    p[it - names.begin()] = parse_number(a.substr(eq + 1), "--param " + name);
  }
  return p;
}
inline Eigen::VectorXd parse_parameters(const std::vector<std::string>& assignments,
                                        const Scene& scene) {
  return parse_parameters(assignments, ModelRecipe(scene).facts());
}

}  // namespace spacearm::cli
