#include "generate_command.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>

#include "cli_input.hpp"
#include "cpp_emitter.hpp"
#include "planar_scene.hpp"
#include "model_recipe.hpp"

namespace spacearm {

namespace {

void print_stats(const EmittedModel& emitted, std::ostream& out) {
  out << "function                     basis   adds   muls   divs  total  sin/cos  tanh/exp  "
         "formulation\n";
  for (const auto& f : emitted.stats) {
    char line[200];
    std::snprintf(line, sizeof line, "%-28s %-6s %5d  %5d  %5d  %5d  %7d  %8d  %s\n",
                  f.name.c_str(), f.variant.empty() ? "-" : f.variant.c_str(), f.ops.adds,
                  f.ops.muls, f.ops.divs, f.ops.total_arithmetic(), f.ops.trig, f.ops.functions,
                  f.formulation.c_str());
    out << line;
  }
}

// What a generation produced, whichever kind of scene.
struct Generated {
  EmittedModel emitted;
  int coordinates = 0, parameters = 0;
  double derive_ms = 0, emit_ms = 0;
};

double ms_since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t).count();
}

Generated generate(const std::string& text, const std::string& path, const EmitOptions& options) {
  Generated g;
  const auto t = std::chrono::steady_clock::now();
  const ModelRecipe recipe = ModelRecipe::parse(text, path);
  cli::say_warnings(recipe.warnings());
  g.emitted = recipe.emit(options, &g.derive_ms);
  g.emit_ms = ms_since(t) - g.derive_ms;
  g.coordinates = recipe.facts().dims.nq;
  g.parameters = static_cast<int>(recipe.facts().parameter_names.size());
  return g;
}

}  // namespace

int run_generate(const GenerateArgs& a) {
  const std::string text = read_scene_file(a.scene_path);
  EmitOptions options;
  options.scene_path = a.scene_path;
  options.command = "spacearm generate " + a.scene_path + " -o " + a.out_dir +
                    (a.file_stem.empty() ? "" : " --file-stem " + a.file_stem) +
                    (a.plain ? " --plain" : "") + (a.casadi ? " --casadi" : "");
  options.file_stem = a.file_stem;
  options.plain = a.plain;
  options.casadi = a.casadi;
  const Generated generated = generate(text, a.scene_path, options);
  const EmittedModel& emitted = generated.emitted;
  const std::string header = a.out_dir + "/" + emitted.header_name,
                    source = a.out_dir + "/" + emitted.source_name;
  if (a.check) {
    const auto stale = stale_files(emitted, a.out_dir);
    for (const auto& f : stale) std::cerr << "spacearm: stale generated file: " << f << "\n";
    if (!stale.empty()) {
      std::cerr << "spacearm: regenerate with: " << options.command << "\n";
      return 1;
    }
    std::cout << "up to date: " << header << ", " << source << "\n";
    return 0;
  }
  const auto t = std::chrono::steady_clock::now();
  write_files(emitted, a.out_dir);
  const double write_ms = ms_since(t);
  std::cout << "wrote " << header << " and " << source << " (" << generated.coordinates
            << " coordinates, " << generated.parameters << " parameters)\n";
  if (!emitted.c_file_name.empty())
    std::cout << "wrote " << a.out_dir << "/" << emitted.c_file_name
              << " (the C interface with CasADi's external functions spacearm_casadi_<output>: "
                 "g++ -O2 -shared -fPIC "
              << a.out_dir << "/" << emitted.c_file_name << " -o lib"
              << emitted.c_file_name.substr(0, emitted.c_file_name.size() - 6) << ".so)\n";
  if (a.stats) {
    print_stats(emitted, std::cout);
    std::cout << "derive " << std::lround(generated.derive_ms) << " ms, emit "
              << std::lround(generated.emit_ms + write_ms) << " ms\n";
  }
  return 0;
}

int run_inspect(const InspectArgs& a) {
  std::cout << cli::load_scene(a.scene_path).inspect_entry(a.entry, a.latex, a.decimal);
  return 0;
}

}  // namespace spacearm
