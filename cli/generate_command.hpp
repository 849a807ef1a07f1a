// `spacearm generate` and `spacearm inspect`: the generator's own subcommands.
#pragma once

#include <string>

namespace spacearm {

struct GenerateArgs {
  std::string scene_path, out_dir, file_stem;
  bool stats = false, check = false, plain = false, casadi = false;
};
// Writes (or, check, compares) the files; returns the exit status. Throws on errors.
int run_generate(const GenerateArgs& args);

struct InspectArgs {
  std::string scene_path, entry;
  bool latex = false, decimal = false;
};
// Prints one symbolic entry; returns the exit status. Throws on errors.
int run_inspect(const InspectArgs& args);

}  // namespace spacearm
