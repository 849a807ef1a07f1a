// The console reporter of the benchmarks, also keeping each benchmark's fastest repetition by
// name for the ratio tables printed after the runs.
#pragma once

#include <benchmark/benchmark.h>

#include <algorithm>
#include <map>
#include <string>
#include <vector>

namespace spacearm::bench {

// Seconds per iteration by benchmark name, without Google Benchmark's "/repeats:",
// "/iterations:" and "/manual_time" suffixes. With --benchmark_repetitions, the fastest
// repetition: on a shared machine, noise only adds time.
class RecordingReporter : public benchmark::ConsoleReporter {
 public:
  explicit RecordingReporter(std::map<std::string, double>& seconds) : seconds_(seconds) {}
  void ReportRuns(const std::vector<Run>& runs) override {
    for (const Run& r : runs) {
      if (r.run_type != Run::RT_Iteration || r.error_occurred) continue;
      std::string name = r.benchmark_name();
      for (const char* suffix : {"/repeats:", "/iterations:", "/manual_time"})
        name = name.substr(0, name.find(suffix));
      const double t = r.real_accumulated_time / static_cast<double>(r.iterations);
      const auto [it, inserted] = seconds_.emplace(name, t);
      if (!inserted) it->second = std::min(it->second, t);
    }
    ConsoleReporter::ReportRuns(runs);
  }

 private:
  std::map<std::string, double>& seconds_;
};

}  // namespace spacearm::bench
