#include "view_command.hpp"

#include <unistd.h>

#include <cstdio>

#include "cpp_printer.hpp"
#include "row_writer.hpp"
#include "run_table.hpp"
#include "view_page.hpp"

namespace spacearm {

namespace cli {

bool is_study_results(const std::string& path) {
  std::string head;
  const Fd fd = open_table(path, "view");
  char buf[64];
  const ssize_t n = ::read(fd.get(), buf, sizeof buf);
  if (n > 0) head.assign(buf, static_cast<size_t>(n));
  if (head.compare(0, 3, "\xEF\xBB\xBF") == 0) head.erase(0, 3);
  return head.compare(0, 11, "run,status,") == 0;
}

}  // namespace cli

int run_view(const ViewArgs& a) {
  if (!cli::viewer_built())
    throw std::invalid_argument(
        "view: this spacearm was built without the viewer (SPACEARM_BUILD_VIEWER=OFF: it needs "
        "Node.js and npm at build time)");
  if (a.output_file.empty() || a.output_file == "-")
    throw std::invalid_argument("-o: give a file name for the page (it is one HTML file)");
  std::vector<std::pair<std::string, std::string>> inputs;
  const bool study = cli::is_study_results(a.file);
  if (study && (!a.scene_path.empty() || !a.compare_file.empty() || !a.param_assignments.empty() ||
                a.camera != "all"))
    throw std::invalid_argument("view: '" + a.file +
                                "' is a study's results.csv: --scene, --compare, --param and "
                                "--camera apply to a run's CSV (the study names its scene)");
  nlohmann::json data = study ? cli::study_view_data(a, inputs) : cli::run_view_data(a, inputs);
  data["format"] = "spacearm-view";
  data["version"] = 1;
  data["info"].push_back({"this page", a.command_line});
  data["info"].push_back({"made by", std::string("spacearm ") + kGeneratorVersion});
  refuse_input_as_output(a.output_file, inputs);
  replace_output_file(a.output_file, cli::view_page(data));
  std::fprintf(stderr, "spacearm: wrote %s (open it in a browser; it needs no network)\n",
               a.output_file.c_str());
  return 0;
}

}  // namespace spacearm
