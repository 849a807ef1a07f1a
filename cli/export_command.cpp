#include "export_command.hpp"

#include <cstdio>
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
  if (!is_spatial_scene(text))
    throw std::invalid_argument("export --mjcf: " + quoted_text(a.scene_path) +
                                " is a planar scene; MuJoCo models are exported from spatial "
                                "scenes (space: spatial)");
  const SpatialScene scene = parse_spatial_scene(text, a.scene_path);
  cli::say_warnings(scene.warnings);
  const ModelRecipe recipe(scene);
  const Eigen::VectorXd params = cli::parse_parameters(a.param_assignments, recipe.facts());
  MjcfOptions options;
  options.params.assign(params.data(), params.data() + params.size());
  if (const std::string why = recipe.parameter_error(options.params); !why.empty())
    throw std::invalid_argument("--param: " + why);
  options.balance_inertia = a.balance_inertia;
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
