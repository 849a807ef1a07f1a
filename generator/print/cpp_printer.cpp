#include "cpp_printer.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <type_traits>
#include <sstream>
#include <stdexcept>

#include "body_printer.hpp"
#include "emitted_text.hpp"
#include "private_folder.hpp"

namespace spacearm {

std::vector<SRef> FunctionSpec::roots() const {
  std::vector<SRef> all;
  std::set<SRef> seen;
  for (const auto& result : entries)
    for (const SRef& r : result)
      if (seen.insert(r).second) all.push_back(r);
  return all;
}

namespace {

bool returns_scalar(const FunctionSpec& f) {
  return f.results.size() == 1 && f.results[0].rows == Size::one && f.results[0].cols == Size::one;
}

std::string matrix_type(const ArraySpec& a, const Dimensions& dims, const std::string& scalar) {
  // The header's aliases where one names the shape, for readable signatures.
  if (a.cols == Size::one && a.rows == Size::nq) return "Coordinates<" + scalar + ">";
  if (a.cols == Size::one && a.rows == Size::nv) return "Velocities<" + scalar + ">";
  if (a.cols == Size::one && a.rows == Size::num_links) return "JointVector<" + scalar + ">";
  return "Eigen::Matrix<" + scalar + ", " + size_constant(a.rows, dims) + ", " +
         size_constant(a.cols, dims) + ">";
}

// with_names: a declaration or definition (definition: inputs may be unused, e.g. a
// constant mass matrix); otherwise the form of an explicit instantiation.
// part: the name suffix of one part of a split body (BodyPrinter), which also takes the work
// array w (a function that returns its value is never split).
std::string signature(const FunctionSpec& f, const Dimensions& dims, const std::string& scalar,
                      bool with_names, bool definition = false, const std::string& part = "") {
  std::string s = (returns_scalar(f) ? scalar : "void") + " " + f.name + part +
                  (with_names ? "" : "<" + scalar + ">") + "(";
  std::vector<std::string> parts;
  auto arg = [&](const std::string& type, const std::string& name, bool input) {
    parts.push_back(std::string(definition && (input || !part.empty()) ? "[[maybe_unused]] " : "") +
                    type + (with_names ? " " + name : ""));
  };
  for (const auto& a : f.inputs) arg("const " + matrix_type(a, dims, scalar) + "&", a.name, true);
  arg("const Parameters<" + scalar + ">&", "params", true);
  if (!returns_scalar(f))
    for (const auto& r : f.results) arg(matrix_type(r, dims, scalar) + "&", r.name, false);
  if (!part.empty()) arg(scalar + "*", "w", false);
  for (size_t i = 0; i < parts.size(); ++i) s += (i ? ", " : "") + parts[i];
  return s + ")";
}

// Entry (i, j) of result k. C arrays: out[k] by position (a result named T would hide the type).
std::string target(const ArraySpec& r, size_t k, int rows, int cols, int i, int j,
                   Spelling spelling) {
  if (spelling == Spelling::c_arrays)
    return "out[" + std::to_string(k) + "][" + std::to_string(i + rows * j) + "]";
  if (cols == 1) return r.name + "(" + std::to_string(i) + ")";
  return r.name + "(" + std::to_string(i) + ", " + std::to_string(j) + ")";
}

// The C interface's names for a function's inputs: q = in[0], ...; in a 4-lane function, the
// inputs' entries as lane values (entry i of every lane at [4 i .. 4 i + 3]).
std::string c_input_aliases(const FunctionSpec& f, bool lanes = false) {
  std::string s;
  for (size_t i = 0; i < f.inputs.size(); ++i)
    s += "  [[maybe_unused]] const " + std::string(lanes ? "T" : "double") + "* " +
         f.inputs[i].name + " = " +
         (lanes ? "reinterpret_cast<const T*>(in[" + std::to_string(i) + "])"
                : "in[" + std::to_string(i) + "]") +
         ";\n";
  return s;
}

// A 4-lane function's first lines: the lane type as T, so that the scalar body runs unchanged,
// and its parameters and results as lane values.
std::string lanes_prologue(const FunctionSpec& f) {
  std::string s =
      "  using T = spacearm_lanes4;\n"
      "  [[maybe_unused]] const T* params = reinterpret_cast<const T*>(lane_params);\n"
      "  [[maybe_unused]] T* const out[] = {";
  for (size_t k = 0; k < f.results.size(); ++k)
    s += (k ? ", " : "") + std::string("reinterpret_cast<T*>(lane_results[") + std::to_string(k) +
         "])";
  return s + "};\n";
}

// The linkage of a part of a C interface function: inside the units' extern "C" block, so C
// linkage, and hidden, so that the library exports only the interface.
const std::string kSharedPartLinkage = "[[gnu::visibility(\"hidden\")]] ";

// A function's body, and the functions of its parts where it is split (BodyPrinter).
struct Body {
  // Each part's definition, printed before the function. A part of the C interface has C
  // linkage, hidden from the library's users, so that it may be compiled in another unit
  // (unit_of_functions) than its function, whose text then declares it (`declarations`).
  std::vector<std::string> parts;
  std::string declarations;
  std::string body;
  bool trig_batches = false;  // calls sincos_batch (kTrigBatchHelper)
  std::string all_parts() const {
    std::string s;
    for (const auto& p : parts) s += p;
    return s;
  }
};

// C arrays: a 1 x 1 result is written to its array like any other, not returned. Eigen: a
// function that returns its value is not split.
Body function_body(const FunctionSpec& f, const Dimensions& dims, int per_part,
                   Spelling spelling = Spelling::eigen, bool lanes = false) {
  const bool returns = returns_scalar(f) && spelling == Spelling::eigen;
  std::vector<Assignment> assignments;
  for (size_t k = 0; k < f.results.size() && !returns; ++k) {
    const ArraySpec& r = f.results[k];
    const int rows = dims(r.rows), cols = dims(r.cols);
    for (int i = 0; i < rows; ++i)
      for (int j = r.symmetric ? i : 0; j < cols; ++j)
        assignments.push_back(
            {target(r, k, rows, cols, i, j, spelling), f.entries[k][i * cols + j], ""});
    if (r.symmetric)  // the lower triangle as copies of the upper one
      for (int i = 0; i < rows; ++i)
        for (int j = 0; j < i; ++j)
          assignments.push_back({target(r, k, rows, cols, i, j, spelling), SRef{},
                                 target(r, k, rows, cols, j, i, spelling)});
  }
  if (returns) assignments.push_back({"", f.entries[0][0], ""});
  const BodyPrinter printer(f.program, assignments, f.plain, spelling, returns ? 0 : per_part);
  const OpCounts ops = f.program.count(f.roots());
  // sin and cos appear only in plain bodies: the others call sincos_batch.
  const std::string usings =
      std::string(f.plain ? "  using std::cos;\n  using std::sin;\n  using std::pow;\n" : "") +
      (ops.functions ? "  using std::exp;\n  using std::tanh;\n" : "");
  if (printer.num_parts() == 1)
    return {{}, "", usings + printer.part(0), printer.has_trig_batches()};
  // Split: each part a function of the same arguments and the work array.
  Body b{{},
         "",
         usings + "  T w[" + std::to_string(std::max(1, printer.work_size())) + "];\n",
         printer.has_trig_batches()};
  if (spelling == Spelling::c_arrays) {
    // A hidden C function of the interface's own arguments, so that it may be compiled in
    // another unit (unit_of_functions); a 4-lane part views them as lanes itself, as its
    // function does (each unit defines the lane type for itself).
    const std::string params = lanes ? "lane_params" : "params",
                      out = lanes ? "lane_results" : "out";
    for (int k = 0; k < printer.num_parts(); ++k) {
      const std::string name =
          "spacearm_" + f.name + (lanes ? kLanesSuffix : "") + "_part" + std::to_string(k);
      b.declarations += kSharedPartLinkage + "void " + name +
                        "(const double* const*, const double*, double* const*, double*);\n";
      b.parts.push_back("[[gnu::noinline]] " + kSharedPartLinkage + "void " + name +
                        "([[maybe_unused]] const double* const* in, [[maybe_unused]] const "
                        "double* " +
                        params + ", [[maybe_unused]] double* const* " + out + ", " +
                        (lanes ? "double* lane_w) {\n" + lanes_prologue(f) +
                                     "  T* w = reinterpret_cast<T*>(lane_w);\n"
                               : "[[maybe_unused]] double* w) {\n") +
                        c_input_aliases(f, lanes) + usings + printer.part(k) + "}\n\n");
      b.body += "  " + name + "(in, " + params + ", " + out + ", " +
                (lanes ? "reinterpret_cast<double*>(w)" : "w") + ");\n";
    }
    return b;
  }
  std::string args;
  for (const auto& a : f.inputs) args += a.name + ", ";
  args += "params";
  for (const auto& r : f.results) args += ", " + r.name;
  for (int k = 0; k < printer.num_parts(); ++k) {
    const std::string suffix = "_part" + std::to_string(k);
    b.parts.push_back("template <typename T>\n[[gnu::noinline]] static " +
                      signature(f, dims, "T", true, true, suffix) + " {\n" + usings +
                      printer.part(k) + "}\n\n");
    b.body += "  " + f.name + suffix + "(" + args + ", w);\n";
  }
  return b;
}

// sin and cos of a function's angles in one call per level (BodyPrinter batches them). Where
// the build defines SPACEARM_VECTOR_TRIG (spacearm's build rules do on x86-64 where glibc has
// libmvec), doubles go four at a time through glibc's vector math library on CPUs with AVX2 and
// FMA: within 4 ulp instead of libm's 1, but branch-free and four at once (README: Long chains).
// Elsewhere std::sin and std::cos.
constexpr const char* kTrigBatchIncludes = R"(
#if defined(SPACEARM_VECTOR_TRIG) && defined(__x86_64__) && defined(__GLIBC__)
// Four doubles in an AVX register, as glibc's libmvec (link -lmvec) takes them. Not
// <immintrin.h>: it would add 0.5 s to every compile.
typedef double spacearm_double4 __attribute__((vector_size(32)));
extern "C" [[gnu::target("avx2,fma")]] ::spacearm_double4 _ZGVdN4v_sin(::spacearm_double4);
extern "C" [[gnu::target("avx2,fma")]] ::spacearm_double4 _ZGVdN4v_cos(::spacearm_double4);
#endif
)";
constexpr const char* kTrigBatchHelper = R"(
// s[i] = sin(angle[i]), c[i] = cos(angle[i]).
template <typename T, int K>
inline void sincos_batch(const T (&angle)[K], T (&s)[K], T (&c)[K]) {
  using std::cos;
  using std::sin;
  for (int i = 0; i < K; ++i) s[i] = sin(angle[i]), c[i] = cos(angle[i]);
}
#if defined(SPACEARM_VECTOR_TRIG) && defined(__x86_64__) && defined(__GLIBC__)
[[gnu::target("avx2,fma")]] inline void sincos4(const double* angle, double* s, double* c) {
  ::spacearm_double4 a;
  __builtin_memcpy(&a, angle, sizeof a);
  const ::spacearm_double4 sines = ::_ZGVdN4v_sin(a), cosines = ::_ZGVdN4v_cos(a);
  __builtin_memcpy(s, &sines, sizeof sines);
  __builtin_memcpy(c, &cosines, sizeof cosines);
}
template <int K>
inline void sincos_batch(const double (&angle)[K], double (&s)[K], double (&c)[K]) {
  if (!__builtin_cpu_supports("avx2") || !__builtin_cpu_supports("fma")) {
    for (int i = 0; i < K; ++i) s[i] = std::sin(angle[i]), c[i] = std::cos(angle[i]);
    return;
  }
  for (int i = 0; i < K; i += 4) {
    double a[4] = {}, sv[4], cv[4];
    for (int j = 0; j < 4 && i + j < K; ++j) a[j] = angle[i + j];
    sincos4(a, sv, cv);
    for (int j = 0; j < 4 && i + j < K; ++j) s[i + j] = sv[j], c[i + j] = cv[j];
  }
}
#endif
)";

// The lane type of the 4-lane functions (spacearm_<name>_x4): four doubles in one vector (an AVX
// register where the library is built for AVX2 or AVX-512, two SSE2 halves elsewhere) with the
// scalar operators, so that the scalar body runs unchanged on it and each lane computes the
// scalar function's operations in its order, bit for bit (no contraction into FMA:
// compile_flags). Unaligned (aligned(8)): the lanes' arrays are the caller's doubles. tanh, exp
// and pow go lane by lane through libm, as the scalar body's calls.
constexpr const char* kLanesHelper = R"(
typedef double spacearm_lane_vector __attribute__((vector_size(32), aligned(8)));
struct spacearm_lanes4 {
  spacearm_lane_vector v;
  spacearm_lanes4() = default;
  [[gnu::always_inline]] spacearm_lanes4(double x) : v{x, x, x, x} {}
  [[gnu::always_inline]] explicit spacearm_lanes4(spacearm_lane_vector x) : v(x) {}
};
using L4 = spacearm_lanes4;
[[gnu::always_inline]] inline L4 operator+(L4 a, L4 b) { return L4(a.v + b.v); }
[[gnu::always_inline]] inline L4 operator-(L4 a, L4 b) { return L4(a.v - b.v); }
[[gnu::always_inline]] inline L4 operator*(L4 a, L4 b) { return L4(a.v * b.v); }
[[gnu::always_inline]] inline L4 operator/(L4 a, L4 b) { return L4(a.v / b.v); }
[[gnu::always_inline]] inline L4 operator-(L4 a) { return L4(-a.v); }
template <class F>
inline L4 each_lane(L4 x, F f) {
  L4 r;
  for (int l = 0; l < 4; ++l) r.v[l] = f(x.v[l]);
  return r;
}
inline L4 sin(L4 x) { return each_lane(x, [](double a) { return std::sin(a); }); }
inline L4 cos(L4 x) { return each_lane(x, [](double a) { return std::cos(a); }); }
inline L4 tanh(L4 x) { return each_lane(x, [](double a) { return std::tanh(a); }); }
inline L4 exp(L4 x) { return each_lane(x, [](double a) { return std::exp(a); }); }
template <class E>
inline L4 pow(L4 x, E e) {
  return each_lane(x, [e](double a) { return std::pow(a, e); });
}
)";

// sin and cos of lane values as the scalar sincos_batch takes them (kTrigBatchHelper): through
// libmvec, four angles per call, where the CPU has AVX2 and FMA; else libm's, lane by lane.
constexpr const char* kLanesTrigHelper = R"(
template <int K>
inline void sincos_batch(const L4 (&angle)[K], L4 (&s)[K], L4 (&c)[K]) {
#if defined(SPACEARM_VECTOR_TRIG) && defined(__x86_64__) && defined(__GLIBC__)
  if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma")) {
    for (int i = 0; i < K; ++i)
      sincos4(reinterpret_cast<const double*>(&angle[i]), reinterpret_cast<double*>(&s[i]),
              reinterpret_cast<double*>(&c[i]));
    return;
  }
#endif
  for (int i = 0; i < K; ++i) s[i] = sin(angle[i]), c[i] = cos(angle[i]);
}
)";

// Which formulation each function was derived by (planar_scene.hpp: Formulation), one line each.
std::string formulation_lines(const LoweredModel& model) {
  std::map<std::string, std::string> by_formulation;
  for (const auto& f : model.functions) {
    if (f.model_constant) continue;  // derived by neither formulation
    std::string& names = by_formulation[f.formulation];
    names += (names.empty() ? "" : ", ") + f.name;
  }
  std::string s = "Formulation (scene: " + model.facts.formulation + "):";
  for (const auto& [formulation, names] : by_formulation) s += "\n  " + formulation + ": " + names;
  return s;
}

std::string banner(const LoweredModel& model, const PrintOptions& options) {
  const ModelFacts& facts = model.facts;
  // Paths and the command are user text: written only through comment_lines().
  return comment_lines("Generated by spacearm generator " + std::string(kGeneratorVersion) +
                       " from scene '" + options.scene_path + "' (content hash " +
                       facts.scene_hash + ").") +
         comment_lines("Regenerate: " + options.command) + comment_lines(formulation_lines(model)) +
         "// DO NOT EDIT: this file is overwritten when the model is regenerated.\n// clang-format "
         "off\n";
}

// Numbers as C++ literals that read back to the same doubles, comma-separated.
std::string number_list(const std::vector<double>& values) {
  std::string s;
  for (double v : values) s += (s.empty() ? "" : ", ") + round_trip(v);
  return s;
}

std::string quoted_list(const std::vector<std::string>& items) {
  std::string s;
  for (const auto& i : items) s += (s.empty() ? "" : ", ") + std::string("\"") + i + "\"";
  return s;
}

// Untrusted text (a URDF's link names) as C++ string literals: every byte but letters, digits
// and '_' as a three-digit octal escape, which no following character can extend.
std::string escaped_list(const std::vector<std::string>& items) {
  std::string s;
  for (const auto& item : items) {
    s += (s.empty() ? "\"" : ", \"");
    for (unsigned char c : item) {
      if (std::isalnum(c) || c == '_') {
        s += static_cast<char>(c);
      } else {
        char octal[8];
        std::snprintf(octal, sizeof octal, "\\%03o", c);
        s += octal;
      }
    }
    s += '"';
  }
  return s;
}

// The values of the scene's range checks (ModelFacts::checks), each printed inline.
std::vector<std::string> check_values(const ModelFacts& facts, Spelling spelling) {
  std::vector<Assignment> values;
  for (const auto& c : facts.checks) values.push_back({"", c.value, ""});
  if (values.empty()) return {};
  const BodyPrinter printer(facts.checks_program, values, true, spelling);
  std::vector<std::string> texts;
  for (const auto& c : facts.checks) texts.push_back(printer.value(c.value));
  return texts;
}

// The body of parameter_error(): the scene's range checks, repeated for the parameters'
// actual values.
std::string parameter_checks(const ModelFacts& facts, Spelling spelling) {
  std::ostringstream s;
  const bool eigen = spelling == Spelling::eigen;
  for (size_t i = 0; i < facts.parameter_names.size(); ++i)
    s << "  if (!std::isfinite(params" << (eigen ? "(" : "[") << i << (eigen ? ")" : "]")
      << ")) return \"parameter '" << facts.parameter_names[i] << "' is not finite\";\n";
  const std::vector<std::string> values = check_values(facts, spelling);
  if (!values.empty()) s << "  using T [[maybe_unused]] = double;\n";
  for (size_t k = 0; k < values.size(); ++k)
    s << "  if (!(" << values[k] << (facts.checks[k].strict ? " > 0" : " >= 0") << ")) return \""
      << facts.checks[k].message << "\";\n";
  s << "  return nullptr;\n}\n";
  return s.str();
}

std::string parameter_error_function(const ModelFacts& facts) {
  return "\n// nullptr if the run-time parameters describe a physical system, else what is wrong\n"
         "// (the scene's range checks, repeated for the parameters' values).\n"
         "inline const char* parameter_error([[maybe_unused]] const Eigen::Matrix<double, "
         "kNumParams, 1>& params) {\n" +
         parameter_checks(facts, Spelling::eigen);
}

template <class List>
std::string comma_list(const List& values) {
  std::string list;
  for (const auto& v : values) {
    if (!list.empty()) list += ", ";
    if constexpr (std::is_same_v<std::decay_t<decltype(v)>, bool>)
      list += v ? "true" : "false";
    else
      list += std::to_string(v);
  }
  return list;
}

std::string header_constants(const ModelFacts& facts) {
  std::ostringstream h;
  h << "inline constexpr int kNq = " << facts.dims.nq << ";\n"
    << "inline constexpr int kNv = " << facts.dims.nv << ";\n"
    << "inline constexpr int kNumLinks = " << facts.dims.num_links << ";\n"
    << "inline constexpr int kNumParams = " << facts.parameter_names.size() << ";\n"
    << "inline constexpr bool kFreeFloating = " << (facts.free_floating ? "true" : "false") << ";\n"
    << "inline constexpr bool kGeared = " << (facts.geared ? "true" : "false") << ";\n"
    << "inline constexpr std::array<const char*, kNq> kCoordinateNames = {"
    << quoted_list(facts.coordinate_names) << "};\n";
  h << "inline constexpr std::array<const char*, kNumParams> kParameterNames = {"
    << quoted_list(facts.parameter_names) << "};\n"
    << "inline constexpr std::array<double, kNumParams> kNominalParameters = {"
    << number_list(facts.nominal_parameters) << "};\n"
    << "inline constexpr const char* kSceneHash = \"" << facts.scene_hash << "\";\n";
  if (!facts.inertia_check.empty())  // a spatial arm's
    h << "// The bodies' inertias: \"physical\" (a rigid body's) or \"positive_definite\" (as "
         "given).\n"
      << "inline constexpr const char* kInertiaCheck = \"" << facts.inertia_check << "\";\n";
  if (facts.right_angles_snapped)
    h << "// snap_right_angles: the frames' angles within 1e-5 rad of a multiple of pi/2 are it.\n"
      << "inline constexpr bool kRightAnglesSnapped = true;\n";
  h << parameter_error_function(facts);
  for (const auto& o : output_registry()) {
    const bool has = std::count(facts.outputs.begin(), facts.outputs.end(), o.id) != 0;
    h << "inline constexpr bool kHas_" << o.name << " = " << (has ? "true" : "false") << ";\n";
  }
  h << "// The base's velocities (0: a fixed base) and where a quaternion (w, x, y, z) sits in q\n"
    << "// (-1: none, nq = nv); springs, dampers or friction besides M qdd + b.\n"
    << "inline constexpr int kNumBase = " << facts.num_base << ";\n"
    << "inline constexpr int kQuaternionOffset = " << facts.quaternion_offset << ";\n"
    << "inline constexpr bool kPassiveForces = " << (facts.has_passive_forces() ? "true" : "false")
    << ";\n"
    << "// Per joint: the velocity index its torque drives, as tau_i / p_i (eq. 14), and whether\n"
    << "// its slot in q holds the motor angle qm = p q (a rigid gear, eq. 12).\n"
    << "inline constexpr std::array<int, kNumLinks> kActuatedCoordinates = {"
    << comma_list(actuated_coordinates(facts)) << "};\n"
    << "inline constexpr std::array<bool, kNumLinks> kMotorAngleSlots = {"
    << comma_list(facts.motor_angle_slots) << "};\n";
  if (facts.dims.num_end_effectors > 1)  // a tree's: the poses' and Jacobian rows' blocks
    h << "// The end effectors, in the order of the pose's blocks of 7 and the Jacobian's of 6 "
         "rows.\n"
      << "inline constexpr int kNumEndEffectors = " << facts.dims.num_end_effectors << ";\n"
      << "inline constexpr std::array<const char*, kNumEndEffectors> kEndEffectorNames = {"
      << escaped_list(facts.end_effector_names) << "};\n";
  h << "\ntemplate <typename T> using Coordinates = Eigen::Matrix<T, kNq, 1>;\n"
    << "template <typename T> using Velocities = Eigen::Matrix<T, kNv, 1>;\n"
    << "template <typename T> using Parameters = Eigen::Matrix<T, kNumParams, 1>;\n"
    << "template <typename T> using MassMatrix = Eigen::Matrix<T, kNv, kNv>;\n"
    << "// The end effector's pose: x, y, phi in the plane; x, y, z, qw, qx, qy, qz in 3D.\n"
    << "template <typename T> using Pose = Eigen::Matrix<T, "
    << size_constant(Size::poses, facts.dims) << ", 1>;\n"
    << "template <typename T> using Vector3 = Pose<T>;  // its former name, kept for old code\n"
    << "template <typename T> using PoseJacobian = Eigen::Matrix<T, "
    << size_constant(Size::twists, facts.dims) << ", kNv>;\n"
    << "template <typename T> using JointVector = Eigen::Matrix<T, kNumLinks, 1>;\n"
    << "template <typename T> using JointPositions = Eigen::Matrix<T, "
    << size_constant(Size::point, facts.dims) << ", " << size_constant(Size::num_points, facts.dims)
    << ">;\n\n";
  return h.str();
}

// The model as a type, so generic code (runtime, tests, benchmarks) can take it as a
// template argument.
std::string model_struct(const LoweredModel& model, const std::string& ns) {
  std::ostringstream h;
  h << "\n// The model as a type for generic code: constants and forwarding functions.\nstruct "
       "Model {\n"
    << "  static constexpr const char* kName = \"" << model.facts.name << "\";\n";
  for (const char* c : {"kNq", "kNv", "kNumLinks", "kNumParams"})
    h << "  static constexpr int " << c << " = " << ns << "::" << c << ";\n";
  for (const char* c : {"kFreeFloating", "kGeared"})
    h << "  static constexpr bool " << c << " = " << ns << "::" << c << ";\n";
  for (const auto& o : output_registry())
    h << "  static constexpr bool kHas_" << o.name << " = " << ns << "::kHas_" << o.name << ";\n";
  for (const char* c : {"kNumBase", "kQuaternionOffset"})
    h << "  static constexpr int " << c << " = " << ns << "::" << c << ";\n";
  if (model.facts.dims.num_end_effectors > 1)  // a tree's (runtime/model.hpp: 1 without it)
    h << "  static constexpr int kNumEndEffectors = " << ns << "::kNumEndEffectors;\n";
  h << "  static constexpr bool kPassiveForces = " << ns << "::kPassiveForces;\n"
    << "  static constexpr const std::array<int, kNumLinks>& actuated_coordinates() { return "
       "kActuatedCoordinates; }\n"
    << "  static constexpr const std::array<bool, kNumLinks>& motor_angle_slots() { return "
       "kMotorAngleSlots; }\n";
  for (const char* alias : {"Coordinates", "Velocities", "Parameters", "MassMatrix", "Pose",
                            "Vector3", "PoseJacobian", "JointVector", "JointPositions"})
    h << "  template <typename T> using " << alias << " = " << ns << "::" << alias << "<T>;\n";
  h << "  static constexpr const std::array<const char*, kNq>& coordinate_names() { return "
       "kCoordinateNames; }\n"
    << "  static constexpr const std::array<const char*, kNumParams>& parameter_names() { return "
       "kParameterNames; }\n"
    << "  static constexpr const std::array<double, kNumParams>& nominal_parameters() { return "
       "kNominalParameters; }\n"
    << "  static const char* parameter_error(const Eigen::Matrix<double, kNumParams, 1>& params) "
       "{\n"
    << "    return " << ns << "::parameter_error(params);\n  }\n";
  for (const auto& f : model.functions) {
    std::string call;
    for (const auto& a : f.inputs) call += a.name + ", ";
    call += "params";
    if (!returns_scalar(f))
      for (const auto& r : f.results) call += ", " + r.name;
    h << "  template <typename T>\n  static " << signature(f, model.facts.dims, "T", true)
      << " {\n    return " << ns << "::" << f.name << "<T>(" << call << ");\n  }\n";
  }
  h << "};\n";
  return h.str();
}

// The library the compile-and-load path builds: self-contained translation units with only
// <cmath>, every function straight-line over plain arrays. Eigen's headers and the templates'
// three instantiations cost seconds to compile; this compiles in a fraction. `units` > 1 deals
// the functions out (largest first, each to the least loaded unit, by text length) so that
// that many compilers can build them at once; the first unit also has the model's facts.
// The first unit's facts of the model: the arrays and functions that state its names, sizes,
// layout, span of values, and parameter_error()'s checks (its body's end: the caller's).
std::string c_facts(const ModelFacts& facts) {
  const std::string nominal = number_list(facts.nominal_parameters);
  const std::string actuated = comma_list(actuated_coordinates(facts));
  std::vector<std::string> span_names;
  std::vector<double> span_values;
  std::vector<int> span_parameters;
  for (const SpanField& f : facts.span_fields)
    span_names.push_back(f.field), span_values.push_back(f.value),
        span_parameters.push_back(f.parameter);
  std::ostringstream s;
  s << "const char* const kCoordinateNames[] = {" << quoted_list(facts.coordinate_names) << "};\n"
    << "const char* const kParameterNames[] = {"
    << (nominal.empty() ? "\"\"" : quoted_list(facts.parameter_names)) << "};\n"
    << "const double kNominalParameters[] = {" << (nominal.empty() ? "0.0" : nominal) << "};\n"
    << "const int kActuatedCoordinates[] = {" << actuated << "};\n"
    << "const bool kMotorAngleSlots[] = {" << comma_list(facts.motor_angle_slots) << "};\n"
    << "const char* const kSpanFields[] = {"
    << (span_names.empty() ? "\"\"" : quoted_list(span_names)) << "};\n"
    << "const double kSpanValues[] = {" << (span_values.empty() ? "0.0" : number_list(span_values))
    << "};\n"
    << "const int kSpanParameters[] = {"
    << (span_parameters.empty() ? "-1" : comma_list(span_parameters)) << "};\n}  // namespace\n\n"
    << "extern \"C\" {\n"
    << "int spacearm_abi_version() { return " << kCInterfaceVersion << "; }\n"
    << "int spacearm_nq() { return " << facts.dims.nq << "; }\n"
    << "int spacearm_nv() { return " << facts.dims.nv << "; }\n"
    << "int spacearm_num_links() { return " << facts.dims.num_links << "; }\n"
    << "int spacearm_num_end_effectors() { return " << facts.dims.num_end_effectors << "; }\n"
    << "int spacearm_num_params() { return " << facts.parameter_names.size() << "; }\n"
    << "int spacearm_num_base() { return " << facts.num_base << "; }\n"
    << "int spacearm_spatial() { return " << facts.dims.spatial << "; }\n"
    << "int spacearm_free_floating() { return " << facts.free_floating << "; }\n"
    << "int spacearm_passive_forces() { return " << facts.has_passive_forces() << "; }\n"
    << "// Where a quaternion (w, x, y, z) sits in q; -1: none, and q has one entry per "
       "velocity.\n"
    << "int spacearm_configuration_layout() { return " << facts.quaternion_offset << "; }\n"
    << "const char* spacearm_name() { return \"" << facts.name << "\"; }\n"
    << "const char* spacearm_coordinate_name(int i) { return kCoordinateNames[i]; }\n"
    << "const char* spacearm_parameter_name(int i) { return kParameterNames[i]; }\n"
    << "double spacearm_nominal_parameter(int i) { return kNominalParameters[i]; }\n"
    << "int spacearm_actuated_coordinate(int joint) { return kActuatedCoordinates[joint]; }\n"
    << "// 1 where the joint's slot in q holds its motor angle qm = p q (a rigid gear, eq. 12).\n"
    << "int spacearm_slot_holds_motor(int joint) { return kMotorAngleSlots[joint]; }\n"
    << "unsigned long spacearm_outputs() { return " << output_mask(facts.outputs) << "ul; }\n"
    << "const char* spacearm_scene_hash() { return \"" << facts.scene_hash << "\"; }\n"
    << "// The numbers a failure's message spans (spacearm's value_span.hpp): field, literal\n"
    << "// or nominal value, the run-time parameter that gives it (-1: none).\n"
    << "int spacearm_num_span_fields() { return " << span_names.size() << "; }\n"
    << "const char* spacearm_span_field(int i) { return kSpanFields[i]; }\n"
    << "double spacearm_span_value(int i) { return kSpanValues[i]; }\n"
    << "int spacearm_span_parameter(int i) { return kSpanParameters[i]; }\n"
    << "const char* spacearm_parameter_error([[maybe_unused]] const double* params) {\n"
    << parameter_checks(facts, Spelling::c_arrays);
  return s.str();
}

// One function of the C interface: its C name (spacearm_ + name), text, whether it is a 4-lane
// version and whether it batches sin/cos (the unit then includes the batch helper); or one part
// of a function's split body (part_of: that function's index), which may go to any unit.
struct CFunction {
  std::string name, text;
  bool lanes = false, trig_batches = false;
  int part_of = -1;
};

// Each function's C text, its parts' and its 4-lane version's.
std::vector<CFunction> c_functions(const LoweredModel& model, int per_part) {
  const ModelFacts& facts = model.facts;
  std::vector<CFunction> functions;
  // A function of body b, then its parts, each naming the function's index.
  auto add = [&functions](const std::string& name, const std::string& text, bool lanes,
                          const Body& b) {
    const int index = static_cast<int>(functions.size());
    functions.push_back({name, text, lanes, b.trig_batches});
    for (size_t k = 0; k < b.parts.size(); ++k)
      functions.push_back(
          {name + "_part" + std::to_string(k), "\n" + b.parts[k], lanes, b.trig_batches, index});
  };
  for (const auto& f : model.functions) {
    const Body b = function_body(f, facts.dims, per_part, Spelling::c_arrays);
    add(f.name,
        "\n// " + f.doc + "\n" + b.declarations + "void spacearm_" + f.name +
            "([[maybe_unused]] const double* const* in, [[maybe_unused]] const "
            "double* params, double* const* out) {\n" +
            (b.parts.empty() ? c_input_aliases(f) : "") + b.body + "}\n",
        false, b);
    // Its 4-lane version: four states per call, every input, parameter and result interleaved.
    if (!f.lanes) continue;
    const Body l = function_body(f, facts.dims, per_part, Spelling::c_arrays, true);
    add(f.name + kLanesSuffix,
        "\n// " + f.name + " of four states at once (kLanesHelper).\n" + l.declarations +
            "void spacearm_" + f.name + kLanesSuffix +
            "([[maybe_unused]] const double* const* in, const double* "
            "lane_params, double* const* lane_results) {\n" +
            (l.parts.empty() ? lanes_prologue(f) + c_input_aliases(f, true)
                             : "  using T = spacearm_lanes4;\n") +
            l.body + "}\n",
        true, l);
  }
  return functions;
}

// Which unit each function goes to: the named leading units first, in their order (a name the
// model lacks is skipped; a leading function's parts with it, so that the unit links alone), then
// the rest over `units` more, balanced by size (largest first), the parts of a split function
// each on its own: a long function's compile is shared by the compilers. With as many compilers
// as units at once, the last unit starts when the leading ones end: it is balanced as if it held
// them too, so that all end together. A function's weight is its size, doubled for a 4-lane one:
// bench_compile measured those 1.6-2.2x as long to compile as scalar functions of about the same
// size.
std::vector<int> unit_of_functions(const std::vector<CFunction>& functions,
                                   const std::vector<std::vector<std::string>>& leading,
                                   int units) {
  std::vector<int> unit_of(functions.size(), -1);
  for (size_t u = 0; u < leading.size(); ++u)
    for (const auto& name : leading[u])
      for (size_t i = 0; i < functions.size(); ++i)
        if (functions[i].part_of < 0 && functions[i].name == name && unit_of[i] < 0)
          unit_of[i] = static_cast<int>(u);
  for (size_t i = 0; i < functions.size(); ++i)
    if (const int parent = functions[i].part_of; parent >= 0 && unit_of[parent] >= 0)
      unit_of[i] = unit_of[parent];
  size_t rest = 0;
  for (int u : unit_of) rest += u < 0;
  units = std::max(1, std::min<int>(units, static_cast<int>(rest)));
  const auto weight = [&](size_t i) {
    return functions[i].text.size() * (functions[i].lanes ? 2 : 1);
  };
  std::vector<size_t> load(units), order;
  for (size_t i = 0; i < functions.size(); ++i)
    if (unit_of[i] < 0)
      order.push_back(i);
    else
      load.back() += weight(i);
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t a, size_t b) { return weight(a) > weight(b); });
  for (size_t i : order) {
    const auto least = std::min_element(load.begin(), load.end()) - load.begin();
    unit_of[i] = static_cast<int>(leading.size() + least);
    load[least] += weight(i);
  }
  return unit_of;
}

// CasADi's sparsity pattern of a dense rows x cols array (compressed columns: rows, cols, the
// columns' offsets, then every entry's row).
std::string dense_sparsity(int rows, int cols) {
  std::string s = std::to_string(rows) + ", " + std::to_string(cols);
  for (int j = 0; j <= cols; ++j) s += ", " + std::to_string(j * rows);
  for (int j = 0; j < cols; ++j)
    for (int i = 0; i < rows; ++i) s += ", " + std::to_string(i);
  return s;
}

// The names and sparsity patterns of a CasADi external function's inputs or outputs (kind "in"
// or "out"): NAME_name_KIND(i) and NAME_sparsity_KIND(i), null past the last.
std::string casadi_tables(const std::string& name, const std::string& kind,
                          const std::vector<std::string>& names,
                          const std::vector<std::string>& sparsity) {
  const std::string type = "spacearm_casadi_int", n = std::to_string(names.size());
  std::string s = "const char* " + name + "_name_" + kind + "(" + type + " i) {\n" +
                  "  static const char* const names[] = {" +
                  (names.empty() ? "\"\"" : quoted_list(names)) + "};\n  return i >= 0 && i < " +
                  n + " ? names[i] : nullptr;\n}\n";
  s += "const " + type + "* " + name + "_sparsity_" + kind + "(" + type + " i) {\n";
  std::string all;
  for (size_t k = 0; k < names.size(); ++k) {
    s += "  static const " + type + " s" + std::to_string(k) + "[] = {" + sparsity[k] + "};\n";
    all += (k ? ", s" : "s") + std::to_string(k);
  }
  return s + "  static const " + type + "* const s[] = {" + (all.empty() ? "nullptr" : all) +
         "};\n  return i >= 0 && i < " + n + " ? s[i] : nullptr;\n}\n";
}

// Function f in CasADi's external form (PrintOptions::casadi), inside unit 0's extern "C" block
// (kNominalParameters is that unit's). Written out here because CasADi's own code generator
// would need CasADi to derive the model; its calling convention is what casadi::external and
// acados' external functions load.
std::string casadi_wrapper(const FunctionSpec& f, const ModelFacts& facts) {
  const std::string name = "spacearm_casadi_" + f.name, type = "spacearm_casadi_int";
  const int inputs = static_cast<int>(f.inputs.size()),
            results = static_cast<int>(f.results.size());
  const int params = static_cast<int>(facts.parameter_names.size());
  const int n_in = inputs + (params > 0 ? 1 : 0);
  std::vector<std::string> in_names, out_names, in_sparsity, out_sparsity;
  std::vector<int> in_sizes, out_sizes;
  for (const ArraySpec& a : f.inputs) {
    in_names.push_back(a.name);
    in_sizes.push_back(facts.dims(a.rows) * facts.dims(a.cols));
    in_sparsity.push_back(dense_sparsity(facts.dims(a.rows), facts.dims(a.cols)));
  }
  if (params > 0) in_names.push_back("params"), in_sparsity.push_back(dense_sparsity(params, 1));
  for (const ArraySpec& r : f.results) {
    out_names.push_back(r.name);
    out_sizes.push_back(facts.dims(r.rows) * facts.dims(r.cols));
    out_sparsity.push_back(dense_sparsity(facts.dims(r.rows), facts.dims(r.cols)));
  }
  int work = 0;
  for (int n : in_sizes) work += n;
  for (int n : out_sizes) work += n;
  const std::string parameters = params > 0 ? "arg[" + std::to_string(inputs) + "] ? arg[" +
                                                  std::to_string(inputs) + "] : kNominalParameters"
                                            : "kNominalParameters";
  std::ostringstream s;
  s << "\n// " << f.name << " in CasADi's external form (PrintOptions::casadi).\n"
    << type << " " << name << "_n_in() { return " << n_in << "; }\n"
    << type << " " << name << "_n_out() { return " << results << "; }\n"
    << casadi_tables(name, "in", in_names, in_sparsity)
    << casadi_tables(name, "out", out_names, out_sparsity) << "int " << name << "_work(" << type
    << "* sz_arg, " << type << "* sz_res, " << type << "* sz_iw, " << type << "* sz_w) {\n"
    << "  if (sz_arg) *sz_arg = " << n_in << ";\n  if (sz_res) *sz_res = " << results
    << ";\n  if (sz_iw) *sz_iw = 0;\n  if (sz_w) *sz_w = " << work << ";\n  return 0;\n}\n"
    << "int " << name << "(const double** arg, double** res, " << type << "*, double* w, int) {\n"
    << "  // A null input is zeros and a null result is not wanted (CasADi's convention): both\n"
    << "  // take room in w. Null parameters are the nominal ones.\n"
    << "  [[maybe_unused]] static const int in_size[] = {" << (inputs ? comma_list(in_sizes) : "0")
    << "}, out_size[] = {" << (results ? comma_list(out_sizes) : "0") << "};\n"
    << "  const double* in[" << std::max(inputs, 1) << "] = {};\n"
    << "  double* out[" << std::max(results, 1) << "] = {};\n"
    << "  for (int i = 0; i < " << inputs << "; ++i) {\n"
    << "    in[i] = arg[i];\n"
    << "    if (in[i]) continue;\n"
    << "    for (int k = 0; k < in_size[i]; ++k) w[k] = 0;\n"
    << "    in[i] = w, w += in_size[i];\n  }\n"
    << "  for (int i = 0; i < " << results << "; ++i) {\n"
    << "    out[i] = res[i];\n"
    << "    if (!out[i]) out[i] = w, w += out_size[i];\n  }\n"
    << "  spacearm_" << f.name << "(in, " << parameters << ", out);\n  return 0;\n}\n";
  return s.str();
}

// The C interface's translation units (PrintOptions::c_units, leading_units); unit 0 also
// states the model's facts.
std::vector<std::string> c_interface(const LoweredModel& model, const PrintOptions& options,
                                     std::vector<std::vector<std::string>>& names) {
  const ModelFacts& facts = model.facts;
  const std::vector<CFunction> functions = c_functions(model, options.statements_per_part);
  const std::vector<int> unit_of =
      unit_of_functions(functions, options.leading_units, options.c_units);
  const int units = unit_of.empty() ? 1 : *std::max_element(unit_of.begin(), unit_of.end()) + 1;
  names.assign(units, {});
  std::vector<std::string> result;
  for (int u = 0; u < units; ++u) {
    std::string texts;
    bool trig_batches = false;
    for (size_t i = 0; i < functions.size(); ++i)
      if (unit_of[i] == u) {
        texts += functions[i].text;
        trig_batches = trig_batches || functions[i].trig_batches;
        if (functions[i].part_of < 0) names[u].push_back(functions[i].name);
      }
    std::ostringstream s;
    s << "// C interface of model " << facts.name << " for dlopen (written by spacearm; do not edit"
      << (units > 1 ? "; part " + std::to_string(u + 1) + " of " + std::to_string(units) : "")
      << ").\n"
      << "// Arrays are column-major; spacearm's cpp_printer.hpp gives the calling convention.\n"
      << "#include <cmath>\n"
      << (trig_batches ? kTrigBatchIncludes : "") << "\nnamespace {\nusing T = double;\n"
      << (trig_batches ? kTrigBatchHelper : "") << kLanesHelper
      << (trig_batches ? kLanesTrigHelper : "");
    if (u > 0) {
      s << "}  // namespace\n\nextern \"C\" {" << texts << "}\n";
    } else {
      s << c_facts(facts) << texts;
      if (options.casadi) {
        s << "\n// CasADi's integer (casadi_int, long long by default).\ntypedef long long "
             "spacearm_casadi_int;\n";
        for (const auto& f : model.functions) s << casadi_wrapper(f, facts);
      }
      s << "}\n";
    }
    result.push_back(s.str());
  }
  return result;
}

}  // namespace

std::string c_body_statements(const FunctionSpec& f, const Dimensions& dims) {
  return function_body(f, dims, 0, Spelling::c_arrays).body;
}

std::vector<std::string> c_check_values(const ModelFacts& facts) {
  return check_values(facts, Spelling::c_arrays);
}

EmittedModel print_cpp(const LoweredModel& model, const PrintOptions& options) {
  const ModelFacts& facts = model.facts;
  // Per-joint facts come from the derived model; a short list would print a wrong header.
  if (facts.motor_angle_slots.size() != size_t(facts.dims.num_links) ||
      !(facts.actuated_coordinates.empty() ||
        facts.actuated_coordinates.size() == size_t(facts.dims.num_links)))
    throw std::logic_error("print_cpp: model " + facts.name +
                           " states motor_angle_slots or actuated_coordinates for " +
                           "another number of joints than " + std::to_string(facts.dims.num_links));
  EmittedModel result;
  const std::string stem = options.file_stem.empty() ? facts.name : options.file_stem;
  check_file_stem(stem, "file stem");
  result.header_name = stem + ".hpp";
  result.source_name = stem + ".cpp";
  const std::string ns = "spacearm::models::" + facts.name;

  std::ostringstream h, s, functions;
  bool trig_batches = false;
  h << banner(model, options)
    << "#pragma once\n\n#include <Eigen/Core>\n\n#include <array>\n#include <cmath>\n\n";
  h << comment_lines(facts.description.empty() ? facts.name : facts.description);
  std::string coordinates;
  for (const auto& c : facts.coordinate_names) coordinates += (coordinates.empty() ? "" : ", ") + c;
  h << "// Coordinates q = [" << coordinates << "]" << facts.coordinates_note << ".\n"
    << "// Instantiated for float, double and long double; constants are double-precision.\n"
    << "namespace " << ns << " {\n\n"
    << header_constants(facts)
    << "// All functions write into caller-provided fixed-size outputs and never allocate.\n";

  for (const auto& f : model.functions) {
    const std::string doc =
        "// " + f.doc +
        (f.equation.empty()
             ? ""
             : std::string(" Paper eq") +
                   (f.equation.find(' ') == std::string::npos ? ". " : "s. ") + f.equation + ".") +
        "\n";
    h << "\n" << doc << "template <typename T>\n" << signature(f, facts.dims, "T", true) << ";\n";
    functions << "\n" << doc;
    if (f.plain) {
      result.stats.push_back({f.name, {}, "", f.formulation});
      functions << "// Baseline: expanded expressions, no common-subexpression elimination.\n";
    } else {
      const OpCounts ops = f.program.count(f.roots());
      result.stats.push_back({f.name, ops, f.variant, f.formulation});
      functions << "// Operations: " << ops.adds << " add, " << ops.muls << " mul, " << ops.divs
                << " div, " << ops.trig << " sin/cos"
                << (ops.functions ? ", " + std::to_string(ops.functions) + " tanh/exp" : "")
                << ".\n"
                << "// Formulation: " << f.formulation << ".\n";
    }
    const Body b = function_body(f, facts.dims, options.statements_per_part);
    trig_batches |= b.trig_batches;
    functions << b.all_parts() << "template <typename T>\n"
              << signature(f, facts.dims, "T", true, true) << " {\n"
              << b.body << "}\n";
  }
  h << model_struct(model, ns);
  s << banner(model, options) << "#include \"" << result.header_name << "\"\n\n#include <cmath>\n"
    << (trig_batches ? kTrigBatchIncludes : "") << "\nnamespace " << ns << " {\n"
    << (trig_batches ? kTrigBatchHelper : "") << functions.str();
  s << "\n// Explicit instantiations.\n";
  for (const char* scalar : {"float", "double", "long double"})
    for (const auto& f : model.functions)
      s << "template " << signature(f, facts.dims, scalar, false) << ";\n";
  s << "\n}  // namespace " << ns << "\n";
  h << "\n}  // namespace " << ns << "\n";
  result.header = h.str();
  result.source = s.str();
  result.c_units = c_interface(model, options, result.c_unit_functions);
  if (options.interpreted) try {
      result.interpreted = std::make_shared<const InterpretedModel>(interpreted_code(model));
    } catch (const std::logic_error& e) {  // the compiled code still serves
      result.interpreted_error = e.what();
    }
  if (result.c_units.size() == 1) result.c_interface = result.c_units[0];
  if (options.casadi) {
    if (result.c_units.size() != 1)
      throw std::logic_error("print_cpp: the CasADi form is written as one file (c_units = 1)");
    result.c_file_name = stem + "_c.cpp";
  }
  return result;
}

// The files a generation writes, by name: the header, the source and, for CasADi, the C
// interface (PrintOptions::casadi).
std::vector<std::pair<std::string, const std::string*>> emitted_files(const EmittedModel& e) {
  std::vector<std::pair<std::string, const std::string*>> files = {{e.header_name, &e.header},
                                                                   {e.source_name, &e.source}};
  if (!e.c_file_name.empty()) files.push_back({e.c_file_name, &e.c_interface});
  return files;
}

// Each file is written to a new temporary of a random name, created with O_EXCL | O_NOFOLLOW
// in the folder opened once (a link planted at the temporary's name is never written
// through), then renamed into place relative to the folder.
void write_files(const EmittedModel& emitted, const std::string& dir) {
  std::filesystem::create_directories(dir);
  const Fd folder(::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC));
  if (!folder.valid()) throw FolderError("cannot open '" + dir + "': " + std::strerror(errno));
  // A device, FIFO or link at a file's name is refused before anything is written.
  const auto files = emitted_files(emitted);
  for (const auto& [name, text] : files)
    refuse_replacing_special_at(folder.get(), name, dir + "/" + name);
  std::vector<std::pair<std::string, std::string>> staged;  // temporary, final name
  try {
    for (const auto& [name, text] : files) {
      const std::string tmp = unique_name("." + name + ".tmp-");
      write_new_file_at(folder.get(), tmp, *text, dir + "/" + tmp, 0644);
      staged.push_back({tmp, name});
    }
    for (const auto& [tmp, name] : staged)
      if (::renameat(folder.get(), tmp.c_str(), folder.get(), name.c_str()) != 0)
        throw FolderError("cannot write '" + dir + "/" + name + "': " + std::strerror(errno));
  } catch (const FolderError&) {
    for (const auto& [tmp, name] : staged) ::unlinkat(folder.get(), tmp.c_str(), 0);
    throw;
  }
}

std::vector<std::string> stale_files(const EmittedModel& emitted, const std::string& dir) {
  std::vector<std::string> stale;
  for (const auto& [name, text] : emitted_files(emitted)) {
    const std::string path = dir + "/" + name;
    std::ifstream in(path, std::ios::binary);
    std::ostringstream existing;
    existing << in.rdbuf();
    if (!in || existing.str() != *text) stale.push_back(path);
  }
  return stale;
}

}  // namespace spacearm
