#include "mjcf_export.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include <cmath>
#include <cstdio>
#include <functional>
#include <sstream>
#include <stdexcept>

#include "text_numbers.hpp"
#include "version.hpp"

namespace spacearm {

namespace {

// Numbers for an attribute, with 17 significant digits: MuJoCo reads back spacearm's doubles.
// One that overflowed (run-time parameters at the edge of their range) is refused, never written.
std::string numbers(std::initializer_list<double> values) {
  std::string text;
  char one[32];
  for (double v : values) {
    if (!std::isfinite(v))
      throw std::invalid_argument(
          "export --mjcf: a number of the MuJoCo model is not finite (the --param values "
          "overflow it)");
    std::snprintf(one, sizeof one, "%.17g", v == 0 ? 0.0 : v);  // no "-0"
    text += (text.empty() ? "" : " ") + std::string(one);
  }
  return text;
}

// Whether a name can be an XML attribute that every parser reads back as it is: valid UTF-8,
// no control character (tab, newline and CR would be read back as spaces), no surrogate or
// non-character (U+FFFE, U+FFFF). Hand-written: a few lines over the bytes.
bool xml_safe(const std::string& name) {
  const auto* s = reinterpret_cast<const unsigned char*>(name.data());
  for (size_t i = 0, n = name.size(); i < n;) {
    const unsigned c = s[i];
    if (c < 0x20 || c == 0x7f) return false;
    if (c < 0x80) {
      ++i;
      continue;
    }
    const int more = c >= 0xf0 ? (c <= 0xf4 ? 3 : -1) : c >= 0xe0 ? 2 : c >= 0xc2 ? 1 : -1;
    if (more < 0 || i + more >= n) return false;
    unsigned code = c & (0x3f >> more);
    for (int k = 1; k <= more; ++k) {
      if ((s[i + k] & 0xc0) != 0x80) return false;
      code = (code << 6) | (s[i + k] & 0x3f);
    }
    const unsigned least[] = {0, 0x80, 0x800, 0x10000};
    if (code < least[more] || code > 0x10ffff || (code >= 0xd800 && code <= 0xdfff) ||
        code == 0xfffe || code == 0xffff)
      return false;
    i += more + 1;
  }
  return true;
}

// Text in an attribute (a URDF's names may hold any character): XML's five as entities.
std::string attribute(const std::string& text) {
  std::string out;
  for (char c : text) switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&apos;";
        break;
      default:
        out += c;
    }
  return out;
}

Eigen::Matrix3d tensor(const std::array<double, 6>& i) {
  Eigen::Matrix3d I;
  I << i[0], i[1], i[2], i[1], i[3], i[4], i[2], i[4], i[5];
  return I;
}

// A rotation's quaternion (w x y z) for an attribute.
std::string quaternion(const Eigen::Matrix3d& R) {
  const Eigen::Quaterniond q(R);
  return numbers({q.w(), q.x(), q.y(), q.z()});
}

// A body's mass, centre and inertia about it (in the body's frame), as numbers.
struct Mass {
  double m = 0;
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  Eigen::Matrix3d I = Eigen::Matrix3d::Zero();
};

// Mass a less a point mass mp at p (exact: its first and second moments removed).
Mass less_point_mass(const Mass& a, double mp, const Eigen::Vector3d& p) {
  auto second_moment = [](double m, const Eigen::Vector3d& r) {
    return Eigen::Matrix3d(m * (r.squaredNorm() * Eigen::Matrix3d::Identity() - r * r.transpose()));
  };
  Mass out;
  out.m = a.m - mp;
  out.c = (a.m * a.c - mp * p) / out.m;
  out.I = a.I + second_moment(a.m, a.c) - second_moment(mp, p) - second_moment(out.m, out.c);
  return out;
}

class MjcfWriter {
 public:
  MjcfWriter(const SpatialScene& s, const MjcfOptions& o) : s_(s), o_(o) {
    params_ = o.params.empty() ? nominal_values(s.parameters) : o.params;
    if (params_.size() != s.parameters.size())
      throw std::invalid_argument("export: " + std::to_string(params_.size()) +
                                  " parameter values for " + std::to_string(s.parameters.size()) +
                                  " parameters");
  }

  MjcfNames names() const {
    MjcfNames n;
    if (s_.chain.free_base) n.base_joint = body_name(0);
    for (size_t j = 0; j < s_.chain.links.size(); ++j) {
      n.joints.push_back(joint_name(j));
      n.rotors.push_back(exact_rotor(j) ? rotor_name(j) : "");
    }
    return n;
  }

  std::string write() {
    const spatial::ChainDescription& c = s_.chain;
    for (size_t j = 0; j < c.links.size(); ++j) refuse_what_mujoco_lacks(j);
    check_names();
    std::vector<Mass> bodies;  // 0 the base, j + 1 link j; less exact rotors' point masses
    for (size_t b = 0; b <= c.links.size(); ++b) bodies.push_back(body_mass(b));
    for (size_t j = 0; j < c.links.size(); ++j)
      if (const int parent = c.parent(int(j) + 1); exact_rotor(j) && (parent > 0 || c.free_base))
        bodies[parent] = with_rotor_removed(bodies[parent], j);
    check_physical(bodies);
    std::ostringstream x;
    header(x);
    x << "  <worldbody>\n    <body name=\"" << attribute(body_name(0)) << "\">\n";
    if (c.free_base) {
      x << "      <freejoint name=\"" << attribute(body_name(0)) << "\"/>\n";
      x << "      " << inertial(bodies[0]) << "\n";
    }
    children(x, 0, bodies, "      ");
    x << "    </body>\n  </worldbody>\n";
    equalities(x);
    x << "</mujoco>\n";
    return x.str();
  }

 private:
  const SpatialScene& s_;
  const MjcfOptions& o_;
  std::vector<double> params_;
  bool balance_ = false;  // some body is not physical and balance_inertia allows it

  double value(const Quantity& q) const { return q.is_parameter() ? params_.at(q.index) : q.value; }
  const spatial::Link& link(size_t j) const { return s_.chain.links.at(j); }
  double ratio(size_t j) const { return link(j).gear.present ? value(link(j).gear.ratio) : 1.0; }
  bool exact_rotor(size_t j) const {
    const spatial::Gear& g = link(j).gear;
    return g.present && exact_coupling(j) && (value(g.axial) != 0 || value(g.transverse) != 0);
  }
  // A coupling factor (refused unless 0 or 1) is exact at 1, armature at 0.
  bool exact_coupling(size_t j) const {
    const spatial::Gear& g = link(j).gear;
    return g.coupled ? value(g.coupling) == 1 : g.exact;
  }
  std::string body_name(size_t b) const {
    if (b < s_.body_names.size()) return s_.body_names[b];
    return b == 0 ? "base" : "link" + std::to_string(b);
  }
  std::string joint_name(size_t j) const {
    return j < s_.joint_names.size() ? s_.joint_names[j] : "joint" + std::to_string(j + 1);
  }
  // "end_effector" for a chain's one; a tree's are named by their links.
  std::string site_name(int e) const {
    const spatial::ChainDescription& c = s_.chain;
    if (c.num_end_effectors() == 1) return "end_effector";
    const std::string& link = c.end_effectors[size_t(e)].link;
    return "end_effector_" + (link.empty() ? std::to_string(e + 1) : link);
  }
  std::string rotor_name(size_t j) const { return "spacearm_rotor_" + std::to_string(j + 1); }
  Eigen::Vector3d axis(size_t j) const {
    const auto& a = link(j).axis;
    return Eigen::Vector3d(a[0], a[1], a[2]).normalized();
  }
  // The joint's frame in its parent body's: where the link body and an exact rotor sit.
  Eigen::Matrix3d joint_rotation(size_t j) const {
    const auto q = spatial::rpy_quaternion(link(j).origin_rpy);
    return Eigen::Quaterniond(q[0], q[1], q[2], q[3]).toRotationMatrix();
  }
  Eigen::Vector3d joint_origin(size_t j) const {
    const auto& p = link(j).origin_xyz;
    return Eigen::Vector3d(p[0], p[1], p[2]);
  }

  void refuse_what_mujoco_lacks(size_t j) const {
    if (link(j).gear.present && link(j).gear.flexible)
      throw std::invalid_argument(
          "export --mjcf: joint " + quoted_text(joint_name(j)) +
          " is flexible (gears: stiffness): its spring between the motor and the link has no "
          "MuJoCo counterpart here yet; export the scene with rigid gears");
    const spatial::Gear& g = link(j).gear;
    if (g.present && g.coupled && value(g.coupling) != 0 && value(g.coupling) != 1)
      throw std::invalid_argument(
          "export --mjcf: joint " + quoted_text(joint_name(j)) + " has rotor_coupling " +
          (g.coupling.is_parameter() ? g.coupling.parameter + " = " : std::string()) +
          number_text(value(g.coupling)) + ": MuJoCo has exact rotors (1) and armature (0) only; " +
          (g.coupling.is_parameter() ? "export with --param " + g.coupling.parameter + "=1 or =0"
                                     : std::string("give rotor_coupling: exact or armature")));
  }

  Mass body_mass(size_t b) const {
    const spatial::Link& l = b == 0 ? s_.chain.base : link(b - 1);
    const spatial::Inertial w = whole_body(
        l, [this](const Quantity& q) { return value(q); }, s_.chain.exact_right_angles);
    Mass m;
    m.m = w.mass.value;
    m.c = Eigen::Vector3d(w.com[0].value, w.com[1].value, w.com[2].value);
    m.I = tensor(w.inertia_values());
    return m;
  }

  // An exact rotor is a body of its own in MuJoCo, which needs a positive mass: a tiny one
  // (1e-9 of its parent's) at the joint's origin, taken from the parent so that the whole keeps
  // spacearm's mass, centre and inertia; and a physical tensor: where its transverse inertia is
  // below half its axial one, the rotor body gets half (a thin disc) and the parent the
  // difference, which turns with it (symmetric about the axis), so the sum is spacearm's.
  Mass with_rotor_removed(const Mass& parent, size_t j) const {
    // The rotor body's mass from the whole parent (a branching parent may carry several).
    const double mr = rotor_mass(body_mass(size_t(s_.chain.parent(int(j) + 1))));
    Mass out = less_point_mass(parent, mr, joint_origin(j));
    const double It = value(link(j).gear.transverse), T = rotor_transverse(j);
    const Eigen::Vector3d a = joint_rotation(j) * axis(j);
    out.I += (It - T) * (Eigen::Matrix3d::Identity() - a * a.transpose());
    return out;
  }
  // A fixed base has no mass of its own: its rotors get 1e-9 kg (the base does not move).
  static double rotor_mass(const Mass& parent) { return parent.m > 0 ? 1e-9 * parent.m : 1e-9; }
  double rotor_transverse(size_t j) const {
    return std::max(value(link(j).gear.transverse), value(link(j).gear.axial) / 2);
  }

  // Every moving body's tensor must be physical for MuJoCo (it refuses others unless its
  // balanceinertia changes them): all such bodies named at once.
  void check_physical(const std::vector<Mass>& bodies) {
    std::string listed, massless;
    for (size_t b = s_.chain.free_base ? 0 : 1; b < bodies.size(); ++b) {
      if (!(bodies[b].m > 0)) {  // a payload of mass 0 with nothing else on its body
        massless += (massless.empty() ? "" : ", ") + quoted_text(body_name(b));
        continue;
      }
      const Eigen::Vector3d m =
          Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(bodies[b].I).eigenvalues();
      if (m.minCoeff() > 0 && m[0] + m[1] >= m[2] * (1 - 1e-12)) continue;
      listed += (listed.empty() ? "" : ", ") + quoted_text(body_name(b));
    }
    if (!massless.empty())
      throw std::invalid_argument(
          "export --mjcf: MuJoCo's moving bodies need a positive mass, "
          "and these bodies' is 0 at the parameters' values: " +
          massless);
    if (listed.empty()) return;
    bool thin_rotor = false;  // a rotor's transverse inertia below half its axial one
    for (size_t j = 0; j < s_.chain.links.size(); ++j)
      thin_rotor =
          thin_rotor || (exact_rotor(j) && rotor_transverse(j) > value(link(j).gear.transverse));
    if (thin_rotor)
      listed +=
          " (exact rotors whose transverse inertia is below half their axial one lend the "
          "difference to their parent body, whose tensor must then stay physical)";
    if (!o_.balance_inertia)
      throw std::invalid_argument(
          "export --mjcf: MuJoCo takes only physical inertias (each principal moment at most the "
          "sum of the other two), and these bodies' are not: " +
          listed +
          ". --balance-inertia lets MuJoCo change them (balanceinertia), so its model "
          "then differs from spacearm's");
    balance_ = true;
  }

  // Every name the file gives, once per kind (MuJoCo refuses a repeated one), none of them
  // MuJoCo's own "world" body, each one XML carries as it is.
  void check_names() const {
    std::vector<std::pair<std::string, std::string>> bodies, joints;  // (name, what it is)
    for (size_t b = 0; b <= s_.chain.links.size(); ++b)
      bodies.push_back({body_name(b), b == 0
                                          ? "the base's body"
                                          : "joint " + quoted_text(joint_name(b - 1)) + "'s body"});
    if (s_.chain.free_base) joints.push_back({body_name(0), "the base's free joint"});
    std::vector<std::pair<std::string, std::string>> sites;
    for (int e = 0; e < s_.chain.num_end_effectors(); ++e)
      sites.push_back({site_name(e), "end effector " + std::to_string(e + 1) + "'s site"});
    for (size_t j = 0; j < s_.chain.links.size(); ++j) {
      joints.push_back({joint_name(j), "a joint"});
      if (exact_rotor(j)) {
        bodies.push_back({rotor_name(j), "an exact rotor's body"});
        joints.push_back({rotor_name(j), "an exact rotor's joint"});
      }
    }
    for (const auto* list : {&bodies, &joints, &sites})
      for (size_t a = 0; a < list->size(); ++a) {
        const auto& [name, what] = (*list)[a];
        if (!xml_safe(name))
          throw std::invalid_argument("export --mjcf: the name " + quoted_text(name) + " of " +
                                      what +
                                      " holds a character XML cannot carry as it is (a control "
                                      "character, or bytes that are not UTF-8)");
        if (list == &bodies && name == "world")
          throw std::invalid_argument(
              "export --mjcf: " + what +
              " is named 'world', MuJoCo's own world body: rename the URDF's link");
        for (size_t b = 0; b < a; ++b)
          if ((*list)[b].first == name)
            throw std::invalid_argument("export --mjcf: " + (*list)[b].second + " and " + what +
                                        " are both named " + quoted_text(name) +
                                        ", and MuJoCo needs each name once: rename one");
      }
  }

  void header(std::ostringstream& x) const {
    const spatial::ChainDescription& c = s_.chain;
    x << "<mujoco model=\"" << attribute(s_.name) << "\">\n"
      << "  <!-- Written by spacearm " << kGeneratorVersion
      << " (spacearm export, MJCF) from a scene, for MuJoCo 2.2 or later.\n"
      << "       In space: no gravity, no contacts. spacearm's coordinates: the base's free "
         "joint\n"
      << "       (origin, quaternion w x y z; linear velocity in the world, angular in the "
         "base),\n"
      << "       then one hinge per joint, its angle the link angle q. Where spacearm's "
         "coordinate\n"
      << "       is a geared joint's motor angle qm = p q, MuJoCo's is qm / p (and its rate "
         "qm' / p);\n"
      << "       a joint torque tau is MuJoCo's qfrc on the hinge (spacearm's tau / p on qm).\n";
    bool any_rotor = false;
    for (size_t j = 0; j < c.links.size(); ++j) any_rotor = any_rotor || exact_rotor(j);
    if (any_rotor)
      x << "       Exact rotors (rotor_coupling: exact) are bodies of their own on the parent,\n"
        << "       each a hinge held at p times its joint's angle by a joint equality, which\n"
        << "       MuJoCo enforces softly: their angles follow the arm's in qpos.\n";
    x << "  -->\n"
      << "  <compiler angle=\"radian\" boundmass=\"0\" boundinertia=\"0\""
      << (balance_ ? " balanceinertia=\"true\"" : "") << "/>\n"
      << "  <option gravity=\"0 0 0\" timestep=\"0.001\" integrator=\"RK4\">\n"
      << "    <flag contact=\"disable\" gravity=\"disable\"/>\n"
      << "  </option>\n";
  }

  // An inertial in its principal axes: MuJoCo then keeps it to double precision.
  static std::string inertial(const Mass& m) {
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(m.I);
    Eigen::Matrix3d axes = eig.eigenvectors();
    if (axes.determinant() < 0) axes.col(2) *= -1;
    const Eigen::Vector3d d = eig.eigenvalues();
    return "<inertial pos=\"" + numbers({m.c[0], m.c[1], m.c[2]}) + "\" quat=\"" +
           quaternion(axes) + "\" mass=\"" + numbers({m.m}) + "\" diaginertia=\"" +
           numbers({d[0], d[1], d[2]}) + "\"/>";
  }

  // The links body b carries, depth-first in their order (MuJoCo numbers its bodies so): each
  // nested in its parent, an exact rotor a sibling after its joint's link.
  void children(std::ostringstream& x, int b, const std::vector<Mass>& bodies,
                const std::string& indent) const {
    const spatial::ChainDescription& c = s_.chain;
    for (size_t j = 0; j < c.links.size(); ++j) {
      if (c.parent(int(j) + 1) != b) continue;
      link_body(x, j, bodies[j + 1], indent);
      children(x, int(j) + 1, bodies, indent + "  ");
      x << indent << "</body>\n";
      if (exact_rotor(j)) rotor_body(x, j, indent);
    }
  }

  void link_body(std::ostringstream& x, size_t j, const Mass& m, const std::string& indent) const {
    const spatial::Link& l = link(j);
    const Eigen::Vector3d a = axis(j);
    x << indent << "<body name=\"" << attribute(body_name(j + 1)) << "\" pos=\""
      << numbers({l.origin_xyz[0], l.origin_xyz[1], l.origin_xyz[2]}) << "\" quat=\""
      << quaternion(joint_rotation(j)) << "\">\n";
    x << indent << "  <joint name=\"" << attribute(joint_name(j)) << "\" type=\"hinge\" axis=\""
      << numbers({a[0], a[1], a[2]}) << "\"" << joint_extras(j) << "/>\n";
    x << indent << "  " << inertial(m) << "\n";
    if (l.friction.present && (l.friction.has_coulomb || l.friction.has_stribeck))
      x << indent
        << "  <!-- this joint's Coulomb friction is smoothed (tanh(w / vs)) in spacearm; "
           "MuJoCo's frictionloss is not: left out -->\n";
    const spatial::ChainDescription& c = s_.chain;
    for (int e = 0; e < c.num_end_effectors(); ++e) {
      if (c.end_effector_body(e) != int(j) + 1) continue;
      const auto& t = c.end_effectors[e].xyz;
      const auto q = spatial::rpy_quaternion(c.end_effectors[e].rpy);
      x << indent << "  <site name=\"" << attribute(site_name(e)) << "\" pos=\""
        << numbers({t[0], t[1], t[2]}) << "\" quat=\"" << numbers({q[0], q[1], q[2], q[3]})
        << "\"/>\n";
    }
  }

  // armature = p^2 I_axial for an armature gear; damping = p^2 b for viscous friction b on the
  // motor's rate (the force p b p q' on q). A URDF's range (link side, as MuJoCo's hinge angle)
  // is kept but not enforced (limited="false"): spacearm's dynamics has no limit forces, so
  // MuJoCo's would differ from it near a limit; set limited="true" to have MuJoCo's.
  std::string joint_extras(size_t j) const {
    const spatial::Link& l = link(j);
    const double p = ratio(j);
    std::string extras;
    if (j < s_.joint_limits.size() && s_.joint_limits[j].has_range())
      extras += " range=\"" + numbers({s_.joint_limits[j].lower, s_.joint_limits[j].upper}) +
                "\" limited=\"false\"";
    if (l.gear.present && !exact_coupling(j) && value(l.gear.axial) != 0)
      extras += " armature=\"" + numbers({p * p * value(l.gear.axial)}) + "\"";
    if (l.friction.present && value(l.friction.viscous) != 0)
      extras += " damping=\"" + numbers({p * p * value(l.friction.viscous)}) + "\"";
    return extras;
  }

  void rotor_body(std::ostringstream& x, size_t j, const std::string& indent) const {
    const spatial::Link& l = link(j);
    const Eigen::Vector3d a = axis(j);
    // The rotor's principal axes in the joint frame: z along the joint axis.
    const Eigen::Matrix3d R =
        Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), a).toRotationMatrix();
    const double T = rotor_transverse(j), Ia = value(l.gear.axial);
    const Mass parent = body_mass(size_t(s_.chain.parent(int(j) + 1)));
    x << indent << "<body name=\"" << rotor_name(j) << "\" pos=\""
      << numbers({l.origin_xyz[0], l.origin_xyz[1], l.origin_xyz[2]}) << "\" quat=\""
      << quaternion(joint_rotation(j)) << "\">\n"
      << indent << "  <joint name=\"" << rotor_name(j) << "\" type=\"hinge\" axis=\""
      << numbers({a[0], a[1], a[2]}) << "\"/>\n"
      << indent << "  <inertial pos=\"0 0 0\" quat=\"" << quaternion(R) << "\" mass=\""
      << numbers({rotor_mass(parent)}) << "\" diaginertia=\"" << numbers({T, T, Ia}) << "\"/>\n"
      << indent << "</body>\n";
  }

  // Each exact rotor's angle is p times its joint's (relative to the parent: qm = p q).
  void equalities(std::ostringstream& x) const {
    std::string rows;
    for (size_t j = 0; j < s_.chain.links.size(); ++j)
      if (exact_rotor(j))
        rows += "    <joint joint1=\"" + rotor_name(j) + "\" joint2=\"" + attribute(joint_name(j)) +
                "\" polycoef=\"0 " + numbers({ratio(j)}) +
                " 0 0 0\" solref=\"0.002 1\" solimp=\"0.9999 0.9999 0.001 0.5 2\"/>\n";
    if (!rows.empty()) x << "  <equality>\n" << rows << "  </equality>\n";
  }
};

}  // namespace

MjcfNames mjcf_names(const SpatialScene& scene, const MjcfOptions& options) {
  return MjcfWriter(scene, options).names();
}

std::string export_mjcf(const SpatialScene& scene, const MjcfOptions& options) {
  return MjcfWriter(scene, options).write();
}

namespace {

// A planar gear as a spatial one at numbers: exact (the rotor on the previous body, eqs. 10-11),
// armature, or a coupling factor at its value (export_mjcf takes 0 and 1 only).
spatial::Gear spatial_gear(const Gear& g, const std::function<double(const Quantity&)>& value) {
  spatial::Gear out;
  out.present = true;
  out.ratio = value(g.ratio);
  out.axial = value(g.motor_inertia);
  out.exact = !g.armature;
  if (g.coupling) out.coupled = true, out.coupling = value(*g.coupling);
  if (g.flexible()) {
    out.flexible = true;
    out.stiffness = value(*g.stiffness);
    if (g.damping) out.has_damping = true, out.damping = value(*g.damping);
  }
  return out;
}

}  // namespace

SpatialScene planar_as_spatial(const Scene& planar, const std::vector<double>& params) {
  const std::vector<double> p = params.empty() ? nominal_values(planar.parameters) : params;
  if (p.size() != planar.parameters.size())
    throw std::invalid_argument("export: " + std::to_string(p.size()) + " parameter values for " +
                                std::to_string(planar.parameters.size()) + " parameters");
  auto value = [&p](const Quantity& q) { return q.is_parameter() ? p.at(q.index) : q.value; };
  // In the plane only izz acts; about x and y the same value keeps the tensor physical.
  auto tensor = [](double izz) { return std::array<Quantity, 6>{izz, 0.0, 0.0, izz, 0.0, izz}; };
  SpatialScene s;
  s.name = planar.name;
  s.source_path = planar.source_path;
  s.chain.free_base = planar.free_floating();
  s.chain.base.mass = value(planar.base.mass);
  s.chain.base.inertia = tensor(value(planar.base.inertia));
  for (int i = 0; i < planar.num_links(); ++i) {
    const Link& l = planar.links[i];
    spatial::Link link;
    link.origin_xyz =
        i == 0 ? std::array<double, 3>{value(planar.base.mount[0]), value(planar.base.mount[1]), 0}
               : std::array<double, 3>{value(planar.links[i - 1].length), 0, 0};
    link.axis = {0, 0, 1};
    link.mass = value(l.mass);
    link.com = {value(l.com[0]), value(l.com[1]), 0.0};
    double izz = value(l.inertia);
    if (planar.has_gear(i)) {
      const Gear& g = *planar.gears[i];
      link.gear = spatial_gear(g, value);
      if (g.compensate_link_inertia) izz -= value(g.motor_inertia);  // the motor's share
    }
    link.inertia = tensor(izz);
    if (i < static_cast<int>(planar.friction.size()) && planar.friction[i]) {
      const Friction& f = *planar.friction[i];
      link.friction = {true,
                       value(f.viscous),
                       value(f.coulomb),
                       value(f.velocity_scale),
                       value(f.stribeck_static),
                       value(f.stribeck_velocity),
                       f.has_coulomb,
                       f.has_stribeck};
    }
    s.chain.links.push_back(link);
  }
  s.chain.end_effectors[0].xyz = {value(planar.links.back().length), 0, 0};
  return s;
}

}  // namespace spacearm
