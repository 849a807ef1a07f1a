// `spacearm export --mjcf SCENE -o MODEL.xml`: a spatial scene as a MuJoCo model
// (export/mjcf_export.hpp), at the nominal or given run-time parameter values.
#pragma once

#include <string>
#include <vector>

namespace spacearm {

struct ExportArgs {
  std::string scene_path, output_file;
  bool mjcf = false, balance_inertia = false, compare = false;
  std::string cache_dir;  // for --compare's compiled model
  std::vector<std::string> param_assignments;
};
// Writes the model (and with compare loads it in MuJoCo and compares it with spacearm's at
// random states); returns the exit status. Throws on errors, naming the option or the field.
int run_export(const ExportArgs& args);

}  // namespace spacearm
