// Running a study (study.hpp, issue 15). A run replays the study's manoeuvre open loop into the
// scene's compiled model at the run's parameters and reduces the motion to one CSV row of
// summary metrics. A sweep runs one shard of the runs on a thread pool into a results folder
// that records each finished row at once, resumes where a killed sweep stopped, and writes
// results.csv, sorted by run, once every run of the study is there. A row depends only on the
// study and the run's index, never on the split: threads, shards and Dask give the same file.
#pragma once

#include <Eigen/Core>

#include <atomic>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "compiled_model.hpp"
#include "study.hpp"
#include "torque_signal.hpp"

namespace spacearm {

// Runs of a study, one at a time, from any thread.
class StudyRunner {
 public:
  // Compiles or loads the scenes (the cache of CompileOptions) and plans the manoeuvre once.
  StudyRunner(Study study, const CompileOptions& options);
  ~StudyRunner();

  const Study& study() const { return study_; }
  // The run scene's compiled model, the torques every run replays (planned once, or the
  // study's) and the start on the link side, [base pose; joint angles]: for peers that replay
  // the same study (bench_sweep's MuJoCo) and for timing the model's functions alone.
  const CompiledModel& model() const;
  const TorqueSignal<Eigen::Dynamic>& torques() const;
  Eigen::VectorXd start_link_side() const;
  // The CSV header of the rows: run, status, every parameter, the metrics, command_ratio,
  // message.
  const std::string& header() const { return header_; }
  // The study's command_ratio as its rows write it: "run" or "nominal".
  std::string command_ratio_text() const {
    return study_.command_ratio == Study::CommandRatio::run ? "run" : "nominal";
  }
  // The row of one run, with its newline. A run that fails (a parameter out of range, a
  // singular mass matrix, a diverging integration) is a row with status 'failed', empty
  // metrics and the message. series: receives the run's time series CSV if the study asks.
  std::string row(long run, std::string* series = nullptr) const;
  // The rows of several runs (the same bytes as row() gives each), integrated lanes() at a time
  // in lockstep where the study allows (fixed-step RK4); series: sized as runs where asked.
  std::vector<std::string> rows(const std::vector<long>& runs,
                                std::vector<std::string>* series = nullptr) const;
  // How the runs are integrated: 0 the reference path (integrate_motion on the run's
  // DynamicModel, every check on every call); 1 in lockstep one run at a time, on caller-owned
  // workspaces; 4 four runs at a time through the generated 4-lane functions (four scalar
  // calls where the library has none). By default 4 where the model has 4-lane functions, else
  // 1. Every setting writes the same bytes (test_sweep).
  int lanes() const { return lanes_; }
  // The plan's checks as `spacearm plan` prints them (empty without a plan): its samples, the
  // largest path error and the largest |qdd - central differences of qd|.
  const std::string& plan_report() const { return plan_report_; }
  // How the runs are integrated, in words (spacearm sweep --verbose says it).
  std::string integration_text() const;
  void set_lanes(int lanes);
  // Why `row` (with its newline) is not a row that row() writes for this study: a run of the
  // study; the header's fields; status ok with numbers, or failed with empty metrics and a
  // quoted message. Empty if it is one; *run receives its run.
  std::string row_problem(const std::string& row, long* run = nullptr) const;

 private:
  struct Loaded;
  Study study_;
  std::unique_ptr<Loaded> loaded_;
  std::string header_;
  std::string plan_report_;
  int lanes_ = 1;
  std::string reference_row(long run, std::string* series) const;
};

// Part i of n (1-based) of a study's runs: run r belongs to part (r mod n) + 1.
struct Shard {
  long index = 1, count = 1;
};
// "i/n" as the --shard option spells it; errors name the option and the value.
Shard parse_shard(const std::string& text);

struct SweepOptions {
  std::string out_dir;
  Shard shard;
  int threads = 1;
  // Progress lines (about every 2 s, with the rate and an estimate of the time left).
  std::function<void(const std::string&)> progress;
  // Set (by a signal handler) to stop after the runs under way; their rows are kept.
  const std::atomic<int>* stop = nullptr;
};

struct SweepSummary {
  long shard_runs = 0;    // runs in this shard
  long already_done = 0;  // of them, found in the folder
  long ran = 0;           // run now
  long failed = 0;        // rows of this shard with status 'failed'
  long study_done = 0;    // rows of the whole study in the folder
  bool interrupted = false;
  std::string results;  // results.csv's path once every run of the study is in the folder
};

// Runs the shard's runs that the folder lacks. Throws StudyError (a folder another user could
// redirect or write to, a folder of another study or with rows but no study.id, a row whose
// digest does not match, another sweep writing the shard's file).
SweepSummary run_sweep(const StudyRunner& runner, const SweepOptions& options);

// The header of a shard file (runs-IofN.csv): the study's, with a digest column last; each row
// there ends with its HMAC-SHA-256 under the folder's study.key.
std::string shard_header(const StudyRunner& runner);

// Merges the rows of shards run in separate folders (on machines without a shared file system):
// each folder's rows checked under its own study.key and study.id, every run present once; then
// out_dir/results.csv, the same bytes as one sweep of the whole study. Returns its path.
std::string merge_sweeps(const StudyRunner& runner, const std::vector<std::string>& dirs,
                         const std::string& out_dir);

// Checks out_dir as run_sweep does and claims it for the study (study.id).
void claim_results_folder(const StudyRunner& runner, const std::string& out_dir);

// Writes results.csv of rows computed elsewhere (spacearm.Study, Dask) into out_dir, checked
// and claimed as run_sweep's folder; returns its path.
std::string write_results(const StudyRunner& runner, const std::string& out_dir,
                          const std::vector<std::string>& rows);

// results.csv: the header, then one row per run in run order, from rows in any order (each with
// its newline). Throws StudyError if a run is missing or given twice with different rows.
std::string merge_rows(const StudyRunner& runner, const std::vector<std::string>& rows);

}  // namespace spacearm
