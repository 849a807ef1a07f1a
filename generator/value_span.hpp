// How many decades a model's numbers span: its masses, inertias, lengths, gear ratios, rotor
// inertias and stiffnesses, each a literal or a run-time parameter. Double precision holds about
// 16 decades; a model whose numbers span too many fails in ways that name no field (a mass
// matrix that is not positive definite, non-finite results), so its failures name the span: the
// generator's self-check at the nominal values, and a run at the run-time parameters' values
// (the library lists these fields; jit/compiled_model.hpp).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

namespace spacearm {

struct SpanField {
  std::string field;   // the scene's field, fixed text: "links[2].mass", "gears[0].ratio"
  double value = 0;    // its literal value (its nominal value where a parameter gives it)
  int parameter = -1;  // the run-time parameter that gives it (params[i]), or -1
};

// The span below which nothing is said: six decades.
constexpr double kNotableSpan = 1e6;

// The fields of the smallest and largest non-zero magnitude and those magnitudes (null where
// none is). params: the run-time values (nullptr: the nominal ones).
struct SpanEnds {
  const SpanField *lo = nullptr, *hi = nullptr;
  double lo_v = 0, hi_v = 0;
};
inline SpanEnds span_ends(const std::vector<SpanField>& fields, const double* params) {
  SpanEnds e;
  for (const SpanField& f : fields) {
    const double v = std::abs(f.parameter >= 0 && params ? params[f.parameter] : f.value);
    if (v == 0 || !std::isfinite(v)) continue;
    if (!e.lo || v < e.lo_v) e.lo = &f, e.lo_v = v;
    if (!e.hi || v > e.hi_v) e.hi = &f, e.hi_v = v;
  }
  return e;
}

// log10 of the largest non-zero magnitude over the smallest (0 where fewer than two).
inline double span_decades(const std::vector<SpanField>& fields, const double* params) {
  const SpanEnds e = span_ends(fields, params);
  return e.lo ? std::log10(e.hi_v / e.lo_v) : 0;
}

// "" where the non-zero magnitudes span less than six decades, else "25 decades, from
// links[6].mass (mp) = 1e-25 to base.mass = 500". params: the run-time values (nullptr: the
// nominal ones); names: the parameters' names.
inline std::string value_span(const std::vector<SpanField>& fields, const double* params,
                              const std::vector<std::string>& names) {
  const auto [lo, hi, lo_v, hi_v] = span_ends(fields, params);
  if (!lo || hi_v / lo_v < kNotableSpan) return "";
  auto named = [&names](const SpanField& f) {
    const bool by_parameter = f.parameter >= 0 && size_t(f.parameter) < names.size();
    return f.field + (by_parameter ? " (" + names[size_t(f.parameter)] + ")" : "");
  };
  char text[400];
  std::snprintf(text, sizeof text, "%.0f decades, from %s = %.4g to %s = %.4g",
                std::floor(std::log10(hi_v / lo_v)), named(*lo).c_str(), lo_v, named(*hi).c_str(),
                hi_v);
  return text;
}

}  // namespace spacearm
