// The only ways user text reaches an emitted file (generated C++, the C shim, the cache's
// marker): as a comment written through comment_lines(), as a file name that passed
// check_file_stem(), as an identifier that passed scene validation, or as a number printed
// from its parsed value by round_trip(). No GiNaC here, so the fuzzer can check it.
#pragma once

#include <string>

namespace spacearm {

// `text` as `//` comment lines, one per source line (\n, \r\n or \r). Bytes outside
// printable ASCII, and a backslash (which would splice the next line into the comment),
// are written as \xNN (and a '?' after a '?', which could start a trigraph), so the comment
// cannot end early, swallow the next line or hide
// text with control or bidirectional characters.
std::string comment_lines(const std::string& text, const std::string& indent = "");

// Throws std::invalid_argument naming `what` unless `stem` is a safe file name stem: 1 to
// 100 characters of letters, digits, '_', '-' and '.', starting with a letter, digit or '_'.
void check_file_stem(const std::string& stem, const std::string& what);

// The shortest decimal text (up to 17 significant digits) that reads back as `value`
// exactly; never the source spelling (`010` is ten here, and octal eight in C++).
std::string round_trip(double value);

// True for names a C++17 compiler or the headers the generated code includes would
// reinterpret: keywords, alternative tokens, names with "__", and every object- or
// function-like macro that <Eigen/Core>, <array> and <cmath> define with the build's
// compiler in GNU mode (the list is produced at build time by cmake/reserved_macros.cmake).
bool is_cpp_reserved(const std::string& name);

}  // namespace spacearm
