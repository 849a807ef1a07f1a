#include "spatial_scene.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cstdio>
#include <optional>
#include <set>

#include "private_folder.hpp"
#include "planar_scene.hpp"
#include "text_numbers.hpp"
#include "urdf_reader.hpp"
#include "yaml_reader.hpp"

namespace spacearm {

namespace {

// A number for a message, as short as it reads ("%g": -1e-09, not -0.000000).
std::string number_text(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", v);
  return text;
}

// A tree's moving joints, and those on one path from the base (a chain's: 30, as in the plane).
// The generated code grows with their product (each joint's column of M walks its path).
constexpr int kMaxLinks = 60, kMaxDepth = 30;

// A body's inertia about its centre as its principal moments, and which rules it keeps.
struct PrincipalMoments {
  Eigen::Vector3d m;  // ascending
  bool positive_definite = false, physical = false;
  std::string text() const {
    return "principal moments " + number_text(m[0]) + ", " + number_text(m[1]) + ", " +
           number_text(m[2]);
  }
};

PrincipalMoments principal_moments(const spatial::Inertial& l) {
  const auto i = l.inertia_values();
  Eigen::Matrix3d I;
  I << i[0], i[1], i[2], i[1], i[3], i[4], i[2], i[4], i[5];
  PrincipalMoments p;
  p.m = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(I).eigenvalues();
  const double slack = 1e-12 * p.m.cwiseAbs().maxCoeff();  // a flat plate or a thin rod passes
  p.positive_definite = p.m.minCoeff() > 0;
  p.physical = p.positive_definite && p.m[0] + p.m[1] >= p.m[2] - slack;
  return p;
}

// Why `check` refuses a body's inertia ("" if it does not).
std::string inertia_problem(const PrincipalMoments& p, InertiaRule check) {
  if (check == InertiaRule::positive_definite)
    return p.positive_definite ? ""
                               : "not positive definite (" + p.text() + ": each must be positive)";
  return p.physical ? ""
                    : "not a physical inertia (" + p.text() +
                          ": each must be positive and at most the sum of the other two)";
}

// A given URDF link's field in the scene's errors: inertials.NAME (quoted unless an identifier).
std::string inertials_error_field(const std::string& link) {
  return "inertials." + (is_identifier(link) ? link : quoted_text(link));
}

// A field's name for a generated message (fixed text: a URDF link's name only where it is a
// short identifier, else the entry's index).
std::string inertials_field(const std::string& link, size_t index) {
  return is_identifier(link) && link.size() <= 64 ? "inertials." + link
                                                  : "inertials[" + std::to_string(index) + "]";
}

// A chain's needs:: bits (outputs.hpp): a free base; springs where a joint is flexible, else
// rigid joints; friction where a joint has some.
unsigned chain_features(const spatial::ChainDescription& chain) {
  const bool friction = std::any_of(chain.links.begin(), chain.links.end(),
                                    [](const spatial::Link& l) { return l.friction.present; });
  return (chain.free_base ? needs::free_base : 0u) |
         (chain.num_flexible() > 0 ? needs::springs : needs::rigid_joints) |
         (friction ? needs::friction : 0u);
}

class SpatialReader {
 public:
  explicit SpatialReader(const YamlReader& r) : r_(r) {}

  SpatialScene read(const YAML::Node& root, const std::string& text,
                    const UrdfFileReader& read_file) {
    r_.check_keys(root, "",
                  {"name", "description", "space", "base", "links", "urdf", "end_effector_link",
                   "end_effector_links", "gears", "friction", "end_effector", "outputs", "lanes",
                   "parameters", "inertials", "inertia_check", "snap_right_angles"});
    SpatialScene s;
    s.content = text;
    s.parameters = read_scene_parameters(r_, root["parameters"]);  // first: fields refer to them
    parameters_.emplace(r_, s.parameters);
    rules_ = &s.run_time_rules;
    s.name = r_.bounded(r_.require(root, "name", ""), "name").Scalar();
    if (!is_identifier(s.name)) r_.fail("name", "'" + s.name + "' is not an identifier");
    const std::string space = r_.bounded(r_.require(root, "space", ""), "space").Scalar();
    if (space != "spatial") r_.fail("space", "expected 'spatial', got '" + space + "'");
    if (root["inertia_check"]) read_inertia_check(root["inertia_check"], s);
    if (root["snap_right_angles"]) {
      const YAML::Node& n = root["snap_right_angles"];
      const std::string v = n.IsScalar() ? r_.bounded(n, "snap_right_angles").Scalar() : "";
      if (v != "true" && v != "false")
        r_.fail("snap_right_angles", "expected true or false, got " + quoted_text(v), n);
      snap_ = v == "true";
    }
    if (root["urdf"]) {
      read_urdf_chain(root, s, read_file);
    } else {
      for (const char* field : {"end_effector_link", "inertials"})
        if (root[field]) r_.fail(field, "names URDF links: needs field 'urdf'", root[field]);
      read_base(r_.require(root, "base", ""), s.chain);
      const YAML::Node links = r_.require(root, "links", "");
      if (!links.IsSequence() || links.size() < 1 || links.size() > kMaxLinks)
        r_.fail("links", "expected a list of 1 to " + std::to_string(kMaxLinks) + " links", links);
      for (size_t i = 0; i < links.size(); ++i)
        s.chain.links.push_back(read_link(links[i], "links[" + std::to_string(i) + "]"));
      read_tree(links, root["end_effector_links"], s.chain);
      check_depth(s.chain, links);
    }
    s.chain.exact_right_angles = snap_;
    if (root["gears"]) read_gears(root["gears"], s.chain);
    const bool from_urdf =
        root["friction"] && root["friction"].IsMap() && root["friction"]["from_urdf"];
    if (from_urdf)
      read_urdf_friction(root["friction"], s);
    else if (root["friction"])
      read_friction(root["friction"], s.chain);
    if (!from_urdf) note_ignored_dynamics(s);
    if (root["end_effector"]) read_end_effector_points(root["end_effector"], s.chain);
    if (root["outputs"]) s.outputs = read_outputs(root["outputs"], s.chain);
    if (root["lanes"]) s.lanes = read_lanes(root["lanes"], spatial_outputs(s));
    parameters_->refuse_unused(root["parameters"]);
    if (!not_physical_.empty()) s.warnings.push_back(accepted_text(not_physical_));
    name_joints_in_rules(s);
    return s;
  }

  // A run-time rule on a joint's gear or friction names the URDF's joint too, or says that one
  // mapping gives every joint: "gears[1].ratio (joint 'elbow') must be positive",
  // "gears.ratio (every joint) must be positive".
  static void name_joints_in_rules(SpatialScene& s) {
    for (RangeRule& r : s.run_time_rules)
      for (const std::string group : {"gears", "friction"}) {
        if (r.field.rfind(group, 0) != 0 || r.field.size() <= group.size()) continue;
        std::string joint = "every joint";
        if (r.field[group.size()] == '[') {
          const size_t j = std::stoul(r.field.substr(group.size() + 1));
          if (j >= s.joint_names.size()) continue;  // a YAML arm: the index is its name
          joint = "joint " + quoted_text(s.joint_names[j]);
        }
        const size_t end = r.field.size();
        if (r.message.compare(0, end, r.field) == 0) r.message.insert(end, " (" + joint + ")");
      }
  }

 private:
  const YamlReader& r_;
  std::optional<DeclaredParameters> parameters_;  // the scene's, once read
  std::vector<RangeRule>* rules_ = nullptr;
  InertiaRule check_ = InertiaRule::physical;  // the scene's inertia_check
  bool snap_ = false;                          // snap_right_angles
  std::vector<std::string> not_physical_;      // bodies positive_definite accepts, with moments

  void read_inertia_check(const YAML::Node& n, SpatialScene& s) {
    if (!n.IsScalar()) r_.fail("inertia_check", "expected physical or positive_definite", n);
    const std::string c = r_.bounded(n, "inertia_check").Scalar();
    if (c != "physical" && c != "positive_definite")
      r_.fail("inertia_check", "expected physical or positive_definite, got " + quoted_text(c), n);
    check_ = s.inertia_check =
        c == "physical" ? InertiaRule::physical : InertiaRule::positive_definite;
  }
  // The one warning for the bodies that positive_definite accepts though no rigid body has them.
  static std::string accepted_text(const std::vector<std::string>& bodies) {
    std::string listed;
    for (const std::string& b : bodies) listed += (listed.empty() ? "" : "; ") + b;
    return "inertia_check: positive_definite takes " + std::to_string(bodies.size()) +
           (bodies.size() == 1 ? " body" : " bodies") +
           " whose inertia no rigid body has (a principal moment above the sum of the other two, "
           "as identified parameters may be): " +
           listed;
  }

  // A number or a declared parameter, resolved: its nominal value and its index in params.
  Quantity quantity(const YAML::Node& n, const std::string& field) {
    return parameters_->resolved(r_.quantity(n, field), field, n);
  }
  template <size_t K>
  std::array<Quantity, K> quantities(const YAML::Node& n, const std::string& field) {
    if (!n.IsSequence() || n.size() != K)
      r_.fail(field, "expected a list of " + std::to_string(K) + " numbers", n);
    std::array<Quantity, K> a;
    for (size_t k = 0; k < K; ++k) a[k] = quantity(n[k], field + "[" + std::to_string(k) + "]");
    return a;
  }
  // Geometry: numbers only (a frame or an axis as a parameter would change the model's form).
  std::array<double, 3> vec3(const YAML::Node& n, const std::string& field) const {
    if (!n.IsSequence() || n.size() != 3) r_.fail(field, "expected a list of 3 numbers", n);
    std::array<double, 3> a;
    for (size_t k = 0; k < 3; ++k) {
      const std::string f = field + "[" + std::to_string(k) + "]";
      const Quantity q = r_.quantity(n[k], f);
      if (q.is_parameter())
        r_.fail(f,
                "'" + q.parameter +
                    "': a frame, an axis or the end effector takes numbers; run-time parameters "
                    "are masses, centres of mass, inertias, gear ratios and rotor inertias",
                n[k]);
      a[k] = q.value;
    }
    return a;
  }
  // Rules on quantities with a parameter, for parameter_error() (the literals are checked here).
  void rule(bool strict, const std::string& field, const Quantity& q) {
    if (q.is_parameter()) rules_->push_back(run_time_rule(sign_rule(field, q, strict)));
  }
  // a >= b, `message` saying what the field must be.
  void not_below(const std::string& field, const Quantity& a, const Quantity& b,
                 const std::string& message) {
    RangeRule r;
    r.field = field;
    r.terms = {{1, false, a}, {-1, false, b}};
    r.strict = false;
    r.message = field + " " + message;
    rules_->push_back(run_time_rule(std::move(r)));
  }
  static RangeRule run_time_rule(RangeRule r) {
    r.at_parse = false;
    return r;
  }

  // A body's mass (> 0) and its inertia about the centre of mass: a physical tensor, positive
  // definite with principal moments that satisfy the triangle inequality. rule_field: the
  // field its run-time rules name (fixed text).
  // part: a URDF link the scene gives (`inertials:`), whose mass may be 0 (a payload not yet
  // there; its body as a whole keeps a positive mass).
  void read_inertial(const YAML::Node& n, const std::string& field, spatial::Inertial& l,
                     const std::string& rule_field, bool part = false) {
    l.mass = quantity(r_.require(n, "mass", field), field + ".mass");
    if (part ? !(l.mass.value >= 0) : !(l.mass.value > 0))
      r_.fail(field + ".mass",
              std::string(part ? "must not be negative" : "must be positive") + ", got " +
                  number_text(l.mass.value),
              n);
    rule(!part, rule_field + ".mass", l.mass);
    if (n["com"]) l.com = quantities<3>(n["com"], field + ".com");
    l.inertia = quantities<6>(r_.require(n, "inertia", field), field + ".inertia");
    const PrincipalMoments p = principal_moments(l);
    if (const std::string why = inertia_problem(p, check_); !why.empty())
      r_.fail(field + ".inertia",
              why + (p.positive_definite ? "; for identified parameters, inertia_check: "
                                           "positive_definite takes any positive definite tensor"
                                         : ""),
              n["inertia"]);
    if (!p.physical) not_physical_.push_back(field + " (" + p.text() + ")");
    if (std::any_of(l.inertia.begin(), l.inertia.end(),
                    [](const Quantity& q) { return q.is_parameter(); })) {
      RangeRule tensor;
      tensor.field = rule_field + ".inertia";
      for (const Quantity& q : l.inertia) tensor.terms.push_back({1, false, q});
      tensor.inertia = check_;
      tensor.message = tensor.field + (check_ == InertiaRule::physical
                                           ? " must be a physical inertia (positive definite, "
                                             "principal moments within the triangle inequality)"
                                           : " must be positive definite");
      rules_->push_back(run_time_rule(std::move(tensor)));
    }
  }

  // The chain of a URDF (urdf_reader.hpp) named by `urdf:`, its bodies checked as the YAML
  // form's are; read_file gives the file's text.
  void read_urdf_chain(const YAML::Node& root, SpatialScene& s, const UrdfFileReader& read_file) {
    // The links whose inertial the scene gives (`inertials:`), by name.
    const YAML::Node given = root["inertials"];
    std::vector<std::string> given_links;
    if (given) {
      if (!given.IsMap() || given.size() == 0)
        r_.fail("inertials", "expected a mapping of URDF link name to {mass, com, inertia}", given);
      for (const auto& kv : given) {
        const std::string link = r_.key_text(kv.first, "inertials");
        if (std::count(given_links.begin(), given_links.end(), link))
          r_.fail(inertials_error_field(link), "given more than once", kv.first);
        given_links.push_back(link);
      }
    }
    for (const char* field : {"links"})
      if (root[field]) r_.fail(field, "comes from the URDF (field 'urdf')", root[field]);
    const YAML::Node base = r_.require(root, "base", "");
    r_.check_keys(base, "base", {"type"});
    const std::string type = r_.bounded(r_.require(base, "type", "base"), "base.type").Scalar();
    if (type != "free_floating" && type != "fixed")
      r_.fail("base.type", "expected free_floating or fixed, got '" + type + "'", base["type"]);
    const std::string path = r_.bounded(root["urdf"], "urdf").Scalar();
    if (root["end_effector_link"] && root["end_effector_links"])
      r_.fail("end_effector_links", "give end_effector_link or end_effector_links, not both",
              root["end_effector_links"]);
    std::vector<std::string> link = end_effector_links(root["end_effector_links"]);
    if (root["end_effector_link"])
      link.push_back(r_.bounded(root["end_effector_link"], "end_effector_link").Scalar());
    for (char c : path)
      if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f)
        r_.fail("urdf", "the path holds a control character", root["urdf"]);
    // The file's and the URDF's errors, under the scene's name and field.
    std::string xml;
    UrdfChain u;
    try {
      xml = read_file(path);
      u = read_urdf(xml, path, type == "free_floating", link,
                    std::set<std::string>(given_links.begin(), given_links.end()), snap_);
    } catch (const SceneError& e) {
      r_.fail("urdf", e.what(), root["urdf"]);
    }
    // The given inertials, into their bodies' parts.
    for (size_t k = 0; k < given_links.size(); ++k) {
      const std::string& name = given_links[k];
      const std::string field = inertials_error_field(name);
      const YAML::Node n = given[name];
      const auto it = u.given_parts.find(name);
      if (it == u.given_parts.end())
        r_.fail(field, "URDF '" + path + "' has no link of this name", n);
      const auto [body, part] = it->second;
      if (body == 0 && !u.chain.free_base)
        r_.fail(field,
                "is the root link of a fixed base or welded to it: it does not move, so its "
                "inertial has no effect",
                n);
      spatial::Link& l = body == 0 ? u.chain.base : u.chain.links[body - 1];
      if (!n.IsMap()) r_.fail(field, "expected a mapping {mass, com, inertia}", n);
      r_.check_keys(n, field, {"mass", "com", "inertia"});
      read_inertial(n, field, l.parts[part].inertial, inertials_field(name, k), true);
    }
    check_urdf_bodies(u, path, root["urdf"]);
    s.chain = u.chain;
    s.joint_names = u.joint_names;
    s.joint_limits = u.limits;
    s.body_visuals = u.body_visuals;
    if (snap_)  // said once, and kept in the model's facts (kRightAnglesSnapped)
      s.warnings.push_back("snap_right_angles: " + std::to_string(u.snapped_angles) +
                           " of the URDF's angles moved to a multiple of pi/2 (at most " +
                           number_text(u.largest_snap) + " rad)");
    for (const auto& links : u.body_links) s.body_names.push_back(links.front());
    s.content += std::string("\0urdf ", 6) + path + '\0' + xml;
  }

  // Every moving body's inertial as lumped from its URDF links (with the scene's parts), checked
  // together: one message lists every body refused, by its links' names, with both remedies.
  void check_urdf_bodies(const UrdfChain& u, const std::string& path, const YAML::Node& node) {
    std::vector<std::string> refused;
    bool mass_only = true;
    for (size_t b = u.chain.free_base ? 0 : 1; b <= u.chain.links.size(); ++b) {
      const std::vector<std::string>& links = u.body_links.at(b);
      std::string name = links.size() == 1 ? "link " : "links ";
      for (size_t k = 0; k < links.size(); ++k) name += (k ? " + " : "") + quoted_text(links[k]);
      const spatial::Inertial l = whole_body(
          b == 0 ? u.chain.base : u.chain.links[b - 1], [](const Quantity& q) { return q.value; },
          u.chain.exact_right_angles);
      if (!(l.mass.value > 0)) {
        refused.push_back(name + " (mass " + number_text(l.mass.value) + ": must be positive)");
        continue;
      }
      const PrincipalMoments p = principal_moments(l);
      if (!inertia_problem(p, check_).empty()) {
        refused.push_back(name + " (" + p.text() + ")");
        mass_only = false;
      } else if (!p.physical) {
        not_physical_.push_back(name + " (" + p.text() + ")");
      }
    }
    if (refused.empty()) return;
    std::string listed;
    for (const std::string& b : refused) listed += (listed.empty() ? "" : "; ") + b;
    const bool physical = check_ == InertiaRule::physical;
    r_.fail(
        "urdf",
        "URDF '" + path + "': " + std::to_string(refused.size()) +
            (refused.size() == 1 ? " body is" : " bodies are") + " refused: " + listed +
            (mass_only  ? ""
             : physical ? ". A rigid body's inertia is positive definite, each principal moment at "
                          "most the sum of the other two"
                        : ". inertia_check: positive_definite takes a positive definite tensor") +
            ". Remedies: give the link's inertial in the scene (inertials: {LINK: {mass, com, "
            "inertia}})" +
            (physical && !mass_only ? ", or, for identified parameters, inertia_check: "
                                      "positive_definite (any positive definite tensor)"
                                    : ""),
        node);
  }

  void read_base(const YAML::Node& n, spatial::ChainDescription& c) {
    r_.check_keys(n, "base", {"type", "mass", "com", "inertia"});
    const std::string type = r_.bounded(r_.require(n, "type", "base"), "base.type").Scalar();
    if (type != "free_floating" && type != "fixed")
      r_.fail("base.type", "expected free_floating or fixed, got '" + type + "'", n["type"]);
    c.free_base = type == "free_floating";
    if (c.free_base) return read_inertial(n, "base", c.base, "base");
    for (const char* field : {"mass", "com", "inertia"})
      if (n[field])
        r_.fail(std::string("base.") + field,
                "a fixed base does not move: it takes no mass, centre or inertia", n[field]);
  }

  // A point in an end effector's frame (URDF: its link's), moving it there: [x, y, z] where the
  // scene has one end effector, else a mapping from end effector link to point.
  void read_end_effector_points(const YAML::Node& n, spatial::ChainDescription& c) {
    auto move = [](spatial::EndEffector& e, const std::array<double, 3>& point) {
      const spatial::Mat3<double> R = spatial::rpy_rotation(e.rpy);
      for (int k = 0; k < 3; ++k)
        e.xyz[k] += R[3 * k] * point[0] + R[3 * k + 1] * point[1] + R[3 * k + 2] * point[2];
    };
    if (!n.IsMap()) {
      if (c.num_end_effectors() != 1)
        r_.fail("end_effector",
                "a point [x, y, z] is for one end effector; this scene has " +
                    std::to_string(c.num_end_effectors()) + " (" + end_effector_list(c) +
                    "): give a mapping from end effector link to point",
                n);
      move(c.end_effectors[0], vec3(n, "end_effector"));
      return;
    }
    if (n.size() == 0) r_.fail("end_effector", "an empty mapping names no end effector", n);
    std::vector<std::string> given;
    for (const auto& kv : n) {
      const std::string link = r_.key_text(kv.first, "end_effector");
      const std::string field = "end_effector." + (is_identifier(link) ? link : quoted_text(link));
      if (std::count(given.begin(), given.end(), link))
        r_.fail(field, "given more than once", kv.first);
      given.push_back(link);
      auto it = std::find_if(c.end_effectors.begin(), c.end_effectors.end(),
                             [&](const spatial::EndEffector& e) { return e.link == link; });
      if (it == c.end_effectors.end())
        r_.fail(field, "is no end effector of this scene (" + end_effector_list(c) + ")", kv.first);
      move(*it, vec3(kv.second, field));
    }
  }

  static std::string end_effector_list(const spatial::ChainDescription& c) {
    std::string listed;
    for (const spatial::EndEffector& e : c.end_effectors)
      listed += (listed.empty() ? "" : ", ") + quoted_text(e.link);
    return listed;
  }

  // The native form's tree: links[i].name (an identifier) and links[i].parent (base, or the name
  // of a link listed before it; default: the link before), and the end effectors: the links
  // end_effector_links names, else every leaf (a link no other carries) at its origin. A chain
  // without names keeps its one end effector at the last link.
  void read_tree(const YAML::Node& links, const YAML::Node& wanted, spatial::ChainDescription& c) {
    std::vector<std::string> names;
    bool tree = false;
    for (size_t i = 0; i < links.size(); ++i) {
      const std::string field = "links[" + std::to_string(i) + "]";
      std::string name = "link" + std::to_string(i + 1);
      if (const YAML::Node n = links[i]["name"]) {
        if (!n.IsScalar()) r_.fail(field + ".name", "expected an identifier other than 'base'", n);
        name = r_.bounded(n, field + ".name").Scalar();
        if (!is_identifier(name) || name == "base")
          r_.fail(field + ".name",
                  "expected an identifier other than 'base', got " + quoted_text(name), n);
        if (std::count(names.begin(), names.end(), name))
          r_.fail(field + ".name", quoted_text(name) + " names an earlier link too", n);
        tree = true;
      } else if (const auto it = std::find(names.begin(), names.end(), name); it != names.end()) {
        r_.fail("links[" + std::to_string(it - names.begin()) + "].name",
                quoted_text(name) + " is the default name of links[" + std::to_string(i) +
                    "], which has none: give it a name, or this link another",
                links[it - names.begin()]["name"]);
      }
      names.push_back(name);
      if (const YAML::Node n = links[i]["parent"]) {
        if (!n.IsScalar())
          r_.fail(field + ".parent", "expected base or the name of a link listed before this one",
                  n);
        const std::string parent = r_.bounded(n, field + ".parent").Scalar();
        const auto it = std::find(names.begin(), names.end() - 1, parent);
        if (parent != "base" && it == names.end() - 1)
          r_.fail(field + ".parent",
                  "expected base or the name of a link listed before this one, got " +
                      quoted_text(parent),
                  n);
        c.links[i].parent = parent == "base" ? 0 : static_cast<int>(it - names.begin()) + 1;
        tree = true;
      }
    }
    if (!tree && !wanted) return;
    std::vector<std::string> chosen = end_effector_links(wanted);
    if (!wanted)
      for (size_t i = 0; i < names.size(); ++i) {
        bool leaf = true;
        for (int k = 1; k <= static_cast<int>(c.links.size()); ++k)
          leaf = leaf && c.parent(k) != static_cast<int>(i) + 1;
        if (leaf) chosen.push_back(names[i]);
      }
    c.end_effectors.clear();
    for (const std::string& link : chosen) {
      const auto it = std::find(names.begin(), names.end(), link);
      if (it == names.end())
        r_.fail("end_effector_links", "no link is named " + quoted_text(link), wanted);
      c.end_effectors.push_back({link, static_cast<int>(it - names.begin()) + 1, {}, {}});
    }
  }

  // At most kMaxDepth joints on a path from the base (the first link past it named).
  void check_depth(const spatial::ChainDescription& c, const YAML::Node& links) const {
    std::vector<int> depth(c.links.size() + 1, 0);
    for (int i = 1; i <= static_cast<int>(c.links.size()); ++i) {
      depth[i] = depth[c.parent(i)] + 1;
      if (depth[i] > kMaxDepth)
        r_.fail("links[" + std::to_string(i - 1) + "]",
                "is joint " + std::to_string(depth[i]) + " on its path from the base; at most " +
                    std::to_string(kMaxDepth) +
                    " on one path (a chain: " + std::to_string(kMaxDepth) +
                    " links; a tree: " + std::to_string(kMaxLinks) + " in all)",
                links[i - 1]);
    }
  }

  // end_effector_links: a list of 1 to 16 distinct link names (empty: none given).
  std::vector<std::string> end_effector_links(const YAML::Node& n) const {
    std::vector<std::string> links;
    if (!n) return links;
    if (!n.IsSequence() || n.size() < 1 || n.size() > 16)
      r_.fail("end_effector_links", "expected a list of 1 to 16 link names", n);
    for (size_t k = 0; k < n.size(); ++k) {
      const std::string field = "end_effector_links[" + std::to_string(k) + "]";
      if (!n[k].IsScalar()) r_.fail(field, "expected a link's name", n[k]);
      const std::string link = r_.bounded(n[k], field).Scalar();
      if (std::count(links.begin(), links.end(), link))
        r_.fail("end_effector_links", quoted_text(link) + " is listed twice", n[k]);
      links.push_back(link);
    }
    return links;
  }

  spatial::Link read_link(const YAML::Node& n, const std::string& field) {
    r_.check_keys(n, field, {"name", "parent", "origin", "rpy", "axis", "mass", "com", "inertia"});
    spatial::Link l;
    if (n["origin"]) l.origin_xyz = vec3(n["origin"], field + ".origin");
    if (n["rpy"]) l.origin_rpy = vec3(n["rpy"], field + ".rpy");
    if (snap_)
      for (double& angle : l.origin_rpy) angle = spatial::snapped_right_angle(angle);
    if (n["axis"]) l.axis = vec3(n["axis"], field + ".axis");  // URDF's default: (1, 0, 0)
    const auto& a = l.axis;
    if (!(a[0] * a[0] + a[1] * a[1] + a[2] * a[2] > 1e-24))
      r_.fail(field + ".axis", "must not be zero", n["axis"]);
    read_inertial(n, field, l, field);
    return l;
  }

  spatial::Gear read_gear(const YAML::Node& n, const std::string& field) {
    r_.check_keys(n, field, {"ratio", "rotor_inertia", "rotor_coupling", "stiffness", "damping"});
    spatial::Gear g;
    g.present = true;
    g.ratio = quantity(r_.require(n, "ratio", field), field + ".ratio");
    if (!(g.ratio.value > 0))
      r_.fail(field + ".ratio", "must be positive, got " + number_text(g.ratio.value), n["ratio"]);
    rule(true, field + ".ratio", g.ratio);
    if (n["rotor_inertia"]) {
      const auto r = quantities<2>(n["rotor_inertia"], field + ".rotor_inertia");
      if (!(r[0].value >= 0 && r[1].value >= 0))
        r_.fail(field + ".rotor_inertia", "axial and transverse inertia must not be negative",
                n["rotor_inertia"]);
      g.axial = r[0];
      g.transverse = r[1];
      for (int k = 0; k < 2; ++k)
        rule(false, field + ".rotor_inertia[" + std::to_string(k) + "]", r[k]);
    }
    if (n["rotor_coupling"]) read_coupling(n["rotor_coupling"], field + ".rotor_coupling", g);
    if (!g.exact && !g.coupled && g.transverse.is_parameter())
      r_.fail(field + ".rotor_inertia[1]",
              "'" + g.transverse.parameter +
                  "': the transverse inertia acts only with rotor_coupling exact (armature keeps "
                  "the axial inertia alone)",
              n["rotor_inertia"]);
    read_spring(n, field, g);
    if (g.flexible && g.coupled)
      r_.fail(field + ".rotor_coupling",
              "a coupling factor needs a rigid gear (a flexible joint's rotor takes exact or "
              "armature)",
              n["rotor_coupling"]);
    return g;
  }

  // rotor_coupling: exact, armature, or a factor c in [0, 1] (a number or a run-time parameter):
  // the rotor turns at c omega_parent + qd_m a, so c = 1 is exact and c = 0 armature in one model.
  void read_coupling(const YAML::Node& n, const std::string& field, spatial::Gear& g) {
    const std::string c = r_.bounded(n, field).Scalar();
    if (c == "exact" || c == "armature") {
      g.exact = c == "exact";
      return;
    }
    Quantity factor;
    try {
      factor = parameters_->resolved(r_.quantity(n, field), field, n);
    } catch (const SceneError&) {
      r_.fail(field,
              "expected exact, armature or a coupling factor in [0, 1] (a number, or a parameter "
              "declared under 'parameters'), got '" +
                  c + "'",
              n);
    }
    if (!(factor.value >= 0 && factor.value <= 1))
      r_.fail(field,
              "expected exact, armature or a coupling factor in [0, 1] (1 exact, 0 armature), "
              "got " +
                  (factor.is_parameter() ? factor.parameter + " = " : std::string()) +
                  number_text(factor.value),
              n);
    if (!factor.is_parameter() && (factor.value == 0 || factor.value == 1)) {
      g.exact = factor.value == 1;  // a literal end of the range is that coupling
      return;
    }
    g.coupled = true;
    g.coupling = factor;
    if (!factor.is_parameter()) return;
    RangeRule low = sign_rule(field, factor, false), high = low;
    low.message = field + " must be in [0, 1] (not negative)";
    high.terms = {{1, true, {}}, {-1, false, factor}};  // 1 - c >= 0
    high.message = field + " must be in [0, 1] (not above 1)";
    rules_->push_back(run_time_rule(std::move(low)));
    rules_->push_back(run_time_rule(std::move(high)));
  }

  // A flexible joint's spring (stiffness > 0) and damper (>= 0, only with a spring): its rotor
  // then has a coordinate of its own, so its axial inertia must be positive (its own equation
  // J (a . alpha' + qdd_m) = Q_m).
  void read_spring(const YAML::Node& n, const std::string& field, spatial::Gear& g) {
    if (n["damping"] && !n["stiffness"])
      r_.fail(field + ".damping", "a damper needs a spring: give 'stiffness' too", n["damping"]);
    if (!n["stiffness"]) return;
    g.flexible = true;
    const std::string k = field + ".stiffness";
    g.stiffness = quantity(n["stiffness"], k);
    if (!(g.stiffness.value > 0))
      r_.fail(k, "must be positive, got " + number_text(g.stiffness.value), n["stiffness"]);
    rule(true, k, g.stiffness);
    if (n["damping"]) {
      const std::string d = field + ".damping";
      g.has_damping = true;
      g.damping = quantity(n["damping"], d);
      if (!(g.damping.value >= 0))
        r_.fail(d, "must not be negative, got " + number_text(g.damping.value), n["damping"]);
      rule(false, d, g.damping);
    }
    const std::string axial = field + ".rotor_inertia[0]";
    if (!(g.axial.value > 0))
      r_.fail(axial,
              "a flexible joint (stiffness given) needs a rotor of positive axial inertia, got " +
                  number_text(g.axial.value),
              n["rotor_inertia"] ? n["rotor_inertia"] : n);
    rule(true, axial, g.axial);
  }

  // A URDF's joint <dynamics damping d friction F> as the joint's friction on its coordinate's
  // rate (the motor's, qm' = p q', where geared): viscous d / p^2 and Coulomb F / p, smoothed by
  // the scene's velocity_scale (URDF has none).
  void read_urdf_friction(const YAML::Node& n, SpatialScene& s) {
    r_.check_keys(n, "friction", {"from_urdf", "velocity_scale"});
    if (!n["from_urdf"].IsScalar() || n["from_urdf"].Scalar() != "true")
      r_.fail("friction.from_urdf", "expected true (or leave it out)", n["from_urdf"]);
    if (s.joint_limits.empty())
      r_.fail("friction.from_urdf", "reads a URDF's <dynamics>: needs field 'urdf'", n);
    bool coulomb = false;
    for (const auto& l : s.joint_limits) coulomb = coulomb || l.friction > 0;
    Quantity vs = 1.0;
    if (n["velocity_scale"]) {
      vs = quantity(n["velocity_scale"], "friction.velocity_scale");
      if (!(vs.value >= kMinFrictionVelocity))
        r_.fail("friction.velocity_scale",
                "must be at least 1e-9 rad/s, got " + number_text(vs.value), n["velocity_scale"]);
      if (vs.is_parameter())
        not_below("friction.velocity_scale", vs, kMinFrictionVelocity,
                  "must be at least 1e-9 rad/s");
    } else if (coulomb) {
      r_.fail("friction.velocity_scale",
              "the URDF's Coulomb friction (<dynamics friction>) needs a positive velocity_scale "
              "vs [rad/s] (tanh(w/vs) smooths sign(w); URDF gives none)",
              n);
    }
    for (size_t j = 0; j < s.chain.links.size(); ++j) {
      const spatial::JointLimits& l = s.joint_limits[j];
      if (!(l.damping > 0 || l.friction > 0)) continue;
      const spatial::Gear& g = s.chain.links[j].gear;
      if (g.present && g.ratio.is_parameter())
        r_.fail("friction.from_urdf",
                "joint " + quoted_text(s.joint_names[j]) +
                    ": its gear ratio is the run-time "
                    "parameter '" +
                    g.ratio.parameter +
                    "', so its URDF friction cannot be moved to "
                    "the motor in numbers; give the friction in the scene",
                n);
      const double p = g.present ? g.ratio.value : 1.0;
      spatial::Friction& f = s.chain.links[j].friction;
      f.present = true;
      f.viscous = l.damping / (p * p);
      f.coulomb = f.stribeck_static = l.friction / p;
      f.has_coulomb = l.friction > 0;
      f.velocity_scale = vs;
    }
  }
  // A URDF's <dynamics> that the scene does not read: said once, naming the joints.
  static void note_ignored_dynamics(SpatialScene& s) {
    std::string listed;
    for (size_t j = 0; j < s.joint_limits.size(); ++j)
      if (s.joint_limits[j].damping > 0 || s.joint_limits[j].friction > 0)
        listed += (listed.empty() ? "" : ", ") + quoted_text(s.joint_names[j]);
    if (!listed.empty())
      s.warnings.push_back("the URDF's <dynamics damping friction> of joints " + listed +
                           " are ignored; friction: {from_urdf: true, velocity_scale: VS} reads "
                           "them");
  }

  // Friction for every joint (a mapping) or per joint (a list; null: none), as in the plane:
  // f(w) = b w + Fc tanh(w/vs) + (Fs - Fc) exp(-(w/vst)^2) tanh(w/vs) on the coordinate's rate.
  void read_friction(const YAML::Node& n, spatial::ChainDescription& c) {
    const size_t N = c.links.size();
    if (n.IsMap()) {
      const spatial::Friction f = read_joint_friction(n, "friction");
      for (auto& l : c.links) l.friction = f;
      return;
    }
    if (!n.IsSequence() || n.size() != N)
      r_.fail("friction", "expected one mapping for all joints or a list of " + std::to_string(N),
              n);
    bool any = false;
    for (size_t i = 0; i < N; ++i) {
      if (n[i].IsNull()) continue;
      c.links[i].friction = read_joint_friction(n[i], "friction[" + std::to_string(i) + "]");
      any = true;
    }
    if (!any) r_.fail("friction", "every entry is null: leave 'friction' out for no friction", n);
  }

  // One joint's friction: a field not given is 0, stribeck_static defaults to coulomb; a tanh
  // term needs velocity_scale, a Stribeck hump stribeck_velocity (each at least
  // kMinFrictionVelocity). A run-time parameter's value is checked again at run time.
  spatial::Friction read_joint_friction(const YAML::Node& n, const std::string& field) {
    if (!n.IsMap()) r_.fail(field, "expected a mapping of friction coefficients", n);
    r_.check_keys(n, field,
                  {"viscous", "coulomb", "velocity_scale", "stribeck_static", "stribeck_velocity"});
    auto number = [&](const char* key, const Quantity& otherwise) {
      if (!n[key]) return otherwise;
      const std::string f = field + "." + key;
      const Quantity v = quantity(n[key], f);
      if (!(v.value >= 0)) r_.fail(f, "must not be negative, got " + number_text(v.value), n[key]);
      rule(false, f, v);
      return v;
    };
    auto given = [](const Quantity& q) { return q.value != 0 || q.is_parameter(); };
    spatial::Friction fr;
    fr.present = true;
    fr.viscous = number("viscous", 0.0);
    fr.coulomb = number("coulomb", 0.0);
    fr.stribeck_static = number("stribeck_static", fr.coulomb);  // Fc's parameter where not given
    fr.has_coulomb = given(fr.coulomb) || given(fr.stribeck_static);
    fr.has_stribeck =
        n["stribeck_static"] && (fr.stribeck_static.is_parameter() || fr.coulomb.is_parameter() ||
                                 fr.stribeck_static.value != fr.coulomb.value);
    const std::string fs = field + ".stribeck_static";
    if (fr.stribeck_static.value < fr.coulomb.value)
      r_.fail(fs,
              "the breakaway level Fs (" + number_text(fr.stribeck_static.value) +
                  ") must not be below the Coulomb level Fc (" + number_text(fr.coulomb.value) +
                  ")",
              n["stribeck_static"]);
    if (fr.has_stribeck && (fr.stribeck_static.is_parameter() || fr.coulomb.is_parameter()))
      not_below(fs, fr.stribeck_static, fr.coulomb, "must not be below coulomb");
    auto velocity = [&](const char* key, bool needed, const std::string& why) {
      if (!n[key]) {
        if (needed) r_.fail(field + "." + key, why, n);
        return Quantity(1.0);
      }
      const std::string f = field + "." + key;
      const Quantity v = quantity(n[key], f);
      if (!(v.value >= kMinFrictionVelocity))
        r_.fail(f,
                "must be at least 1e-9 rad/s (tanh(w/vs) becomes a step that no integrator "
                "follows), got " +
                    number_text(v.value),
                n[key]);
      if (v.is_parameter()) not_below(f, v, kMinFrictionVelocity, "must be at least 1e-9 rad/s");
      return v;
    };
    fr.velocity_scale = velocity("velocity_scale", fr.has_coulomb,
                                 "Coulomb or static friction needs a positive velocity_scale vs "
                                 "[rad/s] (tanh(w/vs) smooths sign(w))");
    fr.stribeck_velocity = velocity("stribeck_velocity", fr.has_stribeck,
                                    "a Stribeck hump (stribeck_static differs from coulomb) needs "
                                    "a positive stribeck_velocity [rad/s]");
    return fr;
  }

  // A list of registry outputs that a spatial arm gives, each once, kept in the registry's order.
  std::vector<Output> read_outputs(const YAML::Node& n,
                                   const spatial::ChainDescription& chain) const {
    const bool free_base = chain.free_base;
    if (!n.IsSequence() || n.size() == 0) r_.fail("outputs", "expected a list of outputs", n);
    std::vector<Output> listed;
    for (size_t i = 0; i < n.size(); ++i) {
      const std::string field = "outputs[" + std::to_string(i) + "]";
      if (!n[i].IsScalar()) r_.fail(field, "expected an output name", n[i]);
      const std::string name = r_.bounded(n[i], field).Scalar();
      const std::optional<Output> o = output_from_string(name);
      if (!o) r_.fail(field, "unknown output '" + name + "'", n[i]);
      if (!spatial_output(*o, free_base))
        r_.fail(field,
                "'" + name + "' is not given for spatial arms yet" +
                    (*o == Output::momentum ? " (momentum needs a free base)" : ""),
                n[i]);
      if (const std::string why = missing_feature(info(*o).needs, chain_features(chain));
          !why.empty())
        r_.fail(field, "'" + name + "' " + why, n[i]);
      if (std::count(listed.begin(), listed.end(), *o))
        r_.fail(field, "'" + name + "' is listed twice", n[i]);
      listed.push_back(*o);
    }
    std::vector<Output> ordered;
    for (const OutputInfo& o : output_registry())
      if (std::count(listed.begin(), listed.end(), o.id)) ordered.push_back(o.id);
    return ordered;
  }

  // Lanes: outputs the scene emits, also for four states per call.
  std::vector<Output> read_lanes(const YAML::Node& n, const std::vector<Output>& emitted) const {
    if (!n.IsSequence() || n.size() == 0)
      r_.fail("lanes", "expected a non-empty list of outputs", n);
    std::vector<Output> listed;
    for (size_t i = 0; i < n.size(); ++i) {
      const std::string field = "lanes[" + std::to_string(i) + "]";
      if (!n[i].IsScalar()) r_.fail(field, "expected an output name", n[i]);
      const std::string name = r_.bounded(n[i], field).Scalar();
      const std::optional<Output> o = output_from_string(name);
      if (!o || !std::count(emitted.begin(), emitted.end(), *o))
        r_.fail(field, lanes_error(name, o.has_value()), n[i]);
      if (std::count(listed.begin(), listed.end(), *o))
        r_.fail(field, "'" + name + "' is listed twice", n[i]);
      listed.push_back(*o);
    }
    return listed;
  }

  void read_gears(const YAML::Node& n, spatial::ChainDescription& c) {
    const size_t N = c.links.size();
    if (n.IsMap()) {
      const spatial::Gear g = read_gear(n, "gears");
      for (auto& l : c.links) l.gear = g;
      return;
    }
    if (!n.IsSequence() || n.size() != N)
      r_.fail("gears", "expected one mapping for all joints or a list of " + std::to_string(N), n);
    for (size_t i = 0; i < N; ++i)
      c.links[i].gear = read_gear(n[i], "gears[" + std::to_string(i) + "]");
  }
};

}  // namespace

spatial::Inertial whole_body(const spatial::Link& l,
                             const std::function<double(const Quantity&)>& value,
                             bool exact_right_angles) {
  auto rigid = [&value](const spatial::Inertial& b) {  // about the frame's origin
    std::array<double, 6> i;
    for (int k = 0; k < 6; ++k) i[k] = value(b.inertia[k]);
    return spatial::about_origin(value(b.mass), {value(b.com[0]), value(b.com[1]), value(b.com[2])},
                                 i, [](double x) { return x; });
  };
  if (l.parts.empty()) {  // as given, not through the origin and back
    spatial::Inertial as_given;
    as_given.mass = value(l.mass);
    for (int k = 0; k < 3; ++k) as_given.com[k] = value(l.com[k]);
    for (int k = 0; k < 6; ++k) as_given.inertia[k] = value(l.inertia[k]);
    return as_given;
  }
  spatial::RigidInertia<double> sum = rigid(l);
  for (const spatial::Part& p : l.parts)
    sum = sum + spatial::in_parent(spatial::part_frame(p, exact_right_angles), rigid(p.inertial));
  spatial::Inertial whole;
  whole.mass = sum.m;
  if (!(sum.m > 0)) return whole;
  const spatial::Vec3<double> c = spatial::scaled(sum.h, 1 / sum.m);
  spatial::Mat3<double> I = sum.I;  // back to the centre: I_c = I_o - m (|c|^2 1 - c c^T)
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 3; ++k)
      I[3 * r + k] -= sum.m * ((r == k ? spatial::dot(c, c) : 0) - c[r] * c[k]);
  whole.com = {c[0], c[1], c[2]};
  whole.inertia = {I[0], I[1], I[2], I[4], I[5], I[8]};
  return whole;
}

bool spatial_output(Output o, bool free_base) {
  switch (o) {
    case Output::mass_matrix:
    case Output::bias_forces:
    case Output::kinetic_energy:
    case Output::inverse_dynamics:
    case Output::forward_dynamics:
    case Output::forward_dynamics_derivatives:
    case Output::mass_matrix_derivative:
    case Output::coriolis_matrix:
    case Output::end_effector_pose:
    case Output::end_effector_jacobian:
    case Output::joint_positions:
    case Output::joint_angles:
    case Output::joint_rates:
    case Output::friction_forces:  // where the scene has friction or springs (their needs)
    case Output::potential_energy:
    case Output::spring_damper_forces:
      return true;
    case Output::momentum:
    case Output::generalized_jacobian:
    case Output::free_base_inverse_dynamics:
      return free_base;
    default:
      return false;
  }
}

std::vector<Output> spatial_outputs(const SpatialScene& scene) {
  if (!scene.outputs.empty()) return scene.outputs;
  std::vector<Output> outputs;
  for (const OutputInfo& o : output_registry())
    if (spatial_output(o.id, scene.chain.free_base) && emitted_by_default(o, false) &&
        missing_feature(o.needs, spatial_features(scene)).empty())
      outputs.push_back(o.id);  // recursive forms only: no closed form in 3D
  return outputs;
}

unsigned spatial_features(const SpatialScene& scene) { return chain_features(scene.chain); }

bool is_spatial_scene(const std::string& yaml_text) {
  const YamlReader r("scene", "", [](const std::string& m) { throw SceneError(m); });
  try {
    const YAML::Node root = r.load(yaml_text);
    return root.IsMap() && root["space"] && root["space"].IsScalar() &&
           root["space"].Scalar() == "spatial";
  } catch (const SceneError&) {
    return false;
  } catch (const YAML::Exception&) {
    return false;
  }
}

SpatialScene parse_spatial_scene(const std::string& yaml_text, const std::string& source_name,
                                 const UrdfFileReader& read_file) {
  const YamlReader r("scene", source_name, [](const std::string& m) { throw SceneError(m); });
  const YAML::Node root = r.load(yaml_text);
  // By default a URDF's path is relative to the scene file's folder.
  std::vector<std::string> opened;
  const UrdfFileReader beside_scene = [&source_name, &opened](const std::string& path) {
    const std::string folder = source_name.substr(0, source_name.find_last_of('/') + 1);
    opened.push_back(path.empty() || path[0] == '/' ? path : folder + path);
    try {  // a regular file only: a FIFO or a device cannot block or fill memory
      return read_regular_file(opened.back(), "URDF", 8 << 20);
    } catch (const FolderError& e) {
      throw SceneError(e.what());
    }
  };
  try {
    SpatialScene s = SpatialReader(r).read(root, yaml_text, read_file ? read_file : beside_scene);
    s.source_path = source_name;
    for (std::string& w : s.warnings) w = "scene " + quoted_text(source_name) + ": " + w;
    s.read_files = opened;
    return s;
  } catch (const YAML::Exception& e) {
    r.fail("", std::string("unexpected YAML structure: ") + e.what());
  }
}

}  // namespace spacearm
