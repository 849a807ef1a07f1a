// `spacearm view`: one self-contained HTML page (view_page.hpp) for a run's CSV (simulate,
// plan, a sweep's time series, a table from Python) drawn with its scene, optionally beside a
// second run (--compare), or for a sweep's results.csv (the study's heat map).
#pragma once

#include <nlohmann/json.hpp>

#include <string>
#include <vector>

namespace spacearm {

struct ViewArgs {
  std::string engine = "auto";  // --engine: CompileOptions::engine (compiled_model.hpp)
  std::string file, scene_path, compare_file, output_file = "view.html", cache_dir;
  std::vector<std::string> param_assignments;
  long max_frames = 2000;  // rows drawn per run (the file's are thinned evenly to this)
  // A run's first view: "all" (every run's points and the base), "arm" (the arm's joints and
  // tip), or "x,y,z[,tx,ty,tz]" (a point to look from, and one to look at).
  std::string camera = "all";
  bool verbose = false;
  std::string command_line;  // this command, shown in the page
};

// Exit status: 0, or 1 on an error (message on stderr).
int run_view(const ViewArgs& args);

namespace cli {

// The page's data for a run (view_run.cpp) and for a study's results.csv (view_study.cpp);
// both add the files they read to `inputs` as (what, path) pairs.
nlohmann::json run_view_data(const ViewArgs& a,
                             std::vector<std::pair<std::string, std::string>>& inputs);
nlohmann::json study_view_data(const ViewArgs& a,
                               std::vector<std::pair<std::string, std::string>>& inputs);

// Whether the CSV at path is a sweep's results (its header starts with run,status).
bool is_study_results(const std::string& path);

}  // namespace cli
}  // namespace spacearm
