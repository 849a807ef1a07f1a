// spacearm: command-line front end of the generator.
//   spacearm generate SCENE -o DIR [--stats]   emit optimized C++ for a scene
//   spacearm inspect SCENE ENTRY [--latex]     print one symbolic entry, e.g. M[3][4]
#include <CLI/CLI.hpp>

#include <chrono>
#include <cstdio>
#include <iostream>

#include "cpp_emitter.hpp"
#include "scene.hpp"
#include "symbolic_model.hpp"

namespace {

void print_stats(const spacearm::EmittedModel& emitted, std::ostream& out) {
  out << "function                 basis   adds   muls   divs  total  sin/cos\n";
  for (const auto& f : emitted.stats) {
    char line[160];
    std::snprintf(line, sizeof line, "%-24s %-6s %5d  %5d  %5d  %5d  %7d\n", f.name.c_str(),
                  f.velocity_basis.empty() ? "-" : f.velocity_basis.c_str(), f.ops.adds, f.ops.muls, f.ops.divs,
                  f.ops.total_arithmetic(), f.ops.trig);
    out << line;
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"spacearm: symbolic dynamics of free-floating space manipulators, emitted as C++"};
  app.require_subcommand(1);

  std::string scene_path, out_dir, entry;
  bool stats = false, latex = false, expanded = false;

  auto* generate = app.add_subcommand("generate", "Derive the model of a scene and emit C++ sources");
  generate->add_option("scene", scene_path, "Scene file (YAML)")->required();
  generate->add_option("-o,--output", out_dir, "Output folder")->required();
  generate->add_flag("--stats", stats, "Print adds, multiplies, divisions and sin/cos calls per function");
  bool check = false;
  generate->add_flag("--check", check,
                     "Write nothing; exit 1 if the files in the output folder differ from what would be generated");

  auto* inspect = app.add_subcommand("inspect", "Print one symbolic entry of the derived model");
  inspect->add_option("scene", scene_path, "Scene file (YAML)")->required();
  inspect->add_option("entry", entry, "T, M[i][j], C[i][j], b[i], h[i] (momentum), x[i] (pose), J[i][j]")
      ->required();
  inspect->add_flag("--latex", latex, "Print LaTeX instead of plain text");
  inspect->add_flag("--decimal", expanded, "Show numeric coefficients as decimals instead of exact fractions");

  CLI11_PARSE(app, argc, argv);

  try {
    using clock = std::chrono::steady_clock;
    const auto t0 = clock::now();
    const spacearm::Scene scene = spacearm::load_scene(scene_path);
    if (*generate) {
      const spacearm::SymbolicModel model = spacearm::derive(scene);
      const auto t1 = clock::now();
      spacearm::EmitOptions options;
      options.scene_path = scene_path;
      options.command = "spacearm generate " + scene_path + " -o " + out_dir;
      const auto emitted = spacearm::emit_cpp(model, options);
      if (check) {
        const auto stale = spacearm::stale_files(emitted, out_dir);
        for (const auto& f : stale) std::cerr << "spacearm: stale generated file: " << f << "\n";
        if (!stale.empty()) {
          std::cerr << "spacearm: regenerate with: " << options.command << "\n";
          return 1;
        }
        std::cout << "up to date: " << out_dir << "/" << emitted.header_name << ", " << out_dir << "/"
                  << emitted.source_name << "\n";
        return 0;
      }
      spacearm::write_files(emitted, out_dir);
      const auto t2 = clock::now();
      auto ms = [](auto a, auto b) { return std::chrono::duration<double, std::milli>(b - a).count(); };
      std::cout << "wrote " << out_dir << "/" << emitted.header_name << " and " << out_dir << "/"
                << emitted.source_name << " (" << scene.num_coordinates() << " coordinates, "
                << scene.parameters.size() << " parameters)\n";
      if (stats) {
        print_stats(emitted, std::cout);
        std::printf("derive %.0f ms, emit %.0f ms\n", ms(t0, t1), ms(t1, t2));
      }
      return 0;
    }
    spacearm::DeriveOptions options;
    options.all_outputs = true;
    const spacearm::SymbolicModel model = spacearm::derive(scene, options);
    GiNaC::ex e = spacearm::symbolic_entry(model, entry);
    // Group by velocities and run-time parameters, so that p, p^2 and p_i p_j stand out.
    GiNaC::lst group_by;
    for (const auto& v : model.qd) group_by.append(v);
    for (const auto& p : model.parameters) group_by.append(p);
    if (expanded) e = GiNaC::evalf(e);
    e = GiNaC::collect(e, group_by, true);
    if (latex)
      std::cout << GiNaC::latex << e << GiNaC::dflt << "\n";
    else
      std::cout << e << "\n";
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "spacearm: error: " << e.what() << "\n";
    return 1;
  }
}
