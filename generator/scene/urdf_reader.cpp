#include "urdf_reader.hpp"

#include <tinyxml2.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <charconv>
#include <cstring>
#include <optional>
#include <string_view>
#include <cmath>
#include <map>
#include <set>
#include <sstream>

#include "planar_scene.hpp"
#include "text_numbers.hpp"

namespace spacearm {

namespace {

struct Frame {  // a pose in its parent's frame: x_parent = R x + p
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  Frame operator*(const Frame& b) const { return {R * b.R, p + R * b.p}; }
};

struct Inertial {
  double mass = 0;
  Eigen::Vector3d com = Eigen::Vector3d::Zero();
  Eigen::Matrix3d I = Eigen::Matrix3d::Zero();  // about the com
};

struct Joint {
  const tinyxml2::XMLElement* element = nullptr;
  std::string name, type, parent, child;
  Frame origin;
  std::array<double, 3> xyz{}, rpy{};
  std::array<double, 3> axis{1, 0, 0};
  spatial::JointLimits limits;
};

// URDF's roll-pitch-yaw: R = Rz(yaw) Ry(pitch) Rx(roll).
Eigen::Matrix3d rpy_matrix(const std::array<double, 3>& rpy) {
  return (Eigen::AngleAxisd(rpy[2], Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(rpy[1], Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(rpy[0], Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}
// Its inverse (a rotation composed through welded links back to rpy), exact to rounding at
// every pitch: roll from R's last row, then pitch and yaw from R Rx(roll)^T = Rz(yaw) Ry(pitch),
// which holds for any roll (at the lock R21 = R22 = 0 gives roll 0).
std::array<double, 3> matrix_rpy(const Eigen::Matrix3d& R) {
  const double roll = std::atan2(R(2, 1), R(2, 2));
  const Eigen::Matrix3d M =
      R * Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()).toRotationMatrix().transpose();
  return {roll, std::atan2(-M(2, 0), M(2, 2)), std::atan2(-M(0, 1), M(1, 1))};
}

// Bounds on what tinyxml2 is given, checked on the bytes before it parses them: it compares each
// new attribute with the element's earlier ones (60 000 attributes took 23 s; the 8 MB file
// limit admits a million), and it recurses into nested elements. A URDF needs a handful of
// attributes per element, a few levels and a few elements per link. This scan only counts: what
// it does not understand is left to tinyxml2, whose error names the line. Hand-written because
// the bound must hold before the parse, which no option of tinyxml2 offers.
constexpr int kMaxAttributes = 64, kMaxDepth = 64;
constexpr long kMaxElements = 100000;
// The moving joints a robot may have, and those on one path from the root (as a scene's links:
// the generated code grows with their product).
constexpr size_t kMaxMovingJoints = 60;
constexpr int kMaxPathJoints = 30;

void bound_the_parse(const std::string& xml, const std::string& source) {
  int line = 1, depth = 0;
  long elements = 0;
  auto fail = [&](const std::string& what) {
    throw SceneError("URDF '" + source + "' line " + std::to_string(line) + ": " + what);
  };
  // Skips to the end of `close` from `at`, counting lines; false if it never comes.
  auto skip_to = [&](size_t& at, const char* close) {
    const size_t end = xml.find(close, at);
    const size_t stop = end == std::string::npos ? xml.size() : end + std::strlen(close);
    line += static_cast<int>(std::count(xml.begin() + at, xml.begin() + stop, '\n'));
    at = stop;
  };
  for (size_t at = 0; at < xml.size();) {
    const char c = xml[at];
    if (c == '\0') fail("a NUL byte (at byte " + std::to_string(at) + "): not a text file");
    if (c != '<') {
      line += c == '\n';
      ++at;
      continue;
    }
    const std::string_view rest(xml.data() + at, xml.size() - at);
    if (rest.rfind("<!--", 0) == 0) {
      skip_to(at, "-->");
    } else if (rest.rfind("<![CDATA[", 0) == 0) {
      skip_to(at, "]]>");
    } else if (rest.rfind("<?", 0) == 0) {
      skip_to(at, "?>");
    } else if (rest.rfind("<!", 0) == 0 || rest.rfind("</", 0) == 0) {
      depth -= rest[1] == '/';
      skip_to(at, ">");
    } else {  // a start tag: its attributes counted by their '=' outside quotes
      const size_t name_end = rest.find_first_of(" \t\r\n/>", 1);
      const std::string name(rest.substr(1, std::min(name_end, rest.size()) - 1));
      if (++elements > kMaxElements)
        fail("more than " + std::to_string(kMaxElements) + " elements (the limit of a URDF here)");
      int attributes = 0;
      char quote = 0;
      size_t end = at + 1;
      for (; end < xml.size() && (quote || xml[end] != '>'); ++end) {
        const char d = xml[end];
        if (d == '\0') fail("a NUL byte (at byte " + std::to_string(end) + "): not a text file");
        line += d == '\n';
        if (quote) {
          quote = d == quote ? 0 : quote;
        } else if (d == '"' || d == '\'') {
          quote = d;
        } else if (d == '=' && ++attributes > kMaxAttributes) {
          fail("the element " + quoted_text(name) + " has more than " +
               std::to_string(kMaxAttributes) + " attributes (the limit of a URDF element here)");
        }
      }
      if (end < xml.size() && xml[end - 1] != '/' && ++depth > kMaxDepth)
        fail("elements nested more than " + std::to_string(kMaxDepth) +
             " deep (the limit of a URDF here)");
      at = end + 1;
    }
  }
}

// tinyxml2's reason, whole (its ErrorStr after "Line number=N: "), control characters shown as
// '?' and at most 200 characters: the name of the error and what it was parsing.
std::string parse_error(const tinyxml2::XMLDocument& doc) {
  std::string why = doc.ErrorStr() ? doc.ErrorStr() : "";
  if (const size_t colon = why.find(": "); colon != std::string::npos) why.erase(0, colon + 2);
  std::string shown = doc.ErrorName();
  if (!why.empty()) shown += ": ";
  for (char c : why.substr(0, 200))
    shown += (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) ? '?' : c;
  return shown + (why.size() > 200 ? "..." : "");
}

class UrdfReader {
 public:
  UrdfReader(std::string source, std::set<std::string> given, bool snap)
      : source_(std::move(source)), given_(std::move(given)), snap_(snap) {}

  [[noreturn]] void fail(const tinyxml2::XMLElement* e, const std::string& what) const {
    std::string where = "URDF '" + source_ + "'";
    if (e) {
      where += " line " + std::to_string(e->GetLineNum()) + ", <" + e->Name();
      if (const char* n = e->Attribute("name")) where += " name=" + quoted_text(n);
      where += ">";
    }
    throw SceneError(where + ": " + what);
  }

  std::string attribute(const tinyxml2::XMLElement* e, const char* name,
                        bool required = true) const {
    const char* v = e->Attribute(name);
    if (!v && required) fail(e, std::string("needs the attribute '") + name + "'");
    return v ? v : "";
  }

  // K decimal numbers separated by white space, each zero or of magnitude 1e-30 to 1e6 (the
  // YAML form's rule, yaml_reader.hpp, with URDF's lengths in metres): std::from_chars, so no
  // hex, no locale, and a token must be one number ("1-2" is refused, not read as 1 and -2).
  template <size_t K>
  std::array<double, K> numbers(const tinyxml2::XMLElement* e, const char* name,
                                std::optional<std::array<double, K>> fallback) const {
    const char* text = e ? e->Attribute(name) : nullptr;
    if (!text && fallback) return *fallback;
    if (!text) fail(e, std::string("needs the attribute '") + name + "'");
    auto bad = [&](const std::string& why) {
      fail(e, std::string("attribute '") + name + "': expected " + std::to_string(K) +
                  (K == 1 ? " number" : " numbers") + ", each 0 or of magnitude 1e-30 to 1e6 (" +
                  why + "), got " + quoted_text(text));
    };
    std::array<double, K> out{};
    const std::string_view all(text);
    size_t at = 0, k = 0;
    auto space = [](char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r'; };
    for (;;) {
      while (at < all.size() && space(all[at])) ++at;
      if (at == all.size()) break;
      size_t end = at;
      while (end < all.size() && !space(all[end])) ++end;
      if (k == K) bad("too many");
      double v = 0;
      const auto r = std::from_chars(all.data() + at, all.data() + end, v);
      if (r.ec != std::errc() || r.ptr != all.data() + end) bad("not a number");
      if (!std::isfinite(v)) bad("not finite");
      if (!(v == 0 || (std::abs(v) >= 1e-30 && std::abs(v) <= 1e6))) bad("out of range");
      out[k++] = v;
      at = end;
    }
    if (k != K) bad("too few");
    return out;
  }

  // The one child element `name` (nullptr: none); a second one is an error, not ignored. (A
  // repeated attribute is not XML: tinyxml2 refuses it.)
  const tinyxml2::XMLElement* only_child(const tinyxml2::XMLElement* e, const char* name) const {
    const tinyxml2::XMLElement* c = e->FirstChildElement(name);
    if (c && c->NextSiblingElement(name)) fail(c->NextSiblingElement(name), "a second one");
    return c;
  }
  Frame origin(const tinyxml2::XMLElement* parent, std::array<double, 3>* xyz = nullptr,
               std::array<double, 3>* rpy = nullptr) const {
    const tinyxml2::XMLElement* o = only_child(parent, "origin");
    const std::array<double, 3> zero{};
    const auto x = numbers<3>(o, "xyz", zero);
    auto r = numbers<3>(o, "rpy", zero);
    if (snap_)
      for (double& angle : r) {
        const double snapped = spatial::snapped_right_angle(angle);
        if (snapped != angle) {
          snapped_.insert({o, static_cast<int>(&angle - r.data())});
          largest_snap_ = std::max(largest_snap_, std::abs(snapped - angle));
        }
        angle = snapped;
      }
    if (xyz) *xyz = x;
    if (rpy) *rpy = r;
    return {rotation(r), Eigen::Vector3d(x[0], x[1], x[2])};
  }
  // rpy as a matrix: Eigen's turns, or with snapping each right angle's turn exactly.
  Eigen::Matrix3d rotation(const std::array<double, 3>& r) const {
    if (!snap_) return rpy_matrix(r);
    const spatial::Mat3<double> R = spatial::rpy_rotation(r, true);
    Eigen::Matrix3d M;
    for (int k = 0; k < 9; ++k) M(k / 3, k % 3) = R[k];
    return M;
  }
  // A composed rotation back to rpy (snapped again: the exact right angles stay exact).
  std::array<double, 3> angles(const Eigen::Matrix3d& R) const {
    std::array<double, 3> r = matrix_rpy(R);
    if (snap_)
      for (double& angle : r) angle = spatial::snapped_right_angle(angle);
    return r;
  }

  // A joint's <limit effort velocity> and <dynamics damping friction>, each not negative, and a
  // revolute joint's <limit lower upper> (lower not above upper; a continuous joint has none).
  spatial::JointLimits limits(const tinyxml2::XMLElement* joint, const std::string& type) const {
    spatial::JointLimits l;
    auto read = [&](const tinyxml2::XMLElement* e, const char* name, double& to) {
      to = numbers<1>(e, name, std::array<double, 1>{0})[0];
      if (!(to >= 0)) fail(e, std::string("attribute '") + name + "': must not be negative");
    };
    if (const tinyxml2::XMLElement* e = only_child(joint, "limit")) {
      read(e, "effort", l.effort);
      read(e, "velocity", l.velocity);
      if (type == "revolute") {
        l.lower = numbers<1>(e, "lower", std::array<double, 1>{0})[0];
        l.upper = numbers<1>(e, "upper", std::array<double, 1>{0})[0];
        if (l.lower > l.upper)
          fail(e, "attributes 'lower' " + number_text(l.lower) + " and 'upper' " +
                      number_text(l.upper) + ": lower must not be above upper");
        if (l.lower == l.upper && l.lower != 0)
          fail(e, "attributes 'lower' and 'upper' are both " + number_text(l.lower) +
                      ": a joint its limits lock (make it a fixed joint; both 0 means no range)");
      }
    }
    if (const tinyxml2::XMLElement* e = only_child(joint, "dynamics")) {
      read(e, "damping", l.damping);
      read(e, "friction", l.friction);
    }
    return l;
  }

  Inertial inertial(const tinyxml2::XMLElement* link) const {
    Inertial in;
    const tinyxml2::XMLElement* e = only_child(link, "inertial");
    if (!e) return in;
    const tinyxml2::XMLElement* m = only_child(e, "mass");
    const tinyxml2::XMLElement* i = only_child(e, "inertia");
    if (!m || !i) fail(e, "needs <mass> and <inertia>");
    in.mass = numbers<1>(m, "value", std::nullopt)[0];
    if (!(in.mass >= 0)) fail(m, "attribute 'value': the mass must not be negative");
    double t[6];
    const char* names[6] = {"ixx", "ixy", "ixz", "iyy", "iyz", "izz"};
    for (int k = 0; k < 6; ++k) t[k] = numbers<1>(i, names[k], std::nullopt)[0];
    Eigen::Matrix3d I;
    I << t[0], t[1], t[2], t[1], t[3], t[4], t[2], t[4], t[5];
    const Frame f = origin(e);
    in.com = f.p;
    in.I = f.R * I * f.R.transpose();
    return in;
  }

  UrdfChain read(const std::string& xml, bool free_base,
                 const std::vector<std::string>& end_effector_links) {
    bound_the_parse(xml, source_);
    tinyxml2::XMLDocument doc;
    if (doc.Parse(xml.data(), xml.size()) != tinyxml2::XML_SUCCESS)
      throw SceneError("URDF '" + source_ + "' line " + std::to_string(doc.ErrorLineNum()) +
                       ": not XML (" + parse_error(doc) + ")");
    const tinyxml2::XMLElement* robot = doc.FirstChildElement("robot");
    if (!robot) fail(nullptr, "expected a <robot> element at the top");
    if (doc.FirstChildElement() != robot || robot->NextSiblingElement())
      fail(doc.FirstChildElement() != robot ? doc.FirstChildElement() : robot->NextSiblingElement(),
           "a second element at the top: an XML document has one root, <robot>");
    refuse_xacro(robot);
    read_elements(robot);
    UrdfChain out = chain(free_base, end_effector_links);
    out.chain.exact_right_angles = snap_;
    out.snapped_angles = static_cast<int>(snapped_.size());
    out.largest_snap = largest_snap_;
    return out;
  }

 private:
  std::string source_;
  std::set<std::string> given_;  // links whose inertial the scene gives: parts, not lumped
  bool snap_ = false;            // snap_right_angles
  mutable std::set<std::pair<const void*, int>> snapped_;  // each <origin>'s angles moved
  mutable double largest_snap_ = 0;
  std::map<std::string, const tinyxml2::XMLElement*> links_;
  std::map<std::string, Joint> joints_;                   // by name
  std::map<std::string, std::string> parent_joint_;       // child link -> joint
  std::multimap<std::string, std::string> child_joints_;  // parent link -> joints

  // xacro (ROS's macro language) is not URDF: its macros add joints and links that a URDF
  // reader would silently drop. Any element or attribute in its namespace, and any ${...} or
  // $(...) expression, is refused by name.
  void refuse_xacro(const tinyxml2::XMLElement* e) const {
    const std::string remedy =
        ": this is xacro, not URDF; run 'xacro FILE.urdf.xacro > FILE.urdf' "
        "first and give the URDF it prints";
    if (std::string_view(e->Name()).rfind("xacro:", 0) == 0)
      fail(e, "the element " + quoted_text(e->Name()) + remedy);
    for (const auto* a = e->FirstAttribute(); a; a = a->Next()) {
      const std::string_view name(a->Name()), value(a->Value());
      if (name.rfind("xacro:", 0) == 0 || value.find("ros.org/wiki/xacro") != std::string::npos)
        fail(e, "the attribute " + quoted_text(a->Name()) + remedy);
      if (value.find("${") != std::string::npos || value.find("$(") != std::string::npos)
        fail(e, "attribute " + quoted_text(a->Name()) + " = " + quoted_text(a->Value()) +
                    " holds a xacro expression" + remedy);
    }
    for (const auto* c = e->FirstChildElement(); c; c = c->NextSiblingElement()) refuse_xacro(c);
  }

  void read_elements(const tinyxml2::XMLElement* robot) {
    for (auto* l = robot->FirstChildElement("link"); l; l = l->NextSiblingElement("link")) {
      const std::string name = attribute(l, "name");
      if (!links_.emplace(name, l).second) fail(l, "a second link of this name");
      if (links_.size() > 1000) fail(l, "more than 1000 links");
    }
    if (links_.empty()) fail(robot, "has no <link>");
    for (auto* e = robot->FirstChildElement("joint"); e; e = e->NextSiblingElement("joint")) {
      Joint j;
      j.element = e;
      j.name = attribute(e, "name");
      j.type = attribute(e, "type");
      const auto* parent = only_child(e, "parent");
      const auto* child = only_child(e, "child");
      if (const auto* mimic = e->FirstChildElement("mimic"))
        fail(mimic, "a mimic joint (coupled to another) is not read");
      if (!parent || !child) fail(e, "needs <parent link=...> and <child link=...>");
      j.parent = attribute(parent, "link");
      j.child = attribute(child, "link");
      for (const auto& [end, name] : {std::pair{parent, j.parent}, std::pair{child, j.child}})
        if (!links_.count(name)) fail(end, "no link named " + quoted_text(name));
      j.origin = origin(e, &j.xyz, &j.rpy);
      if (const auto* axis = only_child(e, "axis")) {
        j.axis = numbers<3>(axis, "xyz", std::array<double, 3>{1, 0, 0});
        const double n =
            std::sqrt(j.axis[0] * j.axis[0] + j.axis[1] * j.axis[1] + j.axis[2] * j.axis[2]);
        if (!(n > 1e-12)) fail(axis, "attribute 'xyz': the axis must not be zero");
      }
      j.limits = limits(e, j.type);
      if (j.type != "revolute" && j.type != "continuous" && j.type != "fixed")
        fail(e, "joint type " + quoted_text(j.type) +
                    ": only revolute, continuous and fixed joints are read (prismatic, "
                    "floating and planar joints are not)");
      if (parent_joint_.count(j.child))
        fail(e, "link " + quoted_text(j.child) + " already has a parent joint, " +
                    quoted_text(parent_joint_[j.child]) + ": a URDF is a tree");
      if (!joints_.emplace(j.name, j).second) fail(e, "a second joint of this name");
      parent_joint_[j.child] = j.name;
      child_joints_.emplace(j.parent, j.name);
    }
  }

  // The links welded to `body` (itself included) with their frames in the body's; the moving
  // joints that leave them.
  void weld(const std::string& link, const Frame& in_body,
            std::vector<std::pair<std::string, Frame>>& welded,
            std::vector<const Joint*>& moving) const {
    welded.push_back({link, in_body});
    const auto [first, last] = child_joints_.equal_range(link);
    for (auto it = first; it != last; ++it) {
      const Joint& j = joints_.at(it->second);
      if (j.type == "fixed")
        weld(j.child, in_body * j.origin, welded, moving);
      else
        moving.push_back(&j);
    }
  }

  // A body's lumped mass, centre and inertia about it, in the body's frame.
  spatial::Link lumped(const std::vector<std::pair<std::string, Frame>>& welded) const {
    double m = 0;
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    std::vector<Inertial> parts;
    for (const auto& [name, f] : welded) {
      if (given_.count(name)) continue;
      Inertial in = inertial(links_.at(name));
      in.com = f.p + f.R * in.com;
      in.I = f.R * in.I * f.R.transpose();
      m += in.mass;
      c += in.mass * in.com;
      parts.push_back(in);
    }
    spatial::Link l;
    l.mass = m;
    if (m > 0) c /= m;
    Eigen::Matrix3d I = Eigen::Matrix3d::Zero();
    for (const Inertial& in : parts) {
      const Eigen::Vector3d d = in.com - c;
      I += in.I + in.mass * (d.squaredNorm() * Eigen::Matrix3d::Identity() - d * d.transpose());
    }
    l.com = {c[0], c[1], c[2]};
    l.inertia = {I(0, 0), I(0, 1), I(0, 2), I(1, 1), I(1, 2), I(2, 2)};
    return l;
  }

  // The <visual> shapes of a body's links, in the body's frame (at most 500 in all).
  void body_visuals(const std::vector<std::pair<std::string, Frame>>& welded,
                    UrdfChain& out) const {
    std::vector<spatial::Visual>& shapes = out.body_visuals.emplace_back();
    for (const auto& [name, f] : welded) {
      const tinyxml2::XMLElement* link = links_.at(name);
      for (auto* v = link->FirstChildElement("visual"); v; v = v->NextSiblingElement("visual")) {
        const tinyxml2::XMLElement* g = only_child(v, "geometry");
        if (!g) continue;
        if (g->FirstChildElement() && g->FirstChildElement()->NextSiblingElement())
          fail(g->FirstChildElement()->NextSiblingElement(), "a second shape in one <geometry>");
        spatial::Visual shape;
        if (!read_shape(g, shape)) {  // not drawn: counted
          out.undrawn += g->FirstChildElement() != nullptr;
          continue;
        }
        const Frame at = f * origin(v);
        shape.xyz = {at.p[0], at.p[1], at.p[2]};
        const Eigen::Quaterniond q(at.R);
        shape.quaternion = {q.w(), q.x(), q.y(), q.z()};
        size_t count = 0;
        for (const auto& body : out.body_visuals) count += body.size();
        if (count >= 500) fail(v, "more than 500 visuals");
        shapes.push_back(shape);
      }
    }
  }

  // A <geometry>'s shape; false for one not drawn (a mesh not STL, a shape URDF does not define).
  bool read_shape(const tinyxml2::XMLElement* g, spatial::Visual& shape) const {
    if (const auto* box = only_child(g, "box")) {
      shape.kind = "box";
      shape.size = numbers<3>(box, "size", std::nullopt);
    } else if (const auto* c = only_child(g, "cylinder")) {
      shape.kind = "cylinder";
      shape.size = {numbers<1>(c, "radius", std::nullopt)[0],
                    numbers<1>(c, "length", std::nullopt)[0], 0};
    } else if (const auto* s = only_child(g, "sphere")) {
      shape.kind = "sphere";
      shape.size = {numbers<1>(s, "radius", std::nullopt)[0], 0, 0};
    } else if (const auto* m = only_child(g, "mesh")) {
      shape.kind = "mesh";
      shape.size = numbers<3>(m, "scale", std::array<double, 3>{1, 1, 1});
      shape.mesh = mesh_path(m);
      if (shape.mesh.empty()) return false;
    } else {
      return false;
    }
    for (double x : shape.size)
      if (x < 0)
        fail(g->FirstChildElement(), "a visual's size must not be negative, got " + number_text(x));
    return true;
  }

  // A mesh's file as a path inside the URDF's folder: "package://PKG/REST" and "REST" are REST,
  // which must be relative, without '..', '.' or empty parts, of at most 255 printable ASCII
  // characters. "" for a mesh that is not STL (drawn as nothing, counted). Untrusted: a scene must
  // not make the viewer embed a file outside the URDF's folder into a page.
  std::string mesh_path(const tinyxml2::XMLElement* m) const {
    const char* attribute = m->Attribute("filename");
    if (!attribute) fail(m, "a <mesh> needs a filename");
    std::string path = attribute;
    const std::string package = "package://";
    if (path.rfind(package, 0) == 0) {
      const size_t slash = path.find('/', package.size());
      path = slash == std::string::npos ? "" : path.substr(slash + 1);
    }
    auto refuse = [&](const std::string& why) {
      fail(m, "mesh filename " + quoted_text(attribute) + ": " + why);
    };
    if (path.empty() || path.size() > 255) refuse("expected a path of 1 to 255 characters");
    if (path.front() == '/' || path.find("://") != std::string::npos)
      refuse("expected a path relative to the URDF's folder (or package://PACKAGE/PATH)");
    for (char c : path)
      if (c < 0x21 || c > 0x7e || c == '\\') refuse("expected printable ASCII without spaces");
    for (size_t at = 0; at <= path.size();) {
      const size_t end = std::min(path.find('/', at), path.size());
      const std::string part = path.substr(at, end - at);
      if (part.empty() || part == "." || part == "..")
        refuse("a path inside the URDF's folder has no empty, '.' or '..' part");
      at = end + 1;
    }
    std::string extension = path.size() > 4 ? path.substr(path.size() - 4) : "";
    for (char& c : extension) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return extension == ".stl" ? path : "";
  }

  UrdfChain chain(bool free_base, const std::vector<std::string>& end_effector_links) {
    UrdfChain out;
    std::vector<std::string> roots;
    for (const auto& [name, e] : links_)
      if (!parent_joint_.count(name)) roots.push_back(name);
    if (roots.size() != 1)
      fail(links_.begin()->second, std::to_string(roots.size()) +
                                       " links have no parent joint; a URDF has exactly one root");
    out.root_link = roots[0];
    out.chain.free_base = free_base;
    Walk walk;
    add_body(roots[0], nullptr, {}, {}, 0, 0, out, walk);
    if (out.chain.links.empty()) fail(links_.at(roots[0]), "no moving joint");
    if (walk.seen.size() != links_.size())
      fail(nullptr, "links not connected to the root " + quoted_text(roots[0]));
    end_effectors(end_effector_links, walk, out);
    return out;
  }

  // What the walk over the bodies keeps for the end effectors: every link's body and frame in
  // it, and each leaf body's welded links (a body no moving joint leaves).
  struct Walk {
    std::set<std::string> seen;
    std::map<std::string, std::pair<int, Frame>> in_body;
    std::vector<std::vector<std::pair<std::string, Frame>>> leaves;
  };

  // Body `link` (the root, or the child of the moving joint `carrier` at joint_xyz/rpy in body
  // `parent`) and, depth-first, the bodies after it: the moving joints that leave its welded
  // links in the order the URDF lists them (MuJoCo's URDF import numbers its bodies so).
  void add_body(const std::string& link, const Joint* carrier, std::array<double, 3> joint_xyz,
                std::array<double, 3> joint_rpy, int parent, int depth, UrdfChain& out,
                Walk& walk) {
    std::vector<std::pair<std::string, Frame>> welded;
    std::vector<const Joint*> moving;
    weld(link, Frame{}, welded, moving);
    const int body = carrier ? static_cast<int>(out.chain.links.size()) + 1 : 0;
    out.body_links.emplace_back();
    for (const auto& [name, f] : welded) {
      walk.seen.insert(name);
      walk.in_body[name] = {body, f};
      out.body_links.back().push_back(name);
    }
    spatial::Link l = lumped(welded);
    for (const auto& [name, f] : welded)
      if (given_.count(name)) {
        out.given_parts[name] = {body, static_cast<int>(l.parts.size())};
        l.parts.push_back({{f.p[0], f.p[1], f.p[2]}, angles(f.R), {}});
      }
    if (carrier) {
      l.origin_xyz = joint_xyz;
      l.origin_rpy = joint_rpy;
      l.axis = carrier->axis;
      l.parent = parent;
      out.chain.links.push_back(l);
      out.joint_names.push_back(carrier->name);
      out.limits.push_back(carrier->limits);
    } else {
      out.chain.base = l;
    }
    body_visuals(welded, out);
    if (moving.empty() && carrier) walk.leaves.push_back(welded);
    for (const Joint* next : moving) {
      if (out.chain.links.size() >= kMaxMovingJoints)
        fail(next->element, "more than " + std::to_string(kMaxMovingJoints) + " moving joints");
      if (depth + 1 > kMaxPathJoints)
        fail(next->element, "more than " + std::to_string(kMaxPathJoints) +
                                " moving joints on one path from the root");
      // The joint's frame in this body: as written where it leaves the body's own link, else
      // composed through the welded link it leaves from.
      std::array<double, 3> xyz = next->xyz, rpy = next->rpy;
      for (const auto& [name, f] : welded)
        if (name == next->parent && name != link) {
          const Frame composed = f * next->origin;
          xyz = {composed.p[0], composed.p[1], composed.p[2]};
          rpy = angles(composed.R);
        }
      add_body(next->child, next, xyz, rpy, body, depth + 1, out, walk);
    }
  }

  // The welded link a URDF's tool ends in: the one leaf among the links welded to a last moving
  // body (the body itself when nothing is welded to it); several leaves are refused, named.
  std::string welded_leaf(const std::vector<std::pair<std::string, Frame>>& welded) const {
    std::vector<std::string> leaves;
    for (const auto& [link, f] : welded)
      if (!child_joints_.count(link)) leaves.push_back(link);
    if (leaves.size() == 1) return leaves[0];
    std::string listed;
    for (const std::string& l : leaves) listed += (listed.empty() ? "" : ", ") + quoted_text(l);
    throw SceneError("URDF '" + source_ + "': the last moving body " +
                     quoted_text(welded.front().first) + " ends in " +
                     std::to_string(leaves.size()) + " welded links (" + listed +
                     "): say which is the end effector with the scene's end_effector_link" +
                     (walk_leaves_ > 1 ? "s" : ""));
  }

  // The end effectors: the links named, in their order, else the tool of every last moving body
  // (its one welded leaf), in the order of the bodies; each at its link's origin and turned as it.
  void end_effectors(const std::vector<std::string>& wanted, const Walk& walk, UrdfChain& out) {
    std::vector<std::string> names = wanted;
    walk_leaves_ = walk.leaves.size();
    if (names.empty())
      for (const auto& welded : walk.leaves) names.push_back(welded_leaf(welded));
    out.chain.end_effectors.clear();
    for (const std::string& name : names) {
      const auto it = walk.in_body.find(name);
      if (it == walk.in_body.end())
        throw SceneError("URDF '" + source_ + "': no link named " + quoted_text(name) +
                         " for the end effector");
      const auto& [body, f] = it->second;
      if (body == 0)
        throw SceneError("URDF '" + source_ + "': end effector link " + quoted_text(name) +
                         " is the base's (welded to the root): it moves with no joint");
      for (const auto& e : out.chain.end_effectors)
        if (e.link == name)
          throw SceneError("URDF '" + source_ + "': end effector link " + quoted_text(name) +
                           " is named twice");
      out.chain.end_effectors.push_back({name, body, {f.p[0], f.p[1], f.p[2]}, angles(f.R)});
    }
    out.end_effector_link = out.chain.end_effectors.front().link;
  }
  size_t walk_leaves_ = 0;
};

}  // namespace

UrdfChain read_urdf(const std::string& xml, const std::string& source, bool free_base,
                    const std::vector<std::string>& end_effector_links,
                    const std::set<std::string>& given, bool snap_right_angles) {
  return UrdfReader(source, given, snap_right_angles).read(xml, free_base, end_effector_links);
}

UrdfChain read_urdf(const std::string& xml, const std::string& source, bool free_base,
                    const std::string& end_effector_link, const std::set<std::string>& given,
                    bool snap_right_angles) {
  std::vector<std::string> links;
  if (!end_effector_link.empty()) links.push_back(end_effector_link);
  return read_urdf(xml, source, free_base, links, given, snap_right_angles);
}

}  // namespace spacearm
