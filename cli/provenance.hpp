// What made a CSV, written beside it by simulate and plan as FILE.provenance.json: the command,
// the folder it ran in, the scene (its absolute path), the run-time parameters' values, spacearm's
// version, and the CSV's size and modification time when written. `spacearm view` shows it in
// the page and takes the scene and parameters from it; a sidecar whose CSV has changed since
// (another size or time) is stale and ignored, with a note. Untrusted like any input file.
#pragma once

#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace spacearm::cli {

struct Provenance {
  std::string command, folder, scene, version;
  std::vector<std::pair<std::string, double>> parameters;
  long long csv_size = -1, csv_mtime_ns = -1;
};

// The record of a run of `command` on the scene at `scene` with these parameter values.
template <class Values>
Provenance run_provenance(const std::string& command, const std::string& scene,
                          const std::vector<std::string>& names, const Values& values) {
  Provenance p;
  p.command = command;
  p.scene = scene;
  for (size_t i = 0; i < names.size(); ++i) p.parameters.push_back({names[i], values[i]});
  return p;
}

// FILE.provenance.json for FILE.
std::string provenance_path(const std::string& csv);

// Writes the sidecar of `csv` (just written; nothing for standard output) whole, through a
// temporary renamed into place: a link planted at its name is not followed. A failure is a
// warning on stderr: the CSV is the result and it is complete.
void write_provenance(const std::string& csv, Provenance p);

// The sidecar of `csv` if there is one and it still describes the file; a stale one sets
// `stale`. Errors (not a regular file, over 1 MB, not the expected JSON) name the sidecar.
std::optional<Provenance> read_provenance(const std::string& csv, bool* stale = nullptr);

}  // namespace spacearm::cli
