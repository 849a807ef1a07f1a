// The page's data for a study: each metric of results.csv over the first two parameters that
// vary (as the paper's Figures 9-10), averaged where several runs share a cell (random draws);
// parameters with more than 60 distinct values are binned. The file is read twice, streaming
// (the axes, then the cells), so memory stays bounded however many runs it has. The time series
// the study wrote (series/run-*.csv beside results.csv) are embedded, thinned, for the cells'
// first runs, up to a total budget.
#include <sys/stat.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <functional>
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
constexpr long kSeriesNumbers = 2000000;  // numbers of all embedded time series, at most
constexpr int kSeriesColumns = 24;        // columns of one embedded series, at most
constexpr long kPointNumbers = 1000000;   // numbers of the runs' own values (the scatter), at most

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

// A parameter as an axis: its distinct values, or kBins equal bins over its range (computed in
// halves, so that a range of +-1e308 does not overflow).
struct Axis {
  std::string name;
  int param = 0;              // its index among the parameters
  std::set<double> distinct;  // up to kMaxCategories + 1 values
  double lo = INFINITY, hi = -INFINITY;
  bool binned() const { return distinct.size() > kMaxCategories; }
  void see(double v) {
    lo = std::min(lo, v), hi = std::max(hi, v);
    if (!binned()) distinct.insert(v);
  }
  std::vector<double> values() const {
    if (!binned()) return {distinct.begin(), distinct.end()};
    std::vector<double> centres;
    const double half_bin = (hi / 2 - lo / 2) / kBins;
    for (int k = 0; k < kBins; ++k)
      centres.push_back(lo / 2 + hi / 2 + (2 * k + 1 - kBins) * half_bin);
    return centres;
  }
  int index(double v) const {
    if (!binned())
      return static_cast<int>(std::distance(distinct.begin(), distinct.lower_bound(v)));
    const double f = (v / 2 - lo / 2) / (hi / 2 - lo / 2);
    return std::isfinite(f) ? std::clamp(static_cast<int>(f * kBins), 0, kBins - 1) : 0;
  }
};

// The header's layout: parameters between `status` and the first metric (ee_...), the metrics
// after them (but the text columns).
struct Layout {
  std::vector<std::string> names;
  std::vector<int> params, metrics;
};

// Calls row(run, ok, parameters, metrics) for each row of results.csv, checked.
void for_each_result(const std::string& path, Layout& layout,
                     const std::function<void(long, bool, const std::vector<double>&,
                                              const std::vector<double>&)>& row) {
  const std::string where = "view '" + path + "'";
  layout = Layout{};
  std::vector<double> params, metrics;
  for_each_line(path, "view", [&](long number, std::string& text) {
    if (text.empty()) return;
    const auto fields = split_quoted(text);
    const std::string at = where + " line " + std::to_string(number);
    if (layout.names.empty()) {
      layout.names = fields;
      size_t c = 2;
      for (; c < fields.size() && fields[c].rfind("ee_", 0) != 0; ++c)
        layout.params.push_back(static_cast<int>(c));
      for (; c < fields.size(); ++c)
        if (fields[c] != "message" && fields[c] != "command_ratio")
          layout.metrics.push_back(static_cast<int>(c));
      if (layout.params.empty() || layout.metrics.empty())
        throw std::invalid_argument(at + ": expected run, status, parameters, then metrics ee_...");
      return;
    }
    if (fields.size() != layout.names.size())
      throw std::invalid_argument(at + ": " + std::to_string(fields.size()) +
                                  " fields, the header has " + std::to_string(layout.names.size()));
    const double run = parse_number(fields[0], at + " column 'run'");
    if (!(run >= 0 && run <= 1e15 && run == std::floor(run)))
      throw std::invalid_argument(at + " column 'run': " + quoted_text(fields[0]) +
                                  " is not a run number");
    const bool ok = fields[1] == "ok";
    if (!ok && fields[1] != "failed")
      throw std::invalid_argument(at + ": status " + quoted_text(fields[1]) +
                                  " (expected ok or failed)");
    params.clear(), metrics.clear();
    for (int c : layout.params)
      params.push_back(parse_number(fields[c], at + " column " + quoted_text(layout.names[c])));
    for (int c : layout.metrics)
      metrics.push_back(ok ? parse_number(fields[c], at + " column " + quoted_text(layout.names[c]))
                           : NAN);
    row(static_cast<long>(run), ok, params, metrics);
  });
  if (layout.names.empty()) throw std::invalid_argument(where + ": empty (no header)");
}

// A run's time series (thinned to `rows`): t, the end effector's columns and the joints'.
json series_of(const std::string& path, long rows) {
  const RunTable t = read_run_table(path, "view (a study's time series)", rows);
  json labels = json::array(), values = json::array();
  for (size_t c = 0; c < t.names.size() && labels.size() < kSeriesColumns; ++c) {
    const std::string& n = t.names[c];
    const bool base = n.size() > 1 && n.back() == '0';  // x0, qw0, ...: the base's
    const bool joint = n.size() > 1 && n[0] == 'q' && n.back() != 'd' && !base;
    if (n.rfind("ee_", 0) == 0 || joint)
      labels.push_back(n), values.push_back(t.values(static_cast<int>(c)));
  }
  return {{"t", t.values(t.column("t"))}, {"labels", labels}, {"values", values}};
}

// The series of each cell's first run, while the budget lasts; a link, a missing or a bad file
// is skipped with a note. Their paths become inputs (not to be written over by -o).
json study_series(const std::filesystem::path& folder, const std::vector<long>& first,
                  std::vector<std::string>& notes,
                  std::vector<std::pair<std::string, std::string>>& inputs) {
  json series = json::object();
  const long cells = std::count_if(first.begin(), first.end(), [](long f) { return f >= 0; });
  const long rows = std::clamp(kSeriesNumbers / std::max(1L, cells) / 10, 10L, 400L);
  long numbers = 0, skipped = 0;
  std::string problem;
  for (long f : first) {
    if (f < 0 || numbers >= kSeriesNumbers) continue;
    char name[32];
    std::snprintf(name, sizeof name, "run-%08ld.csv", f);
    const std::string path = (folder / name).string();
    struct stat st;
    if (::lstat(path.c_str(), &st) != 0) continue;
    inputs.push_back({"a study's time series", path});
    try {
      if (!S_ISREG(st.st_mode)) throw std::invalid_argument("'" + path + "' is not a regular file");
      json s = series_of(path, rows);
      numbers += static_cast<long>(s["t"].size() * (1 + s["labels"].size()));
      series[std::to_string(f)] = std::move(s);
    } catch (const std::invalid_argument& e) {
      ++skipped;
      if (problem.empty()) problem = e.what();
    }
  }
  if (!series.empty())
    notes.push_back("time series of " + std::to_string(series.size()) + " runs from '" +
                    folder.string() + "', thinned to at most " + std::to_string(rows) +
                    " rows each" +
                    (numbers >= kSeriesNumbers ? " (the page's budget: the rest left out)" : ""));
  if (skipped)
    notes.push_back(std::to_string(skipped) + " time series skipped, the first: " + problem);
  return series;
}

}  // namespace

json study_view_data(const ViewArgs& a, std::vector<std::pair<std::string, std::string>>& inputs) {
  inputs.push_back({"the study's results", a.file});
  // Pass 1: which parameters vary, and their values or ranges.
  Layout layout;
  std::vector<Axis> all;
  long runs = 0, failed = 0;
  for_each_result(a.file, layout, [&](long, bool ok, const auto& params, const auto&) {
    if (all.empty())
      for (size_t k = 0; k < params.size(); ++k) {
        Axis axis;
        axis.name = layout.names[layout.params[k]];
        axis.param = static_cast<int>(k);
        all.push_back(axis);
      }
    for (size_t k = 0; k < params.size(); ++k) all[k].see(params[k]);
    ++runs, failed += !ok;
  });
  if (runs == 0) throw std::invalid_argument("view '" + a.file + "': no runs");
  std::vector<Axis> axes;
  for (Axis& axis : all)
    if (axes.size() < 2 && axis.hi > axis.lo) axes.push_back(std::move(axis));
  if (axes.empty())
    throw std::invalid_argument("view '" + a.file + "': no parameter varies between the runs (" +
                                std::to_string(runs) + "): there is no map to draw");
  // Pass 2: each metric's sum and count per cell, and each cell's first run; and every run's
  // own values (every k-th run where they would pass the budget) for the scatter and ranking.
  const size_t nx = axes[0].values().size(), ny = axes.size() > 1 ? axes[1].values().size() : 1;
  std::vector<std::vector<double>> sums(layout.metrics.size(), std::vector<double>(nx * ny, 0));
  std::vector<long> counts(nx * ny, 0), first(nx * ny, -1);
  const long per_run = static_cast<long>(layout.params.size() + layout.metrics.size());
  const long every = std::max(1L, (runs * per_run + kPointNumbers - 1) / kPointNumbers);
  json point_params = json::array(), point_metrics = json::array();
  for (size_t k = 0; k < layout.params.size(); ++k) point_params.push_back(json::array());
  for (size_t m = 0; m < layout.metrics.size(); ++m) point_metrics.push_back(json::array());
  long row = 0, points = 0;
  for_each_result(a.file, layout, [&](long run, bool ok, const auto& params, const auto& metrics) {
    if (row++ % every == 0) {
      ++points;
      for (size_t k = 0; k < params.size(); ++k) point_params[k].push_back(params[k]);
      for (size_t m = 0; m < metrics.size(); ++m)
        point_metrics[m].push_back(ok && std::isfinite(metrics[m]) ? json(metrics[m]) : json());
    }
    const size_t i = axes[0].index(params[axes[0].param]);
    const size_t j = axes.size() > 1 ? axes[1].index(params[axes[1].param]) : 0;
    const size_t cell = std::min(j * nx + i, nx * ny - 1);
    if (first[cell] < 0 || run < first[cell]) first[cell] = run;
    if (!ok) return;
    ++counts[cell];
    for (size_t m = 0; m < metrics.size(); ++m) sums[m][cell] += metrics[m];
  });
  json metrics = json::array();
  for (size_t m = 0; m < layout.metrics.size(); ++m) {
    json cells = json::array();
    for (size_t c = 0; c < nx * ny; ++c)
      cells.push_back(counts[c] ? json(sums[m][c] / static_cast<double>(counts[c])) : json());
    metrics.push_back({{"name", layout.names[layout.metrics[m]]}, {"cells", cells}});
  }
  json first_runs = json::array();
  for (long f : first) first_runs.push_back(f >= 0 ? json(f) : json());
  std::vector<std::string> notes;
  const json series =
      study_series(std::filesystem::path(a.file).parent_path() / "series", first, notes, inputs);
  for (const Axis& axis : axes)
    if (axis.binned())
      notes.push_back(axis.name + ": " + std::to_string(kBins) +
                      " bins (its values are drawn, not a grid)");
  if (failed)
    notes.push_back(std::to_string(failed) + " failed runs (grey where a cell has no other)");
  auto axis_json = [](const Axis& axis) {
    return json{{"name", axis.name}, {"values", axis.values()}};
  };
  if (every > 1)
    notes.push_back("the scatter shows every " + std::to_string(every) + "th run (" +
                    std::to_string(points) + " of " + std::to_string(runs) + ")");
  json parameter_names = json::array();
  for (int c : layout.params) parameter_names.push_back(layout.names[c]);
  const json study = {{"x", axis_json(axes[0])},
                      {"y", axes.size() > 1 ? axis_json(axes[1]) : json()},
                      {"metrics", metrics},
                      {"counts", counts},
                      {"runs", first_runs},
                      {"series", series},
                      {"points",
                       {{"parameters", parameter_names},
                        {"parameter_values", point_params},
                        {"metric_values", point_metrics}}}};
  const std::string folder = std::filesystem::path(a.file).parent_path().filename().string();
  return {{"kind", "study"},
          {"title", "study " + (folder.empty() ? a.file : folder)},
          {"study", study},
          {"notes", notes},
          {"info", json::array({json::array({"results", a.file}),
                                json::array({"runs", std::to_string(runs)})})}};
}

}  // namespace spacearm::cli
