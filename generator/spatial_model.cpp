#include "spatial_model.hpp"

#include "recursive_algorithms.hpp"
#include "scene.hpp"

namespace spacearm {

namespace {

// The coordinate names: the base's origin and quaternion (MuJoCo's free joint), then per joint
// its motor angle qm_i where it is geared (qm = p q), else q_i.
std::vector<std::string> coordinate_names(const spatial::ChainDescription& c) {
  std::vector<std::string> names;
  if (c.free_base) names = {"x0", "y0", "z0", "qw0", "qx0", "qy0", "qz0"};
  for (size_t j = 0; j < c.links.size(); ++j)
    names.push_back((c.links[j].gear.present ? "qm" : "q") + std::to_string(j + 1));
  return names;
}

}  // namespace

ModelFacts spatial_facts(const SpatialScene& scene) {
  const spatial::ChainDescription& c = scene.chain;
  ModelFacts f;
  f.name = scene.name;
  f.description = "spatial arm, " + std::to_string(c.links.size()) + " revolute joints";
  f.coordinates_note = c.free_base ? " (MuJoCo's free joint: origin, quaternion w x y z)" : "";
  f.dims = spatial::Chain<double>::dimensions(c);
  f.free_floating = c.free_base;
  f.num_base = c.num_base();
  f.quaternion_offset = c.free_base ? 3 : -1;
  f.coordinate_names = coordinate_names(c);
  for (const auto& l : c.links) {
    f.geared = f.geared || l.gear.present;
    f.motor_angle_slots.push_back(l.gear.present);
  }
  f.scene_hash = "fnv1a64:" + content_hash(scene.content);
  f.formulation = "recursive";
  f.features = (c.free_base ? needs::free_base : 0u) | needs::rigid_joints;
  f.outputs = spatial_outputs(scene);
  return f;
}

namespace {

// How the spatial chain gives output o (the banner's and --stats' words): as the planar chain
// does, with its end effector from forward kinematics and the compositions with M_bb's solve.
const char* spatial_algorithm(Output o) {
  if (o == Output::end_effector_pose || o == Output::end_effector_jacobian)
    return "forward kinematics";
  if (o == Output::generalized_jacobian) return "CRBA, forward kinematics, base solve";
  if (o == Output::free_base_inverse_dynamics) return "CRBA, RNEA, base solve";
  return recursive_algorithm(o);
}

}  // namespace

std::vector<Output> spatial_outputs(const SpatialScene& scene) {
  if (!scene.outputs.empty()) return scene.outputs;
  // As in the plane, the registry's defaults (the state Jacobian and Mdot only where a scene
  // asks for them).
  std::vector<Output> outputs;
  for (const OutputInfo& o : output_registry())
    if (spatial_output(o.id, scene.chain.free_base) && o.by_default) outputs.push_back(o.id);
  return outputs;
}

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
  // The gear ratios: constants (1 where a joint has no gear).
  auto ratios = [&chain] {
    std::vector<double> p;
    for (const auto& l : chain.links) p.push_back(l.gear.present ? l.gear.ratio : 1.0);
    return p;
  };
  derived.gear_ratios = {
      "constant",
      [ratios](Program& p) {
        std::vector<SRef> r;
        for (double x : ratios()) r.push_back(p.constant(x));
        return std::vector<std::vector<SRef>>{r};
      },
      [ratios](const InputValues&) { return std::vector<std::vector<double>>{ratios()}; }};
  // The reference of every output: the chain in double (no composed outputs here).
  derived.reference = [&chain](Output o, const std::vector<Eigen::VectorXd>& inputs,
                               const Eigen::VectorXd&) {
    const OutputInfo& out = info(o);
    auto input = [&](const std::string& a, int i) {
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
