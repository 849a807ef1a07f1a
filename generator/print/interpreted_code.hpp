// The interpreter's form of a model (jit/interpreter.hpp runs it): each function of the C
// interface (cpp_printer.hpp) as a flat list of operations over a register file, so that a model
// answers at once, before (or without) the compiler.
//
// Read from the very statements the printer prints for the compiler, parsed as C++ parses them
// (+ - * / left-associative, unary minus, parentheses), because the order of operations is a fact
// of that text and not of the program's nodes: the printer splices unparenthesized sums and
// products into the expressions that use them, and a + b + c is (a + b) + c. With no FMA
// contraction in the compiled code (compile_flags), the same operations in the same order give
// the compiled code's numbers, bit for bit.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "function_spec.hpp"

namespace spacearm {

struct InterpretedFunction {
  enum class Op : std::uint8_t {
    add,      // r[dst] = r[a] + r[b]
    sub,      // r[dst] = r[a] - r[b]
    mul,      // r[dst] = r[a] * r[b]
    div,      // r[dst] = r[a] / r[b]
    neg,      // r[dst] = -r[a]
    tanh,     // r[dst] = tanh(r[a]), libm's
    exp,      // r[dst] = exp(r[a])
    pow,      // r[dst] = pow(r[a], r[b])
    sin,      // r[dst] = sin(r[a]) (an unbatched call: the plain baseline)
    cos,      // r[dst] = cos(r[a])
    sincos4,  // up to four angles as the printed sincos_batch takes them (operands below)
    store,    // out[dst][a] = r[b]
  };
  struct Instruction {
    Op op;
    std::int32_t dst, a, b;
  };
  std::string name;    // the C interface's, without "spacearm_"
  bool lanes = false;  // it has a 4-lane version (FunctionSpec::lanes): the same operations
  std::vector<Instruction> code;
  // The registers: the constants' values first, then the run-time parameters, then each input's
  // entries in order, then the computed values (reused after their last reader).
  std::vector<double> constants;
  int num_params = 0;
  std::vector<int> input_sizes, result_sizes;
  int num_registers = 0;
  // sincos4 at operands[a]: b angles' registers (b <= 4), then b sines' and b cosines' registers,
  // one after another in that order (4 + 4 + 4 slots, the unused ones -1).
  std::vector<std::int32_t> operands;
  int first_input_register() const { return static_cast<int>(constants.size()) + num_params; }
};

struct InterpretedModel {
  std::vector<InterpretedFunction> functions;  // LoweredModel::functions, in its order
  // Its results: the values of the scene's range checks (ModelFacts::checks, one each), tested
  // > 0 (or >= 0) as the library's parameter_error() tests them.
  InterpretedFunction check_values;
};

// std::logic_error if the printer printed something it cannot read (a bug here or there).
InterpretedModel interpreted_code(const LoweredModel& model);

// One body of statements as the printer prints them (c_body_statements), over the named inputs
// (sizes given) and params[0 .. num_params): what interpreted_code reads per function.
InterpretedFunction interpreted_statements(const std::string& name,
                                           const std::vector<std::string>& inputs,
                                           const std::vector<int>& input_sizes, int num_params,
                                           const std::string& body,
                                           const std::vector<int>& result_sizes);

}  // namespace spacearm
