// generator/scene/urdf_reader.hpp and the spatial scene's `urdf:` field: models/space_arm7.urdf
// against a forward kinematics written here with Eigen from the URDF's numbers (no code shared
// with the reader or the chain): the end effector's pose at random joint angles, and the
// lumped bodies (fixed joints) through the base block of M, which a rigid motion of the whole
// robot gives as the sum over every link. Malformed and unsupported URDFs get errors naming the
// line and the element.
#include "urdf_reader.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <fstream>
#include <random>
#include <sstream>

#include "recursive_algorithms.hpp"
#include "planar_scene.hpp"
#include "spatial_chain.hpp"
#include "spatial_scene.hpp"
#include "support.hpp"

namespace spacearm {
namespace {

std::string model_file(const std::string& name) {
  std::ifstream in(std::string(SPACEARM_SOURCE_DIR) + "/models/" + name);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// The URDF's numbers (models/space_arm7.urdf), copied by hand: joint origins, axes, link
// inertials (mass, com, principal inertia, inertial yaw).
struct UrdfLink {
  Eigen::Vector3d xyz, rpy, axis;
  double mass;
  Eigen::Vector3d com, I;
  double inertial_yaw;
};
const std::vector<UrdfLink> kArm = {
    {{0.6, 0, 0.8}, {0, 0, 0}, {0, 0, 1}, 8, {0, 0, 0.12}, {0.08, 0.08, 0.03}, 0},
    {{0, 0, 0.25}, {0, 0, 0}, {0, 1, 0}, 7, {0, 0, 0.2}, {0.1, 0.1, 0.02}, 0},
    {{0, 0, 0.45}, {0, 0, 0}, {0, 0, 1}, 6, {0, 0, 0.15}, {0.06, 0.06, 0.015}, 0},
    {{0, 0, 0.35}, {0, 0, 0}, {0, -1, 0}, 5, {0, 0, 0.18}, {0.05, 0.05, 0.01}, 0.3},
    {{0, 0, 0.4}, {0, 0, 0}, {0, 0, 1}, 3, {0, 0, 0.1}, {0.02, 0.02, 0.006}, 0},
    {{0, 0, 0.2}, {0, 0, 0}, {0, 1, 0}, 2, {0, 0, 0.06}, {0.008, 0.008, 0.003}, 0},
    {{0, 0, 0.12}, {0, 0, 0.5}, {0, 0, 1}, 1, {0, 0, 0.04}, {0.003, 0.003, 0.002}, 0},
};

Eigen::Matrix3d rpy(const Eigen::Vector3d& a) {
  return (Eigen::AngleAxisd(a[2], Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(a[1], Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(a[0], Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

struct Body {  // a link's world pose and inertial
  Eigen::Matrix3d R;
  Eigen::Vector3d p;
  double mass;
  Eigen::Vector3d com_world;
  Eigen::Matrix3d I_world;  // about its com
};

// Every link of the URDF in the world, the base at the identity, joints at angles q.
std::vector<Body> world_bodies(const Eigen::VectorXd& q, Eigen::Matrix3d& R_flange,
                               Eigen::Vector3d& p_flange) {
  std::vector<Body> bodies;
  auto add = [&](const Eigen::Matrix3d& R, const Eigen::Vector3d& p, double m,
                 const Eigen::Vector3d& com, const Eigen::Vector3d& I, const Eigen::Matrix3d& Ri) {
    bodies.push_back(
        {R, p, m, p + R * com, R * Ri * I.asDiagonal() * Ri.transpose() * R.transpose()});
  };
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  add(R, p, 500, {0.05, 0, 0}, {120, 140, 110}, Eigen::Matrix3d::Identity());
  const Eigen::Matrix3d Rt = rpy({0, 0.3, 0});
  add(Rt, Eigen::Vector3d(-0.5, 0.3, 0.6), 4, {0, 0, 0.05}, {0.01, 0.01, 0.008},
      Eigen::Matrix3d::Identity());
  for (size_t i = 0; i < kArm.size(); ++i) {
    const UrdfLink& l = kArm[i];
    p = p + R * l.xyz;
    R = R * rpy(l.rpy) * Eigen::AngleAxisd(q[i], l.axis.normalized()).toRotationMatrix();
    add(R, p, l.mass, l.com, l.I, rpy({0, 0, l.inertial_yaw}));
  }
  R_flange = R * rpy({0, 1.5707963267948966, 0});
  p_flange = p + R * Eigen::Vector3d(0, 0, 0.1);
  add(R_flange, p_flange, 0.5, {0, 0, 0.03}, {0.0005, 0.0005, 0.0004}, Eigen::Matrix3d::Identity());
  return bodies;
}

SpatialScene arm7() {
  return parse_spatial_scene(model_file("space_arm7.yaml"),
                             std::string(SPACEARM_SOURCE_DIR) + "/models/space_arm7.yaml");
}

std::vector<double> chain_output(const SpatialScene& s, Output o, const Eigen::VectorXd& q) {
  auto input = [&](const std::string& a, int i) { return a == "q" ? q[i] : 0.0; };
  return evaluate_chain<spatial::Chain>(s.chain, o, input)[0];
}

TEST(UrdfReader, EndEffectorPoseEqualsTheUrdfsKinematics) {
  const SpatialScene s = arm7();
  ASSERT_EQ(s.chain.links.size(), 7u);
  EXPECT_EQ(s.joint_names.front(), "joint1");
  std::mt19937 rng(31);
  std::uniform_real_distribution<double> u(-2, 2);
  for (int trial = 0; trial < 5; ++trial) {
    Eigen::VectorXd angles(7), q = Eigen::VectorXd::Zero(14);
    for (int i = 0; i < 7; ++i) angles[i] = u(rng);
    q[3] = 1;                  // the base at the identity
    q.tail(7) = 100 * angles;  // motor angles qm = p q
    Eigen::Matrix3d R;
    Eigen::Vector3d p;
    world_bodies(angles, R, p);
    const std::vector<double> pose = chain_output(s, Output::end_effector_pose, q);
    EXPECT_LT((Eigen::Vector3d(pose[0], pose[1], pose[2]) - p).norm(), 1e-12);
    const Eigen::Quaterniond got(pose[3], pose[4], pose[5], pose[6]);
    EXPECT_LT((got.toRotationMatrix() - R).norm(), 1e-12);
  }
}

// With the joints still, the robot moves as one rigid body: the base block of M is the
// spatial inertia of all links (welded ones included) about the base origin.
TEST(UrdfReader, LumpedBodiesGiveTheWholeRobotsInertia) {
  const SpatialScene s = arm7();
  Eigen::VectorXd angles(7);
  angles << 0.3, -0.7, 1.1, 0.4, -1.3, 0.8, 2.0;
  Eigen::VectorXd q = Eigen::VectorXd::Zero(14);
  q[3] = 1;
  Eigen::Matrix3d R;
  Eigen::Vector3d p;
  double m = 0;
  Eigen::Vector3d first_moment = Eigen::Vector3d::Zero();
  Eigen::Matrix3d I_origin = Eigen::Matrix3d::Zero();
  for (const Body& b : world_bodies(angles, R, p)) {
    m += b.mass;
    first_moment += b.mass * b.com_world;
    const Eigen::Vector3d c = b.com_world;
    I_origin +=
        b.I_world + b.mass * (c.squaredNorm() * Eigen::Matrix3d::Identity() - c * c.transpose());
  }
  // The rotors' inertia is not in the URDF: a gearless copy, whose coordinates are the angles.
  SpatialScene plain = s;
  for (auto& l : plain.chain.links) l.gear = {};
  q.tail(7) = angles;
  const std::vector<double> Mv = chain_output(plain, Output::mass_matrix, q);
  const Eigen::MatrixXd M =
      Eigen::Map<const Eigen::Matrix<double, -1, -1, Eigen::RowMajor>>(Mv.data(), 13, 13);
  EXPECT_LT((M.topLeftCorner(3, 3) - m * Eigen::Matrix3d::Identity()).norm(), 1e-10 * m);
  EXPECT_LT((M.block<3, 3>(3, 3) - I_origin).norm(), 1e-10 * I_origin.norm());
  Eigen::Matrix3d cross;
  cross << 0, -first_moment[2], first_moment[1], first_moment[2], 0, -first_moment[0],
      -first_moment[1], first_moment[0], 0;
  EXPECT_LT((M.block<3, 3>(0, 3) + cross).norm(), 1e-10 * first_moment.norm());
}

// A scene may give URDF links' inertials, with run-time parameters (`inertials:`): each is a
// part of its body at the link's frame. Given as the URDF has them they reproduce the URDF's
// model; with a parameter's other value, the URDF with that value written in.
TEST(UrdfReader, InertialsTheSceneGivesArePartsOfTheirBodies) {
  const std::string path = std::string(SPACEARM_SOURCE_DIR) + "/models/space_arm7.yaml";
  const std::string xml = model_file("space_arm7.urdf");
  auto with_urdf = [](const std::string& text) {
    return [text](const std::string&) { return text; };
  };
  const std::string given = model_file("space_arm7.yaml") +
                            "parameters: {mp: 0.5}\n"
                            "inertials:\n"
                            "  tool_flange: {mass: mp, com: [0, 0, 0.03],\n"
                            "                inertia: [0.0005, 0, 0, 0.0005, 0, 0.0004]}\n"
                            "  link7: {mass: 1.0, com: [0, 0, 0.04],\n"
                            "          inertia: [0.003, 0, 0, 0.003, 0, 0.002]}\n"
                            "  star_tracker: {mass: 4.0, com: [0, 0, 0.05],\n"
                            "                 inertia: [0.01, 0, 0, 0.01, 0, 0.008]}\n";
  const SpatialScene parts = parse_spatial_scene(given, path, with_urdf(xml));
  EXPECT_EQ(parts.chain.links[6].parts.size(), 2u);  // link7 itself and the flange
  EXPECT_EQ(parts.chain.links[6].mass.value, 0);
  EXPECT_EQ(parts.chain.base.parts.size(), 1u);
  std::string heavier = xml;
  const std::string flange_mass = "<mass value=\"0.5\"/>";
  ASSERT_EQ(heavier.find(flange_mass), heavier.rfind(flange_mass));
  heavier.replace(heavier.find(flange_mass), flange_mass.size(), "<mass value=\"2.5\"/>");
  std::mt19937 rng(32);
  std::uniform_real_distribution<double> u(-1, 1);
  for (double mp : {0.5, 2.5}) {
    const SpatialScene urdf = parse_spatial_scene(model_file("space_arm7.yaml"), path,
                                                  with_urdf(mp == 0.5 ? xml : heavier));
    Eigen::VectorXd q(14), v(13);
    for (int k = 0; k < 14; ++k) q[k] = u(rng);
    for (int k = 0; k < 13; ++k) v[k] = u(rng);
    q.segment(3, 4).normalize();
    auto input = [&](const std::string& a, int i) {
      return a == "q" ? q[i] : a == "qd" ? v[i] : a == "params" ? mp : 0.0;
    };
    for (Output o : {Output::mass_matrix, Output::bias_forces, Output::momentum}) {
      const auto want = evaluate_chain<spatial::Chain>(urdf.chain, o, input)[0];
      const auto got = evaluate_chain<spatial::Chain>(parts.chain, o, input)[0];
      for (size_t k = 0; k < want.size(); ++k)
        EXPECT_NEAR(got[k], want[k], 1e-12 * (1 + std::abs(want[k]))) << to_string(o) << " " << k;
    }
  }
  // Errors name the field.
  EXPECT_THROW_MESSAGE(
      parse_spatial_scene(model_file("space_arm7.yaml") + "inertials: {tool: {mass: 1, inertia: "
                                                          "[1, 0, 0, 1, 0, 1]}}\n",
                          path, with_urdf(xml)),
      SceneError, "field 'inertials.tool': URDF 'space_arm7.urdf' has no link of this name");
  // A fixed base's links do not move: an inertial given for one would have no effect.
  std::string fixed = model_file("space_arm7.yaml");
  fixed.replace(fixed.find("type: free_floating"), 19, "type: fixed");
  EXPECT_THROW_MESSAGE(
      parse_spatial_scene(fixed + "inertials: {star_tracker: {mass: 1, inertia: [1, 0, 0, 1, 0, "
                                  "1]}}\n",
                          path, with_urdf(xml)),
      SceneError, "field 'inertials.star_tracker': is the root link of a fixed base or welded");
  // The body is checked whole: the flange alone a point mass, the body physical with link7.
  std::string point_flange = xml;
  const std::string flange_tensor =
      "<inertia ixx=\"0.0005\" ixy=\"0\" ixz=\"0\" iyy=\"0.0005\" iyz=\"0\" izz=\"0.0004\"/>";
  ASSERT_NE(point_flange.find(flange_tensor), std::string::npos);
  point_flange.replace(point_flange.find(flange_tensor), flange_tensor.size(),
                       "<inertia ixx=\"0\" ixy=\"0\" ixz=\"0\" iyy=\"0\" iyz=\"0\" izz=\"0\"/>");
  EXPECT_NO_THROW(parse_spatial_scene(model_file("space_arm7.yaml") +
                                          "inertials: {link7: {mass: 1, com: [0, 0, 0.04], "
                                          "inertia: [0.003, 0, 0, 0.003, 0, 0.002]}}\n",
                                      path, with_urdf(point_flange)));
  // Issue 51: a payload (a given part) may weigh 0 (uniform: [0, 50] in a study); not less.
  const std::string payload =
      "inertials: {tool_flange: {mass: PAYLOAD, com: [0, 0, 0.03], "
      "inertia: [0.0005, 0, 0, 0.0005, 0, 0.0004]}}\n";
  auto with_payload = [&](const std::string& mass) {
    std::string text = model_file("space_arm7.yaml") + payload;
    return text.replace(text.find("PAYLOAD"), 7, mass);
  };
  EXPECT_EQ(parse_spatial_scene(with_payload("0"), path, with_urdf(xml))
                .chain.links[6]
                .parts.at(0)
                .inertial.mass.value,
            0);
  EXPECT_THROW_MESSAGE(parse_spatial_scene(with_payload("-1"), path, with_urdf(xml)), SceneError,
                       "field 'inertials.tool_flange.mass': must not be negative, got -1");
  EXPECT_THROW_MESSAGE(
      parse_spatial_scene(model_file("space_arm7.yaml") +
                              "inertials:\n  link7: {mass: 1, inertia: [1, 0, 0, 1, 0, 1]}\n"
                              "  link7: {mass: 2, inertia: [1, 0, 0, 1, 0, 1]}\n",
                          path, with_urdf(xml)),
      SceneError, "field 'inertials.link7': given more than once");
  EXPECT_THROW_MESSAGE(
      parse_spatial_scene(model_file("space_arm7.yaml") + "inertials: {link7: {mass: 1}}\n", path,
                          with_urdf(xml)),
      SceneError, "field 'inertials.link7.inertia': missing required field");
  EXPECT_THROW_MESSAGE(
      parse_spatial_scene(model_file("space_arm7.yaml") +
                              "parameters: {m: 1}\ninertials: {link7: {mass: m, com: [0, 0, m], "
                              "inertia: [1, 0, 0, 1, 0, 1], rpy: [0, 0, 0]}}\n",
                          path, with_urdf(xml)),
      SceneError, "rpy");
}

std::string robot(const std::string& body) { return "<robot name=\"r\">\n" + body + "</robot>\n"; }
const std::string kTwoLinks =
    "<link name=\"a\"><inertial><mass value=\"2\"/><inertia ixx=\"1\" ixy=\"0\" ixz=\"0\" "
    "iyy=\"1\" iyz=\"0\" izz=\"1\"/>"
    "</inertial></link>\n"
    "<link name=\"b\"><inertial><mass value=\"1\"/><inertia ixx=\"0.1\" ixy=\"0\" ixz=\"0\" "
    "iyy=\"0.1\" iyz=\"0\" izz=\"0.1\"/>"
    "</inertial></link>\n";
std::string joint(const std::string& name, const std::string& type, const std::string& parent,
                  const std::string& child, const std::string& extra = "") {
  return "<joint name=\"" + name + "\" type=\"" + type + "\"><parent link=\"" + parent +
         "\"/><child link=\"" + child + "\"/>" + extra + "</joint>\n";
}

TEST(UrdfReader, AbsentAxisIsXAndErrorsNameTheElement) {
  const UrdfChain c =
      read_urdf(robot(kTwoLinks + joint("j", "revolute", "a", "b")), "r.urdf", true, "");
  EXPECT_EQ(c.chain.links[0].axis, (std::array<double, 3>{1, 0, 0}));
  EXPECT_EQ(c.end_effector_link, "b");
  const std::string c_link =
      "<link name=\"c\"><inertial><mass value=\"1\"/><inertia ixx=\"1\" ixy=\"0\" ixz=\"0\" "
      "iyy=\"1\" iyz=\"0\" izz=\"1\"/>"
      "</inertial></link>\n";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"<robot", "URDF 'r.urdf' line 1: not XML"},
      {robot(kTwoLinks + joint("slide", "prismatic", "a", "b")),
       "<joint name='slide'>: joint type 'prismatic': only revolute, continuous and fixed"},
      {robot(kTwoLinks + joint("j", "revolute", "a", "nowhere")),
       "<child>: no link named 'nowhere'"},
      {robot(kTwoLinks + joint("j", "revolute", "a", "b", "<axis xyz=\"0 0 0\"/>")),
       "<axis>: attribute 'xyz': the axis must not be zero"},
      {robot(kTwoLinks + joint("j", "revolute", "a", "b", "<origin xyz=\"1 nan 0\"/>")),
       "<origin>: attribute 'xyz': expected 3 numbers, each 0 or of magnitude 1e-30 to 1e6 (not "
       "finite)"},
      {robot(kTwoLinks + joint("j", "revolute", "a", "b") + joint("k", "revolute", "a", "b")),
       "link 'b' already has a parent joint, 'j'"},
      {robot(kTwoLinks), "2 links have no parent joint"},
      {robot(kTwoLinks + joint("j", "fixed", "a", "b")), "no moving joint"},
      {robot(kTwoLinks + joint("j", "revolute", "a", "b", "<origin xyz=\"1-2 3\"/>")),
       "<origin>: attribute 'xyz': expected 3 numbers, each 0 or of magnitude 1e-30 to 1e6 (not "
       "a number)"},
      {robot(kTwoLinks + joint("j", "revolute", "a", "b", "<origin xyz=\"0x1p-3 0 0\"/>")),
       "(not a number)"},
      {robot(kTwoLinks + joint("j", "revolute", "a", "b", "<origin xyz=\"1e-300 0 0\"/>")),
       "(out of range)"},
      {robot(kTwoLinks + joint("j", "revolute", "a", "b", "<origin/><origin/>")),
       "<origin>: a second one"},
      {robot(kTwoLinks + joint("j", "revolute", "a", "b", "<mimic joint=\"k\"/>")),
       "<mimic>: a mimic joint (coupled to another) is not read"},
      {robot("<link name=\"a\" name=\"b\"/>"), "line 2: not XML"},
  };
  for (const auto& [xml, message] : cases) {
    SCOPED_TRACE(message);
    EXPECT_THROW_MESSAGE(read_urdf(xml, "r.urdf", true, ""), SceneError, message);
  }
  EXPECT_THROW_MESSAGE(
      read_urdf(robot(kTwoLinks + joint("j", "revolute", "a", "b")), "r.urdf", true, "a"),
      SceneError,
      "end effector link 'a' is the base's (welded to the root): it moves with no joint");
}

// <limit>: effort and velocity on any moving joint, a range only on a revolute one (a
// continuous joint turns freely, and lower = upper = 0 is URDF's placeholder: none); a range
// upside down names both attributes.
TEST(UrdfReader, JointLimitsAndRangesAreRead) {
  const std::string limit = "<limit lower=\"-1.5\" upper=\"2\" effort=\"30\" velocity=\"1.2\"/>";
  const UrdfChain revolute =
      read_urdf(robot(kTwoLinks + joint("j", "revolute", "a", "b", limit)), "r.urdf", true, "");
  ASSERT_EQ(revolute.limits.size(), 1u);
  const spatial::JointLimits& l = revolute.limits[0];
  EXPECT_EQ(l.effort, 30);
  EXPECT_EQ(l.velocity, 1.2);
  EXPECT_EQ(l.lower, -1.5);
  EXPECT_EQ(l.upper, 2);
  EXPECT_TRUE(l.has_range());
  const UrdfChain continuous =
      read_urdf(robot(kTwoLinks + joint("j", "continuous", "a", "b", limit)), "r.urdf", true, "");
  EXPECT_FALSE(continuous.limits[0].has_range());
  EXPECT_EQ(continuous.limits[0].effort, 30);
  const UrdfChain placeholder = read_urdf(
      robot(kTwoLinks + joint("j", "revolute", "a", "b", "<limit effort=\"1\" velocity=\"1\"/>")),
      "r.urdf", true, "");
  EXPECT_FALSE(placeholder.limits[0].has_range());
  EXPECT_THROW_MESSAGE(
      read_urdf(robot(kTwoLinks + joint("j", "revolute", "a", "b",
                                        "<limit lower=\"1\" upper=\"-1\" effort=\"1\"/>")),
                "r.urdf", true, ""),
      SceneError, "<limit>: attributes 'lower' 1 and 'upper' -1: lower must not be above upper");
  EXPECT_THROW_MESSAGE(
      read_urdf(robot(kTwoLinks + joint("j", "revolute", "a", "b",
                                        "<limit lower=\"0.5\" upper=\"0.5\" effort=\"1\"/>")),
                "r.urdf", true, ""),
      SceneError, "<limit>: attributes 'lower' and 'upper' are both 0.5: a joint its limits lock");
  EXPECT_THROW_MESSAGE(
      read_urdf(robot(kTwoLinks + joint("j", "revolute", "a", "b", "<limit lower=\"inf\"/>")),
                "r.urdf", true, ""),
      SceneError, "<limit>: attribute 'lower': expected 1 number");
}

// Issue 52: a body may carry several moving joints. Two arms on a satellite, the right one on a
// mount welded to it, listed interleaved: the joints are numbered depth-first from the root, a
// body's in the URDF's order (left_1, left_2, right_1, right_2: parents 0, 1, 0, 3), the right
// arm's first joint composed through the mount, and each arm's welded tool is an end effector,
// in the bodies' order; end_effector_links picks and orders them.
TEST(UrdfReader, ATreeIsNumberedDepthFirstWithAnEndEffectorPerArm) {
  auto body = [](const std::string& name) {
    return "<link name=\"" + name +
           "\"><inertial><mass value=\"1\"/><inertia ixx=\"0.1\" ixy=\"0\" ixz=\"0\" "
           "iyy=\"0.1\" iyz=\"0\" izz=\"0.1\"/></inertial></link>\n";
  };
  auto massless = [](const std::string& name) { return "<link name=\"" + name + "\"/>\n"; };
  const std::string at = "<origin xyz=\"0.5 0 0\"/><axis xyz=\"0 0 1\"/>";
  const std::string urdf = robot(
      body("sat") + body("l1") + body("l2") + body("r1") + body("r2") + massless("mount") +
      massless("l_tool") + massless("r_tool") + joint("left_1", "revolute", "sat", "l1", at) +
      joint("to_mount", "fixed", "sat", "mount", "<origin xyz=\"0 -1 0\" rpy=\"0 0 0.3\"/>") +
      joint("right_1", "revolute", "mount", "r1", at) +
      joint("left_2", "revolute", "l1", "l2", at) + joint("right_2", "revolute", "r1", "r2", at) +
      joint("l_flange", "fixed", "l2", "l_tool", "<origin xyz=\"0.2 0 0\"/>") +
      joint("r_flange", "fixed", "r2", "r_tool", "<origin xyz=\"0.1 0 0\"/>"));
  const UrdfChain c = read_urdf(urdf, "r.urdf", true, "");
  EXPECT_EQ(c.joint_names, (std::vector<std::string>{"left_1", "left_2", "right_1", "right_2"}));
  std::vector<int> parents;
  for (int i = 1; i <= 4; ++i) parents.push_back(c.chain.parent(i));
  EXPECT_EQ(parents, (std::vector<int>{0, 1, 0, 3}));
  EXPECT_EQ(c.body_links,
            (std::vector<std::vector<std::string>>{
                {"sat", "mount"}, {"l1"}, {"l2", "l_tool"}, {"r1"}, {"r2", "r_tool"}}));
  EXPECT_NEAR(c.chain.links[2].origin_xyz[0], 0.5 * std::cos(0.3), 1e-15);
  EXPECT_NEAR(c.chain.links[2].origin_xyz[1], -1 + 0.5 * std::sin(0.3), 1e-15);
  EXPECT_NEAR(c.chain.links[2].origin_rpy[2], 0.3, 1e-15);
  ASSERT_EQ(c.chain.num_end_effectors(), 2);
  EXPECT_EQ(c.chain.end_effectors[0].link, "l_tool");
  EXPECT_EQ(c.chain.end_effector_body(0), 2);
  EXPECT_EQ(c.chain.end_effectors[0].xyz, (std::array<double, 3>{0.2, 0, 0}));
  EXPECT_EQ(c.chain.end_effectors[1].link, "r_tool");
  EXPECT_EQ(c.chain.end_effector_body(1), 4);
  const UrdfChain picked =
      read_urdf(urdf, "r.urdf", true, std::vector<std::string>{"r_tool", "l1"});
  ASSERT_EQ(picked.chain.num_end_effectors(), 2);
  EXPECT_EQ(picked.chain.end_effectors[0].link, "r_tool");
  EXPECT_EQ(picked.chain.end_effector_body(1), 1);
  EXPECT_THROW_MESSAGE(read_urdf(urdf, "r.urdf", true, std::vector<std::string>{"mount"}),
                       SceneError, "end effector link 'mount' is the base's");
  EXPECT_THROW_MESSAGE(read_urdf(urdf, "r.urdf", true, std::vector<std::string>{"l1", "l1"}),
                       SceneError, "end effector link 'l1' is named twice");
}

// Issue 51, item 6: by default the end effector is the URDF's tool, the one leaf of the links
// welded to the last moving body (SC_3DoF's Link_EE, 0.75 m beyond its last joint); several
// leaves are refused, listed; end_effector_link still picks any welded link.
TEST(UrdfReader, DefaultEndEffectorIsTheWeldedLeaf) {
  auto massless = [](const std::string& name) { return "<link name=\"" + name + "\"/>\n"; };
  const std::string tool =
      joint("to_flange", "fixed", "b", "flange", "<origin xyz=\"0.5 0 0\"/>") +
      joint("to_tip", "fixed", "flange", "tip", "<origin xyz=\"0.25 0 0\" rpy=\"0 0 0.5\"/>");
  const std::string arm =
      kTwoLinks + massless("flange") + massless("tip") + joint("j", "revolute", "a", "b") + tool;
  const UrdfChain c = read_urdf(robot(arm), "r.urdf", true, "");
  EXPECT_EQ(c.end_effector_link, "tip");
  EXPECT_EQ(c.chain.end_effectors[0].xyz, (std::array<double, 3>{0.75, 0, 0}));
  EXPECT_NEAR(c.chain.end_effectors[0].rpy[2], 0.5, 1e-15);
  EXPECT_EQ(c.body_links, (std::vector<std::vector<std::string>>{{"a"}, {"b", "flange", "tip"}}));
  EXPECT_EQ(read_urdf(robot(arm), "r.urdf", true, "flange").end_effector_link, "flange");
  const std::string two_tools =
      arm + massless("camera") + joint("to_camera", "fixed", "b", "camera");
  EXPECT_THROW_MESSAGE(read_urdf(robot(two_tools), "r.urdf", true, ""), SceneError,
                       "URDF 'r.urdf': the last moving body 'b' ends in 2 welded links ('tip', "
                       "'camera'): say which is the end effector with the scene's "
                       "end_effector_link");
  EXPECT_EQ(read_urdf(robot(two_tools), "r.urdf", true, "camera").end_effector_link, "camera");
}

// Issue 51: snap_right_angles takes an <origin>'s angles within 1e-5 rad of a multiple of pi/2
// as that multiple, so a tensor turned by them keeps its exact zeros and the joint frame turns
// by exact cosines; an angle further off, or the option off, is kept as written.
TEST(UrdfReader, SnappedRightAnglesAreExact) {
  const std::string arm =
      "<link name=\"a\"><inertial><mass value=\"2\"/><inertia ixx=\"1\" ixy=\"0\" ixz=\"0\" "
      "iyy=\"1\" iyz=\"0\" izz=\"1\"/></inertial></link>\n"
      "<link name=\"b\"><inertial><origin rpy=\"1.5708 0 0\"/><mass value=\"1\"/>"
      "<inertia ixx=\"0.1\" ixy=\"0\" ixz=\"0\" iyy=\"0.2\" iyz=\"0\" izz=\"0.25\"/>"
      "</inertial></link>\n" +
      joint("j", "revolute", "a", "b", "<origin rpy=\"0 -1.5708 3.1416\"/>");
  const UrdfChain snapped = read_urdf(robot(arm), "r.urdf", true, "", {}, true);
  const spatial::Link& l = snapped.chain.links.at(0);
  EXPECT_EQ(l.origin_rpy, (std::array<double, 3>{0, -M_PI / 2, M_PI}));
  EXPECT_TRUE(snapped.chain.exact_right_angles);
  EXPECT_EQ(snapped.snapped_angles, 3);
  EXPECT_NEAR(snapped.largest_snap, 7.35e-6, 1e-8);
  // The tensor turned a quarter about x: y and z swap, and the zeros stay zeros.
  const auto I = l.inertia_values();
  EXPECT_EQ(I, (std::array<double, 6>{0.1, 0, 0, 0.25, 0, 0.2}));
  const spatial::Mat3<double> R = spatial::rpy_rotation(l.origin_rpy, true);
  for (double x : R) EXPECT_TRUE(x == 0 || x == 1 || x == -1) << x;
  const UrdfChain rounded = read_urdf(robot(arm), "r.urdf", true, "");
  EXPECT_FALSE(rounded.chain.exact_right_angles);
  EXPECT_EQ(rounded.chain.links[0].origin_rpy, (std::array<double, 3>{0, -1.5708, 3.1416}));
  EXPECT_NE(rounded.chain.links[0].inertia_values()[4], 0);  // a 1e-7 residue of the turn
  std::string further = arm;
  further.replace(further.find("3.1416"), 6, "3.1417");  // 1.07e-4 rad off: kept
  EXPECT_EQ(read_urdf(robot(further), "r.urdf", true, "", {}, true).chain.links[0].origin_rpy[2],
            3.1417);
}

// Issue 51: each body's <visual> shapes (its own link's and those welded to it) in its frame, for
// the viewer; an STL mesh by its path in the URDF's folder (package:// stripped), another mesh
// counted, not read; a negative size, or a mesh path that leaves the folder, refused by name.
TEST(UrdfReader, VisualsAreReadInTheirBodysFrame) {
  const std::string shapes =
      "<link name=\"a\"><inertial><mass value=\"2\"/><inertia ixx=\"1\" ixy=\"0\" ixz=\"0\" "
      "iyy=\"1\" iyz=\"0\" izz=\"1\"/></inertial>"
      "<visual><geometry><box size=\"2.2 2.1 2\"/></geometry></visual>"
      "<visual><geometry><mesh filename=\"bus.dae\"/></geometry></visual></link>\n"
      "<link name=\"panel\"><visual><origin xyz=\"0 0 0.5\" rpy=\"1.5707963267948966 0 0\"/>"
      "<geometry><cylinder radius=\"0.1\" length=\"3\"/></geometry></visual></link>\n"
      "<link name=\"b\"><inertial><mass value=\"1\"/><inertia ixx=\"0.1\" ixy=\"0\" ixz=\"0\" "
      "iyy=\"0.1\" iyz=\"0\" izz=\"0.1\"/></inertial><visual><origin xyz=\"0.2 0 0\"/>"
      "<geometry><mesh filename=\"package://arm/meshes/B.STL\" scale=\"0.001 0.001 0.001\"/>"
      "</geometry></visual></link>\n" +
      joint("wing", "fixed", "a", "panel", "<origin xyz=\"1.5 0 0\"/>") +
      joint("j", "revolute", "a", "b");
  const UrdfChain c = read_urdf(robot(shapes), "r.urdf", true, "");
  ASSERT_EQ(c.body_visuals.size(), 2u);
  const std::vector<spatial::Visual>& base = c.body_visuals[0];
  ASSERT_EQ(base.size(), 2u);
  EXPECT_EQ(c.undrawn, 1);
  EXPECT_EQ(base[0].kind, "box");
  EXPECT_EQ(base[0].size, (std::array<double, 3>{2.2, 2.1, 2}));
  const spatial::Visual& wing = base[1];
  EXPECT_EQ(wing.kind, "cylinder");
  EXPECT_EQ(wing.size, (std::array<double, 3>{0.1, 3, 0}));
  EXPECT_NEAR(wing.xyz[0], 1.5, 1e-15);
  EXPECT_NEAR(wing.xyz[2], 0.5, 1e-15);
  EXPECT_NEAR(wing.quaternion[0], std::sqrt(0.5), 1e-15);  // about x by pi/2
  EXPECT_NEAR(wing.quaternion[1], std::sqrt(0.5), 1e-15);
  ASSERT_EQ(c.body_visuals[1].size(), 1u);
  const spatial::Visual& link = c.body_visuals[1][0];
  EXPECT_EQ(link.kind, "mesh");
  EXPECT_EQ(link.mesh, "meshes/B.STL");
  EXPECT_EQ(link.size, (std::array<double, 3>{0.001, 0.001, 0.001}));
  EXPECT_EQ(link.xyz, (std::array<double, 3>{0.2, 0, 0}));
  for (const auto& [path, message] : std::vector<std::pair<std::string, std::string>>{
           {"../secret.stl", "a path inside the URDF's folder has no empty, '.' or '..' part"},
           {"package://arm/../../x.stl", "a path inside the URDF's folder has no empty"},
           {"meshes//b.stl", "a path inside the URDF's folder has no empty, '.' or '..' part"},
           {"/etc/b.stl", "expected a path relative to the URDF's folder"},
           {"file:///etc/b.stl", "expected a path relative to the URDF's folder"},
           {"a b.stl", "expected printable ASCII without spaces"},
           {"package://arm", "expected a path of 1 to 255 characters"}}) {
    std::string bad = shapes;
    bad.replace(bad.find("package://arm/meshes/B.STL"), 26, path);
    EXPECT_THROW_MESSAGE(read_urdf(robot(bad), "r.urdf", true, ""), SceneError,
                         "mesh filename '" + path + "': " + message);
  }
  std::string negative = shapes;
  negative.replace(negative.find("2.2 2.1 2"), 9, "2.2 -2.1 2");
  EXPECT_THROW_MESSAGE(read_urdf(robot(negative), "r.urdf", true, ""), SceneError,
                       "<box>: a visual's size must not be negative, got -2.1");
}

// Issue 49: the work of a parse is bounded before tinyxml2 sees the bytes (it compares each
// attribute with the element's earlier ones: 60 000 took 23 s), so a hostile file is refused
// at once, naming the limit; the same file under the limit is read as before.
TEST(UrdfReader, AttributesElementsAndDepthAreBoundedBeforeTheParse) {
  std::string many = "<link name=\"c\"";
  for (int k = 0; k < 200000; ++k) many += " a" + std::to_string(k) + "=\"1\"";
  many += "/>\n";
  EXPECT_THROW_MESSAGE(
      read_urdf(robot(kTwoLinks + many + joint("j", "revolute", "a", "b")), "r.urdf", true, ""),
      SceneError, "URDF 'r.urdf' line 4: the element 'link' has more than 64 attributes");
  // A quoted '=' or '>' is a value, not an attribute or the tag's end.
  std::string quoted = "<link name=\"c\" x=\"";
  for (int k = 0; k < 100; ++k) quoted += "=>";
  quoted += "\"/>\n";
  EXPECT_THROW_MESSAGE(
      read_urdf(robot(kTwoLinks + quoted + joint("j", "revolute", "a", "b")), "r.urdf", true, ""),
      SceneError, "2 links have no parent joint");
  std::string deep;
  for (int k = 0; k < 100; ++k) deep += "<g>";
  EXPECT_THROW_MESSAGE(read_urdf(robot(deep), "r.urdf", true, ""), SceneError,
                       "elements nested more than 64 deep");
  std::string wide;
  for (int k = 0; k < 100001; ++k) wide += "<g/>";
  EXPECT_THROW_MESSAGE(read_urdf(robot(wide), "r.urdf", true, ""), SceneError,
                       "more than 100000 elements");
  // Comments, CDATA and declarations are skipped whole, their '<' not counted.
  const std::string skipped =
      "<?xml version=\"1.0\"?>\n<!-- <a b=1 c=2> -->\n" +
      robot(kTwoLinks + "<!-- " + many + " -->\n" + joint("j", "revolute", "a", "b"));
  EXPECT_EQ(read_urdf(skipped, "r.urdf", true, "").chain.links.size(), 1u);
}

// xacro is not URDF: read as URDF, a joint its macro adds would be dropped without a word.
// Its namespace, its elements and attributes and its ${...} expressions are refused by name.
TEST(UrdfReader, XacroIsRefusedNamingWhatAndTheRemedy) {
  const std::string arm = kTwoLinks + joint("j", "revolute", "a", "b");
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"<robot name=\"r\" xmlns:xacro=\"http://www.ros.org/wiki/xacro\">\n" + arm + "</robot>",
       "line 1, <robot name='r'>: the attribute 'xmlns:xacro': this is xacro, not URDF; run "
       "'xacro FILE.urdf.xacro > FILE.urdf' first"},
      {robot(arm + "<xacro:arm_link name=\"c\" parent=\"b\"/>\n"),
       "<xacro:arm_link name='c'>: the element 'xacro:arm_link': this is xacro"},
      {robot(arm + "<xacro:include filename=\"more.xacro\"/>\n"), "'xacro:include'"},
      {robot(kTwoLinks + joint("j", "revolute", "a", "b", "<origin xyz=\"0 0 ${length}\"/>")),
       "<origin>: attribute 'xyz' = '0 0 ${length}' holds a xacro expression"},
      {robot(kTwoLinks + joint("j", "revolute", "a", "b", "<origin xyz=\"$(arg x) 0 0\"/>")),
       "holds a xacro expression"},
  };
  for (const auto& [xml, message] : cases) {
    SCOPED_TRACE(message);
    EXPECT_THROW_MESSAGE(read_urdf(xml, "r.urdf", true, ""), SceneError, message);
  }
}

// One root element, no NUL byte, and tinyxml2's reason shown whole (it was cut at 40
// characters, before the reason).
TEST(UrdfReader, TwoRootsANulByteAndParseErrorsAreNamed) {
  const std::string arm = robot(kTwoLinks + joint("j", "revolute", "a", "b"));
  EXPECT_THROW_MESSAGE(read_urdf(arm + "<robot name=\"twin\"/>\n", "r.urdf", true, ""), SceneError,
                       "<robot name='twin'>: a second element at the top: an XML document has "
                       "one root, <robot>");
  EXPECT_THROW_MESSAGE(read_urdf(std::string(arm) + '\0' + "<joint/>", "r.urdf", true, ""),
                       SceneError, "line 6: a NUL byte (at byte " + std::to_string(arm.size()));
  EXPECT_THROW_MESSAGE(read_urdf(robot("<link name=\"a\"></lnk>"), "r.urdf", true, ""), SceneError,
                       "line 2: not XML (XML_ERROR_MISMATCHED_ELEMENT: XMLElement name=link");
}

// A welded end-effector frame near the gimbal lock (pitch pi/2 - 5e-7) composes back exactly:
// the rotation the reader keeps (as roll-pitch-yaw) is the URDF's.
TEST(UrdfReader, WeldedFramesNearTheGimbalLockAreExact) {
  const std::string xml = robot(
      kTwoLinks + joint("j", "revolute", "a", "b") + "<link name=\"tool\"/>\n" +
      joint("w", "fixed", "b", "tool", "<origin xyz=\"0.1 0.2 0.3\" rpy=\"1 1.5707958 0.4\"/>"));
  const UrdfChain c = read_urdf(xml, "r.urdf", true, "tool");
  const spatial::Mat3<double> got = spatial::rpy_rotation(c.chain.end_effectors[0].rpy);
  const Eigen::Matrix3d want = rpy({1, 1.5707958, 0.4});
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) EXPECT_NEAR(got[3 * i + j], want(i, j), 1e-14) << i << j;
}

// The scene side: the URDF's path relative to the scene file; the fields URDF gives are refused
// beside it; its bodies are checked as the YAML form's are; the URDF's text is in the content
// (the cache key), so an edited URDF is a new model.
TEST(UrdfReader, SceneNamesTheUrdfAndChecksItsBodies) {
  const SpatialScene s = arm7();
  EXPECT_NE(s.content.find("<robot name=\"space_arm7\">"), std::string::npos);
  const std::string head = "name: x\nspace: spatial\nbase: {type: free_floating}\n";
  auto reader = [](const std::string& xml) { return [xml](const std::string&) { return xml; }; };
  const std::string massless_root = robot(
      "<link name=\"a\"/>\n<link name=\"b\"><inertial><mass value=\"1\"/><inertia "
      "ixx=\"1\" ixy=\"0\" ixz=\"0\" iyy=\"1\" iyz=\"0\" izz=\"1\"/></inertial></link>\n" +
      joint("j", "revolute", "a", "b"));
  EXPECT_THROW_MESSAGE(
      parse_spatial_scene(head + "urdf: r.urdf\n", "s.yaml", reader(massless_root)), SceneError,
      "field 'urdf': URDF 'r.urdf': 1 body is refused: link 'a' (mass 0: must be positive). "
      "Remedies: give the link's inertial in the scene (inertials: {LINK: {mass, com, "
      "inertia}})");
  EXPECT_THROW_MESSAGE(
      parse_spatial_scene(head + "urdf: r.urdf\nlinks: []\n", "s.yaml", reader(massless_root)),
      SceneError, "field 'links': comes from the URDF");
  EXPECT_THROW_MESSAGE(parse_spatial_scene(head + "urdf: missing.urdf\n", "/nonexistent/s.yaml"),
                       SceneError, "field 'urdf': URDF: cannot open '/nonexistent/missing.urdf'");
  EXPECT_THROW_MESSAGE(parse_spatial_scene(head + "urdf: /dev/zero\n", "s.yaml"), SceneError,
                       "'/dev/zero' is not a regular file");
}

// A tree has at most 60 moving joints and 30 on one path from the root: two 30-joint arms are
// read; a 31st joint on an arm, or a 61st joint in a third arm, is refused naming the joint.
TEST(UrdfReader, ATreeTakesSixtyJointsAndThirtyOnAPath) {
  auto link = [](const std::string& name) {
    return "<link name=\"" + name +
           "\"><inertial><mass value=\"1\"/><inertia ixx=\"0.1\" ixy=\"0\" ixz=\"0\" "
           "iyy=\"0.1\" iyz=\"0\" izz=\"0.1\"/></inertial></link>\n";
  };
  auto arm = [&](const std::string& side, int joints) {
    std::string text;
    for (int j = 1; j <= joints; ++j) {
      const std::string child = side + std::to_string(j);
      const std::string parent = j == 1 ? "sat" : side + std::to_string(j - 1);
      text += link(child) + joint(side + "_j" + std::to_string(j), "revolute", parent, child,
                                  "<origin xyz=\"0 0 0.1\"/><axis xyz=\"0 0 1\"/>");
    }
    return text;
  };
  const std::string two = link("sat") + arm("l", 30) + arm("r", 30);
  EXPECT_EQ(read_urdf(robot(two), "r.urdf", true, "").chain.links.size(), 60u);
  EXPECT_THROW_MESSAGE(
      read_urdf(robot(link("sat") + arm("l", 31)), "r.urdf", true, ""), SceneError,
      "<joint name='l_j31'>: more than 30 moving joints on one path from the root");
  EXPECT_THROW_MESSAGE(read_urdf(robot(two + arm("c", 1)), "r.urdf", true, ""), SceneError,
                       "<joint name='c_j1'>: more than 60 moving joints");
}

}  // namespace
}  // namespace spacearm
