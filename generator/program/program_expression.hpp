// A root of a straight-line program as one closed-form GiNaC expression: every statement it
// depends on substituted and expanded. The spatial chain's outputs exist only as recorded
// programs; this gives `inspect` their closed forms where they stay small (the expansion of a
// product multiplies term counts, so a budget on terms keeps time and memory bounded).
#pragma once

#include <ginac/ginac.h>

#include <functional>
#include <optional>
#include <string>

#include "straight_line.hpp"

namespace spacearm {

// The expanded expression of `root`, its inputs given by symbol(array, index); nullopt as soon
// as an expansion would pass max_terms terms (checked before each product is expanded).
std::optional<GiNaC::ex> expanded_expression(
    const Program& program, SRef root,
    const std::function<GiNaC::ex(const std::string&, int)>& symbol, size_t max_terms);

}  // namespace spacearm
