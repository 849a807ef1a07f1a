// libFuzzer target: the torque CSV reader, the CLI's number lists and the comment escaping
// of emitted files, on arbitrary bytes (see text_fuzz_target.hpp).
// Build and run: scripts/fuzz.sh (clang, -fsanitize=fuzzer,address,undefined).
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>

#include "text_fuzz_target.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    spacearm::fuzz::check_text(std::string(reinterpret_cast<const char*>(data), size));
  } catch (const std::logic_error& e) {
    std::fprintf(stderr, "text fuzzer: %s\n", e.what());
    std::abort();
  }
  return 0;
}
