#include "spatial_model.hpp"

#include <cmath>

#include "parameter_checks.hpp"
#include "recursive_algorithms.hpp"
#include "spatial_chain.hpp"
#include "planar_scene.hpp"

namespace spacearm {

namespace {

// A rigid gear: joint j's slot holds its motor angle qm = p q.
bool motor_angle_slot(const spatial::Link& l) { return l.gear.present && !l.gear.flexible; }

// The coordinate names: the base's origin and quaternion (MuJoCo's free joint), then per joint
// its motor angle qm_i where a rigid gear drives it (qm = p q), else q_i; then qm_i of each
// flexible joint.
std::vector<std::string> coordinate_names(const spatial::ChainDescription& c) {
  std::vector<std::string> names;
  if (c.free_base) names = {"x0", "y0", "z0", "qw0", "qx0", "qy0", "qz0"};
  for (size_t j = 0; j < c.links.size(); ++j)
    names.push_back((motor_angle_slot(c.links[j]) ? "qm" : "q") + std::to_string(j + 1));
  for (size_t j = 0; j < c.links.size(); ++j)
    if (c.links[j].gear.present && c.links[j].gear.flexible)
      names.push_back("qm" + std::to_string(j + 1));
  return names;
}

// The numbers double precision must hold together (value_span.hpp): every body's mass and
// principal inertias, each joint's offset from its parent, gear ratios, rotor inertias and
// stiffnesses. links[i] is the link the i-th moving joint carries (a URDF's too), parts[k] a
// body welded to it.
std::vector<SpanField> span_fields(const spatial::ChainDescription& c) {
  std::vector<SpanField> fields;
  auto add = [&fields](const std::string& field, const Quantity& q) {
    fields.push_back({field, q.value, q.index});
  };
  auto body = [&add](const std::string& at, const spatial::Inertial& b) {
    add(at + ".mass", b.mass);
    for (const auto& [k, name] : {std::pair{0, "ixx"}, {3, "iyy"}, {5, "izz"}})
      add(at + ".inertia." + name, b.inertia[size_t(k)]);
  };
  if (c.free_base) body("base", c.base);
  for (size_t i = 0; i < c.links.size(); ++i) {
    const spatial::Link& l = c.links[i];
    const std::string at = "links[" + std::to_string(i) + "]";
    body(at, l);
    add(at + ".origin", std::sqrt(spatial::dot(l.origin_xyz, l.origin_xyz)));
    for (size_t k = 0; k < l.parts.size(); ++k)
      body(at + ".parts[" + std::to_string(k) + "]", l.parts[k].inertial);
    const spatial::Gear& g = l.gear;
    if (!g.present) continue;
    const std::string gear = "gears[" + std::to_string(i) + "]";
    add(gear + ".ratio", g.ratio);
    add(gear + ".rotor_inertia.axial", g.axial);
    add(gear + ".rotor_inertia.transverse", g.transverse);
    if (g.flexible) add(gear + ".stiffness", g.stiffness);
  }
  return fields;
}

}  // namespace

ModelFacts spatial_facts(const SpatialScene& scene) {
  const spatial::ChainDescription& c = scene.chain;
  ModelFacts f;
  f.name = scene.name;
  f.description = "spatial arm, " + std::to_string(c.links.size()) + " revolute joints";
  f.coordinates_note =
      std::string(c.free_base ? " (MuJoCo's free joint: origin, quaternion w x y z)" : "") +
      (c.num_flexible() ? " (q: link angles; qm: motor angles, qm = p q for a "
                          "rigid gear; a flexible joint's qm follows the joints)"
                        : "");
  f.dims = spatial::Chain<double>::dimensions(c);
  f.free_floating = c.free_base;
  f.num_base = c.num_base();
  f.quaternion_offset = c.free_base ? 3 : -1;
  f.coordinate_names = coordinate_names(c);
  const bool tree = !c.serial() || c.num_end_effectors() > 1;
  for (int i = 1; tree && i <= static_cast<int>(c.links.size()); ++i) {
    f.joint_names.push_back(size_t(i) <= scene.joint_names.size() ? scene.joint_names[i - 1]
                                                                  : "joint" + std::to_string(i));
    f.joint_parents.push_back(c.parent(i));
  }
  for (int e = 0; tree && e < c.num_end_effectors(); ++e)
    f.end_effector_bodies.push_back(c.end_effector_body(e));
  for (int e = 0; e < c.num_end_effectors(); ++e)
    f.end_effector_names.push_back(c.end_effector_name(e));
  for (const auto& l : c.links) {
    f.geared = f.geared || l.gear.present;
    f.motor_angle_slots.push_back(motor_angle_slot(l));
  }
  if (c.num_flexible())
    for (size_t j = 0; j < c.links.size(); ++j)
      f.actuated_coordinates.push_back(c.motor_coordinate(static_cast<int>(j)));
  f.scene_hash = "fnv1a64:" + content_hash(scene.content);
  f.formulation = "recursive";
  f.inertia_check = scene.inertia_check == InertiaRule::physical ? "physical" : "positive_definite";
  f.right_angles_snapped = scene.chain.exact_right_angles;
  f.features = spatial_features(scene);
  f.outputs = spatial_outputs(scene);
  for (Output o : f.outputs)
    if (std::count(scene.lanes.begin(), scene.lanes.end(), o)) f.lanes.push_back(o);
  f.parameter_names = parameter_names(scene.parameters);
  f.nominal_parameters = nominal_values(scene.parameters);
  add_parameter_checks(scene.run_time_rules, f);
  f.span_fields = span_fields(c);
  return f;
}

namespace {

// How the spatial chain gives output o (the banner's and --stats' words): as the planar chain
// does, with its end effector from forward kinematics and the compositions with M_bb's solve.
const char* spatial_algorithm(Output o) {
  if (o == Output::end_effector_pose || o == Output::end_effector_jacobian ||
      o == Output::joint_positions)
    return "forward kinematics";
  if (o == Output::joint_angles || o == Output::joint_rates) return "gear ratios";
  if (o == Output::generalized_jacobian) return "CRBA, forward kinematics, base solve";
  if (o == Output::free_base_inverse_dynamics) return "CRBA, RNEA, base solve";
  if (o == Output::friction_forces) return "friction law on the joint rates";
  if (o == Output::spring_damper_forces || o == Output::potential_energy)
    return "joint springs and dampers";
  return recursive_algorithm(o);
}

}  // namespace

DerivedModel spatial_derived_model(const SpatialScene& scene) {
  DerivedModel derived;
  derived.facts = spatial_facts(scene);
  derived.tries_recursive = true;
  const spatial::ChainDescription& chain = scene.chain;
  for (Output o : derived.facts.outputs)
    derived.recorded[o] = {
        spatial_algorithm(o),
        [&chain, o](Program& p) { return record_chain<spatial::Chain>(chain, o, p); },
        [&chain, o](const InputValues& input) {
          return evaluate_chain<spatial::Chain>(chain, o, input);
        }};
  // The gear ratios: constants (1 where a joint has no gear) or run-time parameters, as
  // number(x) and parameter(i) give them (recorded, or in double).
  auto ratios = [&chain](const auto& number, const auto& parameter) {
    std::vector<std::decay_t<decltype(number(1.0))>> r;
    for (const auto& l : chain.links)
      r.push_back(!l.gear.present                ? number(1.0)
                  : !l.gear.ratio.is_parameter() ? number(l.gear.ratio.value)
                                                 : parameter(l.gear.ratio.index));
    return std::vector<decltype(r)>{r};
  };
  derived.gear_ratios = {"constant",
                         [ratios](Program& p) {
                           return ratios([&p](double x) { return p.constant(x); },
                                         [&p](int i) { return p.input("params", i); });
                         },
                         [ratios](const InputValues& input) {
                           return ratios([](double x) { return x; },
                                         [&input](int i) { return input("params", i); });
                         }};
  // The reference of every output: the chain in double (no composed outputs here).
  derived.reference = [&chain](Output o, const std::vector<Eigen::VectorXd>& inputs,
                               const Eigen::VectorXd& params) {
    const OutputInfo& out = info(o);
    auto input = [&](const std::string& a, int i) {
      if (a == "params") return params[i];
      for (size_t k = 0; k < out.inputs.size(); ++k)
        if (info(out.inputs[k]).name == a) return inputs[k][i];
      return 0.0;
    };
    const Dimensions dims = spatial::Chain<double>::dimensions(chain);
    std::vector<Eigen::MatrixXd> results;
    const auto values = evaluate_chain<spatial::Chain>(chain, o, input);
    for (size_t r = 0; r < values.size(); ++r) {
      const int rows = dims(out.results[r].rows), cols = dims(out.results[r].cols);
      results.push_back(Eigen::Map<const Eigen::Matrix<double, -1, -1, Eigen::RowMajor>>(
          values[r].data(), rows, cols));
    }
    return results;
  };
  return derived;
}

}  // namespace spacearm
