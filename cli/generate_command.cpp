#include "generate_command.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>

#include "cpp_emitter.hpp"
#include "scene.hpp"
#include "symbolic_model.hpp"

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

}  // namespace

int run_generate(const GenerateArgs& a) {
  using clock = std::chrono::steady_clock;
  const auto t0 = clock::now();
  const Scene scene = load_scene(a.scene_path);
  const SymbolicModel model = derive(scene);
  const auto t1 = clock::now();
  EmitOptions options;
  options.scene_path = a.scene_path;
  options.command = "spacearm generate " + a.scene_path + " -o " + a.out_dir +
                    (a.file_stem.empty() ? "" : " --file-stem " + a.file_stem) +
                    (a.plain ? " --plain" : "");
  options.file_stem = a.file_stem;
  options.plain = a.plain;
  const auto emitted = emit_cpp(model, options);
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
  write_files(emitted, a.out_dir);
  const auto t2 = clock::now();
  auto ms = [](auto from, auto to) {
    return std::chrono::duration<double, std::milli>(to - from).count();
  };
  std::cout << "wrote " << header << " and " << source << " (" << scene.num_coordinates()
            << " coordinates, " << scene.parameters.size() << " parameters)\n";
  if (a.stats) {
    print_stats(emitted, std::cout);
    std::cout << "derive " << std::lround(ms(t0, t1)) << " ms, emit " << std::lround(ms(t1, t2))
              << " ms\n";
  }
  return 0;
}

int run_inspect(const InspectArgs& a) {
  DeriveOptions options;
  options.all_outputs = true;
  const SymbolicModel model = derive(load_scene(a.scene_path), options);
  std::cout << entry_text(model, a.entry, a.latex, a.decimal) << "\n";
  return 0;
}

}  // namespace spacearm
