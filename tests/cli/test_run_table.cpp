// The view's run tables (cli/run_table.hpp): columns by name, every row checked, thinned evenly
// to a bound with the last row kept; bad files are errors naming the line and column.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include "provenance.hpp"
#include "run_table.hpp"
#include "view_fuzz_target.hpp"

namespace {

using spacearm::cli::read_run_table;

class RunTableTest : public ::testing::Test {
 protected:
  // A file per test and process: ctest runs the tests of this fixture at once, in processes of
  // their own, and one's TearDown would remove another's file.
  std::string path = ::testing::TempDir() + "run_table_test_" +
                     ::testing::UnitTest::GetInstance()->current_test_info()->name() + "_" +
                     std::to_string(::getpid()) + ".csv";
  void write(const std::string& text) { std::ofstream(path, std::ios::binary) << text; }
  void TearDown() override { std::remove(path.c_str()); }
  std::string error(long max_rows = 100) {
    try {
      read_run_table(path, "view", max_rows);
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    return "no error";
  }
};

TEST_F(RunTableTest, ReadsColumnsByNameWithBomAndCrlf) {
  write("\xEF\xBB\xBFq1,t,x\r\n1,0,2\r\n3,0.5,4\r\n");
  const auto table = read_run_table(path, "view", 100);
  EXPECT_EQ(table.names, (std::vector<std::string>{"q1", "t", "x"}));
  ASSERT_EQ(table.rows.size(), 2u);
  EXPECT_EQ(table.total_rows, 2);
  EXPECT_FALSE(table.thinned());
  EXPECT_EQ(table.values(table.column("x")), (std::vector<double>{2, 4}));
  EXPECT_EQ(table.column("missing"), -1);
}

// Every k-th row and the last, at most max rows, for sizes around the bound and far past it
// (past 8 max rows the reader halves what it keeps while reading).
TEST_F(RunTableTest, ThinsEvenlyKeepingTheLastRow) {
  for (long n : {1L, 2L, 99L, 100L, 101L, 1000L, 12345L}) {
    for (long max_rows : {2L, 7L, 100L}) {
      std::string text = "t,v\n";
      for (long k = 0; k < n; ++k) text += std::to_string(k) + "," + std::to_string(2 * k) + "\n";
      write(text);
      const auto table = read_run_table(path, "view", max_rows);
      SCOPED_TRACE("n = " + std::to_string(n) + ", max = " + std::to_string(max_rows));
      EXPECT_EQ(table.total_rows, n);
      EXPECT_LE(static_cast<long>(table.rows.size()), std::max(max_rows, 1L));
      EXPECT_EQ(table.thinned(), n > max_rows);
      EXPECT_EQ(table.rows.front()[0], 0);
      EXPECT_EQ(table.rows.back()[0], n - 1);
      for (size_t i = 0; i + 1 < table.rows.size(); ++i) {
        EXPECT_EQ(table.rows[i][1], 2 * table.rows[i][0]);
        if (i + 2 < table.rows.size()) {  // the same stride everywhere but before the last row
          EXPECT_EQ(table.rows[i + 1][0] - table.rows[i][0], table.stride);
        }
      }
      // At least half the bound is used when thinning (the stride is not coarser than needed).
      if (n > max_rows) {
        EXPECT_GE(static_cast<long>(table.rows.size()), max_rows / 2);
      }
    }
  }
}

TEST_F(RunTableTest, BadFilesAreErrorsNamingLineAndColumn) {
  write("");
  EXPECT_NE(error().find("empty (no header)"), std::string::npos) << error();
  write("t,x\n");
  EXPECT_NE(error().find("no rows"), std::string::npos) << error();
  write("x,y\n1,2\n");
  EXPECT_NE(error().find("no column 't'"), std::string::npos) << error();
  write("t,x,x\n1,2,3\n");
  EXPECT_NE(error().find("repeated column name 'x'"), std::string::npos) << error();
  write("t,x\n0,1\n1,2,3\n");
  EXPECT_NE(error().find("line 3: 3 fields, the header has 2"), std::string::npos) << error();
  write("t,x\n0,1\n1,nan\n");
  EXPECT_NE(error().find("line 3 column 'x'"), std::string::npos) << error();
  write("t,x\n0,1\n1,1e999\n");
  EXPECT_NE(error().find("line 3 column 'x'"), std::string::npos) << error();
  write("t,x\n0,1\n0,2\n");
  EXPECT_NE(error().find("line 3: t = 0 does not increase"), std::string::npos) << error();
  // Issue 49: values the page cannot draw, and times a plot cannot tell apart, are refused with
  // the line and column (x0 = 1e300 drew an empty 3D view; steps of 1e-300 s broke every plot).
  write("t,x0\n0,1\n1,1e300\n");
  EXPECT_NE(error().find("line 3 column 'x0': 1e+300 is beyond +-1e9, which the page cannot draw"),
            std::string::npos)
      << error();
  write("t,x\n0,1\n1e-300,2\n2e-300,3\n");
  EXPECT_NE(error().find("line 3: t = 1e-300 is 1e-300 s after the row before: times closer than "
                         "1e-9 s"),
            std::string::npos)
      << error();
  // A thinned-away row is checked too.
  std::string text = "t,x\n";
  for (int k = 0; k < 1000; ++k) text += std::to_string(k) + (k == 501 ? ",x1\n" : ",1\n");
  write(text);
  EXPECT_NE(error(10).find("line 503 column 'x'"), std::string::npos) << error(10);
}

// A file without newlines or with a line of commas fails fast, without filling memory.
TEST_F(RunTableTest, LongLinesAreRefusedBeforeTheyFillMemory) {
  write("t,x\n0,1\n" + std::string(3 << 20, '7'));
  EXPECT_NE(error().find("line 3: longer than 1 MB"), std::string::npos) << error();
  write("t,x\n0,1\n" + std::string(1 << 19, ','));
  EXPECT_NE(error().find("line 3: 524289 fields, the header has 2"), std::string::npos) << error();
  write("t,\x1b[31mred\n0,x\n");
  EXPECT_NE(error().find("column '?[31mred'"), std::string::npos) << error();
}

TEST_F(RunTableTest, RefusesWhatIsNotARegularFile) {
  const std::string fifo =
      ::testing::TempDir() + "run_table_test_" + std::to_string(::getpid()) + ".fifo";
  std::remove(fifo.c_str());
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  try {
    read_run_table(fifo, "view", 10);
    ADD_FAILURE() << "a FIFO was read";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("is not a regular file"), std::string::npos) << e.what();
  }
  std::remove(fifo.c_str());
  EXPECT_THROW(read_run_table(::testing::TempDir(), "view", 10), std::invalid_argument);
  EXPECT_THROW(read_run_table(::testing::TempDir() + "no such file.csv", "view", 10),
               std::invalid_argument);
}

// A provenance record is any file: a rejection names the record and says what is wrong in
// spacearm's words, never nlohmann's, which may quote the text (a number too large quotes it).
TEST(RunTable, ProvenanceRejectionsNameTheFieldAndNeverQuoteTheRecord) {
  const std::string csv =
      ::testing::TempDir() + "provenance_test_" + std::to_string(::getpid()) + ".csv";
  std::ofstream(csv) << "t,x\n0,1\n";
  const auto error = [&](const std::string& record) {
    std::ofstream(spacearm::cli::provenance_path(csv), std::ios::binary) << record;
    try {
      spacearm::cli::read_provenance(csv, nullptr);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  const std::string ok = R"("command":"c","folder":"/","scene":"s","spacearm":"v",)"
                         R"("parameters":{},"csv_size":1,)";
  EXPECT_NE(error("{" + ok + R"("csv_mtime_ns":10e5301})").find("(a number out of range)"),
            std::string::npos);
  EXPECT_EQ(error("{" + ok + R"("csv_mtime_ns":10e5301})").find("5301"), std::string::npos);
  EXPECT_NE(error(R"({"command":"c"})").find("(field 'folder' missing)"), std::string::npos);
  EXPECT_NE(error("{" + ok + R"("csv_mtime_ns":"secret"})")
                .find("'csv_mtime_ns' is not an "
                      "integer"),
            std::string::npos);
  EXPECT_EQ(error("{" + ok + R"("csv_mtime_ns":"secret"})").find("secret"), std::string::npos);
  EXPECT_NE(error("[1,2]").find("(not a JSON object)"), std::string::npos);
  EXPECT_NE(error("{oops").find("(not JSON at byte 2)"), std::string::npos);
  std::remove(spacearm::cli::provenance_path(csv).c_str());
  std::remove(csv.c_str());
}

// Every input the view fuzzer recorded (fuzz/view_seeds, fuzz/view_regressions) replays
// through its check (fuzz/view_fuzz_target.hpp) in every test run.
TEST(RunTable, FuzzSeedsAndRegressionsReplay) {
  namespace fs = std::filesystem;
  int replayed = 0;
  for (const char* folder : {"fuzz/view_seeds", "fuzz/view_regressions"})
    for (const auto& entry : fs::directory_iterator(fs::path(SPACEARM_SOURCE_DIR) / folder)) {
      std::ifstream in(entry.path(), std::ios::binary);
      const std::string text((std::istreambuf_iterator<char>(in)),
                             std::istreambuf_iterator<char>());
      SCOPED_TRACE(entry.path().string());
      EXPECT_NO_THROW(spacearm::fuzz::check_view_input(text));
      ++replayed;
    }
  EXPECT_GE(replayed, 6);
}

}  // namespace
