// C++ emitter: turns the derived expressions of a SymbolicModel into one self-contained
// header/source pair per model (Eigen only), with common-subexpression elimination, one
// sin/cos pair per body angle and no pow. It never differentiates: see symbolic_model.hpp.
#pragma once

#include <string>
#include <vector>

#include "straight_line.hpp"
#include "symbolic_model.hpp"

namespace spacearm {

inline constexpr const char* kGeneratorVersion = "0.1.0";

struct EmitOptions {
  std::string scene_path;  // as shown in the banner (keep it relative for reproducibility)
  std::string command;     // the regeneration command shown in the banner
  std::string file_stem;   // file names STEM.hpp/STEM.cpp; empty: the scene's name
  // Baseline for the benchmarks: every entry printed as GiNaC's expanded expression, with no
  // common-subexpression elimination, no Horner scheme and a sin/cos call per occurrence
  // (what SymPy's ccode without cse gives). Namespace and file stem get the suffix "_plain".
  bool plain = false;
};

struct FunctionStats {
  std::string name;
  OpCounts ops;
  std::string velocity_basis;  // "qd" or "omega" (absolute body rates); empty if no velocity
};

struct EmittedModel {
  std::string header_name, source_name;
  std::string header, source;
  std::vector<FunctionStats> stats;
};

EmittedModel emit_cpp(const SymbolicModel& model, const EmitOptions& options);

// Writes the files into dir through temporary files renamed into place, so that a failed
// run leaves no half-written output.
void write_files(const EmittedModel& emitted, const std::string& dir);

// The files in dir that are missing or differ from `emitted` (byte for byte).
std::vector<std::string> stale_files(const EmittedModel& emitted, const std::string& dir);

}  // namespace spacearm
