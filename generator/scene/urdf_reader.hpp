// A URDF robot as a spatial chain (spatial_chain.hpp), read with tinyxml2 as untrusted input:
// every error names the file, the line and the element. The root link is the base; `revolute`
// and `continuous` joints move; `fixed` joints weld their child to the parent (masses, centres
// and inertias lumped into the moving body, frames kept, so a welded link can be the end
// effector); joint origin xyz/rpy (R = Rz(y) Ry(p) Rx(r)), axis (absent: (1, 0, 0), as the URDF
// specification says), inertial origin xyz/rpy and full tensors. A body may carry several moving
// joints (a tree: several arms, a torso): the moving joints are numbered depth-first from the
// root, a body's in the order the URDF lists them (MuJoCo's URDF import numbers bodies so).
// Prismatic, floating and planar joints are refused by name. A joint's <limit effort velocity> and
// <dynamics damping friction> are read (spatial::JointLimits); its lower and upper are not.
#pragma once

#include <map>
#include <set>
#include <string>
#include <vector>

#include "spatial_description.hpp"

namespace spacearm {

struct UrdfChain {
  spatial::ChainDescription chain;           // gears absent; end effectors at their links' origins
  std::vector<std::string> joint_names;      // the moving joints, depth-first from the root
  std::vector<spatial::JointLimits> limits;  // theirs, from <limit> and <dynamics>
  // Per body (0 the base, i link i), the <visual> boxes, cylinders, spheres and STL meshes of its
  // links, in its frame, for the viewer; other meshes and shapes are counted, not read.
  std::vector<std::vector<spatial::Visual>> body_visuals;
  int undrawn = 0;
  std::string root_link, end_effector_link;  // the first end effector's link
  // snap_right_angles: how many <origin> angles moved to a multiple of pi/2, the largest move.
  int snapped_angles = 0;
  double largest_snap = 0;
  // Per body (0 the base, i link i), the URDF links it is made of: its own, then those welded to
  // it.
  std::vector<std::vector<std::string>> body_links;
  // Each link whose inertial the scene gives: its body (0 the base, i link i) and its index among
  // that body's parts (its frame there; the inertial left to the scene).
  std::map<std::string, std::pair<int, int>> given_parts;
};

// free_base: the root link floats (else it is fixed to the world). end_effector_links: links
// welded to moving bodies, one end effector each in this order (empty: the tool of every last
// moving body, a body no moving joint leaves: the leaf of the links welded to it, the body itself
// where nothing is; several leaves are refused, listed). The base's links are refused.
// Throws SceneError.
// given: links whose inertial the scene gives (left out of the lumping, kept as parts; a name
// that is no link is not in given_parts).
// snap_right_angles: every <origin> rpy angle within 1e-5 rad of a multiple of pi/2 is that
// multiple, turned by exact cosines and sines (URDFs round pi/2 to 1.5708).
UrdfChain read_urdf(const std::string& xml, const std::string& source, bool free_base,
                    const std::vector<std::string>& end_effector_links,
                    const std::set<std::string>& given = {}, bool snap_right_angles = false);
// One end effector link ("": the default).
UrdfChain read_urdf(const std::string& xml, const std::string& source, bool free_base,
                    const std::string& end_effector_link, const std::set<std::string>& given = {},
                    bool snap_right_angles = false);

}  // namespace spacearm
