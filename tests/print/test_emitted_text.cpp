// generator/emitted_text.hpp: user text reaches emitted files only as escaped comments,
// validated file stems, validated identifiers and numbers printed from their values; and
// the property that follows: every scene the validator accepts emits code that compiles with
// -Wall -Wextra -Werror, with user text nowhere but in `//` comment lines.
// Cost: the property test derives about 15 small scenes and runs the compiler with
// -fsyntax-only on each (about 40 s on 2 cores).
#include "emitted_text.hpp"

#include <gtest/gtest.h>

#include <dlfcn.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <map>
#include <set>
#include <fstream>
#include <iterator>
#include <sstream>

#include "cpp_emitter.hpp"
#include "parameter_rules.hpp"
#include "planar_model.hpp"
#include "planar_scene.hpp"
#include "support.hpp"
#include "symbolic_model.hpp"

namespace spacearm {
namespace {

namespace fs = std::filesystem;

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

// One table of range rules (parameter_rules.hpp) gives the scene's errors and the generated
// parameter_error(): the run-time checks are exactly the table's rules that use a parameter, in
// its order; and a nominal value that breaks one of them is a scene error naming its field.
TEST(EmittedText, ParameterChecksAreTheScenesRangeRules) {
  const std::string scene_text = R"(name: rules
parameters: {m: 1.0, p: 50, Im: 1e-5, k: 200, c: 1.0, fc: 0.1, vs: 0.01}
base: {type: free_floating, mass: 10, inertia: m, mount: [0.1, 0]}
links:
  - {mass: m, inertia: 0.1, length: 0.5, com: [0.25, 0]}
  - {mass: 1, inertia: 0.1, length: 0.5, com: [0.25, 0]}
gears:
  - {ratio: p, motor_inertia: Im, stiffness: k}
  - {ratio: 10, motor_inertia: Im, rotor_coupling: c}
friction: {viscous: 0.01, coulomb: fc, velocity_scale: vs}
outputs: [mass_matrix, bias_forces, forward_dynamics]
)";
  const Scene scene = parse_scene(scene_text, "rules.yaml");
  std::vector<std::string> run_time;
  for (const RangeRule& rule : range_rules(scene))
    if (rule.at_run_time && rule.uses_parameter()) run_time.push_back(rule.message);
  const LoweredModel lowered = lower(derive(scene));
  std::vector<std::string> printed;
  for (const ParameterCheck& c : lowered.facts.checks) printed.push_back(c.message);
  EXPECT_EQ(printed, run_time);
  EXPECT_GE(printed.size(), 10u);  // mass, inertias, ratio, Im (twice), k, c (twice), fc, vs
  // A nominal value against a rule: the scene's error, naming the field as the file spells it.
  for (const auto& [from, to, field] :
       {std::tuple{"p: 50", "p: -5", "gears[0].ratio"},
        std::tuple{"c: 1.0", "c: 1.5", "gears[1].rotor_coupling"},
        std::tuple{"vs: 0.01", "vs: 1e-12", "friction.velocity_scale"}}) {
    std::string text = scene_text;
    text.replace(text.find(from), std::string(from).size(), to);
    try {
      parse_scene(text, "rules.yaml");
      ADD_FAILURE() << "accepted " << to;
    } catch (const SceneError& e) {
      EXPECT_NE(std::string(e.what()).find(std::string("field '") + field + "'"), std::string::npos)
          << e.what();
    }
  }
}

TEST(EmittedText, CommentLinesSplitEveryLineBreakAndEscapeWhatCouldEscape) {
  const std::string text =
      std::string("a\nsystem(\"x\");\r\nb\rc\\\nd\\") + '\0' + "\x1b[2J \xe2\x80\xae end";
  const std::string c = comment_lines(text, "  ");
  const auto lines = lines_of(c);
  ASSERT_EQ(lines.size(), 5u) << c;
  for (const auto& l : lines) {
    EXPECT_EQ(l.rfind("  //", 0), 0u) << l;
    EXPECT_NE(l.back(), '\\') << "a trailing backslash splices the next line: " << l;
    for (unsigned char ch : l)
      EXPECT_TRUE(ch >= 0x20 && ch < 0x7f) << "byte " << int(ch) << " in " << l;
  }
  EXPECT_EQ(lines[1], "  // system(\"x\");");
  EXPECT_EQ(lines[3], "  // c\\x5C");
  EXPECT_EQ(lines[4],
            "  // d\\x5C\\x00\\x1B[2J \\xE2\\x80\\xAE end");  // NUL, escape, bidi override
  EXPECT_EQ(comment_lines(""), "//\n");
  // "??/" is a trigraph for a backslash in older modes, and -Wall warns about it in C++17.
  EXPECT_EQ(comment_lines("a ?"
                          "?/"),
            "// a ?\\x3F/\n");
}

TEST(EmittedText, FileStemsAreCheckedNamingTheOption) {
  for (const char* ok : {"paper_geared", "model-2", "a.b", "_x"})
    EXPECT_NO_THROW(check_file_stem(ok, "--file-stem"));
  for (const std::string& bad : std::vector<std::string>{"", "../x", "a/b", "x\"", "a\nb", "-rf",
                                                         ".hidden", "a b", std::string(101, 'a')})
    EXPECT_THROW_MESSAGE(check_file_stem(bad, "--file-stem"), std::invalid_argument, "--file-stem");
}

TEST(EmittedText, NumbersArePrintedFromTheirValues) {
  EXPECT_EQ(round_trip(10), "10.0");
  EXPECT_EQ(round_trip(0.1), "0.1");
  EXPECT_EQ(round_trip(-2.5e-7), "-2.5e-07");
  EXPECT_EQ(std::strtod(round_trip(1.0 / 3).c_str(), nullptr), 1.0 / 3);
  EXPECT_THROW(round_trip(std::numeric_limits<double>::infinity()), std::invalid_argument);
}

TEST(EmittedText, MacrosOfTheGeneratedHeadersAndKeywordsAreReserved) {
  for (const char* name : {"EOF", "errno", "M_PI", "INFINITY", "NULL", "NAN", "EIGEN_WORLD_VERSION",
                           "assert", "class", "and", "a__b", "_x"})
    EXPECT_TRUE(is_cpp_reserved(name)) << name;
  for (const char* name : {"paper_geared", "robot", "p", "Im", "mass2"})
    EXPECT_FALSE(is_cpp_reserved(name)) << name;
}

TEST(EmittedText, SceneNumbersMeanWhatTheReaderRead) {
  // 010 is ten to YAML and to us; C++ would read it as octal eight, so it must not be copied.
  const std::string yaml = R"(
name: leading_zeros
base: {type: free_floating, mass: 010, inertia: 1, mount: [0.1, 0]}
links: [{mass: m1, inertia: 0.1, length: 0.5, com: [0.25, 0]}]
parameters: {m1: 08}
)";
  const Scene s = parse_scene(yaml, "t.yaml");
  EXPECT_EQ(s.base.mass.value, 10);
  const SymbolicModel m = derive(s);
  const auto e = emit_cpp(m, {});
  EXPECT_NE(e.header.find("kNominalParameters = {8.0}"), std::string::npos);
  EXPECT_EQ(e.header.find("010"), std::string::npos);
  EXPECT_EQ(e.header.find("08"), std::string::npos);
  EXPECT_EQ(evaluate(m, m.expression(Output::mass_matrix)(0, 0), {0, 0, 0, 0}, {0, 0, 0, 0}, {8}),
            18);
}

// Every line of an emitted file that holds `marker` is a `//` comment line.
void expect_marker_only_in_comments(const std::string& text, const std::string& marker,
                                    const std::string& file) {
  for (const auto& line : lines_of(text)) {
    if (line.find(marker) == std::string::npos) continue;
    const auto first = line.find_first_not_of(' ');
    EXPECT_EQ(line.compare(first, 2, "//"), 0) << file << ": user text outside a comment: " << line;
  }
  for (const auto& line : lines_of(text))
    if (!line.empty()) {
      EXPECT_NE(line.back(), '\\') << file << ": line continues: " << line;
    }
}

// Runs a shell command; its output, and whether it succeeded.
std::pair<bool, std::string> run(const std::string& command) {
  std::string out;
  FILE* p = popen((command + " 2>&1").c_str(), "r");
  if (!p) return {false, "popen failed"};
  char buf[4096];
  for (size_t n; (n = fread(buf, 1, sizeof buf, p)) > 0;) out.append(buf, n);
  return {pclose(p) == 0, out};
}

// The model's source (with Eigen) and the C interface the compile-and-load path builds
// (alone, without Eigen) both compile without a warning.
void expect_compiles(const EmittedModel& e, const std::string& label) {
  const fs::path dir =
      fs::temp_directory_path() / ("spacearm-emitted-text-" + std::to_string(getpid()));
  fs::remove_all(dir);
  write_files(e, dir.string());
  std::ofstream(dir / "libmodel.cpp") << e.c_interface;
  for (const std::string& source : {e.source_name, std::string("libmodel.cpp")}) {
    const auto [ok, out] = run(
        std::string(SPACEARM_CXX) + " -std=c++17 -Wall -Wextra -Werror -fsyntax-only -I" +
        SPACEARM_EIGEN_INCLUDE_DIR + " -I'" + dir.string() + "' '" + (dir / source).string() + "'");
    EXPECT_TRUE(ok) << label << ": " << source << " does not compile:\n" << out;
  }
  fs::remove_all(dir);
}

// Hostile text in every field that is free text: the description, the scene path and the
// regeneration command (which holds the output folder).
const std::string kMarker = "INJECTED_MARKER";
const std::string kHostile =
    "x ?"
    "?/ */\n#define " +
    kMarker + " 1\r\nint " + kMarker + "_a = system(\"id\");\\\n\\" + "\r" + kMarker +
    "\xe2\x80\xae\x01 \\";

std::string yaml_quoted(const std::string& s) {
  std::string q = "\"";
  for (unsigned char c : s) {
    if (c == '"' || c == '\\') {
      q += '\\';
      q += static_cast<char>(c);
    } else if (c < 0x20) {
      char b[8];
      std::snprintf(b, sizeof b, "\\x%02x", c);
      q += b;
    } else {
      q += static_cast<char>(c);
    }
  }
  return q + "\"";
}

TEST(EmittedText, EveryAcceptedSceneEmitsCodeThatCompilesWithUserTextOnlyInComments) {
  std::vector<std::pair<std::string, std::string>> scenes;  // (label, text)
  for (const char* folder : {"models", "tests/scenes", "fuzz/seeds", "fuzz/regressions"})
    for (const auto& f : fs::directory_iterator(std::string(SPACEARM_SOURCE_DIR) + "/" + folder)) {
      std::ifstream in(f.path(), std::ios::binary);
      std::ostringstream s;
      s << in.rdbuf();
      scenes.push_back({f.path().string(), s.str()});
    }
  for (const char* base : {"free_floating", "fixed"}) {
    std::string yaml = std::string("name: hostile\ndescription: ") + yaml_quoted(kHostile) +
                       "\nbase: {type: " + base +
                       ", mass: 010, inertia: 1, mount: [0.1, 0]}\nlinks:\n" +
                       "  - {mass: m1, inertia: 0.1, length: 0.5, com: [0.25, 0]}\n" +
                       "  - {mass: 1, inertia: 0.1, length: 0.5, com: [0.25, -0.0]}\n" +
                       "gears: {ratio: p, motor_inertia: 0.01}\nparameters: {m1: 08, p: 1e1}\n";
    scenes.push_back({std::string("hostile ") + base, yaml});
  }
  int accepted = 0;
  for (const auto& [label, text] : scenes) {
    Scene scene;
    try {
      scene = parse_scene(text, kHostile);
    } catch (const SceneError&) {
      continue;
    }
    if (scene.num_links() > 6) continue;  // derivation cost only; nothing else differs
    ++accepted;
    EmitOptions options;
    options.scene_path = kHostile;
    options.command = "spacearm generate " + kHostile + " -o " + kHostile;
    for (bool plain : {false, true}) {
      options.plain = plain;
      const EmittedModel e = emit_cpp(derive(scene), options);
      expect_marker_only_in_comments(e.header, kMarker, label + " header");
      expect_marker_only_in_comments(e.source, kMarker, label + " source");
      expect_marker_only_in_comments(e.c_interface, kMarker, label + " C interface");
      expect_compiles(e, label + (plain ? " (plain)" : ""));
      if (label.rfind("hostile", 0) != 0) break;  // the baseline printer: hostile scenes only
    }
  }
  EXPECT_GE(accepted, 10) << "the corpus should hold at least 10 accepted scenes";
  EXPECT_THROW_MESSAGE(
      emit_cpp(derive(parse_scene(scenes.back().second, "t.yaml")), {"", "", "../../evil", false}),
      std::invalid_argument, "file stem");
}

// The lowered model of a scene in the repository (path from its root, "/models/...").
LoweredModel lowered_scene(const std::string& path) {
  return lower(derive(load_scene(std::string(SPACEARM_SOURCE_DIR) + path)));
}

// Every function of a C interface, compiled (with `extra` flags and libraries after the source)
// and loaded, called at one state (inputs 0.3, 0.4, ..., the nominal parameters): each
// result's entries, by function.
// A C interface in several units is linked from all of them.
std::map<std::string, std::vector<double>> call_every_function(
    const LoweredModel& model, const std::vector<std::string>& units, const fs::path& dir,
    const std::string& extra = "") {
  fs::create_directories(dir);
  std::string sources;
  for (size_t u = 0; u < units.size(); ++u) {
    const fs::path source = dir / ("libmodel_" + std::to_string(u) + ".cpp");
    std::ofstream(source) << units[u];
    sources += " '" + source.string() + "'";
  }
  const auto [ok, log] = run(std::string(SPACEARM_CXX) + " -O1 -std=c++17 -fPIC -shared" + sources +
                             " -o '" + (dir / "libmodel.so").string() + "'" + extra);
  EXPECT_TRUE(ok) << log;
  void* lib = dlopen((dir / "libmodel.so").c_str(), RTLD_NOW | RTLD_LOCAL);
  EXPECT_NE(lib, nullptr) << dlerror();
  std::map<std::string, std::vector<double>> values;
  if (!lib) return values;
  using Function = void (*)(const double* const*, const double*, double* const*);
  const Dimensions& dims = model.facts.dims;
  const std::vector<double> params = model.facts.nominal_parameters;
  for (const FunctionSpec& f : model.functions) {
    auto fn = reinterpret_cast<Function>(dlsym(lib, ("spacearm_" + f.name).c_str()));
    EXPECT_NE(fn, nullptr) << f.name;
    if (!fn) continue;
    std::vector<std::vector<double>> in, out;
    std::vector<const double*> in_ptr;
    std::vector<double*> out_ptr;
    for (const ArraySpec& a : f.inputs) {
      in.emplace_back(dims(a.rows) * dims(a.cols));
      for (size_t i = 0; i < in.back().size(); ++i) in.back()[i] = 0.3 + 0.1 * i;
    }
    for (const ArraySpec& r : f.results) out.emplace_back(dims(r.rows) * dims(r.cols), -1.0);
    for (const auto& v : in) in_ptr.push_back(v.data());
    for (auto& v : out) out_ptr.push_back(v.data());
    fn(in_ptr.data(), params.data(), out_ptr.data());
    for (const auto& v : out) values[f.name].insert(values[f.name].end(), v.begin(), v.end());
    // Its 4-lane version, where it has one, with the state in every lane: each lane's results
    // are the scalar function's, bit for bit.
    auto lanes = reinterpret_cast<Function>(dlsym(lib, ("spacearm_" + f.name + "_x4").c_str()));
    EXPECT_EQ(lanes != nullptr, f.lanes) << f.name;
    if (!lanes) continue;
    std::vector<std::vector<double>> in4, out4;
    std::vector<double> params4;
    for (double p : params) params4.insert(params4.end(), 4, p);
    for (const auto& v : in) {
      in4.emplace_back();
      for (double x : v) in4.back().insert(in4.back().end(), 4, x);
    }
    for (const auto& v : out) out4.emplace_back(4 * v.size(), -1.0);
    in_ptr.clear(), out_ptr.clear();
    for (const auto& v : in4) in_ptr.push_back(v.data());
    for (auto& v : out4) out_ptr.push_back(v.data());
    lanes(in_ptr.data(), params4.data(), out_ptr.data());
    for (size_t r = 0; r < out.size(); ++r)
      for (size_t i = 0; i < out4[r].size(); ++i)
        EXPECT_EQ(std::memcmp(&out4[r][i], &out[r][i / 4], sizeof(double)), 0)
            << f.name << "_x4 result " << r << " entry " << i / 4 << " lane " << i % 4 << ": "
            << out4[r][i] << " vs " << out[r][i / 4];
  }
  dlclose(lib);
  return values;
}

std::map<std::string, std::vector<double>> call_every_function(const LoweredModel& model,
                                                               const std::string& c_interface,
                                                               const fs::path& dir,
                                                               const std::string& extra = "") {
  return call_every_function(model, std::vector<std::string>{c_interface}, dir, extra);
}

// PrintOptions::casadi: every function in CasADi's external form, loaded and called as
// casadi::external does (sizes from _n_in/_n_out and _work, shapes from the sparsity patterns),
// computes what the C function computes; a null input is zeros, a null result is skipped, null
// parameters are the nominal ones, and the work array of _work's size is enough.
// Cost: one compile of the paper's geared model's C interface at -O1, about 2 s.
TEST(EmittedText, CasadisExternalFormIsTheCInterface) {
  const fs::path dir = fs::temp_directory_path() / ("spacearm-casadi-" + std::to_string(getpid()));
  const LoweredModel model = lowered_scene("/models/paper_geared.yaml");
  PrintOptions options;
  options.casadi = true;
  options.file_stem = "arm";
  const EmittedModel e = print_cpp(model, options);
  EXPECT_EQ(e.c_file_name, "arm_c.cpp");
  fs::create_directories(dir);
  std::ofstream(dir / "arm_c.cpp") << e.c_interface;
  const auto [ok, log] =
      run(std::string(SPACEARM_CXX) + " -O1 -std=c++17 -Wall -Wextra -Werror -fPIC -shared '" +
          (dir / "arm_c.cpp").string() + "' -o '" + (dir / "arm.so").string() + "'");
  ASSERT_TRUE(ok) << log;
  void* lib = dlopen((dir / "arm.so").c_str(), RTLD_NOW | RTLD_LOCAL);
  ASSERT_NE(lib, nullptr) << dlerror();
  using Int = long long;
  using Direct = void (*)(const double* const*, const double*, double* const*);
  using External = int (*)(const double**, double**, Int*, double*, int);
  const Dimensions& dims = model.facts.dims;
  const std::vector<double> nominal = model.facts.nominal_parameters;
  ASSERT_EQ(nominal.size(), 2u);  // p and Im
  for (const FunctionSpec& f : model.functions) {
    const std::string name = "spacearm_casadi_" + f.name;
    auto sym = [&](const std::string& suffix) { return dlsym(lib, (name + suffix).c_str()); };
    const auto n_in = reinterpret_cast<Int (*)()>(sym("_n_in"));
    const auto n_out = reinterpret_cast<Int (*)()>(sym("_n_out"));
    const auto name_in = reinterpret_cast<const char* (*)(Int)>(sym("_name_in"));
    const auto sparsity_in = reinterpret_cast<const Int* (*)(Int)>(sym("_sparsity_in"));
    const auto sparsity_out = reinterpret_cast<const Int* (*)(Int)>(sym("_sparsity_out"));
    const auto work = reinterpret_cast<int (*)(Int*, Int*, Int*, Int*)>(sym("_work"));
    const auto external = reinterpret_cast<External>(sym(""));
    const auto direct = reinterpret_cast<Direct>(dlsym(lib, ("spacearm_" + f.name).c_str()));
    ASSERT_TRUE(n_in && n_out && name_in && sparsity_in && sparsity_out && work && external &&
                direct)
        << f.name;
    const size_t inputs = f.inputs.size(), results = f.results.size();
    ASSERT_EQ(n_in(), Int(inputs + 1)) << f.name;
    ASSERT_EQ(n_out(), Int(results)) << f.name;
    EXPECT_STREQ(name_in(Int(inputs)), "params");
    EXPECT_EQ(name_in(Int(inputs + 1)), nullptr);
    EXPECT_EQ(sparsity_in(-1), nullptr);
    // Each array's shape from its pattern: rows, cols, dense column offsets.
    auto shape = [](const Int* s) {
      for (Int j = 0; j <= s[1]; ++j) EXPECT_EQ(s[2 + j], j * s[0]);
      return std::make_pair(s[0], s[1]);
    };
    for (size_t i = 0; i < inputs; ++i) {
      EXPECT_STREQ(name_in(Int(i)), f.inputs[i].name.c_str());
      EXPECT_EQ(shape(sparsity_in(Int(i))),
                std::make_pair(Int(dims(f.inputs[i].rows)), Int(dims(f.inputs[i].cols))));
    }
    EXPECT_EQ(shape(sparsity_in(Int(inputs))), std::make_pair(Int(2), Int(1)));
    Int sz_arg = 0, sz_res = 0, sz_iw = -1, sz_w = -1;
    ASSERT_EQ(work(&sz_arg, &sz_res, &sz_iw, &sz_w), 0);
    EXPECT_EQ(sz_arg, n_in());
    EXPECT_EQ(sz_res, n_out());
    EXPECT_EQ(sz_iw, 0);
    // Inputs 0.3, 0.4, ...; parameters off their nominal values.
    std::vector<std::vector<double>> in, want, got;
    for (const ArraySpec& a : f.inputs) {
      in.emplace_back(dims(a.rows) * dims(a.cols));
      for (size_t i = 0; i < in.back().size(); ++i) in.back()[i] = 0.3 + 0.1 * i;
    }
    const std::vector<double> params = {nominal[0] * 1.5, nominal[1] * 2};
    for (size_t k = 0; k < results; ++k) {
      const auto [rows, cols] = shape(sparsity_out(Int(k)));
      EXPECT_EQ(rows * cols, Int(dims(f.results[k].rows) * dims(f.results[k].cols)));
      want.emplace_back(rows * cols, -1.0);
      got.emplace_back(rows * cols, -2.0);
    }
    auto call_direct = [&](const std::vector<std::vector<double>>& x, const double* p) {
      std::vector<const double*> x_ptr;
      std::vector<double*> out_ptr;
      for (const auto& v : x) x_ptr.push_back(v.data());
      for (auto& v : want) out_ptr.push_back(v.data());
      direct(x_ptr.data(), p, out_ptr.data());
    };
    // The work array of _work's size, guarded at its end.
    std::vector<double> w(sz_w + 4, 7.0);
    auto call_external = [&](std::vector<const double*> arg, std::vector<double*> res) {
      ASSERT_EQ(external(arg.data(), res.data(), nullptr, w.data(), 0), 0);
      for (Int i = sz_w; i < sz_w + 4; ++i) EXPECT_EQ(w[i], 7.0) << f.name << ": w overrun";
    };
    std::vector<const double*> arg;
    std::vector<double*> res;
    for (const auto& v : in) arg.push_back(v.data());
    arg.push_back(params.data());
    for (auto& v : got) res.push_back(v.data());
    call_direct(in, params.data());
    call_external(arg, res);
    EXPECT_EQ(got, want) << f.name;
    // Null parameters: the nominal ones.
    arg.back() = nullptr;
    call_direct(in, nominal.data());
    call_external(arg, res);
    EXPECT_EQ(got, want) << f.name << ", nominal parameters";
    // A null first input is zeros; a null first result is skipped, the others written.
    if (inputs == 0) continue;
    std::vector<std::vector<double>> zero_first = in;
    std::fill(zero_first[0].begin(), zero_first[0].end(), 0.0);
    call_direct(zero_first, nominal.data());
    for (auto& v : got) std::fill(v.begin(), v.end(), -2.0);
    arg[0] = nullptr;
    res[0] = nullptr;
    call_external(arg, res);
    EXPECT_TRUE(std::all_of(got[0].begin(), got[0].end(), [](double x) { return x == -2.0; }));
    for (size_t k = 1; k < results; ++k) EXPECT_EQ(got[k], want[k]) << f.name << " result " << k;
  }
  dlclose(lib);
  fs::remove_all(dir);
  // A model without run-time parameters takes none.
  const EmittedModel plain = print_cpp(lowered_scene("/models/paper_reference.yaml"), options);
  EXPECT_NE(plain.c_interface.find("spacearm_casadi_int spacearm_casadi_mass_matrix_n_in() { "
                                   "return 1; }"),
            std::string::npos);
}

// A body split into parts (PrintOptions::statements_per_part, here 40 statements instead of
// 200) computes exactly what the whole body computes: every function of the paper's geared
// model and of a flexible model with friction, compiled both ways, agrees bit for bit.
// Cost: four compiles of the C interface at -O1, about 3 s.
// Issue 28, item 7: valid scenes whose numbers span too many decades for double (gear ratio
// 1e30; links of 1e12 kg on a 1e-12 kg base) are refused naming the fields, not with a bare
// "generator self-check failed".
TEST(EmittedText, ScenesDoublesCannotHoldNameTheFields) {
  const std::string scene =
      test::read_text_file(std::string(SPACEARM_SOURCE_DIR) + "/models/paper_geared.yaml");
  auto error_of = [](const std::string& text) {
    try {
      lower(derive(parse_scene(text, "t.yaml")));
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  std::string ratio = scene;
  ratio.replace(ratio.find("p: 1.0 "), 7, "p: 1e30 ");
  const std::string a = error_of(ratio);
  EXPECT_NE(a.find("double precision cannot hold this model"), std::string::npos) << a;
  EXPECT_NE(a.find("].ratio (p) = 1e+30"), std::string::npos) << a;
  std::string masses = scene;
  masses.replace(masses.find("mass: 64.859"), 12, "mass: 1e-12");
  for (const char* m : {"mass: 2.913", "mass: 2.646", "mass: 1.699"})
    masses.replace(masses.find(m), 11, "mass: 1e12");
  const std::string b = error_of(masses);
  EXPECT_NE(b.find("base.mass = 1e-12"), std::string::npos) << b;
  EXPECT_EQ(b.find("generator self-check failed"), std::string::npos) << b;
}

// Found by an attacker's review: `generate -o DIR` wrote DIR/.NAME.hpp.tmp following a link
// planted there (a shared folder), overwriting the link's target. Temporaries now have random
// names and are created with O_EXCL | O_NOFOLLOW.
TEST(EmittedText, GeneratedFilesNeverWriteThroughALinkPlantedInTheFolder) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("spacearm-planted-" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path victim = dir / "victim.txt";
  std::ofstream(victim) << "precious\n";
  const EmittedModel e = emit_cpp(
      derive(load_scene(std::string(SPACEARM_SOURCE_DIR) + "/tests/scenes/fixed_n1.yaml")), {});
  for (const std::string& name : {e.header_name, e.source_name})
    fs::create_symlink(victim, dir / ("." + name + ".tmp"));
  write_files(e, dir.string());
  EXPECT_EQ(test::read_text_file(victim.string()), "precious\n");
  EXPECT_EQ(test::read_text_file((dir / e.header_name).string()), e.header);
  EXPECT_EQ(test::read_text_file((dir / e.source_name).string()), e.source);
  fs::remove_all(dir);
}

// The C interface in units (one compiler each, at once) computes what one unit computes, bit
// for bit; each unit compiles alone without a warning, and the model's facts are in the first.
// The parts of a split function (scalar or 4-lane) are spread over the units too (one function's
// compile shared by the compilers): some part is in another unit than its function.
TEST(EmittedText, UnitsComputeWhatOneUnitComputes) {
  const fs::path dir = fs::temp_directory_path() / ("spacearm-units-" + std::to_string(getpid()));
  const LoweredModel model = lowered_scene("/models/paper_flexible.yaml");
  PrintOptions three;
  three.c_units = 3;
  three.statements_per_part = 40;
  const EmittedModel one = print_cpp(model, {}), units = print_cpp(model, three);
  const auto unit_defining = [&units](const std::string& function) {
    for (size_t u = 0; u < units.c_units.size(); ++u)
      if (units.c_units[u].find("void spacearm_" + function +
                                "([[maybe_unused]] const double* "
                                "const* in") != std::string::npos)
        return static_cast<int>(u);
    return -1;
  };
  int parts = 0, parts_elsewhere = 0, lanes_parts_elsewhere = 0;
  for (const auto& f : model.functions)
    for (const std::string name : {f.name, f.name + kLanesSuffix}) {
      const int home = unit_defining(name);
      for (int k = 0; unit_defining(name + "_part" + std::to_string(k)) >= 0; ++k, ++parts) {
        const bool elsewhere = unit_defining(name + "_part" + std::to_string(k)) != home;
        parts_elsewhere += elsewhere;
        lanes_parts_elsewhere += elsewhere && name != f.name;
      }
    }
  EXPECT_GT(parts, 20);
  EXPECT_GT(parts_elsewhere, 0);
  EXPECT_GT(lanes_parts_elsewhere, 0);
  ASSERT_EQ(one.c_units.size(), 1u);
  ASSERT_EQ(one.c_units[0], one.c_interface);
  ASSERT_EQ(units.c_units.size(), 3u);
  EXPECT_TRUE(units.c_interface.empty());
  for (size_t u = 0; u < 3; ++u) {
    EXPECT_EQ(units.c_units[u].find("spacearm_abi_version") != std::string::npos, u == 0) << u;
    EXPECT_NE(units.c_units[u].find("void spacearm_"), std::string::npos) << u;
    fs::create_directories(dir);
    std::ofstream(dir / "unit.cpp") << units.c_units[u];
    const auto [ok, out] =
        run(std::string(SPACEARM_CXX) + " -std=c++17 -Wall -Wextra -Werror -fsyntax-only '" +
            (dir / "unit.cpp").string() + "'");
    EXPECT_TRUE(ok) << "unit " << u << " does not compile:\n" << out;
  }
  const auto want = call_every_function(model, one.c_interface, dir / "one");
  const auto got = call_every_function(model, units.c_units, dir / "three");
  ASSERT_EQ(got.size(), model.functions.size());
  for (const auto& [name, values] : want) {
    ASSERT_EQ(got.at(name).size(), values.size()) << name;
    for (size_t i = 0; i < values.size(); ++i)
      EXPECT_EQ(got.at(name)[i], values[i]) << name << " entry " << i;
  }
  fs::remove_all(dir);
}

// Leading units (PrintOptions::leading_units: what a command calls first, compiled first): unit 0
// holds the model's facts and exactly the named functions the model has, the others are spread
// over c_units more, each function once, and the units compute what one unit computes.
TEST(EmittedText, LeadingUnitsHoldTheNamedFunctionsFirst) {
  const fs::path dir = fs::temp_directory_path() / ("spacearm-leading-" + std::to_string(getpid()));
  const LoweredModel model = lowered_scene("/models/paper_flexible.yaml");
  PrintOptions first;
  first.c_units = 2;
  first.statements_per_part = 40;  // a leading function's parts stay in its unit
  first.leading_units = {{"forward_dynamics", "no_such_function", "momentum_x4"}};
  const EmittedModel one = print_cpp(model, {}), units = print_cpp(model, first);
  ASSERT_EQ(units.c_units.size(), 3u);
  ASSERT_EQ(units.c_unit_functions.size(), 3u);
  EXPECT_EQ(
      std::set<std::string>(units.c_unit_functions[0].begin(), units.c_unit_functions[0].end()),
      (std::set<std::string>{"forward_dynamics", "momentum_x4"}));
  std::multiset<std::string> all, want;
  for (const auto& names : units.c_unit_functions) all.insert(names.begin(), names.end());
  for (const auto& names : one.c_unit_functions) want.insert(names.begin(), names.end());
  EXPECT_EQ(all, want);
  EXPECT_GT(want.size(), 10u);
  for (size_t u = 0; u < 3; ++u) {
    EXPECT_EQ(units.c_units[u].find("spacearm_abi_version") != std::string::npos, u == 0) << u;
    for (const auto& name : units.c_unit_functions[u])
      EXPECT_NE(units.c_units[u].find("void spacearm_" + name + "("), std::string::npos) << name;
  }
  EXPECT_EQ(units.c_units[1].find("void spacearm_forward_dynamics("), std::string::npos);
  ASSERT_NE(units.c_units[0].find("void spacearm_forward_dynamics_part2("), std::string::npos);
  for (size_t u = 1; u < 3; ++u)
    EXPECT_EQ(units.c_units[u].find("void spacearm_forward_dynamics_part"), std::string::npos) << u;
  const auto values = call_every_function(model, one.c_interface, dir / "one");
  const auto got = call_every_function(model, units.c_units, dir / "leading");
  ASSERT_EQ(got.size(), values.size());
  for (const auto& [name, v] : values) EXPECT_EQ(got.at(name), v) << name;
  fs::remove_all(dir);
}

TEST(EmittedText, SplitBodiesComputeWhatWholeBodiesCompute) {
  const fs::path dir =
      fs::temp_directory_path() / ("spacearm-split-bodies-" + std::to_string(getpid()));
  for (const char* scene : {"/models/paper_geared.yaml", "/models/paper_flexible.yaml"}) {
    SCOPED_TRACE(scene);
    const LoweredModel model = lowered_scene(scene);
    PrintOptions one_part, split;
    one_part.statements_per_part = 0;
    split.statements_per_part = 40;
    const EmittedModel whole = print_cpp(model, one_part), parts = print_cpp(model, split);
    ASSERT_EQ(whole.c_interface.find("_part"), std::string::npos);
    ASSERT_NE(parts.c_interface.find("_part3("), std::string::npos);     // split, several times
    ASSERT_NE(parts.c_interface.find("_x4_part3("), std::string::npos);  // 4-lane versions too
    ASSERT_NE(parts.c_interface.find("  w[0] = "), std::string::npos);   // values passed on
    ASSERT_NE(parts.source.find("_part3("), std::string::npos);          // the Eigen spelling too
    const auto want = call_every_function(model, whole.c_interface, dir / "whole");
    const auto got = call_every_function(model, parts.c_interface, dir / "parts");
    ASSERT_EQ(got.size(), model.functions.size());
    for (const auto& [name, values] : want) {
      ASSERT_EQ(got.at(name).size(), values.size()) << name;
      for (size_t i = 0; i < values.size(); ++i)
        EXPECT_EQ(got.at(name)[i], values[i]) << name << " entry " << i;
    }
    expect_compiles(parts, std::string(scene) + " (split)");
  }
  fs::remove_all(dir);
}

// The sin and cos of a function are printed as one sincos_batch call per level (angles that
// depend on no sin/cos, then those that depend on the first level's, ...). A hand-made function
// nests three levels, read across parts: its values equal std::sin/std::cos evaluated here.
// Cost: two compiles of a small C interface, about 1 s.
TEST(EmittedText, NestedSinCosBatchesComputeWhatTheyRead) {
  LoweredModel model = lowered_scene("/models/paper_reference.yaml");
  FunctionSpec f;
  f.name = "nested_trig";
  f.doc = "nested sin and cos";
  f.inputs = {{"q", Size::nq, Size::one}};
  f.results = {{"r", Size::nq, Size::one}};
  Program& p = f.program;
  const SRef q0 = p.input("q", 0), q1 = p.input("q", 1), q2 = p.input("q", 2);
  // Two angles at each level: q0, q1, q2; a, a2 (sin/cos of level 0); b, b2 (of level 1).
  const SRef a = p.add({p.sin(q0), q1}), a2 = p.mul({p.cos(q1), q2});
  const SRef b = p.mul({p.cos(a), p.cos(q2)}), b2 = p.add({p.sin(a2), q0});
  f.entries = {{a, b, p.add({p.sin(b), p.mul({p.sin(a), q2})}), p.cos(b2), p.cos(a2),
                p.mul({p.cos(q0), p.sin(q2)})}};
  model.functions = {f};
  const double x0 = 0.3, x1 = 0.4, x2 = 0.5;  // call_every_function's inputs
  const double ea = std::sin(x0) + x1, ea2 = std::cos(x1) * x2;
  const double eb = std::cos(ea) * std::cos(x2), eb2 = std::sin(ea2) + x0;
  const std::vector<double> want = {ea,
                                    eb,
                                    std::sin(eb) + std::sin(ea) * x2,
                                    std::cos(eb2),
                                    std::cos(ea2),
                                    std::cos(x0) * std::sin(x2)};
  PrintOptions split;
  split.statements_per_part = 3;
  const fs::path dir = fs::temp_directory_path() / ("spacearm-trig-" + std::to_string(getpid()));
  for (const PrintOptions& options : {PrintOptions{}, split}) {
    const EmittedModel e = print_cpp(model, options);
    ASSERT_NE(e.c_interface.find("sincos_batch(angles2, sines2, cosines2)"), std::string::npos)
        << e.c_interface;
    if (options.statements_per_part == 3) {
      ASSERT_NE(e.c_interface.find("_part2("), std::string::npos);
    }
    const auto got = call_every_function(model, e.c_interface, dir);
    ASSERT_EQ(got.at("nested_trig").size(), want.size());
    for (size_t i = 0; i < want.size(); ++i)
      EXPECT_NEAR(got.at("nested_trig")[i], want[i], 1e-15) << "entry " << i;
    expect_compiles(e, "nested trig");
  }
  fs::remove_all(dir);
}

// With SPACEARM_VECTOR_TRIG and libmvec (the default build rules on x86-64 glibc), the batches
// go through glibc's vector sin/cos: every function of the paper's geared and flexible models
// agrees with the libm build to 1e-13 of its largest entry, the library does call libmvec, and
// on a CPU with AVX2 and FMA some entry differs (the vector path ran, not the fallback).
// Cost: four compiles of the C interface at -O1, about 3 s.
TEST(EmittedText, VectorSinCosAgreesWithLibm) {
#if !(defined(__x86_64__) && defined(__GLIBC__))
  GTEST_SKIP() << "libmvec's AVX2 variants exist on x86-64 glibc only";
#else
  const fs::path dir = fs::temp_directory_path() / ("spacearm-vtrig-" + std::to_string(getpid()));
  for (const char* scene : {"/models/paper_geared.yaml", "/models/paper_flexible.yaml"}) {
    SCOPED_TRACE(scene);
    const LoweredModel model = lowered_scene(scene);
    const EmittedModel e = print_cpp(model, {});
    const auto libm = call_every_function(model, e.c_interface, dir / "libm");
    const auto vector =
        call_every_function(model, e.c_interface, dir / "vector", " -DSPACEARM_VECTOR_TRIG -lmvec");
    std::ifstream so(dir / "vector" / "libmodel.so", std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(so)), std::istreambuf_iterator<char>());
    EXPECT_NE(bytes.find("_ZGVdN4v_sin"), std::string::npos) << "libmvec not called";
    int differ = 0;
    for (const auto& [name, values] : libm) {
      double scale = 0;
      for (double v : values) scale = std::max(scale, std::abs(v));
      ASSERT_EQ(vector.at(name).size(), values.size()) << name;
      for (size_t i = 0; i < values.size(); ++i) {
        EXPECT_NEAR(vector.at(name)[i], values[i], 1e-13 * scale) << name << " entry " << i;
        differ += vector.at(name)[i] != values[i];
      }
    }
    if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma")) {
      EXPECT_GT(differ, 0);
    }
  }
  fs::remove_all(dir);
#endif
}

}  // namespace
}  // namespace spacearm
