#include "planar_model.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

#include "numeric_outputs.hpp"
#include "planar_chain.hpp"

namespace spacearm {

namespace {

// The smallest and largest non-zero magnitudes among the scene's masses, inertias, lengths,
// gear ratios, motor inertias and stiffnesses (nominal values), by field; empty when they span
// less than six decades. Double precision cannot hold a model whose numbers span too far.
std::string value_span(const Scene& scene) {
  std::vector<std::pair<std::string, double>> values;
  auto add = [&](const std::string& field, const Quantity& q) {
    if (q.value != 0) values.push_back({field, std::abs(q.value)});
  };
  if (scene.free_floating())
    add("base.mass", scene.base.mass), add("base.inertia", scene.base.inertia);
  for (int i = 0; i < scene.num_links(); ++i) {
    const std::string l = "links[" + std::to_string(i) + "]",
                      g = "gears[" + std::to_string(i) + "]";
    add(l + ".mass", scene.links[i].mass);
    add(l + ".inertia", scene.links[i].inertia);
    add(l + ".length", scene.links[i].length);
    if (!scene.has_gear(i)) continue;
    add(g + ".ratio", scene.gears[i]->ratio);
    add(g + ".motor_inertia", scene.gears[i]->motor_inertia);
    if (scene.gears[i]->stiffness) add(g + ".stiffness", *scene.gears[i]->stiffness);
  }
  if (values.empty()) return "";
  const auto [lo, hi] =
      std::minmax_element(values.begin(), values.end(),
                          [](const auto& a, const auto& b) { return a.second < b.second; });
  if (hi->second / lo->second < 1e6) return "";
  char text[200];
  std::snprintf(text, sizeof text, "%.0f decades, from %s = %g to %s = %g",
                std::floor(std::log10(hi->second / lo->second)), lo->first.c_str(), lo->second,
                hi->first.c_str(), hi->second);
  return text;
}

// The scene's range checks for quantities that depend on run-time parameters (positive
// mass, inertia, length, ratio and stiffness, non-negative motor inertia, damping and friction,
// positive compensated link inertia): the validation the scene parser does for literals,
// repeated at run time.
class ParameterChecks {
 public:
  ParameterChecks(const Scene& scene, ModelFacts& facts) : facts_(facts), p_(facts.checks_program) {
    for (size_t i = 0; i < scene.parameters.size(); ++i)
      index_[scene.parameters[i].name] = static_cast<int>(i);
    if (scene.free_floating()) {
      check(scene.base.mass, true, "base.mass must be positive");
      check(scene.base.inertia, true, "base.inertia must be positive");
    }
    for (int i = 0; i < scene.num_links(); ++i) {
      const Link& l = scene.links[i];
      const std::string f = "links[" + std::to_string(i) + "]";
      check(l.mass, true, f + ".mass must be positive");
      check(l.inertia, true, f + ".inertia must be positive");
      check(l.length, true, f + ".length must be positive");
      if (scene.has_gear(i)) gear(*scene.gears[i], l, i);
      if (scene.has_friction() && scene.friction[i]) friction(*scene.friction[i], i);
    }
  }

 private:
  ModelFacts& facts_;
  Program& p_;
  std::map<std::string, int> index_;

  SRef value(const Quantity& q) {
    if (q.is_parameter()) return p_.input("params", index_.at(q.parameter));
    return q.value == 0 ? p_.zero() : p_.constant(q.value);
  }
  void check(bool uses_parameter, SRef v, bool strict, const std::string& what) {
    if (uses_parameter) facts_.checks.push_back({v, strict, what});
  }
  void check(const Quantity& q, bool strict, const std::string& what) {
    check(q.is_parameter(), value(q), strict, what);
  }

  void gear(const Gear& g, const Link& l, int i) {
    const std::string gf = "gears[" + std::to_string(i) + "]";
    check(g.ratio, true, gf + ".ratio must be positive");
    check(g.motor_inertia, g.flexible(),
          gf + (g.flexible() ? ".motor_inertia must be positive (a flexible joint)"
                             : ".motor_inertia must not be negative"));
    if (g.compensate_link_inertia)
      check(g.motor_inertia.is_parameter() || l.inertia.is_parameter(),
            p_.add({value(l.inertia), -value(g.motor_inertia)}), true,
            gf + ".motor_inertia must be smaller than the inertia of link " +
                std::to_string(i + 1) + " it compensates");
    if (g.stiffness) check(*g.stiffness, true, gf + ".stiffness must be positive");
    if (g.coupling) {
      check(*g.coupling, false, gf + ".rotor_coupling must be in [0, 1] (not negative)");
      check(g.coupling->is_parameter(), p_.add({p_.constant(1), -value(*g.coupling)}), false,
            gf + ".rotor_coupling must be in [0, 1] (not above 1)");
    }
    if (g.damping) check(*g.damping, false, gf + ".damping must not be negative");
  }

  void friction(const Friction& f, int i) {
    const std::string ff = "friction[" + std::to_string(i) + "]";
    check(f.viscous, false, ff + ".viscous must not be negative");
    check(f.coulomb, false, ff + ".coulomb must not be negative");
    auto at_least = [&](const Quantity& q, const std::string& what) {
      check(q.is_parameter(), p_.add({value(q), p_.constant(-kMinFrictionVelocity)}), false, what);
    };
    if (f.has_coulomb)
      at_least(f.velocity_scale, ff + ".velocity_scale must be at least 1e-9 rad/s");
    if (!f.has_stribeck) return;
    at_least(f.stribeck_velocity, ff + ".stribeck_velocity must be at least 1e-9 rad/s");
    check(f.stribeck_static.is_parameter() || f.coulomb.is_parameter(),
          p_.add({value(f.stribeck_static), -value(f.coulomb)}), false,
          ff + ".stribeck_static must not be below coulomb");
  }
};

ModelFacts model_facts(const Scene& scene) {
  ModelFacts facts;
  facts.name = scene.name;
  facts.description = scene.description;
  facts.coordinates_note =
      scene.num_flexible() ? " (q: link angles; qm: motor angles, qm = p q for a rigid gear, paper "
                             "eq. 12; a flexible joint's qm follows the joint slots)"
      : scene.geared()     ? " (motor angles qm = p q, paper eq. 12)"
                           : "";
  facts.features = scene.features();
  if (scene.num_flexible())
    for (int j = 0; j < scene.num_links(); ++j)
      facts.actuated_coordinates.push_back(scene.motor_coordinate(j));
  facts.dims = scene.dimensions();
  facts.free_floating = scene.free_floating();
  facts.num_base = scene.free_floating() ? 3 : 0;  // x0, y0, q0
  facts.passive_forces = (scene.features() & (needs::springs | needs::friction)) != 0;
  facts.geared = scene.geared();
  facts.coordinate_names = scene.coordinate_names();
  for (const auto& p : scene.parameters) {
    facts.parameter_names.push_back(p.name);
    facts.nominal_parameters.push_back(p.nominal.value);
  }
  facts.scene_hash = "fnv1a64:" + content_hash(scene.content);
  facts.formulation = to_string(scene.formulation);
  for (const auto& o : output_registry())
    if (scene.wants(o.id)) facts.outputs.push_back(o.id);
  ParameterChecks{scene, facts};
  return facts;
}

}  // namespace

DerivedModel planar_derived_model(const SymbolicModel& model) {
  const Scene& scene = model.scene;
  DerivedModel derived;
  derived.facts = model_facts(scene);
  derived.value_span = value_span(scene);
  derived.closed_forms = &model;
  derived.tries_recursive = scene.tries_recursive();
  for (const OutputInfo& o : output_registry()) {
    if (!has_recursive_form(o.id)) continue;
    derived.recorded[o.id] = {
        recursive_algorithm(o.id),
        [&scene, id = o.id](Program& p) { return record_recursive(scene, id, p); },
        [&scene, id = o.id](const InputValues& input) {
          return evaluate_recursive(scene, id, input);
        }};
  }
  derived.reference = [&model](Output o, const std::vector<Eigen::VectorXd>& inputs,
                               const Eigen::VectorXd& params) {
    return evaluate_output(model, o, inputs, params);
  };
  return derived;
}

LoweredModel lower(const SymbolicModel& model, const LowerOptions& options) {
  return lower(planar_derived_model(model), options);
}

}  // namespace spacearm
