// C++ printer: turns lowered functions (function_spec.hpp) into one self-contained
// header/source pair per model (Eigen only) and the C interface the compile-and-load path
// exports. It knows shapes and programs, nothing about bodies, angles or gears.
#pragma once

#include <string>
#include <vector>

#include <memory>

#include "function_spec.hpp"
#include "interpreted_code.hpp"
#include "version.hpp"

namespace spacearm {

// Version of the C interface (c_interface): each function is exported as
//   void spacearm_<name>(const double* const* inputs, const double* params, double* const* results)
// with arrays column-major in the order and shapes of its FunctionSpec; the model describes
// itself (spacearm_name, _nq, _nv, _num_links, _num_base, _spatial, _free_floating,
// _passive_forces, _configuration_layout, _outputs, ...), so a loader needs no scene. 7: the
// self-description. 8: per joint, whether its slot holds a motor angle (_slot_holds_motor).
// 9: the numbers whose span a failure names (_num_span_fields, _span_field, _span_value,
// _span_parameter). 10: the end effectors (_num_end_effectors; a tree may have several).
inline constexpr int kCInterfaceVersion = 10;
// Beside some of them (FunctionSpec::lanes), spacearm_<name>_x4 of the same signature takes four
// states per call: entry i of lane l of every input, parameter and result at [4 i + l]. A
// library without them still loads (the caller takes one state per call).
inline constexpr const char* kLanesSuffix = "_x4";

struct PrintOptions {
  std::string scene_path;  // as shown in the banner (keep it relative for reproducibility)
  std::string command;     // the regeneration command shown in the banner
  std::string file_stem;   // file names STEM.hpp/STEM.cpp; empty: the model's name
  // Bodies of more statements than this are split into parts of this many temporaries (the
  // entries they write join the part of their last operand; a sin/cos batch stays whole), each its
  // own non-inlined function: a compiler's register allocation grows faster than linearly with one
  // function's length (N = 30's state Jacobian, 42 000 statements in one function, took 259 s
  // and 8.9 GB to compile at -O1; in parts of 2000, 33 s and 0.6 GB). Values a later part reads
  // pass through a work array on the stack whose slots are reused after their last reader. Parts
  // of 200 against 2000 halve the compile of space_arm7's state Jacobian (4.1 to 2.2 s in one
  // unit) and leave the generated functions' speed within a few per cent (docs/performance.md).
  int statements_per_part = 200;
  // The C interface in this many translation units (c_units), for as many compilers at once,
  // after the leading ones: unit k < leading_units.size() holds the functions named in
  // leading_units[k] (C names without "spacearm_"; 4-lane ones end in kLanesSuffix; a name the
  // model lacks is skipped), so that a caller can compile and load them first. Unit 0 also
  // states the model's facts.
  int c_units = 1;
  std::vector<std::vector<std::string>> leading_units;
  // Also the interpreter's form of the C interface (EmittedModel::interpreted).
  bool interpreted = false;
  // Also the C interface as one file (EmittedModel::c_file_name, c_units = 1) with every
  // function in CasADi's external form as well (casadi::external, acados' external functions):
  // spacearm_casadi_<name>(arg, res, iw, w, mem), its inputs, then the run-time parameters
  // where the model has them (a null parameters argument: the nominal values; a null input:
  // zeros; a null result: not wanted), dense column-major, with _n_in, _n_out, _name_in,
  // _name_out, _sparsity_in, _sparsity_out and _work.
  bool casadi = false;
};

struct FunctionStats {
  std::string name;
  OpCounts ops;
  std::string variant;      // e.g. the velocity basis; empty if lowering had no choice
  std::string formulation;  // "closed form", "recursive (ABA)", ...
};

struct EmittedModel {
  std::string header_name, source_name;
  std::string header, source;
  std::string c_interface;  // extern "C" wrappers of every function, for dlopen (c_units = 1)
  std::string c_file_name;  // PrintOptions::casadi: STEM_c.cpp, holding c_interface
  std::vector<std::string> c_units;  // the same in PrintOptions::c_units translation units
  std::vector<std::vector<std::string>> c_unit_functions;  // the functions of each of them
  std::vector<FunctionStats> stats;
  // PrintOptions::interpreted: the same functions for the interpreter (interpreted_code.hpp).
  std::shared_ptr<const InterpretedModel> interpreted;
  std::string interpreted_error;  // why there is none, where it was asked for (a bug to report)
};

EmittedModel print_cpp(const LoweredModel& model, const PrintOptions& options);

// What the interpreter reads (interpreted_code.hpp): the statements of function f's body in the
// C interface, printed whole (one part), and the C interface's values of the scene's range checks
// (ModelFacts::checks, in order), each an expression over params[i].
std::string c_body_statements(const FunctionSpec& f, const Dimensions& dims);
std::vector<std::string> c_check_values(const ModelFacts& facts);

// Writes the header and source into dir through temporary files renamed into place, so
// that a failed run leaves no half-written output.
void write_files(const EmittedModel& emitted, const std::string& dir);

// The files in dir that are missing or differ from `emitted` (byte for byte).
std::vector<std::string> stale_files(const EmittedModel& emitted, const std::string& dir);

}  // namespace spacearm
