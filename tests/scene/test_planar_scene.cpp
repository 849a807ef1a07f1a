// Scene files: the paper's scenes parse; bad input gets an error naming field and value.
#include <gtest/gtest.h>

#include <algorithm>

#include <cctype>
#include <filesystem>
#include <fstream>
#include <set>

#include "planar_scene.hpp"
#include "scene_fuzz_target.hpp"
#include "support.hpp"

namespace spacearm {
namespace {

const char* kValid = R"(
name: two_links
base: {type: free_floating, mass: 10, inertia: 1, mount: [0.1, 0]}
links:
  - {mass: 1, inertia: 0.1, length: 0.5, com: [0.25, 0]}
  - {mass: 1, inertia: 0.1, length: 0.5, com: [0.25, 0]}
)";

std::string error_of(const std::string& yaml) {
  try {
    parse_scene(yaml, "test.yaml");
  } catch (const SceneError& e) {
    return e.what();
  }
  return "";
}

std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const auto pos = text.find(from);
  EXPECT_NE(pos, std::string::npos) << from;
  return text.replace(pos, from.size(), to);
}

TEST(Scene, PaperScenesParse) {
  const Scene ref = load_scene(SPACEARM_SOURCE_DIR "/models/paper_reference.yaml");
  EXPECT_EQ(ref.name, "paper_reference");
  EXPECT_TRUE(ref.free_floating());
  EXPECT_FALSE(ref.geared());
  ASSERT_EQ(ref.num_links(), 3);
  EXPECT_DOUBLE_EQ(ref.base.mass.value, 64.859);
  EXPECT_DOUBLE_EQ(ref.links[2].com[1].value, -0.002);
  EXPECT_EQ(ref.coordinate_names(), (std::vector<std::string>{"x0", "y0", "q0", "q1", "q2", "q3"}));

  const Scene geared = load_scene(SPACEARM_SOURCE_DIR "/models/paper_geared.yaml");
  ASSERT_TRUE(geared.geared());
  ASSERT_EQ(geared.gears.size(), 3u);
  EXPECT_EQ(geared.gears[1]->ratio.parameter, "p");
  EXPECT_EQ(geared.parameters.size(), 2u);
  EXPECT_EQ(geared.coordinate_names()[3], "qm1");
}

TEST(Scene, DefaultsToTheRegistrysDefaultOutputsAndFixedBaseHasNoFreeBaseOnes) {
  const Scene s = parse_scene(kValid, "t.yaml");
  const Scene fixed = parse_scene(replaced(kValid, "type: free_floating", "type: fixed"), "t.yaml");
  for (const OutputInfo& o : output_registry()) {
    // A rigid scene without friction has neither springs nor friction.
    EXPECT_EQ(s.wants(o.id),
              o.by_default && (o.needs & ~(needs::free_base | needs::rigid_joints)) == 0)
        << o.name;
    EXPECT_EQ(fixed.wants(o.id), o.by_default && (o.needs & ~needs::rigid_joints) == 0) << o.name;
  }
  EXPECT_FALSE(fixed.wants(Output::momentum));
  EXPECT_EQ(fixed.num_coordinates(), 2);
}

// `lanes:` gives listed outputs a 4-lane version too (ModelFacts::lanes): only outputs the scene
// emits, each once, by name.
TEST(Scene, LanesListOutputsTheSceneEmits) {
  const Scene s = parse_scene(std::string(kValid) +
                                  "outputs: [forward_dynamics, forward_dynamics_derivatives]\n"
                                  "lanes: [forward_dynamics_derivatives]\n",
                              "t.yaml");
  EXPECT_EQ(s.lanes, std::set<Output>{Output::forward_dynamics_derivatives});
  EXPECT_TRUE(parse_scene(kValid, "t.yaml").lanes.empty());
  const std::string listed = std::string(kValid) + "outputs: [forward_dynamics]\n";
  EXPECT_THROW_MESSAGE(parse_scene(listed + "lanes: [mass_matrix]\n", "t.yaml"), SceneError,
                       "field 'lanes[0]': 'mass_matrix' is not an output this scene emits "
                       "(list it in 'outputs')");
  EXPECT_THROW_MESSAGE(parse_scene(listed + "lanes: [fast]\n", "t.yaml"), SceneError,
                       "field 'lanes[0]': unknown output 'fast' (known: mass_matrix,");
  EXPECT_THROW_MESSAGE(
      parse_scene(listed + "lanes: [forward_dynamics, forward_dynamics]\n", "t.yaml"), SceneError,
      "field 'lanes[1]': output 'forward_dynamics' listed twice");
  EXPECT_THROW_MESSAGE(parse_scene(listed + "lanes: forward_dynamics\n", "t.yaml"), SceneError,
                       "field 'lanes': expected a non-empty list of output names");
  EXPECT_THROW_MESSAGE(parse_scene(listed + "lanes: [{a: 1}]\n", "t.yaml"), SceneError,
                       "field 'lanes[0]': expected an output name");
}

TEST(Scene, ErrorsNameTheFieldAndValue) {
  struct Case {
    std::string from, to, expected;
  };
  const std::vector<Case> cases = {
      {"mass: 10", "mass: -10", "field 'base.mass': must be positive, got -10"},
      {"inertia: 0.1, length: 0.5, com: [0.25, 0]}\n  - {mass: 1",
       "inertia: 0.1, length: 0, com: [0.25, 0]}\n  - {mass: 1",
       "field 'links[0].length': must be positive, got 0"},
      {"mass: 10", "mass: .nan", "field 'base.mass'"},
      {"mass: 10", "mass: heavy", "refers to parameter 'heavy'"},
      {"type: free_floating", "type: floating",
       "expected 'free_floating' or 'fixed', got 'floating'"},
      {"name: two_links", "name: two links", "field 'name'"},
      {"mount: [0.1, 0]", "mount: [0.1]", "field 'base.mount'"},
      {"mount: [0.1, 0]", "mount: [0.1, 0], colour: red", "field 'base.colour': unknown field"},
      {"name: two_links", "name: new", "'new' is reserved"},
      {"inertia: 1, mount", "mount", "field 'base.inertia': missing required field"},
      {"mass: 10,", "mass: 10, mass: 11,", "field 'base.mass': given more than once"},
      // Found by the fuzzer (fuzz/regressions/non_scalar_key.yaml): a key that is not a name.
      {"mass: 10,", "[mass]: 10,", "field 'base': expected a field name, got a list"},
      {"name: two_links", "name: two_links\n? {a: 1}\n: 2", "expected a field name, got a mapping"},
      {"mass: 10", "mass: 1" + std::string(300, '0'),
       "field 'base.mass': value is too long (301 characters"},
      // A decimal comma in a flow mapping makes "0" a key: say what it probably is.
      {"mass: 10,", "mass: 10,0,",
       "field 'base.0': unknown field (allowed here: inertia, mass, mount, type); a decimal "
       "comma?"},
      // Digits lost to underflow, and names the preprocessor would rewrite.
      {"mount: [0.1, 0]", "mount: [0.1, 1e-400]", "'1e-400' is too small for double precision"},
      {"name: two_links", "name: EOF",
       "'EOF' is reserved (a C++ keyword, a macro of the generated code's headers"},
      {"name: two_links", "name: M_PI", "'M_PI' is reserved"},
      {"name: two_links", "name: two__links", "'two__links' is reserved"},
      {"name: two_links", "name: spacearm_double4", "'spacearm_double4' is reserved"},
      {"name: two_links", "name: SPACEARM_VECTOR_TRIG", "'SPACEARM_VECTOR_TRIG' is reserved"},
      {"name: two_links", "description: [a]\nname: two_links",
       "field 'description': expected text"},
      // Found by review: values whose products overflow double, exponents that overflow the
      // exact reader, names too long for a file name, a second YAML document.
      {"mass: 10", "mass: 1e200", "'1e200' is outside the supported magnitude range 1e-30 .. 1e30"},
      {"mount: [0.1, 0]", "mount: [0.1, 0e99999999999999999999]",
       "has an exponent beyond the supported range"},
      {"name: two_links", "name: " + std::string(65, 'a'),
       "field 'name': is 65 characters long, at most 64"},
      {"name: two_links", "name: two_links\n---\nname: other", "holds more than one YAML document"},
  };
  for (const auto& c : cases) {
    const std::string err = error_of(replaced(kValid, c.from, c.to));
    EXPECT_NE(err.find(c.expected), std::string::npos)
        << "got: '" << err << "', expected to contain: " << c.expected;
    EXPECT_NE(err.find("test.yaml"), std::string::npos) << err;
  }
}

TEST(Scene, GearAndParameterErrors) {
  const std::string geared =
      std::string(kValid) + "gears: {ratio: p, motor_inertia: 1.0e-5}\nparameters: {p: 0}\n";
  EXPECT_NE(error_of(geared).find("field 'gears.ratio': must be positive, got p = 0"),
            std::string::npos)
      << error_of(geared);
  const std::string big_motor = std::string(kValid) + "gears: {ratio: 10, motor_inertia: 0.5}\n";
  EXPECT_NE(error_of(big_motor).find("must be smaller than the inertia of link 1"),
            std::string::npos)
      << error_of(big_motor);
  const std::string negative_motor =
      std::string(kValid) + "gears: {ratio: 10, motor_inertia: -1.0e-5}\n";
  EXPECT_NE(error_of(negative_motor)
                .find("field 'gears.motor_inertia': must not be negative, got -1.0e-5"),
            std::string::npos)
      << error_of(negative_motor);
  const std::string unused = std::string(kValid) + "parameters: {k: 1}\n";
  EXPECT_NE(error_of(unused).find("parameter 'k' is declared but never used"), std::string::npos)
      << error_of(unused);
  const std::string wrong_count =
      std::string(kValid) + "gears:\n  - {ratio: 10, motor_inertia: 0}\n";
  EXPECT_NE(error_of(wrong_count).find("expected one entry per link (2), got 1"), std::string::npos)
      << error_of(wrong_count);
  const std::string reserved =
      std::string(kValid) + "gears: {ratio: q1, motor_inertia: 0}\nparameters: {q1: 2}\n";
  EXPECT_NE(error_of(reserved).find("parameter name 'q1' is reserved"), std::string::npos)
      << error_of(reserved);
  const std::string coupling =
      std::string(kValid) + "gears: {ratio: 10, motor_inertia: 0, rotor_coupling: approx}\n";
  EXPECT_NE(error_of(coupling).find(
                "field 'gears.rotor_coupling': expected 'exact', 'armature' or a coupling factor "
                "(a number "
                "in [0, 1], or a parameter declared under 'parameters'), got 'approx'"),
            std::string::npos)
      << error_of(coupling);
  EXPECT_TRUE(parse_scene(replaced(coupling, "approx", "armature"), "t.yaml").gears[1]->armature);
  const std::string twice =
      std::string(kValid) + "gears: {ratio: p, motor_inertia: 0}\nparameters: {p: 2, p: 3}\n";
  EXPECT_NE(error_of(twice).find("field 'parameters.p': parameter 'p' given more than once"),
            std::string::npos)
      << error_of(twice);
  for (const char* v : {".inf", "-.inf", "1e400", ".nan"}) {
    const std::string err = error_of(replaced(kValid, "mass: 10", std::string("mass: ") + v));
    EXPECT_NE(err.find("field 'base.mass': value '" + std::string(v) + "' is not finite"),
              std::string::npos)
        << err;
  }
  // 0 < p < 1 (a speed-up) is allowed, with a warning naming the field.
  testing::internal::CaptureStderr();
  const Scene speedup =
      parse_scene(std::string(kValid) + "gears: {ratio: 0.5, motor_inertia: 0}\n", "t.yaml");
  const std::string warning = testing::internal::GetCapturedStderr();
  EXPECT_EQ(speedup.gears[0]->ratio.value, 0.5);
  EXPECT_NE(warning.find("warning: scene 't.yaml', field 'gears.ratio': 0.5 < 1"),
            std::string::npos)
      << warning;
  const std::string bad_output = std::string(kValid) + "outputs: [mass_matrix, jerk]\n";
  EXPECT_NE(error_of(bad_output).find("unknown output 'jerk'"), std::string::npos)
      << error_of(bad_output);
}

TEST(Scene, LinkCountLimits) {
  EXPECT_NE(
      error_of(
          replaced(
              kValid,
              "links:\n  - {mass: 1, inertia: 0.1, length: 0.5, com: [0.25, 0]}\n  - {mass: 1, "
              "inertia: 0.1, length: 0.5, com: [0.25, 0]}\n",
              "links: []\n"))
          .find("needs at least one link, got 0"),
      std::string::npos);
  std::string many = "name: many\nbase: {type: fixed, mount: [0, 0]}\nlinks:\n";
  for (int i = 0; i <= kMaxLinks; ++i)
    many += "  - {mass: 1, inertia: 0.1, length: 0.5, com: [0.25, 0]}\n";
  EXPECT_NE(error_of(many).find("at most 30 links are supported, got 31"), std::string::npos)
      << error_of(many);
}

// formulation: closed | recursive | auto; beyond kClosedFormLinks every output has a recursive
// form and can be asked for; the defaults leave out only C (its cost).
TEST(Scene, FormulationAndTheClosedFormsReach) {
  EXPECT_EQ(parse_scene(kValid, "t.yaml").formulation, Formulation::automatic);
  EXPECT_EQ(parse_scene(std::string(kValid) + "formulation: closed\n", "t.yaml").formulation,
            Formulation::closed);
  EXPECT_EQ(parse_scene(std::string(kValid) + "formulation: recursive\n", "t.yaml").formulation,
            Formulation::recursive);
  const std::string bad = error_of(std::string(kValid) + "formulation: fast\n");
  EXPECT_NE(bad.find("field 'formulation': expected 'closed', 'recursive' or 'auto', got 'fast'"),
            std::string::npos)
      << bad;
  std::string long_chain =
      "name: long_chain\nbase: {type: free_floating, mass: 10, inertia: 1, "
      "mount: [0.1, 0]}\nlinks:\n";
  for (int i = 0; i <= kClosedFormLinks; ++i)
    long_chain += "  - {mass: 1, inertia: 0.1, length: 0.5, com: [0.25, 0]}\n";
  const Scene defaults = parse_scene(long_chain, "t.yaml");
  for (const OutputInfo& o : output_registry())
    EXPECT_EQ(defaults.wants(o.id), o.by_default && o.id != Output::coriolis_matrix &&
                                        (o.needs & ~needs::free_base & ~needs::rigid_joints) == 0)
        << o.name;
  EXPECT_TRUE(parse_scene(long_chain + "outputs: [coriolis_matrix]\n", "t.yaml")
                  .wants(Output::coriolis_matrix));
  const Scene asked = parse_scene(
      long_chain + "outputs: [christoffel_coriolis_matrix, forward_dynamics_derivatives]\n",
      "t.yaml");
  EXPECT_TRUE(asked.wants(Output::forward_dynamics_derivatives));
  EXPECT_TRUE(
      parse_scene(long_chain + "formulation: closed\n", "t.yaml").wants(Output::coriolis_matrix));
  // Issue 28, item 5: beyond kMaxClosedFormLinks the closed form is refused up front (30 links
  // derived for minutes and gigabytes without a word).
  while (std::count(long_chain.begin(), long_chain.end(), '\n') - 3 < kMaxClosedFormLinks)
    long_chain += "  - {mass: 1, inertia: 0.1, length: 0.5, com: [0.25, 0]}\n";
  EXPECT_EQ(parse_scene(long_chain + "formulation: closed\n", "t.yaml").num_links(),
            kMaxClosedFormLinks);
  long_chain += "  - {mass: 1, inertia: 0.1, length: 0.5, com: [0.25, 0]}\n";
  const std::string too_long = error_of(long_chain + "formulation: closed\n");
  EXPECT_NE(too_long.find("field 'formulation': 'closed' is derived up to 12 links"),
            std::string::npos)
      << too_long;
  EXPECT_NE(too_long.find("got 13 links; use 'auto' or 'recursive'"), std::string::npos)
      << too_long;
}

// Every file the fuzzer starts from or has recorded a crash for (fuzz/), and the shipped and
// test scenes: each is accepted as a scene that keeps the rules or rejected with an error that
// names the file; nothing else escapes (scene_fuzz_target.hpp).
TEST(Scene, FuzzCorpusAndRegressionsReplay) {
  namespace fs = std::filesystem;
  int accepted = 0, rejected = 0;
  for (const char* folder : {"fuzz/seeds", "fuzz/regressions", "models", "tests/scenes"}) {
    for (const auto& entry :
         fs::recursive_directory_iterator(fs::path(SPACEARM_SOURCE_DIR) / folder)) {
      if (!entry.is_regular_file()) continue;
      std::ifstream in(entry.path(), std::ios::binary);
      const std::string text((std::istreambuf_iterator<char>(in)),
                             std::istreambuf_iterator<char>());
      SCOPED_TRACE(entry.path().string());
      try {
        // A scene's URDF beside it, as the CLI reads it.
        const auto beside = [&entry](const std::string& path) {
          std::ifstream urdf(entry.path().parent_path() / path, std::ios::binary);
          if (!urdf) throw SceneError("no file '" + path + "'");
          return std::string((std::istreambuf_iterator<char>(urdf)),
                             std::istreambuf_iterator<char>());
        };
        const auto verdict = fuzz::check_scene_text(text, beside);
        (verdict == fuzz::Verdict::accepted ? accepted : rejected)++;
        const std::string f = folder;
        if ((f == "models" || f == "tests/scenes") && entry.path().extension() == ".yaml") {
          EXPECT_EQ(verdict, fuzz::Verdict::accepted);
        }
      } catch (const std::exception& e) {
        ADD_FAILURE() << e.what();
      }
    }
  }
  EXPECT_GT(accepted, 5);
  EXPECT_GT(rejected, 3);
}

TEST(Scene, ContentHashIsStable) {
  EXPECT_EQ(content_hash(""), "cbf29ce484222325");   // FNV-1a 64 offset basis
  EXPECT_EQ(content_hash("a"), "af63dc4c8601ec8c");  // published FNV-1a 64 test vector
  EXPECT_NE(content_hash(kValid), content_hash(std::string(kValid) + " "));
}

}  // namespace
}  // namespace spacearm

namespace spacearm {
namespace {

// The registry's names become identifiers in generated code and keys in eval's JSON: unique,
// and clear of the names the printer uses itself (T the scalar, params, temporaries t<k>).
// Flexible joints, joints without a gear and friction: the coordinate layout, and each
// invalid field named with its value.
TEST(Scene, FlexibleJointsMixedJointsAndFrictionLayOutTheirCoordinates) {
  const Scene s = parse_scene(std::string(kValid) +
                                  "gears:\n  - {ratio: 10, motor_inertia: 1e-4, stiffness: 500}\n"
                                  "  - null\nfriction: {viscous: 0.01}\n",
                              "t.yaml");
  EXPECT_EQ(s.coordinate_names(), (std::vector<std::string>{"x0", "y0", "q0", "q1", "q2", "qm1"}));
  EXPECT_EQ(s.num_coordinates(), 6);
  EXPECT_EQ(s.motor_coordinate(0), 5);
  EXPECT_EQ(s.motor_coordinate(1), 4);
  EXPECT_TRUE(s.is_flexible(0));
  EXPECT_FALSE(s.has_gear(1));
  EXPECT_TRUE(s.has_friction());
  EXPECT_TRUE(s.wants(Output::potential_energy));
  EXPECT_TRUE(s.wants(Output::friction_forces));
  EXPECT_FALSE(s.wants(Output::generalized_jacobian));  // not defined with flexible joints
  // A rigid scene neither wants nor may ask for them.
  EXPECT_FALSE(parse_scene(kValid, "t.yaml").wants(Output::potential_energy));
}

TEST(Scene, InvalidFlexibleJointsAndFrictionAreNamedErrors) {
  const std::string gear = std::string(kValid) + "gears: {ratio: 10, ";
  const std::string fr = std::string(kValid) + "friction: {";
  const struct {
    std::string yaml, message;
  } cases[] = {
      {gear + "motor_inertia: 0, stiffness: 100}\n",
       "field 'gears.motor_inertia': a flexible joint (stiffness given) needs motor_inertia > 0, "
       "got 0"},
      {gear + "motor_inertia: 1e-5, damping: 1}\n",
       "field 'gears.damping': a damper needs a spring"},
      {gear + "motor_inertia: 1e-5, stiffness: -3}\n",
       "field 'gears.stiffness': must be positive, got -3"},
      {gear + "motor_inertia: 1e-5, stiffness: 3, damping: -1}\n",
       "field 'gears.damping': must not be negative, got -1"},
      {fr + "coulomb: 0.1}\n", "field 'friction.velocity_scale': Coulomb or static friction needs"},
      {fr + "coulomb: 0.1, velocity_scale: 0}\n",
       "field 'friction.velocity_scale': must be positive, got 0"},
      {fr + "coulomb: 0.1, velocity_scale: 0.1, stribeck_static: 0.05}\n",
       "field 'friction.stribeck_static': the breakaway level Fs (0.050000) must not be below the "
       "Coulomb level Fc (0.100000)"},
      {fr + "coulomb: 0.1, velocity_scale: 0.1, stribeck_static: 0.2}\n",
       "field 'friction.stribeck_velocity': a Stribeck hump"},
      {fr + "coulomb: 0.1, velocity_scale: 1e-30}\n",
       "field 'friction.velocity_scale': must be at least 1e-9 rad/s (tanh(w/vs) becomes a step"},
      {fr + "coulomb: 0.1, velocity_scale: 0.1, stribeck_static: 0.2, stribeck_velocity: 1e-12}\n",
       "field 'friction.stribeck_velocity': must be at least 1e-9 rad/s"},
      {fr + "viscous: -1}\n", "field 'friction.viscous': must not be negative, got -1"},
      {fr + "sticky: 1}\n", "field 'friction.sticky': unknown field"},
      {std::string(kValid) + "friction: [null, null]\n", "field 'friction': every entry is null"},
      {std::string(kValid) + "gears: [null, null]\n", "field 'gears': every entry is null"},
      {std::string(kValid) + "friction: [{viscous: 1}]\n",
       "field 'friction': expected one entry per link (2), got 1"},
      {std::string(kValid) + "outputs: [potential_energy]\n",
       "'potential_energy' needs a flexible joint"},
      {gear + "motor_inertia: 1e-5, stiffness: 3}\noutputs: [generalized_jacobian]\n",
       "'generalized_jacobian' is not defined for a scene with flexible joints"},
  };
  for (const auto& c : cases) {
    const std::string err = error_of(c.yaml);
    EXPECT_NE(err.find(c.message), std::string::npos) << "got: " << err << "\nfor:\n" << c.yaml;
  }
}

TEST(OutputRegistry, NamesAreUniqueAndClearOfGeneratedNames) {
  std::set<std::string> names, symbols;
  auto is_generated = [](const std::string& n) {
    return n == "T" || n == "params" ||
           (n.size() > 1 && n[0] == 't' && std::isdigit(static_cast<unsigned char>(n[1])));
  };
  for (const OutputInfo& o : output_registry()) {
    SCOPED_TRACE(o.name);
    EXPECT_TRUE(names.insert(o.name).second);
    EXPECT_TRUE(symbols.insert(o.symbol).second);
    for (char c : std::string(o.symbol))
      EXPECT_TRUE(std::isalpha(static_cast<unsigned char>(c)));  // inspect's syntax
    EXPECT_EQ(output_from_string(o.name), o.id);
    EXPECT_EQ(&info(o.id), &o);
    std::set<std::string> arguments;
    for (Input i : o.inputs) EXPECT_TRUE(arguments.insert(info(i).name).second) << info(i).name;
    const bool scalar =
        o.results.size() == 1 && o.results[0].rows == Size::one && o.results[0].cols == Size::one;
    for (const ResultInfo& r : o.results) {
      if (!scalar) {
        EXPECT_FALSE(is_generated(r.name)) << r.name;  // a returned scalar is not an argument
      }
      EXPECT_TRUE(arguments.insert(r.name).second) << r.name;
      EXPECT_TRUE(!r.symmetric || r.rows == r.cols) << r.name;
    }
    for (const std::string& a : arguments)
      if (!(scalar && a == o.results[0].name)) {
        EXPECT_FALSE(is_generated(a)) << a;
      }
    // Composed outputs are made of closed forms only.
    for (Output c : o.composed_of) EXPECT_TRUE(info(c).composed_of.empty()) << to_string(c);
  }
}

}  // namespace
}  // namespace spacearm
