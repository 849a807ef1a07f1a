// libFuzzer target: study files and the torque files they name (sweep/study.cpp,
// runtime/torque_csv.hpp) on arbitrary text; see study_fuzz_target.hpp.
// Build and run: scripts/fuzz.sh (clang, -fsanitize=fuzzer,address,undefined).
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <stdexcept>

#include "study_fuzz_target.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::string scratch = [] {
    const auto dir = std::filesystem::temp_directory_path() /
                     ("spacearm-study-fuzz-" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    return dir.string();
  }();
  try {
    spacearm::fuzz::check_study_input(std::string(reinterpret_cast<const char*>(data), size),
                                      SPACEARM_SOURCE_DIR "/models/paper_geared.yaml", scratch);
  } catch (const std::logic_error& e) {
    std::fprintf(stderr, "study fuzzer: %s\n", e.what());
    std::abort();
  }
  return 0;
}
