#include "compiled_model.hpp"

#include <dlfcn.h>
#include <unistd.h>

#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "cpp_emitter.hpp"
#include "symbolic_model.hpp"

#ifndef SPACEARM_EIGEN_INCLUDE_DIR
#define SPACEARM_EIGEN_INCLUDE_DIR "/usr/include/eigen3"
#endif

namespace spacearm {

namespace fs = std::filesystem;

// The C functions every compiled model exports (see c_api_source below).
struct CompiledModel::Api {
  using Vec = void (*)(const double*, const double*, double*);
  using VecVel = void (*)(const double*, const double*, const double*, double*);
  VecVel coriolis_matrix = nullptr, bias_forces = nullptr, momentum = nullptr;
  Vec mass_matrix = nullptr, end_effector_pose = nullptr;
  double (*kinetic_energy)(const double*, const double*, const double*) = nullptr;
  void (*gear_ratios)(const double*, double*) = nullptr;
  const char* (*parameter_error)(const double*) = nullptr;
};

namespace {

constexpr int kAbiVersion = 2;

std::string c_api_source(const Scene& scene, const std::string& header) {
  const std::string ns = "spacearm::models::" + scene.name;
  std::ostringstream s;
  s << "// C interface of model " << scene.name << " for dlopen (written by spacearm; do not edit).\n"
    << "#include \"" << header << "\"\n\n"
    << "namespace m = " << ns << ";\n"
    << "using Q = Eigen::Map<const m::Coordinates<double>>;\n"
    << "using P = Eigen::Map<const m::Parameters<double>>;\n\n"
    << "extern \"C\" {\n"
    << "int spacearm_abi_version() { return " << kAbiVersion << "; }\n"
    << "int spacearm_nq() { return m::kNq; }\n"
    << "int spacearm_num_links() { return m::kNumLinks; }\n"
    << "int spacearm_num_params() { return m::kNumParams; }\n"
    << "const char* spacearm_coordinate_name(int i) { return m::kCoordinateNames[i]; }\n"
    << "const char* spacearm_parameter_name(int i) { return m::kNumParams ? m::Model::parameter_names()[i] : \"\"; }\n"
    << "double spacearm_nominal_parameter(int i) { return m::kNumParams ? m::Model::nominal_parameters()[i] : 0.0; }\n";
  unsigned mask = 0;
  for (Output o : all_outputs())
    if (scene.wants(o)) mask |= 1u << static_cast<unsigned>(o);
  s << "unsigned spacearm_outputs() { return " << mask << "u; }\n";
  s << "const char* spacearm_parameter_error(const double* p) { return m::parameter_error(P(p)); }\n";
  s << "void spacearm_gear_ratios(const double* p, double* r) {\n"
    << "  m::JointVector<double> out; m::gear_ratios<double>(P(p), out); Eigen::Map<m::JointVector<double>>{r} = out;\n}\n";
  if (scene.wants(Output::mass_matrix))
    s << "void spacearm_mass_matrix(const double* q, const double* p, double* M) {\n"
      << "  m::MassMatrix<double> out; m::mass_matrix<double>(Q(q), P(p), out); "
         "Eigen::Map<m::MassMatrix<double>>{M} = out;\n}\n";
  if (scene.wants(Output::coriolis_matrix))
    s << "void spacearm_coriolis_matrix(const double* q, const double* qd, const double* p, double* C) {\n"
      << "  m::MassMatrix<double> out; m::coriolis_matrix<double>(Q(q), Q(qd), P(p), out); "
         "Eigen::Map<m::MassMatrix<double>>{C} = out;\n}\n";
  if (scene.wants(Output::bias_forces))
    s << "void spacearm_bias_forces(const double* q, const double* qd, const double* p, double* b) {\n"
      << "  m::Coordinates<double> out; m::bias_forces<double>(Q(q), Q(qd), P(p), out); "
         "Eigen::Map<m::Coordinates<double>>{b} = out;\n}\n";
  if (scene.wants(Output::kinetic_energy))
    s << "double spacearm_kinetic_energy(const double* q, const double* qd, const double* p) {\n"
      << "  return m::kinetic_energy<double>(Q(q), Q(qd), P(p));\n}\n";
  if (scene.wants(Output::momentum))
    s << "void spacearm_momentum(const double* q, const double* qd, const double* p, double* h) {\n"
      << "  m::Vector3<double> out; m::momentum<double>(Q(q), Q(qd), P(p), out); "
         "Eigen::Map<m::Vector3<double>>{h} = out;\n}\n";
  if (scene.wants(Output::end_effector_pose))
    s << "void spacearm_end_effector_pose(const double* q, const double* p, double* x) {\n"
      << "  m::Vector3<double> out; m::end_effector_pose<double>(Q(q), P(p), out); "
         "Eigen::Map<m::Vector3<double>>{x} = out;\n}\n";
  s << "}\n";
  return s.str();
}

std::string first_line_of_command(const std::string& command) {
  std::array<char, 512> buf{};
  std::string out;
  if (FILE* p = popen(command.c_str(), "r")) {
    if (fgets(buf.data(), buf.size(), p)) out = buf.data();
    pclose(p);
  }
  while (!out.empty() && (out.back() == '\n' || out.back() == '\r')) out.pop_back();
  return out;
}

std::string read_file(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

void write_file(const fs::path& p, const std::string& text) {
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  out << text;
  if (!out) throw CompileError("cannot write '" + p.string() + "'");
}

std::string shell_quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

// Identity of the running generator: a hash of its own executable, so that a rebuilt
// generator (which may emit different code under the same version number) gets new entries.
const std::string& generator_identity() {
  static const std::string id = content_hash(read_file("/proc/self/exe")) + "-abi" + std::to_string(kAbiVersion);
  return id;
}

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

std::string cache_directory(const CompileOptions& options) {
  if (!options.cache_dir.empty()) return options.cache_dir;
  if (const char* d = std::getenv("SPACEARM_CACHE_DIR"); d && *d) return d;
  if (const char* d = std::getenv("XDG_CACHE_HOME"); d && *d) return std::string(d) + "/spacearm";
  if (const char* h = std::getenv("HOME"); h && *h) return std::string(h) + "/.cache/spacearm";
  return (fs::temp_directory_path() / "spacearm-cache").string();
}

CompiledModel CompiledModel::load(const Scene& scene, const CompileOptions& options, StageReport* report) {
  StageReport local;
  StageReport& rep = report ? *report : local;
  auto say = [&](const std::string& m) {
    if (options.progress) options.progress(m);
  };
  std::string compiler = options.compiler;
  if (compiler.empty()) compiler = std::getenv("CXX") && *std::getenv("CXX") ? std::getenv("CXX") : "c++";
  const std::string compiler_id = first_line_of_command(shell_quote(compiler) + " --version 2>/dev/null");
  if (compiler_id.empty()) throw CompileError("C++ compiler '" + compiler + "' not found (set CXX)");

  const std::string key = content_hash(scene.content + '\0' + kGeneratorVersion + '\0' + generator_identity() + '\0' +
                                       compiler_id + '\0' +
                                       options.flags + '\0' + SPACEARM_EIGEN_INCLUDE_DIR);
  const fs::path cache = cache_directory(options);
  const fs::path entry = cache / (scene.name + "-" + key);
  rep.cache_entry = entry.string();
  const fs::path library = entry / "libmodel.so";
  const fs::path complete = entry / "COMPLETE";

  // An entry is valid only with its COMPLETE marker (written last) and a library that
  // loads; a corrupted entry is removed and built again, once.
  for (int attempt = 0;; ++attempt) {
  if (!(fs::exists(complete) && fs::exists(library))) {
    fs::create_directories(cache);
    // Build in a private folder, then rename into place: a failed or concurrent build never
    // leaves a half-written entry behind.
    const fs::path work = cache / (scene.name + "-" + key + ".tmp-" + std::to_string(getpid()));
    fs::remove_all(work);
    fs::create_directories(work);
    say("deriving " + scene.name);
    auto t0 = std::chrono::steady_clock::now();
    const SymbolicModel model = derive(scene);
    rep.derive_ms = ms_since(t0);
    say("emitting C++");
    t0 = std::chrono::steady_clock::now();
    EmitOptions eo;
    eo.scene_path = scene.source_path;
    eo.command = "spacearm (compile-and-load cache)";
    const EmittedModel emitted = emit_cpp(model, eo);
    write_files(emitted, work.string());
    write_file(work / "c_api.cpp", c_api_source(scene, emitted.header_name));
    rep.emit_ms = ms_since(t0);
    rep.generated = true;

    say("compiling with " + compiler);
    t0 = std::chrono::steady_clock::now();
    const fs::path log = work / "compile.log";
    const std::string command = shell_quote(compiler) + " " + options.flags + " -I" +
                                shell_quote(SPACEARM_EIGEN_INCLUDE_DIR) + " -I" + shell_quote(work.string()) + " " +
                                shell_quote((work / emitted.source_name).string()) + " " +
                                shell_quote((work / "c_api.cpp").string()) + " -o " +
                                shell_quote((work / "libmodel.so").string()) + " > " + shell_quote(log.string()) +
                                " 2>&1";
    write_file(work / "compile_command.txt", command + "\n");
    const int status = std::system(command.c_str());
    rep.compile_ms = ms_since(t0);
    if (status != 0) {
      // Keep the failed sources for inspection, outside the valid entries.
      const fs::path failed = cache / "failed" / (scene.name + "-" + key);
      fs::remove_all(failed);
      fs::create_directories(failed.parent_path());
      fs::rename(work, failed);
      throw CompileError("compiling model '" + scene.name + "' failed:\n" + read_file(failed / "compile.log") +
                         "sources and command: " + failed.string());
    }
    rep.compiled = true;
    // The marker records the library's hash: a truncated or altered library is detected
    // before dlopen (mapping a truncated ELF file can crash the process instead of failing).
    write_file(work / "COMPLETE", "library " + content_hash(read_file(work / "libmodel.so")) + "\nscene " +
                                      scene.source_path + "\ngenerator " + kGeneratorVersion + "\ncompiler " +
                                      compiler_id + "\nflags " + options.flags + "\n");
    std::error_code ec;
    fs::remove_all(entry, ec);  // an incomplete entry left by a crash
    fs::rename(work, entry, ec);
    if (ec) {
      // Another process finished the same entry first: use it, drop ours.
      fs::remove_all(work);
      if (!fs::exists(complete)) throw CompileError("cannot install cache entry '" + entry.string() + "': " + ec.message());
    }
  }

  const std::string marker = read_file(complete);
  if (marker.rfind("library " + content_hash(read_file(library)) + "\n", 0) != 0) {
    if (attempt == 0 && !rep.compiled) {
      say("cache entry " + entry.string() + " is corrupted (library does not match its hash): rebuilding");
      fs::remove_all(entry);
      continue;
    }
    throw CompileError("cache entry '" + entry.string() + "' is corrupted and could not be rebuilt");
  }
  say("loading " + library.string());
  const auto t0 = std::chrono::steady_clock::now();
  CompiledModel m;
  m.handle_ = dlopen(library.c_str(), RTLD_NOW | RTLD_LOCAL);
  auto sym = [&](const char* name) { return m.handle_ ? dlsym(m.handle_, name) : nullptr; };
  auto abi = reinterpret_cast<int (*)()>(sym("spacearm_abi_version"));
  if (!m.handle_ || !abi || abi() != kAbiVersion) {
    const std::string why = m.handle_ ? "wrong interface version" : dlerror();
    if (attempt == 0 && !rep.compiled) {
      say("cache entry " + entry.string() + " is corrupted (" + why + "): rebuilding");
      fs::remove_all(entry);
      continue;
    }
    throw CompileError("cannot load '" + library.string() + "': " + why);
  }
  m.nq_ = reinterpret_cast<int (*)()>(sym("spacearm_nq"))();
  m.num_links_ = reinterpret_cast<int (*)()>(sym("spacearm_num_links"))();
  m.outputs_ = reinterpret_cast<unsigned (*)()>(sym("spacearm_outputs"))();
  const int np = reinterpret_cast<int (*)()>(sym("spacearm_num_params"))();
  auto coordinate = reinterpret_cast<const char* (*)(int)>(sym("spacearm_coordinate_name"));
  auto parameter = reinterpret_cast<const char* (*)(int)>(sym("spacearm_parameter_name"));
  auto nominal = reinterpret_cast<double (*)(int)>(sym("spacearm_nominal_parameter"));
  for (int i = 0; i < m.nq_; ++i) m.coordinate_names_.push_back(coordinate(i));
  for (int i = 0; i < np; ++i) {
    m.parameter_names_.push_back(parameter(i));
    m.nominal_.push_back(nominal(i));
  }
  m.api_ = std::make_unique<Api>();
  m.api_->mass_matrix = reinterpret_cast<Api::Vec>(sym("spacearm_mass_matrix"));
  m.api_->coriolis_matrix = reinterpret_cast<Api::VecVel>(sym("spacearm_coriolis_matrix"));
  m.api_->bias_forces = reinterpret_cast<Api::VecVel>(sym("spacearm_bias_forces"));
  m.api_->momentum = reinterpret_cast<Api::VecVel>(sym("spacearm_momentum"));
  m.api_->end_effector_pose = reinterpret_cast<Api::Vec>(sym("spacearm_end_effector_pose"));
  m.api_->kinetic_energy = reinterpret_cast<double (*)(const double*, const double*, const double*)>(
      sym("spacearm_kinetic_energy"));
  m.api_->gear_ratios = reinterpret_cast<void (*)(const double*, double*)>(sym("spacearm_gear_ratios"));
  m.api_->parameter_error = reinterpret_cast<const char* (*)(const double*)>(sym("spacearm_parameter_error"));
  rep.load_ms = ms_since(t0);
  return m;
  }
}

CompiledModel::~CompiledModel() {
  if (handle_) dlclose(handle_);
}
CompiledModel::CompiledModel(CompiledModel&& o) noexcept { *this = std::move(o); }
CompiledModel& CompiledModel::operator=(CompiledModel&& o) noexcept {
  std::swap(api_, o.api_);
  std::swap(handle_, o.handle_);
  nq_ = o.nq_;
  num_links_ = o.num_links_;
  outputs_ = o.outputs_;
  coordinate_names_ = std::move(o.coordinate_names_);
  parameter_names_ = std::move(o.parameter_names_);
  nominal_ = std::move(o.nominal_);
  return *this;
}

bool CompiledModel::has(Output o) const { return (outputs_ >> static_cast<unsigned>(o)) & 1u; }

void CompiledModel::check(const char* what, const Eigen::VectorXd& v, int size) const {
  if (v.size() != size)
    throw std::invalid_argument(std::string(what) + ": expected " + std::to_string(size) + " values, got " +
                                std::to_string(v.size()));
  for (int i = 0; i < size; ++i)
    if (!std::isfinite(v[i]))
      throw std::invalid_argument(std::string(what) + "[" + std::to_string(i) + "] is not finite: " +
                                  std::to_string(v[i]));
  if (std::string(what) == "params")
    if (const char* error = api_->parameter_error(v.data()))
      throw std::invalid_argument(std::string("parameters: ") + error);
}

void CompiledModel::require(Output o) const {
  if (!has(o)) throw std::invalid_argument("the scene does not emit '" + to_string(o) + "' (add it to outputs)");
}

Eigen::MatrixXd CompiledModel::mass_matrix(const Eigen::VectorXd& q, const Eigen::VectorXd& params) const {
  require(Output::mass_matrix);
  check("q", q, nq_);
  check("params", params, static_cast<int>(nominal_.size()));
  Eigen::MatrixXd M(nq_, nq_);
  api_->mass_matrix(q.data(), params.data(), M.data());
  return M;
}

Eigen::MatrixXd CompiledModel::coriolis_matrix(const Eigen::VectorXd& q, const Eigen::VectorXd& qd,
                                               const Eigen::VectorXd& params) const {
  require(Output::coriolis_matrix);
  check("q", q, nq_);
  check("qd", qd, nq_);
  check("params", params, static_cast<int>(nominal_.size()));
  Eigen::MatrixXd C(nq_, nq_);
  api_->coriolis_matrix(q.data(), qd.data(), params.data(), C.data());
  return C;
}

Eigen::VectorXd CompiledModel::bias_forces(const Eigen::VectorXd& q, const Eigen::VectorXd& qd,
                                           const Eigen::VectorXd& params) const {
  require(Output::bias_forces);
  check("q", q, nq_);
  check("qd", qd, nq_);
  check("params", params, static_cast<int>(nominal_.size()));
  Eigen::VectorXd b(nq_);
  api_->bias_forces(q.data(), qd.data(), params.data(), b.data());
  return b;
}

double CompiledModel::kinetic_energy(const Eigen::VectorXd& q, const Eigen::VectorXd& qd,
                                     const Eigen::VectorXd& params) const {
  require(Output::kinetic_energy);
  check("q", q, nq_);
  check("qd", qd, nq_);
  check("params", params, static_cast<int>(nominal_.size()));
  return api_->kinetic_energy(q.data(), qd.data(), params.data());
}

Eigen::Vector3d CompiledModel::momentum(const Eigen::VectorXd& q, const Eigen::VectorXd& qd,
                                        const Eigen::VectorXd& params) const {
  require(Output::momentum);
  check("q", q, nq_);
  check("qd", qd, nq_);
  check("params", params, static_cast<int>(nominal_.size()));
  Eigen::Vector3d h;
  api_->momentum(q.data(), qd.data(), params.data(), h.data());
  return h;
}

Eigen::Vector3d CompiledModel::end_effector_pose(const Eigen::VectorXd& q, const Eigen::VectorXd& params) const {
  require(Output::end_effector_pose);
  check("q", q, nq_);
  check("params", params, static_cast<int>(nominal_.size()));
  Eigen::Vector3d x;
  api_->end_effector_pose(q.data(), params.data(), x.data());
  return x;
}

Eigen::VectorXd CompiledModel::gear_ratios(const Eigen::VectorXd& params) const {
  check("params", params, static_cast<int>(nominal_.size()));
  Eigen::VectorXd r(num_links_);
  api_->gear_ratios(params.data(), r.data());
  return r;
}

}  // namespace spacearm
