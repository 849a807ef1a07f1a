// libFuzzer target: scene parsing and validation (generator/scene/scene.cpp) on arbitrary text.
// Build and run: scripts/fuzz.sh (clang, -fsanitize=fuzzer,address,undefined).
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>

#include "scene_fuzz_target.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    spacearm::fuzz::check_scene_text(std::string(reinterpret_cast<const char*>(data), size));
  } catch (const std::logic_error& e) {
    std::fprintf(stderr, "scene fuzzer: %s\n", e.what());
    std::abort();
  }
  return 0;
}
