#include "planar_scene.hpp"

#include "emitted_text.hpp"
#include "parameter_rules.hpp"
#include "yaml_reader.hpp"

#include <yaml-cpp/eventhandler.h>
#include <yaml-cpp/yaml.h>

#include <cfloat>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <functional>
#include <regex>
#include <sstream>

namespace spacearm {

namespace {

// Names the emitted code or the emitter uses itself (coordinates, velocities, trig and
// rate symbols, temporaries, namespaces), and every name C++ or the included headers'
// macros would reinterpret: not allowed as scene or parameter names.
bool is_reserved(const std::string& s) {
  static const std::regex generated(
      "(x0|y0|x0d|y0d|q|qd|T|params|q[0-9]+d?|qm[0-9]+d?|c[0-9]+(_[0-9]+)?|s[0-9]+(_[0-9]+)?|Omega["
      "0-9]+|t[0-9]+)");
  static const std::set<std::string> names = {
      "std", "Eigen", "spacearm", "models", "Model", "I", "Pi", "Euler", "Catalan", "sin", "cos",
      "pow", "sqrt",
      // the generated sources' sin/cos helpers (cpp_printer.cpp) and their macro
      "sincos_batch", "sincos4", "spacearm_double4", "SPACEARM_VECTOR_TRIG"};
  return std::regex_match(s, generated) || names.count(s) != 0 || is_cpp_reserved(s);
}

using Reader = YamlReader;

}  // namespace

std::vector<Parameter> read_scene_parameters(const YamlReader& r, const YAML::Node& ps) {
  std::vector<Parameter> parameters;
  if (!ps.IsDefined() || ps.IsNull()) return parameters;
  if (!ps.IsMap())
    r.fail("parameters", "expected a mapping of parameter name to nominal value, e.g. {p: 1.0}",
           ps);
  std::set<std::string> seen;
  for (const auto& kv : ps) {
    const std::string pname = r.key_text(kv.first, "parameters");
    const std::string field = "parameters." + pname;
    if (!is_identifier(pname))
      r.fail(field, "parameter name '" + pname + "' is not an identifier", kv.first);
    if (is_reserved(pname))
      r.fail(field,
             "parameter name '" + pname +
                 "' is reserved (a coordinate, a generated symbol or a C++ keyword)",
             kv.first);
    if (!seen.insert(pname).second)
      r.fail(field, "parameter '" + pname + "' given more than once", kv.first);
    Parameter p{pname, r.quantity(kv.second, field)};
    if (p.nominal.is_parameter())
      r.fail(field, "nominal value must be a number, got '" + p.nominal.parameter + "'", kv.second);
    parameters.push_back(p);
  }
  return parameters;
}

namespace {

void read_pair(const Reader& r, const YAML::Node& n, const std::string& field, Quantity out[2]) {
  if (!n.IsSequence() || n.size() != 2) r.fail(field, "expected a list of two numbers [x, y]", n);
  out[0] = r.quantity(n[0], field + "[0]");
  out[1] = r.quantity(n[1], field + "[1]");
}

Gear read_gear(const Reader& r, const YAML::Node& n, const std::string& field) {
  r.check_keys(n, field,
               {"ratio", "motor_inertia", "compensate_link_inertia", "rotor_coupling", "stiffness",
                "damping"});
  Gear g;
  g.ratio = r.quantity(r.require(n, "ratio", field), field + ".ratio");
  g.motor_inertia = r.quantity(r.require(n, "motor_inertia", field), field + ".motor_inertia");
  if (n["stiffness"].IsDefined()) g.stiffness = r.quantity(n["stiffness"], field + ".stiffness");
  if (n["damping"].IsDefined()) g.damping = r.quantity(n["damping"], field + ".damping");
  if (n["compensate_link_inertia"].IsDefined()) {
    const auto& c = n["compensate_link_inertia"];
    try {
      g.compensate_link_inertia = c.as<bool>();
    } catch (const YAML::Exception&) {
      r.fail(field + ".compensate_link_inertia",
             "expected true or false, got '" +
                 (c.IsScalar() ? c.Scalar() : std::string("a non-scalar")) + "'",
             c);
    }
  }
  if (n["rotor_coupling"].IsDefined()) {
    const auto& c = n["rotor_coupling"];
    const std::string v = c.IsScalar() ? c.Scalar() : "";
    if (v == "exact" || v == "armature") {
      g.armature = v == "armature";
    } else if (c.IsScalar()) {
      // A coupling factor c: a run-time parameter, or a number (in [0, 1]: read_gears).
      if (!is_decimal(v) && !is_identifier(v))
        r.fail(field + ".rotor_coupling",
               "expected 'exact', 'armature' or a coupling factor in [0, 1] (a number or a "
               "parameter: 1 exact, 0 armature)",
               c);
      g.coupling = r.quantity(c, field + ".rotor_coupling");
    } else {
      r.fail(field + ".rotor_coupling",
             "expected 'exact', 'armature' or a coupling factor in [0, 1], got a non-scalar", c);
    }
  }
  return g;
}

}  // namespace

const char* to_string(Formulation f) {
  switch (f) {
    case Formulation::closed:
      return "closed";
    case Formulation::recursive:
      return "recursive";
    case Formulation::automatic:
      break;
  }
  return "auto";
}

bool Scene::geared() const {
  for (const auto& g : gears)
    if (g) return true;
  return false;
}

bool Scene::has_friction() const {
  for (const auto& f : friction)
    if (f) return true;
  return false;
}

bool Scene::has_gear(int joint) const { return !gears.empty() && gears.at(joint).has_value(); }

bool Scene::is_flexible(int joint) const { return has_gear(joint) && gears[joint]->flexible(); }

int Scene::num_flexible() const {
  int count = 0;
  for (int j = 0; j < num_links(); ++j) count += is_flexible(j);
  return count;
}

int Scene::motor_coordinate(int joint) const {
  if (!is_flexible(joint)) return joint_coordinate(joint);
  int before = 0;
  for (int j = 0; j < joint; ++j) before += is_flexible(j);
  return num_base() + num_links() + before;
}

unsigned Scene::features() const {
  return (free_floating() ? needs::free_base : 0u) |
         (num_flexible() == 0 ? needs::rigid_joints : needs::springs) |
         (has_friction() ? needs::friction : 0u);
}

std::vector<std::string> Scene::coordinate_names() const {
  std::vector<std::string> names;
  if (free_floating()) names = {"x0", "y0", "q0"};
  for (int j = 0; j < num_links(); ++j)
    names.push_back((has_gear(j) && !is_flexible(j) ? "qm" : "q") + std::to_string(j + 1));
  for (int j = 0; j < num_links(); ++j)
    if (is_flexible(j)) names.push_back("qm" + std::to_string(j + 1));
  return names;
}

std::string content_hash(const std::string& text) {
  std::uint64_t h = 14695981039346656037ull;
  for (unsigned char c : text) {
    h ^= c;
    h *= 1099511628211ull;
  }
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(h));
  return buf;
}

namespace {

// Reads a scene's fields into a Scene, in the order in which they may refer to each other
// (parameters first). Every error names the field (Reader::fail).
class SceneReader {
 public:
  SceneReader(const Reader& r, const YAML::Node& root, const std::string& source_name)
      : r(r), root(root), source_name(source_name) {}

  Scene read(const std::string& yaml_text) {
    if (!root.IsMap()) r.fail("", "expected a mapping at the top level");
    // A spatial scene (spatial_scene.hpp) reaching a command that takes planar ones only.
    if (root["space"] && root["space"].IsScalar() && root["space"].Scalar() == "spatial")
      r.fail("space",
             "a spatial arm, which this reader of planar scenes does not take (every spacearm "
             "command and Python's load read it through ModelRecipe)",
             root["space"]);
    r.check_keys(root, "",
                 {"name", "description", "base", "links", "gears", "friction", "parameters",
                  "outputs", "lanes", "formulation"});
    s.source_path = source_name;
    s.content = yaml_text;
    read_name();
    read_parameters();  // first: fields may refer to them
    read_base();
    read_links();
    read_gears();
    read_friction();
    check_ranges();
    read_formulation();  // before the outputs: it decides which are affordable
    coupling_formulation();
    read_outputs();
    read_lanes();
    declared->refuse_unused(root["parameters"]);
    return s;
  }

 private:
  const Reader& r;
  const YAML::Node& root;
  const std::string& source_name;
  Scene s;
  std::optional<DeclaredParameters> declared;  // from read_parameters() on
  std::map<std::string, YAML::Node> nodes;     // by field, for the range rules' errors
  // "gears[1]" -> "gears" where one mapping gives every joint's gear (per_joint).
  std::map<std::string, std::string> joint_fields;
  std::vector<std::function<void()>> after_ranges;  // checks that follow the range rules

  // A rule's field ("gears[1].ratio") as the scene file spells it ("gears.ratio" where one
  // mapping gives every joint's gear).
  std::string spelt(const std::string& field) const {
    const size_t end = field.find(']');
    if (end == std::string::npos) return field;
    const auto it = joint_fields.find(field.substr(0, end + 1));
    return it == joint_fields.end() ? field : it->second + field.substr(end + 1);
  }

  void read_name() {
    const YAML::Node name = r.require(root, "name", "");
    if (!name.IsScalar() || !is_identifier(r.bounded(name, "name").Scalar()))
      r.fail("name",
             "expected a C++ identifier (letters, digits, _), got '" +
                 (name.IsScalar() ? name.Scalar() : std::string("a non-scalar")) + "'",
             name);
    s.name = name.Scalar();
    if (s.name.size() > 64)
      r.fail("name",
             "is " + std::to_string(s.name.size()) +
                 " characters long, at most 64 (it names files and a namespace)",
             name);
    if (is_reserved(s.name))
      r.fail("name",
             "'" + s.name +
                 "' is reserved (a C++ keyword, a macro of the generated code's headers or a "
                 "generated name)",
             name);
    if (root["description"].IsDefined()) {
      if (!root["description"].IsScalar())
        r.fail("description", "expected text", root["description"]);
      s.description = root["description"].Scalar();
      if (s.description.size() > 4000)
        r.fail("description",
               "text is too long (" + std::to_string(s.description.size()) +
                   " characters, at most 4000)",
               root["description"]);
    }
  }

  void read_parameters() {
    s.parameters = read_scene_parameters(r, root["parameters"]);
    declared.emplace(r, s.parameters);
  }

  // Resolves a quantity's value (a parameter's nominal one) and keeps its node: its range is
  // checked with the others' (check_ranges).
  Quantity resolved(Quantity q, const std::string& field, const YAML::Node& node) {
    nodes[field] = node;
    return declared->resolved(std::move(q), field, node);
  }
  Quantity number(const YAML::Node& map, const std::string& key, const std::string& field) {
    const YAML::Node n = r.require(map, key, field);
    const std::string path = field + "." + key;
    return resolved(r.quantity(n, path), path, n);
  }

  // The range rules (parameter_rules.hpp) at the literal and nominal values, in their order;
  // then the checks that follow them (after_ranges) and the warning of a gear that speeds up.
  void check_ranges() {
    const auto given = [this](const std::string& field) { return nodes.count(spelt(field)) != 0; };
    for (const RangeRule& rule : range_rules(s, given)) {
      if (!rule.at_parse || rule.holds()) continue;
      const auto node = nodes.find(spelt(rule.node_field.empty() ? rule.field : rule.node_field));
      r.fail(spelt(rule.field), rule.literal_message, node == nodes.end() ? root : node->second);
    }
    for (const auto& check : after_ranges) check();
    for (int i = 0; i < s.num_links(); ++i)
      if (s.has_gear(i) && s.gears[i]->ratio.value < 1.0)
        std::fprintf(stderr,
                     "warning: scene '%s', field '%s': %g < 1 (a speed-up, not a reduction)\n",
                     source_name.c_str(), spelt("gears[" + std::to_string(i) + "].ratio").c_str(),
                     s.gears[i]->ratio.value);
  }
  void pair(const YAML::Node& map, const std::string& key, const std::string& field,
            Quantity out[2]) {
    const YAML::Node n = r.require(map, key, field);
    const std::string path = field + "." + key;
    read_pair(r, n, path, out);
    for (int k = 0; k < 2; ++k)
      out[k] = resolved(out[k], path + "[" + std::to_string(k) + "]", n[k]);
  }

  void read_base() {
    const YAML::Node base = r.require(root, "base", "");
    r.check_keys(base, "base", {"type", "mass", "inertia", "mount"});
    const YAML::Node type = r.require(base, "type", "base");
    const std::string type_name = type.IsScalar() ? type.Scalar() : "";
    if (type_name == "free_floating") {
      s.base.type = BaseType::free_floating;
      s.base.mass = number(base, "mass", "base");
      s.base.inertia = number(base, "inertia", "base");
    } else if (type_name == "fixed") {
      s.base.type = BaseType::fixed;
      if (base["mass"].IsDefined()) s.base.mass = number(base, "mass", "base");
      if (base["inertia"].IsDefined()) s.base.inertia = number(base, "inertia", "base");
    } else {
      r.fail("base.type", "expected 'free_floating' or 'fixed', got '" + type_name + "'", type);
    }
    pair(base, "mount", "base", s.base.mount);
  }

  void read_links() {
    const YAML::Node links = r.require(root, "links", "");
    if (!links.IsSequence()) r.fail("links", "expected a list of links", links);
    if (links.size() == 0) r.fail("links", "needs at least one link, got 0", links);
    if (links.size() > static_cast<size_t>(kMaxLinks))
      r.fail("links",
             "at most " + std::to_string(kMaxLinks) + " links are supported, got " +
                 std::to_string(links.size()),
             links);
    for (size_t i = 0; i < links.size(); ++i) {
      const std::string field = "links[" + std::to_string(i) + "]";
      const YAML::Node l = links[i];
      r.check_keys(l, field, {"mass", "inertia", "length", "com"});
      Link link;
      link.mass = number(l, "mass", field);
      link.inertia = number(l, "inertia", field);
      link.length = number(l, "length", field);
      pair(l, "com", field, link.com);
      s.links.push_back(link);
    }
  }

  // Per-joint entries: one mapping for all joints, or a list with one entry per joint where
  // null leaves a joint without it. Returns (node, field) per joint; a null node for none.
  std::vector<std::pair<YAML::Node, std::string>> per_joint(const std::string& key) {
    std::vector<std::pair<YAML::Node, std::string>> entries;
    const YAML::Node g = root[key];
    if (!g.IsDefined() || g.IsNull()) return entries;
    if (g.IsMap()) {
      for (size_t i = 0; i < s.links.size(); ++i) {
        entries.push_back({g, key});
        joint_fields[key + "[" + std::to_string(i) + "]"] = key;  // one mapping for all joints
      }
    } else if (g.IsSequence()) {
      if (g.size() != s.links.size())
        r.fail(key,
               "expected one entry per link (" + std::to_string(s.links.size()) + "), got " +
                   std::to_string(g.size()),
               g);
      for (size_t i = 0; i < g.size(); ++i)
        entries.push_back({g[i], key + "[" + std::to_string(i) + "]"});
    } else {
      r.fail(key, "expected a mapping (all joints) or a list (one per joint, null for none)", g);
    }
    return entries;
  }

  void read_gears() {
    const auto entries = per_joint("gears");
    for (size_t i = 0; i < entries.size(); ++i) {
      const auto& [node, field] = entries[i];
      if (node.IsNull()) {
        s.gears.emplace_back();
        continue;
      }
      nodes[field] = node;
      Gear gear = read_gear(r, node, field);
      gear.ratio = resolved(gear.ratio, field + ".ratio", node["ratio"]);
      gear.motor_inertia =
          resolved(gear.motor_inertia, field + ".motor_inertia", node["motor_inertia"]);
      if (gear.coupling) {
        if (gear.coupling->is_parameter() && !declared->declared(gear.coupling->parameter))
          r.fail(field + ".rotor_coupling",
                 std::string("expected 'exact', 'armature' or a coupling factor (a number in "
                             "[0, 1], or a parameter declared under 'parameters'), got '") +
                     gear.coupling->parameter + "'",
                 node["rotor_coupling"]);
        gear.coupling = resolved(*gear.coupling, field + ".rotor_coupling", node["rotor_coupling"]);
      }
      flexibility(gear, node, field);
      s.gears.push_back(gear);
    }
    if (!entries.empty() && !s.geared())
      r.fail("gears", "every entry is null: leave 'gears' out for a model without gears",
             root["gears"]);
  }

  // A flexible joint needs a rotor (with I_m = 0 its motor coordinate has no inertia and M is
  // singular) and a spring for its damper.
  void flexibility(Gear& gear, const YAML::Node& node, const std::string& field) {
    if (gear.damping && !gear.stiffness)
      r.fail(field + ".damping", "a damper needs a spring: give 'stiffness' too", node["damping"]);
    if (!gear.stiffness) return;
    gear.stiffness = resolved(*gear.stiffness, field + ".stiffness", node["stiffness"]);
    if (gear.damping) gear.damping = resolved(*gear.damping, field + ".damping", node["damping"]);
  }

  void read_friction() {
    const auto entries = per_joint("friction");
    for (const auto& [node, field] : entries) {
      if (node.IsNull()) {
        s.friction.emplace_back();
        continue;
      }
      s.friction.push_back(friction(node, field));
    }
    if (!entries.empty() && !s.has_friction())
      r.fail("friction", "every entry is null: leave 'friction' out for no friction",
             root["friction"]);
  }

  // f(w) = b w + Fc tanh(w/vs) + (Fs - Fc) exp(-(w/vst)^2) tanh(w/vs); missing fields are 0,
  // Fs defaults to Fc. vs is needed by any tanh term, vst by a Stribeck hump (Fs != Fc).
  Friction friction(const YAML::Node& n, const std::string& field) {
    r.check_keys(n, field,
                 {"viscous", "coulomb", "velocity_scale", "stribeck_static", "stribeck_velocity"});
    auto optional = [&](const char* key) {
      Quantity q;
      q.literal = "0";
      if (n[key].IsDefined()) q = number(n, key, field);
      return q;
    };
    Friction f;
    f.viscous = optional("viscous");
    f.coulomb = optional("coulomb");
    f.velocity_scale = optional("velocity_scale");
    f.stribeck_static = n["stribeck_static"].IsDefined() ? optional("stribeck_static") : f.coulomb;
    f.stribeck_velocity = optional("stribeck_velocity");
    auto present = [](const Quantity& q) { return q.is_parameter() || q.value != 0; };
    f.has_coulomb = present(f.coulomb) || present(f.stribeck_static);
    f.has_stribeck = n["stribeck_static"].IsDefined() &&
                     (f.stribeck_static.is_parameter() || f.coulomb.is_parameter() ||
                      f.stribeck_static.value != f.coulomb.value);
    // After the range rules: a breakaway level below Coulomb's is the first thing to fix.
    after_ranges.push_back([this, f, n, field] {
      if (f.has_coulomb && !n["velocity_scale"].IsDefined())
        r.fail(field + ".velocity_scale",
               "Coulomb or static friction needs a positive velocity_scale vs [rad/s] (tanh(w/vs) "
               "smooths sign(w))",
               n);
      if (f.has_stribeck && !n["stribeck_velocity"].IsDefined())
        r.fail(field + ".stribeck_velocity",
               "a Stribeck hump (stribeck_static differs from coulomb) needs a positive "
               "stribeck_velocity [rad/s]",
               n);
    });
    return f;
  }

  // A rotor coupling factor exists in the closed form only (the recursive algorithms carry a
  // rotor on the previous body whole or not at all): auto becomes closed, recursive is refused.
  void coupling_formulation() {
    for (size_t i = 0; i < s.gears.size(); ++i) {
      if (!s.gears[i] || !s.gears[i]->coupling) continue;
      const std::string field = spelt("gears[" + std::to_string(i) + "].rotor_coupling");
      if (s.formulation == Formulation::recursive || s.num_links() > kMaxClosedFormLinks)
        r.fail(field,
               "a coupling factor needs the closed form ('formulation: closed', up to " +
                   std::to_string(kMaxClosedFormLinks) + " links); use exact or armature",
               root["gears"]);
      s.formulation = Formulation::closed;
      return;
    }
  }

  void read_formulation() {
    const YAML::Node f = root["formulation"];
    if (!f.IsDefined()) return;
    const std::string v = f.IsScalar() ? r.bounded(f, "formulation").Scalar() : "";
    for (Formulation k : {Formulation::closed, Formulation::recursive, Formulation::automatic})
      if (v == to_string(k)) {
        s.formulation = k;
        if (k == Formulation::closed && s.num_links() > kMaxClosedFormLinks)
          r.fail("formulation",
                 "'closed' is derived up to " + std::to_string(kMaxClosedFormLinks) +
                     " links (its cost doubles about every two links: 16 s at 12, over 2 "
                     "minutes and 1 GB at 20), got " +
                     std::to_string(s.num_links()) + " links; use 'auto' or 'recursive'",
                 f);
        return;
      }
    r.fail("formulation",
           "expected 'closed', 'recursive' or 'auto', got '" +
               (f.IsScalar() ? v : std::string("a non-scalar")) + "'",
           f);
  }

  // Outputs: all unless the scene lists a subset.
  void read_outputs() {
    if (root["outputs"].IsDefined()) {
      const YAML::Node outs = root["outputs"];
      if (!outs.IsSequence() || outs.size() == 0)
        r.fail("outputs", "expected a non-empty list of output names", outs);
      for (size_t i = 0; i < outs.size(); ++i) {
        const std::string n = outs[i].IsScalar() ? outs[i].Scalar() : "";
        auto o = output_from_string(n);
        if (!o)
          r.fail("outputs[" + std::to_string(i) + "]",
                 "unknown output '" + n + "' (known: " + output_names() + ")", outs[i]);
        if (!s.outputs.insert(*o).second)
          r.fail("outputs[" + std::to_string(i) + "]", "output '" + n + "' listed twice", outs[i]);
      }
    } else {
      for (const OutputInfo& o : output_registry())
        if (emitted_by_default(o, s.closed_form_affordable()) &&
            missing_feature(o.needs, s.features()).empty())
          s.outputs.insert(o.id);
    }
    for (Output o : s.outputs) {
      if (const std::string why = missing_feature(info(o).needs, s.features()); !why.empty())
        r.fail("outputs", "'" + to_string(o) + "' " + why, root["outputs"]);
    }
  }

  // Lanes: outputs the scene emits, also for four states per call.
  void read_lanes() {
    const YAML::Node n = root["lanes"];
    if (!n.IsDefined()) return;
    if (!n.IsSequence() || n.size() == 0)
      r.fail("lanes", "expected a non-empty list of output names", n);
    for (size_t i = 0; i < n.size(); ++i) {
      const std::string field = "lanes[" + std::to_string(i) + "]";
      if (!n[i].IsScalar()) r.fail(field, "expected an output name", n[i]);
      const std::string name = n[i].Scalar();
      const std::optional<Output> o = output_from_string(name);
      if (!o || !s.outputs.count(*o)) r.fail(field, lanes_error(name, o.has_value()), n[i]);
      if (!s.lanes.insert(*o).second) r.fail(field, "output '" + name + "' listed twice", n[i]);
    }
  }
};

Scene read_scene(const Reader& r, const YAML::Node& root, const std::string& yaml_text,
                 const std::string& source_name) {
  return SceneReader(r, root, source_name).read(yaml_text);
}

}  // namespace

Scene parse_scene(const std::string& yaml_text, const std::string& source_name) {
  const Reader r("scene", source_name, [](const std::string& m) { throw SceneError(m); });
  const YAML::Node root = r.load(yaml_text);
  try {
    return read_scene(r, root, yaml_text, source_name);
  } catch (const YAML::Exception& e) {
    // A YAML shape the checks above did not foresee: still an error that names the file,
    // never a crash. The fuzzer treats reaching this line as a finding.
    r.fail("", std::string("unexpected YAML structure: ") + e.what());
  }
}

std::string read_scene_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw SceneError("scene '" + path + "': cannot open file");
  // Scene files are a few kilobytes: read at most 1 MB (a pipe still works; /dev/zero or a
  // huge file is refused instead of filling the memory).
  constexpr std::streamsize kMaxSceneBytes = 1 << 20;
  std::string text(kMaxSceneBytes + 1, '\0');
  in.read(text.data(), kMaxSceneBytes + 1);
  text.resize(static_cast<size_t>(in.gcount()));
  if (static_cast<std::streamsize>(text.size()) > kMaxSceneBytes)
    throw SceneError("scene '" + path + "': larger than 1 MB; scene files are a few kilobytes");
  return text;
}

Scene load_scene(const std::string& path) { return parse_scene(read_scene_file(path), path); }

}  // namespace spacearm
