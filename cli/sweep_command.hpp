// `spacearm sweep STUDY -o DIR`: the runs of a study (sweep/study.hpp) on a thread pool into a
// results folder (sweep/sweep.hpp). --shard i/n runs one part, so the same command runs under
// GNU parallel, Slurm job arrays or HTCondor; a killed sweep resumes where it stopped; once the
// folder holds every run, results.csv is written, the same bytes however the runs were split.
// SIGINT and SIGTERM let the runs under way finish, keep their rows and exit with 130 and 143.
#pragma once

#include <string>
#include <vector>

namespace spacearm {

struct SweepArgs {
  std::string engine = "auto";  // --engine: CompileOptions::engine (compiled_model.hpp)
  std::string study_path, out_dir, shard = "1/1", cache_dir;
  int threads = 0;  // 0: one per hardware thread
  // Folders of shards run apart (--merge): their rows checked and merged into -o's results.csv.
  std::vector<std::string> merge;
  bool verbose = false;
};

// Exit status: 0 when the shard's runs are done (failed runs are rows too, counted on
// stderr), 1 on an error (message on stderr), 128 + signal when interrupted.
int run_sweep_command(const SweepArgs& args);

}  // namespace spacearm
