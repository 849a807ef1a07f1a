#include "planar_model.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

#include "numeric_outputs.hpp"
#include "parameter_checks.hpp"
#include "parameter_rules.hpp"
#include "planar_chain.hpp"
#include "planar_expressions.hpp"

namespace spacearm {

namespace {

// Each run-time parameter's index in params, by name.
std::map<std::string, int> parameter_index(const Scene& scene) {
  std::map<std::string, int> index;
  for (size_t i = 0; i < scene.parameters.size(); ++i)
    index[scene.parameters[i].name] = static_cast<int>(i);
  return index;
}

// The numbers double precision must hold together (value_span.hpp): masses, inertias, lengths,
// gear ratios, motor inertias and stiffnesses, each a literal or a run-time parameter.
std::vector<SpanField> span_fields(const Scene& scene) {
  const std::map<std::string, int> index = parameter_index(scene);
  std::vector<SpanField> fields;
  auto add = [&](const std::string& field, const Quantity& q) {
    fields.push_back({field, q.value, q.is_parameter() ? index.at(q.parameter) : -1});
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
  return fields;
}

}  // namespace

ModelFacts planar_facts(const Scene& scene) {
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
  for (int j = 0; j < scene.num_links(); ++j)
    facts.motor_angle_slots.push_back(scene.has_gear(j) && !scene.is_flexible(j));
  facts.dims = scene.dimensions();
  facts.free_floating = scene.free_floating();
  facts.num_base = scene.num_base();
  facts.geared = scene.geared();
  facts.coordinate_names = scene.coordinate_names();
  facts.parameter_names = parameter_names(scene.parameters);
  facts.nominal_parameters = nominal_values(scene.parameters);
  facts.scene_hash = "fnv1a64:" + content_hash(scene.content);
  facts.formulation = to_string(scene.formulation);
  for (const auto& o : output_registry()) {
    if (scene.wants(o.id)) facts.outputs.push_back(o.id);
    if (scene.lanes.count(o.id)) facts.lanes.push_back(o.id);
  }
  add_parameter_checks(range_rules(scene), facts);
  facts.span_fields = span_fields(scene);
  return facts;
}

DerivedModel planar_derived_model(const SymbolicModel& model) {
  const Scene& scene = model.scene;
  DerivedModel derived;
  derived.facts = planar_facts(scene);
  derived.closed_forms = &model;
  derived.closed_form_builder = [&model, dims = derived.facts.dims,
                                 free = derived.facts.free_floating](bool body_rates) {
    return planar_builder(model, dims, free, body_rates);
  };
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

}  // namespace spacearm
