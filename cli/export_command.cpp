#include "export_command.hpp"

#include <cstdio>
#include <optional>
#include <stdexcept>

#include "cli_input.hpp"
#include "mjcf_export.hpp"
#include "mujoco_compare.hpp"
#include "row_writer.hpp"
#include "spatial_scene.hpp"

namespace spacearm {

int run_export(const ExportArgs& a) {
  if (!a.mjcf) throw std::invalid_argument("export: say which format: --mjcf (MuJoCo's)");
  if (a.compare && !cli::mujoco_built())
    throw std::invalid_argument(
        "--compare: this spacearm was built without MuJoCo (libmujoco-dev; scripts/setup.sh "
        "installs it)");
  if (a.output_file.empty() || a.output_file == "-")
    throw std::invalid_argument("-o: give a file name for the MuJoCo model");
  const std::string text = read_scene_file(a.scene_path);
  // A planar scene: the spatial arm that moves in its plane, at the parameters' values.
  const bool planar = !is_spatial_scene(text);
  if (planar && a.compare)
    throw std::invalid_argument(
        "--compare: compares a spatial scene's model; a planar scene's MuJoCo model moves in "
        "3D (free joint), so its M has the plane's rows among others (MjcfExport tests them)");
  // Each read once: a spatial scene reads its URDF.
  const std::optional<Scene> planar_scene =
      planar ? std::optional<Scene>(parse_scene(text, a.scene_path)) : std::nullopt;
  const std::optional<SpatialScene> spatial_scene =
      planar ? std::nullopt : std::optional<SpatialScene>(parse_spatial_scene(text, a.scene_path));
  const ModelRecipe recipe = planar ? ModelRecipe(*planar_scene) : ModelRecipe(*spatial_scene);
  cli::say_warnings(recipe.warnings());
  const Eigen::VectorXd params = cli::parse_parameters(a.param_assignments, recipe.facts());
  MjcfOptions options;
  options.params.assign(params.data(), params.data() + params.size());
  if (const std::string why = recipe.parameter_error(options.params); !why.empty())
    throw std::invalid_argument("--param: " + why);
  options.balance_inertia = a.balance_inertia;
  const SpatialScene scene =
      planar ? planar_as_spatial(*planar_scene, options.params) : *spatial_scene;
  if (planar) options.params.clear();  // the numbers are written in
  const std::string xml = export_mjcf(scene, options);
  refuse_input_as_output(a.output_file, cli::scene_inputs(a.scene_path, recipe));
  replace_output_file(a.output_file, xml);
  std::fprintf(stderr, "spacearm: wrote %s (MuJoCo model of scene '%s')\n", a.output_file.c_str(),
               scene.name.c_str());
  if (a.compare)
    std::printf("%s\n", cli::compare_in_mujoco(recipe, mjcf_names(scene, options), params,
                                               a.output_file, a.cache_dir)
                            .c_str());
  return 0;
}

}  // namespace spacearm
