// What the command-line tests share (tests/cli/): a fresh cache folder per test, running the
// spacearm program, JSON compared to 1e-12, and the fixtures of `spacearm eval` and `simulate`.
#pragma once

#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <unistd.h>

#include "support.hpp"

namespace spacearm::test {

namespace fs = std::filesystem;

// An empty cache folder of this test's name and process.
inline fs::path fresh_cache(const std::string& name) {
  const fs::path dir =
      fs::temp_directory_path() / ("spacearm-test-cache-" + name + "-" + std::to_string(getpid()));
  fs::remove_all(dir);
  return dir;
}

inline std::string run(const std::string& command, int* status = nullptr) {
  return run_command(command, status);
}

inline Eigen::MatrixXd matrix_of(const nlohmann::json& j) {
  Eigen::MatrixXd m(j.size(), j[0].size());
  for (size_t i = 0; i < j.size(); ++i)
    for (size_t k = 0; k < j[i].size(); ++k) m(i, k) = j[i][k].get<double>();
  return m;
}
inline Eigen::VectorXd vector_of(const nlohmann::json& j) {
  Eigen::VectorXd v(j.size());
  for (size_t i = 0; i < j.size(); ++i) v[i] = j[i].get<double>();
  return v;
}

// Numbers, lists, lists of rows or objects of them, equal to 1e-12 relative to the largest entry.
inline void expect_json_near(const nlohmann::json& a, const nlohmann::json& b) {
  ASSERT_EQ(a.type(), b.type());
  if (a.is_object()) {
    for (const auto& [key, value] : b.items()) {
      SCOPED_TRACE(key);
      ASSERT_TRUE(a.contains(key));
      expect_json_near(a[key], value);
    }
  } else if (a.is_number()) {
    EXPECT_NEAR(a.get<double>(), b.get<double>(), 1e-12 * std::max(1.0, std::abs(b.get<double>())));
  } else if (a[0].is_array()) {
    EXPECT_MATRIX_NEAR(matrix_of(a), matrix_of(b), 1e-12);
  } else {
    EXPECT_MATRIX_NEAR(vector_of(a), vector_of(b), 1e-12);
  }
}

class EvalCli : public testing::Test {
 protected:
  fs::path cache = fresh_cache("cli");
  std::string cli = std::string(SPACEARM_CLI) + " eval --cache-dir " + cache.string() + " ";
  void TearDown() override { fs::remove_all(cache); }
  std::string unknown_field_scene() {
    fs::create_directories(cache);
    const fs::path p = cache / "unknown_field.yaml";
    std::ofstream(p)
        << "name: x\nbase: {type: fixed, mount: [0, 0]}\n"
           "links:\n  - {mass: 1, inertia: 0.1, length: 0.5, com: [0.2, 0], colour: red}\n";
    return p.string();
  }
};

class SimulateCli : public EvalCli {
 protected:
  std::string sim = std::string(SPACEARM_CLI) + " simulate --cache-dir " + cache.string() + " " +
                    std::string(SPACEARM_SOURCE_DIR) + "/models/paper_geared.yaml ";
  static std::vector<std::vector<double>> rows(const std::string& csv) {
    std::vector<std::vector<double>> out;
    std::stringstream in(csv);
    std::string line;
    std::getline(in, line);  // header
    while (std::getline(in, line)) {
      std::vector<double> row;
      std::stringstream l(line);
      std::string cell;
      while (std::getline(l, cell, ',')) row.push_back(std::stod(cell));
      EXPECT_FALSE(out.size() && out.back().size() != row.size())
          << "a row of another length: " << line;
      out.push_back(row);
    }
    return out;
  }
};

}  // namespace spacearm::test
