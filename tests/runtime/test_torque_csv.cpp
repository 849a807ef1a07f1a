// runtime/torque_csv.hpp: a torque file means what it says (columns by name, errors naming
// line and column), and the text fuzzer's seeds and recorded crashes replay cleanly.
#include "torque_csv.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "support.hpp"
#include "text_fuzz_target.hpp"

namespace spacearm {
namespace {

TEST(TorqueCsv, ColumnsAreFoundByNameInAnyOrder) {
  const TorqueTable a = read_torque_csv("t,tau1,tau2\n0,1,2\n0.5,3,4\n1,5,6\n", 2, "a.csv");
  const TorqueTable b =
      read_torque_csv("\xEF\xBB\xBFtau2 , t,tau1\r\n2,0,1\r\n\r\n4,0.5,3\r\n6,1,5\r\n", 2, "b.csv");
  ASSERT_EQ(a.samples.size(), 3u);
  ASSERT_EQ(b.samples.size(), 3u);
  EXPECT_EQ(a.t0, 0);
  EXPECT_EQ(a.dt, 0.5);
  EXPECT_EQ(a.t_last(), 1.0);
  for (size_t k = 0; k < 3; ++k) EXPECT_EQ(a.samples[k], b.samples[k]);
  EXPECT_EQ(a.samples[2], Eigen::Vector2d(5, 6));
}

TEST(TorqueCsv, EveryMistakeIsAnErrorNamingLineAndColumn) {
  struct Case {
    std::string text, message;
  };
  for (const Case& c : std::vector<Case>{
           {"", "torque file 'f.csv': empty"},
           {"t,tau1,tau3\n0,0,0\n1,0,0\n", "line 1: unknown column 'tau3' (expected t,tau1,tau2)"},
           {"t,tau1\n0,0\n1,0\n", "line 1: missing column 'tau2'"},
           {"t,t,tau1,tau2\n0,0,0,0\n1,1,0,0\n", "line 1: column 't' appears twice"},
           {"t,tau1,tau2,\n0,0,0,\n1,0,0,\n", "line 1: unknown column 4 (not a column name)"},
           {"0,1,2\n1,1,2\n", "line 1: starts with data ('0'), not a header"},
           {"t,tau1,tau2\n0,0,0\n", "needs at least two rows of samples, got 1"},
           {"t,tau1,tau2\n0,0,0\n1,0\n", "line 3: expected 3 fields, got 2"},
           {"t,tau1,tau2\n0,0,0\n1,0,1,5\n", "line 3: expected 3 fields, got 4"},
           {"t,tau1,tau2\n0,0,0\n1,0,nan\n", "line 3, column 'tau2': 'nan' is not finite"},
           {"t,tau1,tau2\n0,0,0\n1,0,3,0\n", "expected 3 fields"},
           {"t,tau1,tau2\n0,0,0\n1,0,\"3\"\n", "line 3, column 'tau2': '\"3\"' is not a number"},
           {"t,tau1,tau2\n0,0,0\n1,2,0\n1.5,0,0\n",
            "line 4: time step 0.5 differs from the first step 1"},
           {"t,tau1,tau2\n1,0,0\n0,0,0\n", "time step -1 is not positive"},
           {"t,tau1,tau2\n1e6,0,0\n1000000.0000000001,0,0\n",
            "time step 1.164153218e-10 is not positive or too small to resolve at t = 1000000"},
           {std::string("t,tau1,tau2\n0,0,0\n1,7\0"
                        "5,0\n",
                        24),
            "holds a NUL byte"},
       })
    EXPECT_THROW_MESSAGE(read_torque_csv(c.text, 2, "f.csv"), std::invalid_argument, c.message);
}

// Steps that each pass the uniformity check but drift in one direction (found by review:
// a sample landed a step late).
TEST(TorqueCsv, DriftingGridsAreRefused) {
  std::string text = "t,tau1\n";
  double t = 0;
  for (int k = 0; k <= 4000; ++k) {
    char row[64];
    std::snprintf(row, sizeof row, "%.17g,0\n", t);
    text += row;
    t += k == 0 ? 0.001 : k < 2000 ? 0.001 * (1 - 0.9e-6) : 0.001 * (1 + 0.9e-6);
  }
  EXPECT_THROW_MESSAGE(read_torque_csv(text, 1, "drift.csv"), std::invalid_argument,
                       "steps off the uniform grid");
}

TEST(TorqueCsv, FuzzSeedsAndRegressionsReplay) {
  namespace fs = std::filesystem;
  int replayed = 0;
  for (const char* folder : {"fuzz/text_seeds", "fuzz/text_regressions"})
    for (const auto& entry : fs::directory_iterator(fs::path(SPACEARM_SOURCE_DIR) / folder)) {
      std::ifstream in(entry.path(), std::ios::binary);
      const std::string text((std::istreambuf_iterator<char>(in)),
                             std::istreambuf_iterator<char>());
      SCOPED_TRACE(entry.path().string());
      EXPECT_NO_THROW(fuzz::check_text(text));
      ++replayed;
    }
  EXPECT_GE(replayed, 6);
}

}  // namespace
}  // namespace spacearm
