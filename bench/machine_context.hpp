// The machine a benchmark ran on, in its output's context (the console's header and the JSON's
// "context"): the CPU's model name, the vector instruction sets it offers and the ones this
// binary and the compile-and-load cache use. The machines this project runs on vary (AVX-512 on
// some, AVX2 only on others), so every figure must say which it came from.
#pragma once

#include <benchmark/benchmark.h>

#include <fstream>
#include <string>

namespace spacearm::bench {

// The first value of a /proc/cpuinfo field ("model name", "flags"); empty where there is none.
inline std::string cpuinfo_field(const std::string& field) {
  std::ifstream in("/proc/cpuinfo");
  for (std::string line; std::getline(in, line);)
    if (line.rfind(field, 0) == 0) {
      const size_t colon = line.find(':');
      return colon == std::string::npos ? "" : line.substr(colon + 2);
    }
  return "";
}

inline void add_machine_context() {
  const std::string flags = " " + cpuinfo_field("flags") + " ";
  auto has = [&flags](const char* f) {
    return flags.find(std::string(" ") + f + " ") != std::string::npos;
  };
  benchmark::AddCustomContext("cpu_model", cpuinfo_field("model name"));
  benchmark::AddCustomContext("cpu_vector_sets", std::string(has("avx512f") ? "avx512f " : "") +
                                                     (has("avx2") ? "avx2 " : "") + "sse2");
  // The cache's libraries are built for the widest (compiled_model.hpp: host_instruction_set);
  // the linked models of bench_dynamics for what this binary was compiled with.
  benchmark::AddCustomContext("binary_vector_set",
#if defined(__AVX512F__)
                              "avx512f"
#elif defined(__AVX2__)
                              "avx2"
#else
                              "sse2"
#endif
  );
  benchmark::AddCustomContext("compiler", __VERSION__);
}

}  // namespace spacearm::bench
