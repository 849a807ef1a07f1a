// libFuzzer target: spacearm view's inputs, a run's CSV and its provenance record, on arbitrary
// bytes (see view_fuzz_target.hpp). Build and run: scripts/fuzz.sh.
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>

#include "view_fuzz_target.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    spacearm::fuzz::check_view_input(std::string(reinterpret_cast<const char*>(data), size));
  } catch (const std::logic_error& e) {
    std::fprintf(stderr, "view fuzzer: %s\n", e.what());
    std::abort();
  }
  return 0;
}
