// A number of a scene, of either kind: a literal (kept as its exact decimal text where the
// scene wrote one, so the closed forms fold it as an exact rational) or a run-time parameter,
// by its name and its place in `params`; its value is then the parameter's nominal value (what
// the scene's checks use). A derivation reads the parameter, never the nominal value.
#pragma once

#include <string>
#include <vector>

namespace spacearm {

constexpr int kLiteral = -1;  // Quantity::index of a literal

struct Quantity {
  std::string parameter;  // non-empty: a run-time parameter of this name
  std::string literal;    // decimal text of the number, e.g. "0.181" (empty: a computed number)
  double value = 0.0;     // the literal's value, or the parameter's nominal value
  int index = kLiteral;   // the parameter's place in params (set where the scene is read)

  Quantity() = default;
  // A number is a literal quantity (a computed one: a URDF's lumped mass, a default).
  Quantity(double number) : value(number) {}  // NOLINT(google-explicit-constructor)

  bool is_parameter() const { return !parameter.empty(); }
};

struct Parameter {
  std::string name;
  Quantity nominal;  // always a literal: used for self-checks and as a default at run time
};
// The parameters' names and nominal values in their order (params[i] in the generated code).
inline std::vector<std::string> parameter_names(const std::vector<Parameter>& parameters) {
  std::vector<std::string> names;
  for (const Parameter& p : parameters) names.push_back(p.name);
  return names;
}
inline std::vector<double> nominal_values(const std::vector<Parameter>& parameters) {
  std::vector<double> values;
  for (const Parameter& p : parameters) values.push_back(p.nominal.value);
  return values;
}

}  // namespace spacearm
