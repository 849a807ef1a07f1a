#include "parameter_rules.hpp"

#include <cmath>
#include <cstdio>
#include <string>

namespace spacearm {

bool RangeRule::uses_parameter() const {
  for (const RangeTerm& t : terms)
    if (!t.constant && t.quantity.is_parameter()) return true;
  return false;
}

bool RangeRule::holds() const {
  if (inertia != InertiaRule::none)
    return true;  // the spatial reader's own check (inertia_problem)
  double value = 0;
  for (const RangeTerm& t : terms)
    value += t.constant ? t.coefficient : t.coefficient * t.quantity.value;
  return strict ? value > 0 : value >= 0;
}

namespace {
std::string shown_value(double v) {  // "%g": -3, 1e+300, 2e-05
  char text[32];
  std::snprintf(text, sizeof text, "%g", v);
  return text;
}
}  // namespace

std::string parameter_range_error(const std::vector<std::string>& names,
                                  const std::vector<double>& values) {
  for (size_t i = 0; i < values.size(); ++i)
    if (values[i] != 0 && !(std::abs(values[i]) >= 1e-30 && std::abs(values[i]) <= 1e30))
      return "'" + names.at(i) + "' = " + shown_value(values[i]) +
             " is outside the supported magnitude range 1e-30 .. 1e30 (or 0)";
  return "";
}

std::string moved_parameters(const std::vector<std::string>& names,
                             const std::vector<double>& nominal,
                             const std::vector<double>& values) {
  std::string moved;
  for (size_t i = 0; i < values.size(); ++i)
    if (values[i] != nominal.at(i))
      moved += (moved.empty() ? "" : "; ") + names.at(i) + " = " + shown_value(values[i]);
  return moved;
}

RangeRule sign_rule(const std::string& field, const Quantity& q, bool strict) {
  RangeRule r;
  r.field = field;
  r.terms = {{1, false, q}};
  r.strict = strict;
  r.message = field + (strict ? " must be positive" : " must not be negative");
  return r;
}

std::string shown(const Scene& scene, const Quantity& q) {
  if (!q.is_parameter()) return q.literal;
  for (const Parameter& p : scene.parameters)
    if (p.name == q.parameter) return q.parameter + " = " + p.nominal.literal;
  return q.parameter;
}

namespace {

// Builds the table in parameter_error()'s order.
class RuleTable {
 public:
  RuleTable(const Scene& scene, std::function<bool(const std::string&)> given)
      : s_(scene), given_(std::move(given)) {}
  bool given(const std::string& field) const { return !given_ || given_(field); }
  std::vector<RangeRule> rules;

  // A rule on `field`: the sum of `terms` > 0 (strict) or >= 0.
  RangeRule& add(const std::string& field, std::vector<RangeTerm> terms, bool strict,
                 std::string message, std::string literal_message) {
    RangeRule r;
    r.field = field;
    r.terms = std::move(terms);
    r.strict = strict;
    r.message = std::move(message);
    r.literal_message = std::move(literal_message);
    rules.push_back(std::move(r));
    return rules.back();
  }

  // A single quantity > 0 (strict) or >= 0, with the usual messages.
  RangeRule& sign(const std::string& field, const Quantity& q, bool strict) {
    rules.push_back(sign_rule(field, q, strict));
    rules.back().literal_message =
        std::string(strict ? "must be positive, got " : "must not be negative, got ") +
        shown(s_, q);
    return rules.back();
  }

  void base() {
    // A fixed base's mass and inertia are checked where given, and never used.
    const bool free = s_.free_floating();
    const Base& b = s_.base;
    for (const auto& [key, q] : {std::pair{"mass", &b.mass}, std::pair{"inertia", &b.inertia}})
      if (free || given(std::string("base.") + key))
        sign(std::string("base.") + key, *q, true).at_run_time = free;
  }

  void link(int i) {
    const Link& l = s_.links[i];
    const std::string f = "links[" + std::to_string(i) + "]";
    sign(f + ".mass", l.mass, true);
    sign(f + ".inertia", l.inertia, true);
    sign(f + ".length", l.length, true);
  }

  void gear(const Gear& g, const Link& l, int i) {
    const std::string gf = "gears[" + std::to_string(i) + "]";
    sign(gf + ".ratio", g.ratio, true);
    RangeRule& im = sign(gf + ".motor_inertia", g.motor_inertia, g.flexible());
    if (g.flexible()) {
      im.message = gf + ".motor_inertia must be positive (a flexible joint)";
      im.literal_message = "a flexible joint (stiffness given) needs motor_inertia > 0, got " +
                           shown(s_, g.motor_inertia) +
                           " (the motor coordinate would have no inertia)";
    }
    if (g.compensate_link_inertia)
      add(gf + ".motor_inertia", {{1, false, l.inertia}, {-1, false, g.motor_inertia}}, true,
          gf + ".motor_inertia must be smaller than the inertia of link " + std::to_string(i + 1) +
              " it compensates",
          "motor inertia " + std::to_string(g.motor_inertia.value) +
              " must be smaller than the inertia of link " + std::to_string(i + 1) + " (" +
              std::to_string(l.inertia.value) + ") that it compensates")
          .node_field = gf;
    if (g.stiffness) sign(gf + ".stiffness", *g.stiffness, true);
    if (g.coupling) coupling(*g.coupling, gf);
    if (g.damping) sign(gf + ".damping", *g.damping, false);
  }

  void coupling(const Quantity& c, const std::string& gf) {
    const std::string field = gf + ".rotor_coupling";
    sign(field, c, false).message = field + " must be in [0, 1] (not negative)";
    add(field, {{1, true, {}}, {-1, false, c}}, false, field + " must be in [0, 1] (not above 1)",
        "a coupling factor is in [0, 1] (1 exact, 0 armature), got " + shown(s_, c));
  }

  void friction(const Friction& f, int i) {
    const std::string ff = "friction[" + std::to_string(i) + "]";
    sign(ff + ".viscous", f.viscous, false);
    sign(ff + ".coulomb", f.coulomb, false);
    // Given velocities must be positive and at least 1e-9 rad/s; at run time where they act.
    auto velocity = [&](const char* key, const Quantity& q, bool acts) {
      const bool is_given = given(ff + "." + key);
      if (is_given) sign(ff + "." + key, q, true).at_run_time = false;
      if (!is_given && !acts) return;
      RangeRule& r =
          add(ff + "." + key, {{1, false, q}, {-kMinFrictionVelocity, true, {}}}, false,
              ff + "." + key + " must be at least 1e-9 rad/s",
              "must be at least 1e-9 rad/s (tanh(w/vs) becomes a step that no integrator follows), "
              "got " +
                  shown(s_, q));
      r.at_parse = is_given;
      r.at_run_time = acts;
    };
    velocity("velocity_scale", f.velocity_scale, f.has_coulomb);
    if (given(ff + ".stribeck_static"))
      sign(ff + ".stribeck_static", f.stribeck_static, false).at_run_time = false;
    velocity("stribeck_velocity", f.stribeck_velocity, f.has_stribeck);
    add(ff + ".stribeck_static", {{1, false, f.stribeck_static}, {-1, false, f.coulomb}}, false,
        ff + ".stribeck_static must not be below coulomb",
        "the breakaway level Fs (" + std::to_string(f.stribeck_static.value) +
            ") must not be below the Coulomb level Fc (" + std::to_string(f.coulomb.value) + ")")
        .at_run_time = f.has_stribeck;
  }

 private:
  const Scene& s_;
  std::function<bool(const std::string&)> given_;
};

}  // namespace

std::vector<RangeRule> range_rules(const Scene& scene,
                                   const std::function<bool(const std::string&)>& given) {
  RuleTable t(scene, given);
  t.base();
  for (int i = 0; i < scene.num_links(); ++i) {
    t.link(i);
    if (scene.has_gear(i)) t.gear(*scene.gears[i], scene.links[i], i);
    if (scene.has_friction() && scene.friction[i]) t.friction(*scene.friction[i], i);
  }
  return t.rules;
}

}  // namespace spacearm
