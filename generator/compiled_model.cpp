#include "compiled_model.hpp"

#include <dlfcn.h>
#include <unistd.h>

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

constexpr int kAbiVersion = 3;

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

// First line the compiler prints for --version (its identity in the cache key), run
// without a shell.
std::string compiler_identity(const std::string& compiler, const std::string& scratch) {
  if (run_interruptible({compiler, "--version"}, scratch, nullptr) != 0) return "";
  std::ifstream in(scratch);
  std::string line;
  std::getline(in, line);
  std::error_code ec;
  fs::remove(scratch, ec);
  while (!line.empty() && (line.back() == '\r' || line.back() == ' ')) line.pop_back();
  return line;
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
  out.close();
  if (!out) throw CompileError("cannot write '" + p.string() + "'");
}

std::vector<std::string> split_flags(const std::string& flags) {
  std::vector<std::string> out;
  std::istringstream in(flags);
  for (std::string f; in >> f;) out.push_back(f);
  return out;
}

// Identity of the running generator: a hash of its own executable, so that a rebuilt
// generator (which may emit different code under the same version number) gets new entries.
const std::string& generator_identity() {
  static const std::string id = sha256_hex(read_file("/proc/self/exe")) + "-abi" + std::to_string(kAbiVersion);
  return id;
}

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

// The C symbols a library must export for `scene` (checked before anything is called).
std::vector<std::string> required_symbols(const Scene& scene) {
  std::vector<std::string> names = {"spacearm_abi_version",     "spacearm_nq",           "spacearm_num_links",
                                    "spacearm_num_params",      "spacearm_coordinate_name", "spacearm_parameter_name",
                                    "spacearm_nominal_parameter", "spacearm_outputs",    "spacearm_parameter_error",
                                    "spacearm_gear_ratios"};
  for (Output o : {Output::mass_matrix, Output::coriolis_matrix, Output::bias_forces, Output::kinetic_energy,
                   Output::momentum, Output::end_effector_pose})
    if (scene.wants(o)) names.push_back("spacearm_" + to_string(o));
  return names;
}

// Generates and compiles the scene into a new work folder; returns it, ready to install.
std::string build_entry(const Scene& scene, const CacheFolder& cache, const std::string& entry,
                        const std::string& compiler, const std::string& compiler_id, const CompileOptions& options,
                        StageReport& rep) {
  auto say = [&](const std::string& m) {
    if (options.progress) options.progress(m);
  };
  const std::string work = cache.make_work_folder(entry);
  try {
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
    write_files(emitted, work);
    write_file(fs::path(work) / "c_api.cpp", c_api_source(scene, emitted.header_name));
    rep.emit_ms = ms_since(t0);
    rep.generated = true;

    say("compiling with " + compiler);
    t0 = std::chrono::steady_clock::now();
    std::vector<std::string> argv{compiler};
    for (const auto& f : split_flags(options.flags)) argv.push_back(f);
    for (const std::string& a : {"-I" + std::string(SPACEARM_EIGEN_INCLUDE_DIR), "-I" + work,
                                work + "/" + emitted.source_name, work + "/c_api.cpp", std::string("-o"), work + "/libmodel.so"})
      argv.push_back(a);
    std::string shown;
    for (const auto& a : argv) shown += (shown.empty() ? "" : " ") + a;
    write_file(fs::path(work) / "compile_command.txt", shown + "\n");
    const int status = run_interruptible(argv, work + "/compile.log", [&] {
      std::error_code ec;
      fs::remove_all(work, ec);
    });
    rep.compile_ms = ms_since(t0);
    if (status == -2) throw CompileError("compiling model '" + scene.name + "' was interrupted");
    if (status != 0) {
      const std::string log = read_file(fs::path(work) / "compile.log");
      const std::string kept = cache.keep_failed(work, entry);
      throw CompileError("compiling model '" + scene.name + "' failed" +
                         (status < 0 ? " (could not run '" + compiler + "')" : "") + ":\n" + log +
                         "sources and command: " + kept);
    }
    rep.compiled = true;
    // The marker, written last, records the library's SHA-256 on its first line.
    write_file(fs::path(work) / "COMPLETE",
               "sha256 " + sha256_hex(read_file(fs::path(work) / "libmodel.so")) + "\ngenerator " +
                   kGeneratorVersion + "\ncompiler " + compiler_id + "\nflags " + options.flags + "\n");
    return work;
  } catch (...) {
    std::error_code ec;
    fs::remove_all(work, ec);
    throw;
  }
}

}  // namespace

std::string cache_directory(const CompileOptions& options) {
  if (!options.cache_dir.empty()) return options.cache_dir;
  if (const char* d = std::getenv("SPACEARM_CACHE_DIR"); d && *d) return d;
  if (const char* d = std::getenv("XDG_CACHE_HOME"); d && *d) return std::string(d) + "/spacearm";
  if (const char* h = std::getenv("HOME"); h && *h) return std::string(h) + "/.cache/spacearm";
  throw CompileError(
      "no cache folder for compiled models: set HOME, XDG_CACHE_HOME or SPACEARM_CACHE_DIR, or pass --cache-dir");
}

CompiledModel CompiledModel::load(const Scene& scene, const CompileOptions& options, StageReport* report) {
  StageReport local;
  StageReport& rep = report ? *report : local;
  auto say = [&](const std::string& m) {
    if (options.progress) options.progress(m);
  };
  const CacheFolder cache(cache_directory(options));
  cache.remove_stale_work();
  std::string compiler = options.compiler;
  if (compiler.empty()) compiler = std::getenv("CXX") && *std::getenv("CXX") ? std::getenv("CXX") : "c++";
  const std::string compiler_id =
      compiler_identity(compiler, cache.path() + "/.tmp-" + std::to_string(getpid()) + "-compiler-version");
  if (compiler_id.empty()) throw CompileError("C++ compiler '" + compiler + "' not found (set CXX)");

  const std::string key = sha256_hex(scene.content + '\0' + kGeneratorVersion + '\0' + generator_identity() +
                                     '\0' + compiler_id + '\0' + options.flags + '\0' + SPACEARM_EIGEN_INCLUDE_DIR)
                              .substr(0, 32);
  const std::string entry = scene.name + "-" + key;
  rep.cache_entry = cache.path() + "/" + entry;

  // A verified entry is loaded; an incomplete or corrupted one is discarded and built
  // again, once. A racing process may install the entry first: then its entry is used.
  for (int attempt = 0;; ++attempt) {
    std::string problem;
    Fd library = cache.open_library(entry, problem);
    if (!library.valid()) {
      if (attempt > 1 || (attempt == 1 && rep.compiled))
        throw CompileError("cache entry '" + rep.cache_entry + "' is " + problem + " after a fresh build");
      if (problem != "absent") {
        say("cache entry " + rep.cache_entry + " is " + problem + ": rebuilding");
        cache.discard(entry);
      }
      const std::string work = build_entry(scene, cache, entry, compiler, compiler_id, options, rep);
      cache.install(work, entry);
      continue;
    }
    std::string why;
    CompiledModel m = open_verified(scene, library, rep, why);
    if (why.empty()) return m;
    if (attempt > 0 || rep.compiled)
      throw CompileError("cannot load '" + rep.cache_entry + "/libmodel.so': " + why);
    say("cache entry " + rep.cache_entry + " is corrupted (" + why + "): rebuilding");
    cache.discard(entry);
  }
}

// dlopen of the verified open file (through /proc/self/fd, so the bytes hashed are the
// bytes mapped), then every symbol the scene needs is looked up before any is called.
CompiledModel CompiledModel::open_verified(const Scene& scene, const Fd& library, StageReport& rep, std::string& why) {
  const auto t0 = std::chrono::steady_clock::now();
  CompiledModel m;
  const std::string path = "/proc/self/fd/" + std::to_string(library.get());
  m.handle_ = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!m.handle_) {
    const char* e = dlerror();
    why = e ? e : "dlopen failed";
    return m;
  }
  for (const auto& name : required_symbols(scene))
    if (!dlsym(m.handle_, name.c_str())) {
      why = "the library lacks the symbol " + name;
      return m;
    }
  auto sym = [&](const char* name) { return dlsym(m.handle_, name); };
  if (reinterpret_cast<int (*)()>(sym("spacearm_abi_version"))() != kAbiVersion) {
    why = "wrong interface version";
    return m;
  }
  m.nq_ = reinterpret_cast<int (*)()>(sym("spacearm_nq"))();
  m.num_links_ = reinterpret_cast<int (*)()>(sym("spacearm_num_links"))();
  m.outputs_ = reinterpret_cast<unsigned (*)()>(sym("spacearm_outputs"))();
  const int np = reinterpret_cast<int (*)()>(sym("spacearm_num_params"))();
  if (m.nq_ != scene.num_coordinates() || m.num_links_ != scene.num_links() ||
      np != static_cast<int>(scene.parameters.size())) {
    why = "its sizes do not match the scene";
    return m;
  }
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
  m.api_->kinetic_energy =
      reinterpret_cast<double (*)(const double*, const double*, const double*)>(sym("spacearm_kinetic_energy"));
  m.api_->gear_ratios = reinterpret_cast<void (*)(const double*, double*)>(sym("spacearm_gear_ratios"));
  m.api_->parameter_error = reinterpret_cast<const char* (*)(const double*)>(sym("spacearm_parameter_error"));
  rep.load_ms = ms_since(t0);
  return m;
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
