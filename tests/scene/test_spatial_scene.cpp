// generator/scene/spatial_scene.hpp: the native YAML form of a spatial arm is read into the chain's
// description, and every malformed or unphysical field is an error naming the field.
#include "spatial_scene.hpp"

#include <algorithm>

#include "model_recipe.hpp"
#include "planar_scene.hpp"
#include "support.hpp"

namespace spacearm {
namespace {

const std::string kArm = R"(name: arm2
space: spatial
base: {type: free_floating, mass: 500, com: [0.1, 0, 0], inertia: [100, 0, 0, 120, 0, 150]}
links:
  - {origin: [0.5, 0, 0.2], rpy: [0, 1.5707963, 0], axis: [0, 0, 1], mass: 5, com: [0.2, 0, 0],
     inertia: [0.01, 0, 0, 0.2, 0, 0.2]}
  - {origin: [0.4, 0, 0], mass: 3, inertia: [0.01, 0.001, 0, 0.1, 0, 0.1]}
gears: {ratio: 100, rotor_inertia: [1.0e-4, 6.0e-5], rotor_coupling: armature}
end_effector: [0.3, 0, 0]
)";

TEST(SpatialScene, ReadsTheChain) {
  std::string listed = kArm + "outputs: [forward_dynamics, mass_matrix]\n";
  EXPECT_EQ(
      parse_spatial_scene(listed, "arm2.yaml").outputs,
      (std::vector<Output>{Output::mass_matrix, Output::forward_dynamics}));  // registry order
  const SpatialScene s = parse_spatial_scene(kArm, "arm2.yaml");
  EXPECT_TRUE(s.outputs.empty());
  EXPECT_EQ(s.name, "arm2");
  const spatial::ChainDescription& c = s.chain;
  EXPECT_TRUE(c.free_base);
  EXPECT_EQ(c.nv(), 8);
  EXPECT_EQ(c.nq(), 9);
  EXPECT_EQ(c.base.mass.value, 500);
  EXPECT_EQ(c.base.inertia[5].value, 150);
  ASSERT_EQ(c.links.size(), 2u);
  EXPECT_EQ(c.links[0].origin_xyz[2], 0.2);
  EXPECT_EQ(c.links[0].axis[2], 1);
  EXPECT_EQ(c.links[1].axis[0], 1);  // URDF's default axis
  EXPECT_EQ(c.links[1].inertia[1].value, 0.001);
  for (const auto& l : c.links) {
    EXPECT_TRUE(l.gear.present);
    EXPECT_EQ(l.gear.ratio.value, 100);
    EXPECT_FALSE(l.gear.exact);
    EXPECT_EQ(l.gear.transverse.value, 6.0e-5);
  }
  EXPECT_EQ(c.end_effectors[0].xyz[0], 0.3);
}

// Each malformed field, with the text that replaces a part of the valid arm, and the message.
// (20 + 4 outputs cases.)
TEST(SpatialScene, NamesEveryBadField) {
  struct Bad {
    std::string from, to, message;
  };
  const std::vector<Bad> cases = {
      {"space: spatial", "space: planar", "field 'space': expected 'spatial', got 'planar'"},
      {"axis: [0, 0, 1]", "axis: [0, 0, 0]", "field 'links[0].axis': must not be zero"},
      {"axis: [0, 0, 1]", "axis: [0, 1]", "field 'links[0].axis': expected a list of 3 numbers"},
      {"mass: 5,", "mass: -5,", "field 'links[0].mass': must be positive"},
      {"inertia: [0.01, 0, 0, 0.2, 0, 0.2]", "inertia: [0.5, 0, 0, 0.2, 0, 0.2]",
       "field 'links[0].inertia': not a physical inertia"},
      {"inertia: [100, 0, 0, 120, 0, 150]", "inertia: [100, 0, 0, 120, 0, -1]",
       "field 'base.inertia': not a physical inertia"},
      {"ratio: 100", "ratio: 0", "field 'gears.ratio': must be positive"},
      {"ratio: 100", "ratio: p",
       "field 'gears.ratio': refers to parameter 'p', which is not declared under 'parameters'"},
      {"end_effector: [0.3, 0, 0]", "parameters: {p: 1}",
       "field 'parameters.p': parameter 'p' is declared but never used"},
      {"end_effector: [0.3, 0, 0]", "parameters: {x0: 1}",
       "field 'parameters.x0': parameter name 'x0' is reserved"},
      {"rotor_inertia: [1.0e-4, 6.0e-5], rotor_coupling: armature}",
       "rotor_inertia: [1.0e-4, It], rotor_coupling: armature}\nparameters: {It: 1}",
       "field 'gears.rotor_inertia[1]': 'It': the transverse inertia acts only with "
       "rotor_coupling exact"},
      {"type: free_floating, mass: 500", "type: fixed, mass: 500",
       "field 'base.mass': a fixed base does not move"},
      {"origin: [0.4, 0, 0]", "origin: [L, 0, 0]",
       "field 'links[1].origin[0]': 'L': a frame, an axis or the end effector takes numbers"},
      {"rotor_coupling: armature", "rotor_coupling: loose",
       "field 'gears.rotor_coupling': expected exact, armature or a coupling factor in [0, 1] "
       "(a number, or a parameter declared under 'parameters'), got 'loose'"},
      {"rpy: [0, 1.5707963, 0]", "rpy: [0, .nan, 0]",
       "field 'links[0].rpy[1]': value '.nan' is not finite"},
      {"end_effector:", "end_effektor:", "field 'end_effektor': unknown field"},
      {"type: free_floating", "type: floating",
       "field 'base.type': expected free_floating or fixed"},
  };
  for (const Bad& b : cases) {
    std::string text = kArm;
    const size_t at = text.find(b.from);
    ASSERT_NE(at, std::string::npos) << b.from;
    text.replace(at, b.from.size(), b.to);
    EXPECT_THROW_MESSAGE(parse_spatial_scene(text, "arm2.yaml"), SceneError, b.message);
  }
  std::string many = "name: long\nspace: spatial\nbase: {type: fixed}\nlinks:\n";
  for (int i = 0; i < 31; ++i) many += "  - {mass: 1, inertia: [1, 0, 0, 1, 0, 1]}\n";
  EXPECT_THROW_MESSAGE(parse_spatial_scene(many, "long.yaml"), SceneError,
                       "field 'links[30]': is joint 31 on its path from the base; at most "
                       "30 on one path (a chain: 30 links; a tree: 60 in all)");
  for (int i = 31; i < 61; ++i) many += "  - {mass: 1, inertia: [1, 0, 0, 1, 0, 1]}\n";
  EXPECT_THROW_MESSAGE(parse_spatial_scene(many, "long.yaml"), SceneError,
                       "field 'links': expected a list of 1 to 60 links");
  std::string gears = kArm;
  gears.replace(gears.find("gears: {"), 8, "gears: [{");
  gears.replace(gears.find("armature}"), 9, "armature}]");
  EXPECT_THROW_MESSAGE(parse_spatial_scene(gears, "arm2.yaml"), SceneError,
                       "field 'gears': expected one mapping for all joints or a list of 2");
}

// `lanes:` as in the plane: outputs the scene emits (its defaults where it lists none).
TEST(SpatialScene, LanesListOutputsTheSceneEmits) {
  EXPECT_EQ(parse_spatial_scene(kArm + "lanes: [mass_matrix]\n", "arm2.yaml").lanes,
            std::vector<Output>{Output::mass_matrix});
  EXPECT_THROW_MESSAGE(
      parse_spatial_scene(kArm + "lanes: [forward_dynamics_derivatives]\n", "arm2.yaml"),
      SceneError,
      "field 'lanes[0]': 'forward_dynamics_derivatives' is not an output this scene emits");
  EXPECT_THROW_MESSAGE(parse_spatial_scene(kArm + "lanes: [mass_matrix, mass_matrix]\n", "a.yaml"),
                       SceneError, "field 'lanes[1]': 'mass_matrix' is listed twice");
  EXPECT_THROW_MESSAGE(parse_spatial_scene(kArm + "lanes: [\"a\\x01\"]\n", "a.yaml"), SceneError,
                       "field 'lanes[0]': unknown output 'a?'");
  EXPECT_THROW_MESSAGE(parse_spatial_scene(kArm + "lanes: [[mass_matrix]]\n", "a.yaml"), SceneError,
                       "field 'lanes[0]': expected an output name");
  EXPECT_THROW_MESSAGE(parse_spatial_scene(kArm + "lanes: []\n", "a.yaml"), SceneError,
                       "field 'lanes': expected a non-empty list of outputs");
}

// Friction as in the plane, per joint or for all; numbers only in 3D. It adds friction_forces
// to the default outputs, and needs to be there for friction_forces to be listed.
TEST(SpatialScene, ReadsFrictionAndNamesItsBadFields) {
  const std::string all = kArm + "friction: {viscous: 0.01, coulomb: 0.2, velocity_scale: 0.05}\n";
  const SpatialScene s = parse_spatial_scene(all, "arm2.yaml");
  for (const auto& l : s.chain.links) {
    EXPECT_TRUE(l.friction.present);
    EXPECT_EQ(l.friction.coulomb.value, 0.2);
    EXPECT_EQ(l.friction.stribeck_static.value, 0.2);  // Fs defaults to Fc: no hump
    EXPECT_TRUE(l.friction.has_coulomb);
    EXPECT_FALSE(l.friction.has_stribeck);
  }
  const std::vector<Output> outputs = spatial_outputs(s);
  EXPECT_EQ(std::count(outputs.begin(), outputs.end(), Output::friction_forces), 1);
  const std::vector<Output> plain = spatial_outputs(parse_spatial_scene(kArm, "arm2.yaml"));
  EXPECT_EQ(std::count(plain.begin(), plain.end(), Output::friction_forces), 0);
  const SpatialScene one =
      parse_spatial_scene(kArm + "friction: [null, {viscous: 0.5}]\n", "arm2.yaml");
  EXPECT_FALSE(one.chain.links[0].friction.present);
  EXPECT_EQ(one.chain.links[1].friction.viscous.value, 0.5);
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"friction: {viscous: -1}", "field 'friction.viscous': must not be negative"},
      {"friction: {coulomb: 0.2}",
       "field 'friction.velocity_scale': Coulomb or static friction "
       "needs a positive velocity_scale"},
      {"friction: {coulomb: 0.2, velocity_scale: 1e-12}",
       "field 'friction.velocity_scale': must be at least 1e-9 rad/s"},
      {"friction: {coulomb: 0.2, stribeck_static: 0.1, velocity_scale: 1}",
       "field 'friction.stribeck_static': the breakaway level Fs (0.1) must not be below"},
      {"friction: {coulomb: 0.2, stribeck_static: 0.3, velocity_scale: 1}",
       "field 'friction.stribeck_velocity': a Stribeck hump"},
      {"friction: {viscous: b}",
       "field 'friction.viscous': refers to parameter 'b', which is not declared"},
      {"friction: [null, null]", "field 'friction': every entry is null"},
      {"friction: [{viscous: 1}]",
       "field 'friction': expected one mapping for all joints or a "
       "list of 2"},
      {"friction: {viscous: 1, drag: 2}", "field 'friction.drag': unknown field"},
      {"outputs: [friction_forces]", "field 'outputs[0]': 'friction_forces' needs joint friction"},
  };
  for (const auto& [add, message] : bad)
    EXPECT_THROW_MESSAGE(parse_spatial_scene(kArm + add + "\n", "arm2.yaml"), SceneError, message);
}

// Flexible joints as in the plane: a spring (and a damper) between the gear's output and the
// link, per joint or for all; the motor angles follow the joints, and the springs' outputs join
// the defaults. A spring needs a rotor with axial inertia.
TEST(SpatialScene, ReadsFlexibleJointsAndNamesTheirBadFields) {
  std::string flexible = kArm;
  flexible.replace(flexible.find("rotor_coupling: armature}"), 25,
                   "rotor_coupling: armature, stiffness: 800, damping: 0.2}");
  const SpatialScene s = parse_spatial_scene(flexible, "arm2.yaml");
  for (const auto& l : s.chain.links) {
    EXPECT_TRUE(l.gear.flexible);
    EXPECT_EQ(l.gear.stiffness.value, 800);
    EXPECT_TRUE(l.gear.has_damping);
    EXPECT_EQ(l.gear.damping.value, 0.2);
  }
  EXPECT_EQ(s.chain.nv(), 10);
  EXPECT_EQ(s.chain.motor_coordinate(1), 9);
  const std::vector<Output> outputs = spatial_outputs(s);
  for (Output o : {Output::potential_energy, Output::spring_damper_forces})
    EXPECT_EQ(std::count(outputs.begin(), outputs.end(), o), 1) << to_string(o);
  const std::vector<Output> rigid = spatial_outputs(parse_spatial_scene(kArm, "arm2.yaml"));
  EXPECT_EQ(std::count(rigid.begin(), rigid.end(), Output::potential_energy), 0);
  auto with_gear = [](const std::string& gear) {
    std::string text = kArm;
    const size_t at = text.find("gears: {");
    text.replace(at, text.find('\n', at) - at, "gears: " + gear);
    return text;
  };
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"{ratio: 10, rotor_inertia: [1e-4, 0], stiffness: 0}",
       "field 'gears.stiffness': must be positive, got 0"},
      {"{ratio: 10, rotor_inertia: [1e-4, 0], stiffness: 10, damping: -1}",
       "field 'gears.damping': must not be negative"},
      {"{ratio: 10, rotor_inertia: [1e-4, 0], damping: 1}",
       "field 'gears.damping': a damper needs a spring: give 'stiffness' too"},
      {"{ratio: 10, stiffness: 100}",
       "field 'gears.rotor_inertia[0]': a flexible joint (stiffness given) needs a rotor of "
       "positive axial inertia, got 0"},
      {"{ratio: 10, rotor_inertia: [1e-4, 0], stiffness: k}",
       "field 'gears.stiffness': refers to parameter 'k', which is not declared"},
      {"{ratio: 10, rotor_inertia: [1e-4, 0], stiffness: [1]}", "field 'gears.stiffness'"},
  };
  for (const auto& [gear, message] : bad)
    EXPECT_THROW_MESSAGE(parse_spatial_scene(with_gear(gear), "arm2.yaml"), SceneError, message);
  EXPECT_THROW_MESSAGE(
      parse_spatial_scene(kArm + "outputs: [potential_energy]\n", "arm2.yaml"), SceneError,
      "field 'outputs[0]': 'potential_energy' needs a flexible joint (gears: stiffness)");
}

// Issue 51: identified inertias. A URDF whose link tensors hold the motors' reflected inertia
// about the joint axis (Izz above Ixx + Iyy, as ETS-VII's identified links): `physical` refuses
// every such body in one message, by its URDF link names, with both remedies;
// `positive_definite` takes them, says so once, and records it in the model's facts; a tensor
// that is not positive definite is refused under either.
std::string identified_urdf(const std::string& izz3 = "1.69", const std::string& izz1 = "1.69") {
  auto link = [](const std::string& name, const std::string& m, const std::string& ixx,
                 const std::string& izz) {
    return "<link name=\"" + name + "\"><inertial><mass value=\"" + m + "\"/><inertia ixx=\"" +
           ixx + "\" ixy=\"0\" ixz=\"0\" iyy=\"" + ixx + "\" iyz=\"0\" izz=\"" + izz +
           "\"/></inertial></link>\n";
  };
  auto joint = [](const std::string& name, const std::string& type, const std::string& parent,
                  const std::string& child) {
    return "<joint name=\"" + name + "\" type=\"" + type + "\"><parent link=\"" + parent +
           "\"/><child link=\"" + child +
           "\"/><origin xyz=\"0 0 0.5\"/><axis xyz=\"0 0 1\"/></joint>\n";
  };
  return "<robot name=\"identified\">\n" + link("bus", "2500", "1500", "2000") +
         link("Link_1", "25", "0.25", izz1) + link("Link_2", "25", "0.25", "0.3") +
         link("Link_3", "20", "0.25", izz3) + link("Link_EE", "2", "0.01", "0.01") +
         joint("Joint_1", "revolute", "bus", "Link_1") +
         joint("Joint_2", "revolute", "Link_1", "Link_2") +
         joint("Joint_3", "revolute", "Link_2", "Link_3") +
         joint("Joint_EE", "fixed", "Link_3", "Link_EE") + "</robot>\n";
}

SpatialScene identified_scene(const std::string& check, const std::string& xml) {
  const std::string text =
      "name: ets\nspace: spatial\nbase: {type: free_floating}\nurdf: e.urdf\n" +
      (check.empty() ? "" : "inertia_check: " + check + "\n");
  return parse_spatial_scene(text, "ets.yaml", [xml](const std::string&) { return xml; });
}

TEST(SpatialScene, PhysicalRefusesEveryIdentifiedBodyInOneMessage) {
  for (const std::string check : {"", "physical"}) {
    try {
      identified_scene(check, identified_urdf());
      ADD_FAILURE() << "identified tensors taken under '" << check << "'";
    } catch (const SceneError& e) {
      const std::string m = e.what();
      EXPECT_NE(m.find("field 'urdf': URDF 'e.urdf': 2 bodies are refused: link 'Link_1' "
                       "(principal moments 0.25, 0.25, 1.69); links 'Link_3' + 'Link_EE' "
                       "(principal moments"),
                std::string::npos)
          << m;
      EXPECT_EQ(m.find("Link_2"), std::string::npos) << m;  // physical: not listed
      EXPECT_NE(m.find("give the link's inertial in the scene (inertials:"), std::string::npos);
      EXPECT_NE(m.find("inertia_check: positive_definite"), std::string::npos) << m;
    }
  }
  EXPECT_THROW_MESSAGE(identified_scene("rigid", identified_urdf()), SceneError,
                       "field 'inertia_check': expected physical or positive_definite, got "
                       "'rigid'");
}

TEST(SpatialScene, PositiveDefiniteTakesIdentifiedBodiesWithOneWarning) {
  const SpatialScene s = identified_scene("positive_definite", identified_urdf());
  EXPECT_EQ(s.inertia_check, InertiaRule::positive_definite);
  ASSERT_EQ(s.warnings.size(), 1u);
  EXPECT_NE(s.warnings[0].find("scene 'ets.yaml': inertia_check: positive_definite takes 2 bodies "
                               "whose inertia no rigid body has"),
            std::string::npos)
      << s.warnings[0];
  EXPECT_NE(s.warnings[0].find("link 'Link_1' (principal moments 0.25, 0.25, 1.69)"),
            std::string::npos);
  EXPECT_EQ(s.chain.links[0].inertia[5].value, 1.69);  // as given
  EXPECT_EQ(ModelRecipe(s).facts().inertia_check, "positive_definite");
  EXPECT_EQ(ModelRecipe(s).warnings(), s.warnings);
  const std::string rigid = identified_urdf("0.3", "0.3");
  EXPECT_EQ(identified_scene("positive_definite", rigid).warnings.size(), 0u);
  EXPECT_EQ(ModelRecipe(identified_scene("", rigid)).facts().inertia_check, "physical");
  // Not positive definite: refused under either rule, naming the rule it breaks.
  EXPECT_THROW_MESSAGE(identified_scene("positive_definite", identified_urdf("-0.3")), SceneError,
                       "1 body is refused: links 'Link_3' + 'Link_EE' (principal moments -");
  EXPECT_THROW_MESSAGE(identified_scene("positive_definite", identified_urdf("-0.3")), SceneError,
                       "inertia_check: positive_definite takes a positive definite tensor");
}

TEST(SpatialScene, YamlLinksNameTheFieldAndTheRemedy) {
  const std::string identified = "inertia: [0.01, 0, 0, 0.2, 0, 0.5]";  // 0.5 > 0.01 + 0.2
  std::string text = kArm;
  text.replace(text.find("inertia: [0.01, 0, 0, 0.2, 0, 0.2]"), 34, identified);
  EXPECT_THROW_MESSAGE(parse_spatial_scene(text, "arm2.yaml"), SceneError,
                       "field 'links[0].inertia': not a physical inertia (principal moments 0.01, "
                       "0.2, 0.5: each must be positive and at most the sum of the other two); "
                       "for identified parameters, inertia_check: positive_definite takes");
  const SpatialScene s =
      parse_spatial_scene(text + "inertia_check: positive_definite\n", "arm2.yaml");
  ASSERT_EQ(s.warnings.size(), 1u);
  EXPECT_NE(s.warnings[0].find("1 body whose inertia no rigid body has"), std::string::npos);
  EXPECT_NE(s.warnings[0].find("links[0] (principal moments 0.01, 0.2, 0.5)"), std::string::npos)
      << s.warnings[0];
}

// Issue 52: the native form's trees. Links name their parents (base, or a link listed before;
// default: the one before); the end effectors are the leaves, or those end_effector_links names,
// each moved by its point in end_effector's mapping; a serial chain keeps its one unnamed end
// effector. Every malformed tree field is named.
const std::string kTwoArms = R"(name: two_arms
space: spatial
base: {type: free_floating, mass: 400, com: [0, 0, 0], inertia: [60, 0, 0, 60, 0, 80]}
links:
  - {name: l1, parent: base, origin: [0.6, 0.5, 0.5], axis: [0, 0, 1], mass: 5, inertia: [0.1, 0, 0, 0.1, 0, 0.1]}
  - {name: l2, origin: [0, 0, 0.3], axis: [0, 1, 0], mass: 4, inertia: [0.1, 0, 0, 0.1, 0, 0.1]}
  - {name: r1, parent: base, origin: [0.6, -0.5, 0.5], axis: [0, 0, 1], mass: 5, inertia: [0.1, 0, 0, 0.1, 0, 0.1]}
  - {name: r2, parent: r1, origin: [0, 0, 0.3], axis: [0, 1, 0], mass: 4, inertia: [0.1, 0, 0, 0.1, 0, 0.1]}
)";

TEST(SpatialScene, ReadsANativeTree) {
  const SpatialScene s = parse_spatial_scene(
      kTwoArms + "end_effector: {r2: [0.2, 0, 0], l2: [0.1, 0, 0]}\n", "t.yaml");
  const spatial::ChainDescription& c = s.chain;
  EXPECT_FALSE(c.serial());
  std::vector<int> parents;
  for (int i = 1; i <= 4; ++i) parents.push_back(c.parent(i));
  EXPECT_EQ(parents, (std::vector<int>{0, 1, 0, 3}));
  ASSERT_EQ(c.num_end_effectors(), 2);
  EXPECT_EQ(c.end_effectors[0].link, "l2");
  EXPECT_EQ(c.end_effector_body(0), 2);
  EXPECT_EQ(c.end_effectors[0].xyz, (std::array<double, 3>{0.1, 0, 0}));
  EXPECT_EQ(c.end_effectors[1].link, "r2");
  EXPECT_EQ(c.end_effectors[1].xyz, (std::array<double, 3>{0.2, 0, 0}));
  const ModelFacts f = ModelRecipe(s).facts();
  EXPECT_EQ(f.dims.num_end_effectors, 2);
  EXPECT_EQ(f.joint_parents, (std::vector<int>{0, 1, 0, 3}));
  EXPECT_EQ(f.joint_names, (std::vector<std::string>{"joint1", "joint2", "joint3", "joint4"}));
  const SpatialScene picked =
      parse_spatial_scene(kTwoArms + "end_effector_links: [r1, l2, r2]\n", "t.yaml");
  ASSERT_EQ(picked.chain.num_end_effectors(), 3);
  EXPECT_EQ(picked.chain.end_effector_body(0), 3);
  // A chain: one end effector, unnamed, at the last link (the generated code as before trees).
  const SpatialScene chain = parse_spatial_scene(kArm, "arm2.yaml");
  ASSERT_EQ(chain.chain.num_end_effectors(), 1);
  EXPECT_EQ(chain.chain.end_effectors[0].link, "");
  EXPECT_EQ(chain.chain.end_effector_body(0), 2);
  EXPECT_TRUE(ModelRecipe(chain).facts().joint_parents.empty());
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"parent: r1,", "parent: r2,"},     {"name: r2,", "name: l1,"},
      {"name: r2,", "name: base,"},       {"name: r2,", "name: [x],"},
      {"parent: r1,", "parent: {a: 1},"}, {"parent: r1,", "parent: 2,"},
  };
  const std::vector<std::string> messages = {
      "field 'links[3].parent': expected base or the name of a link listed before this one, got "
      "'r2'",
      "field 'links[3].name': 'l1' names an earlier link too",
      "field 'links[3].name': expected an identifier other than 'base', got 'base'",
      "field 'links[3].name'",
      "field 'links[3].parent': expected base or the name of a link listed before this one",
      "field 'links[3].parent': expected base or the name of a link listed before this one, got "
      "'2'",
  };
  for (size_t k = 0; k < bad.size(); ++k) {
    std::string text = kTwoArms;
    const size_t at = text.rfind(bad[k].first);
    ASSERT_NE(at, std::string::npos) << bad[k].first;
    text.replace(at, bad[k].first.size(), bad[k].second);
    SCOPED_TRACE(bad[k].second);
    EXPECT_THROW_MESSAGE(parse_spatial_scene(text, "t.yaml"), SceneError, messages[k]);
  }
  EXPECT_THROW_MESSAGE(parse_spatial_scene(kTwoArms + "end_effector: [0, 0, 1]\n", "t.yaml"),
                       SceneError,
                       "field 'end_effector': a point [x, y, z] is for one end effector; this "
                       "scene has 2 ('l2', 'r2'): give a mapping from end effector link to point");
  EXPECT_THROW_MESSAGE(parse_spatial_scene(kTwoArms + "end_effector: {r1: [0, 0, 1]}\n", "t.yaml"),
                       SceneError, "field 'end_effector.r1': is no end effector of this scene");
  EXPECT_THROW_MESSAGE(parse_spatial_scene(kTwoArms + "end_effector_links: [l2, hand]\n", "t.yaml"),
                       SceneError, "field 'end_effector_links': no link is named 'hand'");
  EXPECT_THROW_MESSAGE(parse_spatial_scene(kTwoArms + "end_effector_links: [l2, l2]\n", "t.yaml"),
                       SceneError, "field 'end_effector_links': 'l2' is listed twice");
  EXPECT_THROW_MESSAGE(
      parse_spatial_scene(kTwoArms + "end_effector: {l2: [0, 0, 1], l2: [0, 0, 1]}\n", "t.yaml"),
      SceneError, "field 'end_effector.l2': given more than once");
  EXPECT_THROW_MESSAGE(parse_spatial_scene(kTwoArms + "end_effector: {}\n", "t.yaml"), SceneError,
                       "field 'end_effector': an empty mapping names no end effector");
  // A name that is another link's default (linkK) would put two end effectors on one link.
  std::string defaults = kTwoArms;
  defaults.replace(defaults.find("name: l1"), 8, "name: link2");
  defaults.replace(defaults.find("{name: l2, "), 11, "{parent: base, ");
  EXPECT_THROW_MESSAGE(parse_spatial_scene(defaults, "t.yaml"), SceneError,
                       "field 'links[0].name': 'link2' is the default name of links[1], which has "
                       "none");
  EXPECT_THROW_MESSAGE(parse_spatial_scene(kTwoArms + "end_effector_links: [[l2], r2]\n", "t.yaml"),
                       SceneError, "field 'end_effector_links[0]': expected a link's name");
  EXPECT_THROW_MESSAGE(parse_spatial_scene(kTwoArms + "end_effector_links: []\n", "t.yaml"),
                       SceneError,
                       "field 'end_effector_links': expected a list of 1 to 16 link names");
}

}  // namespace
}  // namespace spacearm
