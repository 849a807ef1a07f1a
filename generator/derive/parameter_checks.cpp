#include "parameter_checks.hpp"

#include <algorithm>
#include <array>
#include <stdexcept>
#include <utility>

#include "recorded_scalar.hpp"

namespace spacearm {

namespace {

// A physical inertia (ixx, ixy, ixz, iyy, iyz, izz) as conditions value > 0 or >= 0: positive
// definite (I's leading minors), and principal moments within the triangle inequality, which is
// Sigma = tr(I) / 2 - I positive semidefinite (all its principal minors; Sigma is the body's
// second moment of mass). A minor of degree k may fall short of 0 by 1e-12 tr^k: the reader's
// slack, so that a flat plate or a thin rod at its nominal value passes.
std::vector<std::pair<Sym, bool>> physical_inertia(const std::array<Sym, 6>& i) {
  const Sym &a = i[0], &b = i[1], &c = i[2], &d = i[3], &e = i[4], &f = i[5];
  const Sym tr = a + d + f, slack = tr * 1e-12;
  const Sym sx = (d + f - a) * 0.5, sy = (a + f - d) * 0.5, sz = (a + d - f) * 0.5;
  const Sym det_I = a * (d * f - e * e) - b * (b * f - e * c) + c * (b * e - d * c);
  const Sym det_sigma = sx * sy * sz - sx * e * e - sy * c * c - sz * b * b - b * c * e * 2.0;
  return {{a, true},
          {a * d - b * b, true},
          {det_I, true},
          {sx + slack, false},
          {sy + slack, false},
          {sz + slack, false},
          {sx * sy - b * b + slack * tr, false},
          {sx * sz - c * c + slack * tr, false},
          {sy * sz - e * e + slack * tr, false},
          {det_sigma + slack * tr * tr, false}};
}

}  // namespace

void add_parameter_checks(const std::vector<RangeRule>& rules, ModelFacts& facts) {
  Program& p = facts.checks_program;
  const std::vector<std::string>& names = facts.parameter_names;
  auto value = [&](const Quantity& q) {
    if (!q.is_parameter()) return q.value == 0 ? p.zero() : p.constant(q.value);
    const auto it = std::find(names.begin(), names.end(), q.parameter);
    if (it == names.end()) throw std::logic_error("parameter checks: no parameter " + q.parameter);
    return p.input("params", static_cast<int>(it - names.begin()));
  };
  for (const RangeRule& rule : rules) {
    if (!rule.at_run_time || !rule.uses_parameter()) continue;
    if (rule.inertia != InertiaRule::none) {
      std::array<Sym, 6> i;
      for (int k = 0; k < 6; ++k) {
        const Quantity& q = rule.terms.at(k).quantity;
        i[k] = q.is_parameter() ? Sym(&p, value(q)) : Sym::number(&p, q.value);
      }
      auto conditions = physical_inertia(i);
      if (rule.inertia == InertiaRule::positive_definite)
        conditions.resize(3);  // the leading minors alone
      for (const auto& [v, strict] : conditions)
        if (!v.is_zero())  // 0 >= 0 (a strict one cannot fold to 0: the reader checked it)
          facts.checks.push_back({v.ref(), strict, rule.message});
      continue;
    }
    // The sum of the terms: a quantity, minus one, or a constant.
    std::vector<SRef> terms;
    for (const RangeTerm& t : rule.terms)
      terms.push_back(t.constant          ? p.constant(t.coefficient)
                      : t.coefficient < 0 ? -value(t.quantity)
                                          : value(t.quantity));
    facts.checks.push_back(
        {terms.size() == 1 ? terms[0] : p.add(terms), rule.strict, rule.message});
  }
}

}  // namespace spacearm
