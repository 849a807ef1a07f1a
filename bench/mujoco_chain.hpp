// The same chain as a MuJoCo model, for the peer benchmark: base as slide-x, slide-y and
// hinge-z at the base CoM, then one hinge per link; gravity, contacts and constraints off.
// Gears can only be the armature approximation there (I_m p^2 on the joint's diagonal).
#pragma once

#include "mujoco_model.hpp"

#include <sstream>
#include <string>

#include "planar_scene.hpp"

namespace spacearm::bench {

// MJCF text of a free-floating scene; run-time parameters at their nominal values.
inline std::string mjcf_of(const Scene& s) {
  auto value = [&](const Quantity& q) {
    if (!q.is_parameter()) return q.value;
    for (const auto& p : s.parameters)
      if (p.name == q.parameter) return p.nominal.value;
    throw std::logic_error("unknown parameter " + q.parameter);
  };
  std::ostringstream x;
  x.precision(17);
  x << "<mujoco model=\"" << s.name << "\">\n"
    << "  <option gravity=\"0 0 0\" timestep=\"0.001\" integrator=\"RK4\">\n"
    << "    <flag contact=\"disable\" constraint=\"disable\" passive=\"disable\" "
       "gravity=\"disable\"/>\n"
    << "  </option>\n  <worldbody>\n";
  // Diagonal inertia (I, I, I): only the z component acts in planar motion, and equal
  // components satisfy MuJoCo's triangle inequality.
  auto inertial = [&](double m, double I, double cx, double cy) {
    std::ostringstream e;
    e.precision(17);
    e << "<inertial pos=\"" << cx << " " << cy << " 0\" mass=\"" << m << "\" diaginertia=\"" << I
      << " " << I << " " << I << "\"/>";
    return e.str();
  };
  x << "    <body name=\"base\">\n"
    << "      <joint name=\"x0\" type=\"slide\" axis=\"1 0 0\"/>\n"
    << "      <joint name=\"y0\" type=\"slide\" axis=\"0 1 0\"/>\n"
    << "      <joint name=\"q0\" type=\"hinge\" axis=\"0 0 1\"/>\n"
    << "      " << inertial(value(s.base.mass), value(s.base.inertia), 0, 0) << "\n";
  double px = value(s.base.mount[0]), py = value(s.base.mount[1]);
  std::string indent = "      ";
  for (int i = 0; i < s.num_links(); ++i) {
    const Link& l = s.links[i];
    double I = value(l.inertia), armature = 0;
    if (s.has_gear(i)) {
      const Gear& g = *s.gears[i];
      const double p = value(g.ratio), Im = value(g.motor_inertia);
      if (g.compensate_link_inertia) I -= Im;
      armature = Im * p * p;
    }
    x << indent << "<body name=\"link" << i + 1 << "\" pos=\"" << px << " " << py << " 0\">\n"
      << indent << "  <joint name=\"q" << i + 1 << "\" type=\"hinge\" axis=\"0 0 1\" armature=\""
      << armature << "\"/>\n"
      << indent << "  " << inertial(value(l.mass), I, value(l.com[0]), value(l.com[1])) << "\n";
    px = value(l.length);
    py = 0;
    indent += "  ";
  }
  for (int i = 0; i <= s.num_links(); ++i) x << "    </body>\n";
  x << "  </worldbody>\n</mujoco>\n";
  return x.str();
}

using test::MujocoModel;  // loaded from mjcf_of(scene)

}  // namespace spacearm::bench
