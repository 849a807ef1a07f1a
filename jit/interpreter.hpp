// Runs a model's functions from their interpreted code (interpreted_code.hpp): the first tier of
// a model, which answers before the compiler has built its library (compiled_model.hpp), with the
// compiled functions' calling convention (cpp_printer.hpp) and their numbers, bit for bit.
#pragma once

#include "interpreted_code.hpp"

namespace spacearm {

// Where the compiled library's sin and cos come from, for the interpreter to take them from the
// same place: libmvec's four-lane functions where it was built with SPACEARM_VECTOR_TRIG and the
// CPU has AVX2 and FMA (cpp_printer.cpp's sincos_batch), else libm's, one angle at a time.
struct TrigSource {
  bool vector_trig = false;  // the library was built with SPACEARM_VECTOR_TRIG
};

// f at one state: in[k] holds input k's entries, params the run-time parameters, out[r] room for
// result r (column-major, as the C interface). Not checked: the caller checks, as for a
// compiled function. Thread-safe (each thread has a register file of its own).
void interpret(const InterpretedFunction& f, TrigSource trig, const double* const* in,
               const double* params, double* const* out);

// The same for four states at once, the 4-lane functions' layout: entry i of lane l of every
// input, parameter and result at [4 i + l]. Each lane gets interpret()'s numbers.
void interpret_lanes(const InterpretedFunction& f, TrigSource trig, const double* const* in,
                     const double* params, double* const* out);

}  // namespace spacearm
