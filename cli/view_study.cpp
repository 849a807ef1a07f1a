// The page's data for a study: each metric of results.csv over the first two parameters that
// vary (as the paper's Figures 9-10), averaged where several runs share a cell (random draws);
// parameters with more than 60 distinct values are binned. The time series the study wrote
// (series/run-*.csv beside results.csv) are embedded, thinned, for the cells' first runs.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <set>

#include "private_folder.hpp"
#include "run_table.hpp"
#include "text_numbers.hpp"
#include "view_command.hpp"

namespace spacearm::cli {

using nlohmann::json;

namespace {

constexpr size_t kMaxCategories = 60;  // distinct values drawn as they are; more are binned
constexpr int kBins = 40;
constexpr double kSeriesNumbers = 2e6;  // numbers of embedded time series, at most

// Splits a results.csv line: fields may be double-quoted (the message), "" inside is a quote.
std::vector<std::string> split_quoted(const std::string& line) {
  std::vector<std::string> fields(1);
  bool quoted = false;
  for (size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted && c == '"' && i + 1 < line.size() && line[i + 1] == '"')
      fields.back() += '"', ++i;
    else if (c == '"')
      quoted = !quoted;
    else if (c == ',' && !quoted)
      fields.emplace_back();
    else
      fields.back() += c;
  }
  return fields;
}

// A parameter as an axis: its distinct values, or kBins equal bins over its range.
struct Axis {
  std::string name;
  std::vector<double> values;  // categories, or the bins' centres
  bool binned = false;
  double lo = 0, hi = 0;
  int index(double v) const {
    if (!binned)
      return static_cast<int>(std::lower_bound(values.begin(), values.end(), v) - values.begin());
    const int k = hi > lo ? static_cast<int>((v - lo) / (hi - lo) * kBins) : 0;
    return std::clamp(k, 0, kBins - 1);
  }
};

Axis axis_of(const std::string& name, const std::set<double>& distinct) {
  Axis a{name, {distinct.begin(), distinct.end()}};
  if (distinct.size() <= kMaxCategories) return a;
  a.binned = true;
  a.lo = *distinct.begin(), a.hi = *distinct.rbegin();
  a.values.clear();
  for (int k = 0; k < kBins; ++k) a.values.push_back(a.lo + (k + 0.5) * (a.hi - a.lo) / kBins);
  return a;
}

struct Results {
  std::vector<std::string> names;
  std::vector<int> params, metrics;  // columns
  std::vector<long> runs;
  std::vector<std::vector<double>> values;  // per row: params then metrics (nan: failed)
  long failed = 0;
};

Results read_results(const std::string& path) {
  Results r;
  Fd fd;
  try {
    fd = open_regular_file(path, "view", ~size_t(0));
  } catch (const FolderError& e) {
    throw std::invalid_argument(e.what());
  }
  const std::string where = "view '" + path + "'";
  for_each_line(fd.get(), where, [&](long number, std::string& text) {
    if (text.empty()) return;
    const auto fields = split_quoted(text);
    const std::string at = where + " line " + std::to_string(number);
    if (r.names.empty()) {
      r.names = fields;
      size_t c = 2;
      for (; c < fields.size() && fields[c].rfind("ee_", 0) != 0; ++c)
        r.params.push_back(static_cast<int>(c));
      for (; c < fields.size(); ++c)
        if (fields[c] != "message" && fields[c] != "command_ratio")
          r.metrics.push_back(static_cast<int>(c));
      if (r.params.empty() || r.metrics.empty())
        throw std::invalid_argument(at + ": expected run, status, parameters, then metrics ee_...");
      return;
    }
    if (fields.size() != r.names.size())
      throw std::invalid_argument(at + ": " + std::to_string(fields.size()) +
                                  " fields, the header has " + std::to_string(r.names.size()));
    const double run = parse_number(fields[0], at + " column 'run'");
    if (!(run >= 0 && run <= 1e15 && run == std::floor(run)))
      throw std::invalid_argument(at + " column 'run': " + quoted_text(fields[0]) +
                                  " is not a run number");
    r.runs.push_back(static_cast<long>(run));
    const bool ok = fields[1] == "ok";
    if (!ok && fields[1] != "failed")
      throw std::invalid_argument(at + ": status " + quoted_text(fields[1]) +
                                  " (expected ok or failed)");
    r.failed += !ok;
    std::vector<double> row;
    for (int c : r.params)
      row.push_back(parse_number(fields[c], at + " column '" + r.names[c] + "'"));
    for (int c : r.metrics)
      row.push_back(ok ? parse_number(fields[c], at + " column '" + r.names[c] + "'") : NAN);
    r.values.push_back(std::move(row));
  });
  if (r.values.empty()) throw std::invalid_argument(where + ": no runs");
  return r;
}

// A run's time series (thinned to `rows`): t, the end effector's columns and the joints'.
json series_of(const std::string& path, long rows) {
  const RunTable t = read_run_table(path, "view (a study's time series)", rows);
  json labels = json::array(), values = json::array();
  for (size_t c = 0; c < t.names.size(); ++c) {
    const std::string& n = t.names[c];
    const bool joint = n.size() > 1 && n[0] == 'q' && n.back() != 'd' && n.rfind("q0", 0) != 0 &&
                       n.rfind("qw", 0) != 0 && n.rfind("qx", 0) != 0 && n.rfind("qy", 0) != 0 &&
                       n.rfind("qz", 0) != 0;
    if (n.rfind("ee_", 0) == 0 || joint)
      labels.push_back(n), values.push_back(t.values(static_cast<int>(c)));
  }
  return {{"t", t.values(t.column("t"))}, {"labels", labels}, {"values", values}};
}

}  // namespace

json study_view_data(const ViewArgs& a, std::vector<std::pair<std::string, std::string>>& inputs) {
  inputs.push_back({"the study's results", a.file});
  const Results r = read_results(a.file);
  // The first two parameters that vary are the axes.
  std::vector<Axis> axes;
  std::vector<size_t> axis_param;  // their index among the parameters
  for (size_t k = 0; k < r.params.size() && axes.size() < 2; ++k) {
    std::set<double> distinct;
    for (const auto& row : r.values) distinct.insert(row[k]);
    if (distinct.size() < 2) continue;
    axes.push_back(axis_of(r.names[r.params[k]], distinct));
    axis_param.push_back(k);
  }
  if (axes.empty())
    throw std::invalid_argument("view '" + a.file + "': no parameter varies between runs");
  const size_t nx = axes[0].values.size(), ny = axes.size() > 1 ? axes[1].values.size() : 1;
  std::vector<std::vector<double>> sums(r.metrics.size(), std::vector<double>(nx * ny, 0));
  std::vector<long> counts(nx * ny, 0), first(nx * ny, -1);
  for (size_t row = 0; row < r.values.size(); ++row) {
    const auto& v = r.values[row];
    const size_t i = axes[0].index(v[axis_param[0]]);
    const size_t j = axes.size() > 1 ? axes[1].index(v[axis_param[1]]) : 0;
    const size_t cell = j * nx + i;
    if (first[cell] < 0 || r.runs[row] < first[cell]) first[cell] = r.runs[row];
    if (std::isnan(v[r.params.size()])) continue;
    ++counts[cell];
    for (size_t m = 0; m < r.metrics.size(); ++m) sums[m][cell] += v[r.params.size() + m];
  }
  json metrics = json::array();
  for (size_t m = 0; m < r.metrics.size(); ++m) {
    json cells = json::array();
    for (size_t c = 0; c < nx * ny; ++c)
      cells.push_back(counts[c] ? json(sums[m][c] / static_cast<double>(counts[c]))
                                : json(nullptr));
    metrics.push_back({{"name", r.names[r.metrics[m]]}, {"cells", cells}});
  }
  json runs = json::array();
  for (long f : first) runs.push_back(f >= 0 ? json(f) : json(nullptr));
  // The series beside results.csv, for each cell's first run.
  const std::filesystem::path folder = std::filesystem::path(a.file).parent_path() / "series";
  json series = json::object();
  long cells_with_runs = std::count_if(first.begin(), first.end(), [](long f) { return f >= 0; });
  const long rows =
      std::clamp(static_cast<long>(kSeriesNumbers / std::max(1L, cells_with_runs) / 10), 10L, 400L);
  std::vector<std::string> notes;
  for (long f : first) {
    if (f < 0) continue;
    char name[32];
    std::snprintf(name, sizeof name, "run-%08ld.csv", f);
    const std::filesystem::path p = folder / name;
    std::error_code ec;
    if (!std::filesystem::is_regular_file(p, ec)) continue;
    series[std::to_string(f)] = series_of(p.string(), rows);
  }
  if (!series.empty())
    notes.push_back("time series of " + std::to_string(series.size()) + " runs from '" +
                    folder.string() + "', thinned to at most " + std::to_string(rows) +
                    " rows each");
  for (const Axis& ax : axes)
    if (ax.binned)
      notes.push_back(ax.name + ": " + std::to_string(kBins) +
                      " bins (its values are drawn, not a grid)");
  if (r.failed)
    notes.push_back(std::to_string(r.failed) + " failed runs (grey where a cell has no other)");
  auto axis_json = [](const Axis& ax) { return json{{"name", ax.name}, {"values", ax.values}}; };
  json study = {{"x", axis_json(axes[0])},
                {"y", axes.size() > 1 ? axis_json(axes[1]) : json(nullptr)},
                {"metrics", metrics},
                {"counts", counts},
                {"runs", runs},
                {"series", series}};
  return {{"kind", "study"},
          {"title", "study " + std::filesystem::path(a.file).parent_path().filename().string()},
          {"study", study},
          {"notes", notes},
          {"info", json::array({json::array({"results", a.file}),
                                json::array({"runs", std::to_string(r.values.size())})})}};
}

}  // namespace spacearm::cli
