#include "sweep_command.hpp"

#include <atomic>
#include <csignal>
#include <cstdio>
#include <thread>

#include "cli_input.hpp"
#include "stop_on_signals.hpp"
#include "sweep.hpp"

namespace spacearm {

namespace {

void say(const std::string& line) { std::fprintf(stderr, "spacearm: %s\n", line.c_str()); }

}  // namespace

int run_sweep_command(const SweepArgs& a) {
  const Shard shard = parse_shard(a.shard);
  Study study = load_study(a.study_path);
  if (study.scene.is_spatial()) cli::say_warnings(study.scene.spatial->warnings);
  const long runs = study.num_runs();
  CompileOptions compile;
  compile.cache_dir = a.cache_dir;
  compile.engine = parse_engine(a.engine);
  // By value: a compile in the background says its last stage after this function returns.
  compile.progress = [verbose = a.verbose](const std::string& m) {
    if (verbose || worth_saying(m)) say(m);
  };
  const StudyRunner runner(std::move(study), compile);
  if (!a.merge.empty()) {
    say("sweep: wrote " + merge_sweeps(runner, a.merge, a.out_dir) + " (" + std::to_string(runs) +
        " runs from " + std::to_string(a.merge.size()) + " folders)");
    return 0;
  }
  SweepOptions o;
  o.out_dir = a.out_dir;
  o.shard = shard;
  o.threads = a.threads > 0 ? a.threads
                            : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  o.progress = say;
  o.stop = &cli::stop_signal();
  say("sweep: study '" + a.study_path + "', " + std::to_string(runs) + " runs" +
      (shard.count > 1 ? ", shard " + a.shard : "") + ", " + std::to_string(o.threads) +
      " threads, into '" + a.out_dir + "'");
  if (a.verbose) say("sweep: " + runner.integration_text());
  if (!runner.plan_report().empty()) say("sweep: " + runner.plan_report());
  if (runner.study().scene.geared)
    say(runner.command_ratio_text() == "run"
            ? "sweep: command_ratio run (the default): each run's motors get tau / its own p, a "
              "known gearbox; 'manoeuvre: {command_ratio: nominal}' gives tau / the nominal p"
            : "sweep: command_ratio nominal: every run's motors get tau / the scene's nominal p");
  const cli::StopOnSignals signals;
  const SweepSummary s = run_sweep(runner, o);
  char line[256];
  std::snprintf(line, sizeof line,
                "sweep: %ld runs now, %ld found done, %ld of the shard's %ld failed", s.ran,
                s.already_done, s.failed, s.shard_runs);
  say(line);
  if (s.interrupted) {
    say(std::string("sweep: interrupted by ") + cli::signal_name(cli::stop_signal()) +
        "; every finished run is in '" + a.out_dir + "': the same command resumes");
    return 128 + cli::stop_signal();
  }
  if (!s.results.empty())
    say("sweep: wrote " + s.results + " (" + std::to_string(runs) + " runs)");
  else
    say("sweep: the folder holds " + std::to_string(s.study_done) + " of " + std::to_string(runs) +
        " runs; results.csv follows once every shard's runs-*.csv is in one folder and a sweep "
        "of it runs (it only merges then)");
  return 0;
}

}  // namespace spacearm
