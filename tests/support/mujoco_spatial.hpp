// A spatial chain (spatial_chain.hpp) as MuJoCo's MJCF (load it with mujoco_model.hpp), the peer
// for agreement tests and benchmarks: the base a free joint (MuJoCo's layout is the chain's), one
// hinge per joint at its body's origin; gravity, contacts, constraints and passive forces off. A
// gear can only be the armature approximation there: p^2 I_axial on the joint's diagonal (MuJoCo's
// coordinate is the link angle q, the chain's the motor angle qm = p q).
#pragma once

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include <sstream>
#include <string>

#include "mujoco_model.hpp"
#include "spatial_chain.hpp"

namespace spacearm::test {

inline std::string mjcf_of(const spatial::ChainDescription& c) {
  std::ostringstream x;
  x.precision(17);
  // The principal axes by Eigen's exact symmetric solver: MuJoCo's own (fullinertia, an
  // iterative eig3) leaves about 1e-10 relative in M.
  auto inertial = [&x](const spatial::Link& l) {
    const auto i = l.inertia_values();  // ixx ixy ixz iyy iyz izz
    Eigen::Matrix3d I;
    I << i[0], i[1], i[2], i[1], i[3], i[4], i[2], i[4], i[5];
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(I);
    Eigen::Matrix3d axes = eig.eigenvectors();
    if (axes.determinant() < 0) axes.col(2) *= -1;
    const Eigen::Quaterniond r(axes);
    x << "<inertial pos=\"" << l.com[0].value << " " << l.com[1].value << " " << l.com[2].value
      << "\" mass=\"" << l.mass.value << "\" quat=\"" << r.w() << " " << r.x() << " " << r.y()
      << " " << r.z() << "\" diaginertia=\"" << eig.eigenvalues()[0] << " " << eig.eigenvalues()[1]
      << " " << eig.eigenvalues()[2] << "\"/>\n";
  };
  x << "<mujoco model=\"spatial\">\n"
    << "  <compiler angle=\"radian\" boundmass=\"0\" boundinertia=\"0\"/>\n"
    << "  <option gravity=\"0 0 0\" timestep=\"0.001\">\n"
    << "    <flag contact=\"disable\" constraint=\"disable\" passive=\"disable\" "
       "gravity=\"disable\"/>\n"
    << "  </option>\n  <worldbody>\n    <body name=\"base\">\n";
  if (c.free_base) x << "      <freejoint/>\n";
  x << "      ";
  inertial(c.base);
  for (size_t j = 0; j < c.links.size(); ++j) {
    const spatial::Link& l = c.links[j];
    const auto q = spatial::rpy_quaternion(l.origin_rpy);
    const double armature = l.gear.present && !l.gear.exact
                                ? l.gear.axial.value * l.gear.ratio.value * l.gear.ratio.value
                                : 0;
    x << "<body name=\"link" << j + 1 << "\" pos=\"" << l.origin_xyz[0] << " " << l.origin_xyz[1]
      << " " << l.origin_xyz[2] << "\" quat=\"" << q[0] << " " << q[1] << " " << q[2] << " " << q[3]
      << "\">\n<joint type=\"hinge\" axis=\"" << l.axis[0] << " " << l.axis[1] << " " << l.axis[2]
      << "\" armature=\"" << armature << "\"/>\n";
    inertial(l);
  }
  for (size_t j = 0; j <= c.links.size(); ++j) x << "</body>\n";
  x << "  </worldbody>\n</mujoco>\n";
  return x.str();
}

}  // namespace spacearm::test
