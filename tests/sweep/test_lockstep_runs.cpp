// sweep/lockstep_runs.cpp: after its set-up a run allocates nothing per step. Every allocation
// of the process is counted (malloc itself, which Eigen and operator new both call), and a run
// three times as long must allocate no more than the short one; the reference path, which
// allocates at every sample, shows that the count sees a step's allocations. The rows' bytes across
// the paths are test_sweep's.
#include <gtest/gtest.h>

#include <string>

#include "counting_malloc.hpp"
#include "sweep.hpp"

namespace spacearm {
namespace {

// The paper's geared system replaying a plan of `duration` s (RK4 at 0.01 s) for 4 draws.
Study study(const std::string& duration) {
  const std::string text = "scene: " + std::string(SPACEARM_SOURCE_DIR) +
                           "/models/paper_geared.yaml\n"
                           "manoeuvre:\n  plan: {from: [1.5, 0.0, 0.5235987755982988], "
                           "to: [1.45, 0.02, 0.55], duration: " +
                           duration +
                           "}\nintegrator: {method: rk4, dt: 0.01}\n"
                           "random:\n  runs: 4\n  seed: 3\n  draws:\n"
                           "    p: {uniform: [1, 10]}\n    Im: {log_uniform: [1.0e-6, 1.0e-4]}\n";
  return parse_study(text, "allocations.yaml");
}

// The allocations of the four runs' rows on `lanes` lanes (after one call: lazy set-up).
long allocations_of(const StudyRunner& runner, int lanes) {
  const_cast<StudyRunner&>(runner).set_lanes(lanes);
  const std::vector<long> runs = {0, 1, 2, 3};
  runner.rows(runs);
  counting_malloc::start();
  const std::vector<std::string> rows = runner.rows(runs);
  const long allocations = counting_malloc::stop();
  for (const std::string& row : rows) EXPECT_NE(row.find(",ok,"), std::string::npos) << row;
  return allocations;
}

TEST(LockstepRuns, AllocateNothingPerStep) {
  if (!counting_malloc::enabled()) GTEST_SKIP() << "AddressSanitizer replaces malloc";
  CompileOptions options;
  options.cache_dir = SPACEARM_TEST_CACHE_DIR;
  const StudyRunner short_runs(study("1"), options), long_runs(study("3"), options);
  for (int lanes : {1, 4}) {
    const long once = allocations_of(short_runs, lanes), thrice = allocations_of(long_runs, lanes);
    // 200 more steps of 4 runs: not one allocation more (a row's text may need one more when
    // its numbers print longer: at most one per run).
    EXPECT_LE(thrice, once + 4) << "lanes " << lanes << ": " << once << " then " << thrice;
    EXPECT_GT(once, 0);  // the count sees the rows' set-up
    RecordProperty("allocations_lanes_" + std::to_string(lanes),
                   std::to_string(once) + " then " + std::to_string(thrice));
  }
  // The reference path allocates at every sample (the metrics through DynamicModel's functions,
  // which return vectors): the count sees it.
  const long once = allocations_of(short_runs, 0), thrice = allocations_of(long_runs, 0);
  EXPECT_GT(thrice, once + 4 * 200 * 4) << once << " then " << thrice;
  RecordProperty("allocations_reference", std::to_string(once) + " then " + std::to_string(thrice));
}

}  // namespace
}  // namespace spacearm
