// The check the scene fuzzer runs on every input, shared with the replay test
// (Scene.FuzzCorpusAndRegressionsReplay in tests/scene/test_scene.cpp) so that every recorded
// crash stays a regression test.
// A scene text must either be rejected with a SceneError that names its source, or be
// accepted as a scene that keeps every documented rule; anything else (another exception,
// a crash, a sanitizer report) is a bug.
#pragma once

#include <cmath>
#include <string>

#include "comment_rule.hpp"
#include "emitted_text.hpp"
#include "planar_scene.hpp"
#include "spatial_scene.hpp"
#include "urdf_reader.hpp"

namespace spacearm::fuzz {

// Empty when the accepted scene keeps the rules, else the rule it breaks.
inline std::string broken_rule(const Scene& s) {
  auto finite = [](const Quantity& q) { return std::isfinite(q.value); };
  if (s.links.empty() || s.num_links() > kMaxLinks) return "number of links out of range";
  if (s.free_floating() && !(s.base.mass.value > 0 && s.base.inertia.value > 0))
    return "base mass/inertia";
  if (!finite(s.base.mount[0]) || !finite(s.base.mount[1])) return "base mount not finite";
  for (const Link& l : s.links) {
    if (!(l.mass.value > 0 && l.inertia.value > 0 && l.length.value > 0))
      return "link mass/inertia/length";
    if (!finite(l.mass) || !finite(l.inertia) || !finite(l.length) || !finite(l.com[0]) ||
        !finite(l.com[1]))
      return "link value not finite";
  }
  if (s.geared() && s.gears.size() != s.links.size()) return "gear count";
  for (size_t i = 0; i < s.gears.size(); ++i) {
    if (!s.gears[i]) continue;
    const Gear& g = *s.gears[i];
    if (g.damping && !g.stiffness) return "damper without a spring";
    if (g.stiffness && !(g.stiffness->value > 0 && g.motor_inertia.value > 0))
      return "flexible joint without a positive stiffness and motor inertia";
    if (!(g.ratio.value > 0) || !finite(g.ratio)) return "gear ratio";
    if (!(g.motor_inertia.value >= 0) || !finite(g.motor_inertia)) return "motor inertia";
    if (g.compensate_link_inertia && !(g.motor_inertia.value < s.links[i].inertia.value))
      return "motor inertia not below the link inertia it compensates";
  }
  for (size_t i = 0; i < s.parameters.size(); ++i)
    for (size_t j = i + 1; j < s.parameters.size(); ++j)
      if (s.parameters[i].name == s.parameters[j].name) return "duplicate parameter";
  if (s.outputs.empty()) return "no outputs";
  if (static_cast<int>(s.coordinate_names().size()) != s.num_coordinates())
    return "coordinate names";
  // What reaches emitted text: names C++ will not reinterpret, the description only as
  // comment lines of printable ASCII that cannot continue onto the next line.
  if (is_cpp_reserved(s.name)) return "reserved scene name";
  for (const Parameter& p : s.parameters)
    if (is_cpp_reserved(p.name)) return "reserved parameter name";
  return broken_comment_rule(comment_lines(s.description + "\n" + s.source_path));
}

// A number of the description: a plain double, or a Quantity's (nominal) value.
inline double number_of(double x) { return x; }
inline double number_of(const Quantity& q) { return q.value; }

// Every number of a list is finite.
template <class List>
bool all_finite(const List& a) {
  for (const auto& x : a)
    if (!std::isfinite(number_of(x))) return false;
  return true;
}

// The same for a spatial arm (spatial_scene.hpp).
inline std::string broken_spatial_rule(const SpatialScene& s) {
  const auto& c = s.chain;
  if (c.links.empty() || c.links.size() > 30) return "number of links out of range";
  auto body = [&](const spatial::Link& l) {
    if (!(l.mass.value > 0) || !std::isfinite(l.mass.value) || !all_finite(l.com) ||
        !all_finite(l.inertia))
      return false;
    const auto i = l.inertia_values();
    return i[0] > 0 && i[3] > 0 && i[5] > 0;  // a positive definite tensor's diagonal
  };
  if (c.free_base && !body(c.base)) return "base mass/com/inertia";
  for (const auto& l : c.links) {
    if (!body(l)) return "link mass/com/inertia";
    if (!all_finite(l.origin_xyz) || !all_finite(l.origin_rpy) || !all_finite(l.axis))
      return "link frame";
    if (!(l.axis[0] * l.axis[0] + l.axis[1] * l.axis[1] + l.axis[2] * l.axis[2] > 0))
      return "zero axis";
    if (l.gear.present &&
        !(l.gear.ratio.value > 0 && l.gear.axial.value >= 0 && l.gear.transverse.value >= 0))
      return "gear";
  }
  for (const auto& e : c.end_effectors)
    if (!all_finite(e.xyz)) return "end effector";
  if (is_cpp_reserved(s.name)) return "reserved scene name";
  return "";
}

enum class Verdict { accepted, rejected };

// A rejection must name the file and come from the checks, not from the YAML fallback.
inline Verdict rejected(const SceneError& e, const std::string& source) {
  const std::string what = e.what();  // prefixes, not substrings: messages echo the input
  if (what.rfind("scene '" + source + "'", 0) != 0)
    throw std::logic_error("rejection does not start with the file name: " + what);
  if (what.rfind("scene '" + source + "': unexpected YAML structure", 0) == 0)
    throw std::logic_error("a YAML exception reached the fallback: " + what);
  return Verdict::rejected;
}

// The spatial reader on the same text: accepted only keeping its rules, else named.
inline Verdict check_spatial_text(const std::string& text, const UrdfFileReader& read_file) {
  const std::string source = "fuzz-input.yaml";
  try {
    const std::string rule = broken_spatial_rule(parse_spatial_scene(text, source, read_file));
    if (!rule.empty()) throw std::logic_error("accepted a spatial scene that breaks: " + rule);
    return Verdict::accepted;
  } catch (const SceneError& e) {
    return rejected(e, source);
  }
}

// The URDF reader on the same text (urdf_reader.hpp): a chain that keeps the spatial rules, or
// an error naming the file.
inline Verdict check_urdf_text(const std::string& text) {
  try {
    const spatial::ChainDescription c = read_urdf(text, "fuzz-input.urdf", true, "").chain;
    // The reader's promises (the scene then checks masses and inertias): 1 to 60 joints, at
    // most 30 on a path, each one's parent before it, end effectors on moving bodies, finite
    // numbers, nonzero axes.
    if (c.links.empty() || c.links.size() > 60)
      throw std::logic_error("URDF: number of joints out of range");
    std::vector<int> depth(c.links.size() + 1, 0);
    for (int i = 1; i <= static_cast<int>(c.links.size()); ++i) {
      if (c.parent(i) < 0 || c.parent(i) >= i)
        throw std::logic_error("URDF: a parent after its link");
      if ((depth[i] = depth[c.parent(i)] + 1) > 30) throw std::logic_error("URDF: a path too long");
    }
    if (c.end_effectors.empty()) throw std::logic_error("URDF: no end effector");
    for (int e = 0; e < c.num_end_effectors(); ++e)
      if (c.end_effector_body(e) < 1 || c.end_effector_body(e) > static_cast<int>(c.links.size()))
        throw std::logic_error("URDF: an end effector off the moving bodies");
    for (const auto& l : c.links)
      if (!all_finite(l.origin_xyz) || !all_finite(l.origin_rpy) || !all_finite(l.com) ||
          !all_finite(l.inertia) || !std::isfinite(l.mass.value) ||
          !(l.axis[0] * l.axis[0] + l.axis[1] * l.axis[1] + l.axis[2] * l.axis[2] > 0))
        throw std::logic_error("URDF: a link's numbers");
    for (const auto& e : c.end_effectors)
      if (!all_finite(e.xyz) || !all_finite(e.rpy)) throw std::logic_error("URDF: end effector");
    return Verdict::accepted;
  } catch (const SceneError& e) {
    if (std::string(e.what()).rfind("URDF 'fuzz-input.urdf'", 0) != 0)
      throw std::logic_error("a URDF rejection does not start with the file name: " +
                             std::string(e.what()));
    return Verdict::rejected;
  }
}

// A scene's `urdf:` file while fuzzing: none is read.
inline std::string no_files(const std::string& path) {
  throw SceneError("'" + path + "' is not read while fuzzing");
}

// Accepted: one of the readers (planar, spatial, URDF) accepts the text. read_file gives a
// spatial scene's URDF (by default none).
// Throws std::logic_error for a broken rule or an unnamed rejection; lets any other
// exception escape (the fuzzer reports it as a crash).
inline Verdict check_scene_text(const std::string& text,
                                const UrdfFileReader& read_file = no_files) {
  const std::string source = "fuzz-input.yaml";
  const Verdict urdf = check_urdf_text(text);
  const Verdict spatial = check_spatial_text(text, read_file);
  if (urdf == Verdict::accepted) return urdf;
  try {
    const Scene s = parse_scene(text, source);
    const std::string rule = broken_rule(s);
    if (!rule.empty()) throw std::logic_error("accepted a scene that breaks a rule: " + rule);
    if (content_hash(text).size() != 16) throw std::logic_error("content hash");
    if (spatial == Verdict::accepted) throw std::logic_error("both readers accepted the text");
    return Verdict::accepted;
  } catch (const SceneError& e) {
    rejected(e, source);
    return spatial;
  }
}

}  // namespace spacearm::fuzz
