#include "compiled_model.hpp"

#include <dlfcn.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>

#include <Eigen/Cholesky>

#include <sstream>
#include <tuple>

#include "dynamics_checks.hpp"

#include "cpp_emitter.hpp"
#include "outputs.hpp"
#include "symbolic_model.hpp"

namespace spacearm {

namespace fs = std::filesystem;

namespace {

// The whole content of a memory file (a log).
std::string read_log(const Fd& log) {
  try {
    return read_all(log.get(), "compiler log", 1 << 24);
  } catch (const FolderError& e) {
    return std::string("(") + e.what() + ")\n";
  }
}

// Why a compiler could not be run, as a message: "not found" only when it is not there.
std::string cannot_run(const std::string& compiler, int error) {
  if (error == ENOENT) return "C++ compiler '" + compiler + "' not found (set CXX)";
  return "cannot run the C++ compiler '" + compiler + "': " + std::strerror(error);
}

// First line the compiler prints for --version (its identity in the cache key), run without
// a shell in the cache folder; empty if it cannot be run, with `problem` saying why.
std::string compiler_identity(const std::string& compiler, int work_dir, std::string& problem) {
  const Fd log = memory_file("spacearm-compiler-version");
  const RunResult r = run_interruptible({compiler, "--version"}, work_dir, log.get(), nullptr);
  if (r.interrupted) throw CompileError("interrupted while asking '" + compiler + "' its version");
  if (r.status < 0) problem = cannot_run(compiler, r.start_error);
  if (r.status > 0)
    problem = "the C++ compiler '" + compiler + "' failed to print its version (exit status " +
              std::to_string(r.status) + "): " + read_log(log).substr(0, 200);
  if (r.status != 0) return "";
  std::string line = read_log(log);
  line = line.substr(0, line.find('\n'));
  while (!line.empty() && (line.back() == '\r' || line.back() == ' ')) line.pop_back();
  if (line.empty()) problem = "the C++ compiler '" + compiler + "' printed no version";
  return line;
}

std::string read_file(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
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
  static const std::string id =
      sha256_hex(read_file("/proc/self/exe")) + "-abi" + std::to_string(kCInterfaceVersion);
  return id;
}

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

// The self-description every library exports (cpp_printer.hpp), checked before anything is
// called.
const std::vector<std::string>& description_symbols() {
  static const std::vector<std::string> names = {"spacearm_abi_version",
                                                 "spacearm_nq",
                                                 "spacearm_nv",
                                                 "spacearm_num_links",
                                                 "spacearm_num_params",
                                                 "spacearm_coordinate_name",
                                                 "spacearm_parameter_name",
                                                 "spacearm_nominal_parameter",
                                                 "spacearm_outputs",
                                                 "spacearm_scene_hash",
                                                 "spacearm_parameter_error",
                                                 "spacearm_actuated_coordinate",
                                                 "spacearm_name",
                                                 "spacearm_num_base",
                                                 "spacearm_free_floating",
                                                 "spacearm_passive_forces",
                                                 "spacearm_configuration_layout",
                                                 "spacearm_spatial",
                                                 "spacearm_slot_holds_motor"};
  return names;
}

// The functions a library with the outputs `mask` exports: gear_ratios, one per output, and M
// and b in one call where it has both.
std::vector<std::string> exported_functions(unsigned long mask) {
  std::vector<std::string> names = {"gear_ratios"};
  for (const auto& o : output_registry())
    if (mask & output_bit(o.id)) names.push_back(o.name);
  if ((mask & output_bit(Output::mass_matrix)) && (mask & output_bit(Output::bias_forces)))
    names.push_back(kMassMatrixAndBias);
  return names;
}

// Generates and compiles the scene into a new work folder; returns it, ready to install.
// Every file is written and read relative to the folder's descriptor, and the compiler runs
// inside it with relative names: nothing goes through the cache's path again.
WorkFolder build_entry(const Scene& scene, const CacheFolder& cache, const std::string& entry,
                       const std::string& compiler, const std::string& compiler_id,
                       const CompileOptions& options, StageReport& rep) {
  auto say = [&](const std::string& m) {
    if (options.progress) options.progress(m);
  };
  WorkFolder work = cache.make_work_folder(entry);
  const std::string shown = cache.path() + "/" + work.name;
  const int dir = work.fd.get();
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
    // Only the self-contained C interface is compiled (no Eigen: cpp_printer.cpp says why).
    write_new_file_at(dir, "libmodel.cpp", emitted.c_interface, shown + "/libmodel.cpp");
    rep.emit_ms = ms_since(t0);
    rep.generated = true;

    say("compiling with " + compiler);
    t0 = std::chrono::steady_clock::now();
    std::vector<std::string> argv{compiler};
    for (const auto& f : split_flags(options.flags)) argv.push_back(f);
    for (const char* a : {"libmodel.cpp", "-o", "libmodel.so"}) argv.push_back(a);
    for (const auto& l : split_flags(options.libraries)) argv.push_back(l);
    std::string command;
    for (const auto& a : argv) command += (command.empty() ? "" : " ") + a;
    write_new_file_at(dir, "compile_command.txt", "cd " + shown + " && " + command + "\n",
                      shown + "/compile_command.txt");
    // The log in memory: the compiler's messages survive a full disk.
    const Fd log = memory_file("spacearm-compile-log");
    const RunResult run = run_interruptible(argv, dir, log.get(), [&] { cache.remove(work); });
    rep.compile_ms = ms_since(t0);
    if (run.interrupted) throw CompileError("compiling model '" + scene.name + "' was interrupted");
    if (run.status != 0) {
      const std::string text =
          run.status < 0 ? cannot_run(compiler, run.start_error) + "\n" : read_log(log);
      try {
        write_new_file_at(dir, "compile.log", text, shown + "/compile.log");
      } catch (const FolderError&) {  // a full disk: the message below still has the log
      }
      const std::string kept = cache.keep_failed(work, entry);
      throw CompileError(
          "compiling model '" + scene.name + "' failed" +
          (text.empty() ? " without a message (exit status " + std::to_string(run.status) + ")"
                        : "") +
          ":\n" + text + "sources and command: " + kept);
    }
    rep.compiled = true;
    // The marker, written last, records the library's SHA-256 on its first line.
    const Fd library =
        open_private_at(dir, "libmodel.so", false, shown + "/libmodel.so", "compiled library");
    if (!library.valid()) throw CompileError("the compiler wrote no '" + shown + "/libmodel.so'");
    write_new_file_at(dir, "COMPLETE",
                      "sha256 " + sha256_hex(read_all(library.get(), shown + "/libmodel.so")) +
                          "\ngenerator " + kGeneratorVersion + "\ncompiler " + compiler_id +
                          "\nflags " + options.flags + "\nlibraries " + options.libraries + "\n",
                      shown + "/COMPLETE");
    return work;
  } catch (const FolderError& e) {
    cache.remove(work);
    throw CompileError(e.what());
  } catch (...) {
    cache.remove(work);
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
      "no cache folder for compiled models: set HOME, XDG_CACHE_HOME or SPACEARM_CACHE_DIR, or "
      "pass --cache-dir");
}

// Entries are named SCENE-SOURCE-COMPILER: the hash of what the code is made from (scene,
// generator, flags, libraries), then of the compiler's identity. Without a compiler (a Dask
// worker's image, a read-only cache), an entry of the same source built by any compiler loads.
CompiledModel CompiledModel::load(const Scene& scene, const CompileOptions& options,
                                  StageReport* report) {
  StageReport local;
  StageReport& rep = report ? *report : local;
  auto say = [&](const std::string& m) {
    if (options.progress) options.progress(m);
  };
  const CacheFolder cache(cache_directory(options));
  cache.remove_stale_work();
  std::string compiler = options.compiler;
  if (compiler.empty())
    compiler = std::getenv("CXX") && *std::getenv("CXX") ? std::getenv("CXX") : "c++";
  const std::string source =
      scene.name + "-" +
      sha256_hex(scene.content + '\0' + kGeneratorVersion + '\0' + generator_identity() + '\0' +
                 options.flags + '\0' + options.libraries)
          .substr(0, 24) +
      "-";
  std::string no_compiler;
  const std::string compiler_id = compiler_identity(compiler, cache.fd(), no_compiler);
  if (compiler_id.empty()) return load_built(scene, cache, source, no_compiler, rep);
  const std::string entry = source + sha256_hex(compiler_id).substr(0, 8);
  rep.cache_entry = cache.path() + "/" + entry;

  // A verified entry is loaded; an incomplete or corrupted one is discarded and built
  // again, once. A racing process may install the entry first: then its entry is used.
  for (int attempt = 0;; ++attempt) {
    std::string problem;
    Fd library = cache.open_library(entry, problem);
    if (!library.valid()) {
      if (attempt > 1 || (attempt == 1 && rep.compiled))
        throw CompileError("cache entry '" + rep.cache_entry + "' is " + problem +
                           " after a fresh build");
      if (problem != "absent") {
        say("cache entry " + rep.cache_entry + " is " + problem + ": rebuilding");
        cache.discard(entry);
      }
      const WorkFolder work = build_entry(scene, cache, entry, compiler, compiler_id, options, rep);
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

// A complete, verified entry of `source` built before by any compiler; nothing is written.
CompiledModel CompiledModel::load_built(const Scene& scene, const CacheFolder& cache,
                                        const std::string& source, const std::string& no_compiler,
                                        StageReport& rep) {
  std::string last;
  for (const auto& entry : cache.entries_starting_with(source)) {
    rep.cache_entry = cache.path() + "/" + entry;
    std::string problem;
    Fd library;
    try {  // an unusable entry (a link, a pipe) does not hide a good one
      library = cache.open_library(entry, problem);
    } catch (const CompileError& e) {
      last = std::string("; ") + e.what();
      continue;
    }
    if (!library.valid()) {
      last = "; '" + rep.cache_entry + "' is " + problem;
      continue;
    }
    std::string why;
    CompiledModel m = open_verified(scene, library, rep, why);
    if (why.empty()) return m;
    last = "; '" + rep.cache_entry + "/libmodel.so' cannot be loaded: " + why;
  }
  throw CompileError(no_compiler + ", and the cache folder '" + cache.path() +
                     "' holds no complete build of model '" + scene.name + "' to load instead" +
                     last);
}

// dlopen hands back a loaded library for any name that library was opened by, and
// /proc/self/fd/N names another file once N is reused: each load spells the descriptor's path
// in a way never used before in this process ("./" and ".//" segments, a counter in binary,
// which the kernel resolves to the same descriptor). Nothing is written: a read-only cache
// loads too.
std::string never_used_path(int fd) {
  static std::atomic<unsigned long> loads{0};
  std::string path = "/proc/self/fd/";
  for (unsigned long k = loads++;; k >>= 1) {
    path += (k & 1) ? ".//" : "./";
    if (k <= 1) break;
  }
  return path + std::to_string(fd);
}

// dlopen of the verified open file (through /proc/self/fd, so the bytes hashed are the bytes
// mapped), then every symbol the scene needs is looked up before any is called, and the
// library's scene hash must be this scene's.
CompiledModel CompiledModel::open_verified(const Scene& scene, const Fd& library, StageReport& rep,
                                           std::string& why) {
  const auto t0 = std::chrono::steady_clock::now();
  CompiledModel m;
  m.handle_ = dlopen(never_used_path(library.get()).c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!m.handle_) {
    const char* e = dlerror();
    why = e ? e : "dlopen failed";
    return m;
  }
  for (const auto& name : description_symbols())
    if (!dlsym(m.handle_, name.c_str())) {
      why = "the library lacks the symbol " + name;
      return m;
    }
  auto sym = [&](const std::string& name) { return dlsym(m.handle_, name.c_str()); };
  auto number = [&](const char* name) { return reinterpret_cast<int (*)()>(sym(name))(); };
  if (number("spacearm_abi_version") != kCInterfaceVersion) {
    why = "wrong interface version";
    return m;
  }
  // The library of this scene, not another one the process has loaded (dlopen matches names).
  const std::string hash = reinterpret_cast<const char* (*)()>(sym("spacearm_scene_hash"))();
  if (hash != "fnv1a64:" + content_hash(scene.content)) {
    why = "it was built from another scene (" + hash + ")";
    return m;
  }
  // The model's facts, as the library states them.
  m.name_ = reinterpret_cast<const char* (*)()>(sym("spacearm_name"))();
  m.dims_ = {number("spacearm_nq"), number("spacearm_nv"), number("spacearm_num_links"),
             number("spacearm_spatial") != 0};
  m.num_base_ = number("spacearm_num_base");
  m.free_floating_ = number("spacearm_free_floating") != 0;
  m.passive_forces_ = number("spacearm_passive_forces") != 0;
  m.quaternion_offset_ = number("spacearm_configuration_layout");
  m.outputs_ = reinterpret_cast<unsigned long (*)()>(sym("spacearm_outputs"))();
  const int np = number("spacearm_num_params");
  auto coordinate = reinterpret_cast<const char* (*)(int)>(sym("spacearm_coordinate_name"));
  auto parameter = reinterpret_cast<const char* (*)(int)>(sym("spacearm_parameter_name"));
  auto nominal = reinterpret_cast<double (*)(int)>(sym("spacearm_nominal_parameter"));
  auto actuated = reinterpret_cast<int (*)(int)>(sym("spacearm_actuated_coordinate"));
  if (m.dims_.nq < 0 || m.dims_.nv < 0 || m.dims_.num_links < 0 || np < 0) {
    why = "it states negative sizes";
    return m;
  }
  for (int i = 0; i < m.dims_.nq; ++i) m.coordinate_names_.push_back(coordinate(i));
  for (int i = 0; i < np; ++i) {
    m.parameter_names_.push_back(parameter(i));
    m.nominal_.push_back(nominal(i));
  }
  auto motor_on_slot = reinterpret_cast<int (*)(int)>(sym("spacearm_slot_holds_motor"));
  for (int j = 0; j < m.dims_.num_links; ++j) {
    m.actuated_.push_back(actuated(j));
    m.motor_angle_slots_.push_back(motor_on_slot(j) != 0);
  }
  // A cross-check only: the hash already names the scene.
  if (m.name_ != scene.name || m.dims_.nq != scene.num_coordinates() ||
      m.dims_.nv != scene.num_velocities() || m.dims_.num_links != scene.num_links() ||
      np != static_cast<int>(scene.parameters.size()) || m.outputs_ != output_mask(scene.outputs) ||
      m.free_floating_ != scene.free_floating()) {
    why = "its facts do not match the scene";
    return m;
  }
  for (int j = 0; j < m.dims_.num_links; ++j)
    if (m.motor_angle_slots_[j] != (scene.has_gear(j) && !scene.is_flexible(j))) {
      why = "its joint slots do not match the scene";
      return m;
    }
  m.parameter_error_ =
      reinterpret_cast<const char* (*)(const double*)>(sym("spacearm_parameter_error"));
  for (const auto& f : exported_functions(m.outputs_)) {
    m.functions_[f] = reinterpret_cast<Function>(sym("spacearm_" + f));
    if (!m.functions_[f]) {
      why = "the library lacks the symbol spacearm_" + f;
      return m;
    }
  }
  rep.load_ms = ms_since(t0);
  return m;
}

CompiledModel::~CompiledModel() {
  if (handle_) dlclose(handle_);
}
CompiledModel::CompiledModel(CompiledModel&& o) noexcept { *this = std::move(o); }
CompiledModel& CompiledModel::operator=(CompiledModel&& o) noexcept {
  std::swap(handle_, o.handle_);
  dims_ = o.dims_;
  name_ = std::move(o.name_);
  outputs_ = o.outputs_;
  functions_ = std::move(o.functions_);
  parameter_error_ = o.parameter_error_;
  coordinate_names_ = std::move(o.coordinate_names_);
  parameter_names_ = std::move(o.parameter_names_);
  nominal_ = std::move(o.nominal_);
  actuated_ = std::move(o.actuated_);
  motor_angle_slots_ = std::move(o.motor_angle_slots_);
  free_floating_ = o.free_floating_;
  passive_forces_ = o.passive_forces_;
  num_base_ = o.num_base_;
  quaternion_offset_ = o.quaternion_offset_;
  return *this;
}

bool CompiledModel::has(Output o) const { return (outputs_ & output_bit(o)) != 0; }

CompiledModel::Function CompiledModel::function(Output o) const {
  if (!has(o))
    throw std::invalid_argument("the scene does not emit '" + std::string(info(o).name) +
                                "' (add it to outputs)");
  return functions_.at(info(o).name);
}

void CompiledModel::check(const char* what, Eigen::Ref<const Eigen::VectorXd> v, int size) const {
  if (v.size() != size)
    throw std::invalid_argument(std::string(what) + ": expected " + std::to_string(size) +
                                " values, got " + std::to_string(v.size()));
  for (int i = 0; i < size; ++i)
    if (!std::isfinite(v[i]))
      throw std::invalid_argument(std::string(what) + "[" + std::to_string(i) +
                                  "] is not finite: " + std::to_string(v[i]));
}

// Calls an exported function with checked parameters; results sized by `shapes`.
std::vector<Eigen::MatrixXd> CompiledModel::call(const std::string& function,
                                                 const std::vector<std::pair<Size, Size>>& shapes,
                                                 const std::vector<const double*>& inputs,
                                                 const Eigen::VectorXd& params) const {
  check("params", params, static_cast<int>(nominal_.size()));
  if (const char* error = parameter_error_(params.data()))
    throw std::invalid_argument(std::string("parameters: ") + error);
  std::vector<Eigen::MatrixXd> results;
  std::vector<double*> out;
  for (const auto& [rows, cols] : shapes) results.emplace_back(dims_(rows), dims_(cols));
  for (auto& r : results) out.push_back(r.data());
  functions_.at(function)(inputs.data(), params.data(), out.data());
  return results;
}

std::vector<Eigen::MatrixXd> CompiledModel::evaluate(Output o,
                                                     const std::vector<Eigen::VectorXd>& inputs,
                                                     const Eigen::VectorXd& params) const {
  const OutputInfo& out = info(o);
  if (!has(o))
    throw std::invalid_argument("the scene does not emit '" + std::string(out.name) +
                                "' (add it to outputs)");
  if (inputs.size() != out.inputs.size())
    throw std::invalid_argument(std::string(out.name) + " takes " +
                                std::to_string(out.inputs.size()) + " inputs, got " +
                                std::to_string(inputs.size()));
  std::vector<const double*> data;
  for (size_t i = 0; i < inputs.size(); ++i) {
    check(info(out.inputs[i]).name, inputs[i], dims_(info(out.inputs[i]).size));
    data.push_back(inputs[i].data());
  }
  std::vector<std::pair<Size, Size>> shapes;
  for (const auto& r : out.results) shapes.push_back({r.rows, r.cols});
  return call(out.name, shapes, data, params);
}

namespace {

// Runs f, naming the state of a batch in any error it throws (in the error's own type).
template <class F>
void for_state(long s, bool batch, F&& f) {
  if (!batch) return f();
  try {
    f();
  } catch (const DynamicsError& e) {
    throw DynamicsError("state " + std::to_string(s) + ": " + e.what());
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument("state " + std::to_string(s) + ": " + e.what());
  }
}

}  // namespace

void CompiledModel::evaluate_batch(Output o, long k, const std::vector<const double*>& inputs,
                                   const Eigen::VectorXd& params,
                                   const std::vector<double*>& results) const {
  const OutputInfo& out = info(o);
  const Function f = function(o);
  if (inputs.size() != out.inputs.size() || results.size() != out.results.size())
    throw std::invalid_argument(std::string(out.name) + ": wrong number of inputs or results");
  check("params", params, static_cast<int>(nominal_.size()));
  if (const char* error = parameter_error_(params.data()))
    throw std::invalid_argument(std::string("parameters: ") + error);
  // One state's results in the generated code's layout (column-major), then row-major.
  std::vector<Eigen::MatrixXd> state;
  std::vector<double*> state_out;
  for (const auto& r : out.results) state.emplace_back(dims_(r.rows), dims_(r.cols));
  for (auto& r : state) state_out.push_back(r.data());
  std::vector<const double*> in(inputs.size());
  for (long s = 0; s < k; ++s)
    for_state(s, k > 1, [&] {
      for (size_t i = 0; i < in.size(); ++i) {
        const int n = dims_(info(out.inputs[i]).size);
        in[i] = inputs[i] + s * n;
        check(info(out.inputs[i]).name, Eigen::Map<const Eigen::VectorXd>(in[i], n), n);
      }
      f(in.data(), params.data(), state_out.data());
      if (o == Output::forward_dynamics) check_forward_dynamics(state, name_);
      for (size_t r = 0; r < state.size(); ++r) {
        if (!all_finite(state[r]))  // as eval's: no overflow passes as a number
          throw DynamicsError(std::string(out.results[r].name) +
                              " is not finite: the state or parameters overflow");
        const Eigen::Index size = state[r].size();
        Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
            results[r] + s * size, state[r].rows(), state[r].cols()) = state[r];
      }
    });
}

Eigen::MatrixXd CompiledModel::mass_matrix(const Eigen::VectorXd& q,
                                           const Eigen::VectorXd& params) const {
  return evaluate(Output::mass_matrix, {q}, params)[0];
}
Eigen::VectorXd CompiledModel::bias_forces(const Eigen::VectorXd& q, const Eigen::VectorXd& qd,
                                           const Eigen::VectorXd& params) const {
  return evaluate(Output::bias_forces, {q, qd}, params)[0];
}
void CompiledModel::mass_matrix_and_bias(const Eigen::VectorXd& q, const Eigen::VectorXd& qd,
                                         const Eigen::VectorXd& params, Eigen::MatrixXd& M,
                                         Eigen::VectorXd& b) const {
  if (!has(Output::mass_matrix) || !has(Output::bias_forces))
    throw std::invalid_argument(
        "the scene does not emit mass_matrix and bias_forces (add them to outputs)");
  check("q", q, dims_.nq);
  check("qd", qd, dims_.nv);
  auto r = call(kMassMatrixAndBias, {{Size::nv, Size::nv}, {Size::nv, Size::one}},
                {q.data(), qd.data()}, params);
  M = std::move(r[0]);
  b = std::move(r[1]);
}
double CompiledModel::kinetic_energy(const Eigen::VectorXd& q, const Eigen::VectorXd& qd,
                                     const Eigen::VectorXd& params) const {
  return evaluate(Output::kinetic_energy, {q, qd}, params)[0](0, 0);
}
Eigen::VectorXd CompiledModel::momentum(const Eigen::VectorXd& q, const Eigen::VectorXd& qd,
                                        const Eigen::VectorXd& params) const {
  return evaluate(Output::momentum, {q, qd}, params)[0];
}
Eigen::VectorXd CompiledModel::end_effector_pose(const Eigen::VectorXd& q,
                                                 const Eigen::VectorXd& params) const {
  return evaluate(Output::end_effector_pose, {q}, params)[0];
}
Eigen::MatrixXd CompiledModel::end_effector_jacobian(const Eigen::VectorXd& q,
                                                     const Eigen::VectorXd& params) const {
  return evaluate(Output::end_effector_jacobian, {q}, params)[0];
}
double CompiledModel::potential_energy(const Eigen::VectorXd& q,
                                       const Eigen::VectorXd& params) const {
  return evaluate(Output::potential_energy, {q}, params)[0](0, 0);
}
Eigen::VectorXd CompiledModel::friction_forces(const Eigen::VectorXd& qd,
                                               const Eigen::VectorXd& params) const {
  return evaluate(Output::friction_forces, {qd}, params)[0];
}
bool CompiledModel::has_forward_dynamics() const {
  return has(Output::forward_dynamics) ||
         (has(Output::mass_matrix) && has(Output::bias_forces) && !passive_forces_);
}
Eigen::VectorXd CompiledModel::forward_dynamics_derivatives(
    const Eigen::VectorXd& q, const Eigen::VectorXd& qd, const Eigen::VectorXd& Q,
    const Eigen::VectorXd& params, Eigen::MatrixXd& dqdd_dq, Eigen::MatrixXd& dqdd_dqd) const {
  auto r = evaluate(Output::forward_dynamics_derivatives, {q, qd, Q}, params);
  for (const auto& part : r)
    if (!part.allFinite())
      throw DynamicsError("model " + name_ +
                          ": the state Jacobian is not finite (mass matrix singular?)");
  dqdd_dq = std::move(r[0]);
  dqdd_dqd = std::move(r[1]);
  return r[2];
}
Eigen::VectorXd CompiledModel::forward_dynamics(const Eigen::VectorXd& q, const Eigen::VectorXd& qd,
                                                const Eigen::VectorXd& Q,
                                                const Eigen::VectorXd& params) const {
  // Wrong sizes are the caller's error; non-finite values one of the dynamics (as Model<G>'s).
  for (const auto& [what, v, size] :
       {std::tuple{"q", &q, dims_.nq}, std::tuple{"qd", &qd, dims_.nv},
        std::tuple{"Q", &Q, dims_.nv}})
    if (v->size() != size)
      throw std::invalid_argument(std::string(what) + ": expected " + std::to_string(size) +
                                  " values, got " + std::to_string(v->size()));
  check_finite_inputs(q, qd, Q, name_, coordinate_names_);
  Eigen::VectorXd qdd, pivots, scaled_pivots;
  if (has(Output::forward_dynamics)) {
    const auto r = evaluate(Output::forward_dynamics, {q, qd, Q}, params);
    qdd = r[0];
    pivots = r[1];
    scaled_pivots = r[2];
  } else {
    if (passive_forces_)
      throw std::invalid_argument("model " + name_ +
                                  ": a scene with springs, dampers or friction needs the "
                                  "forward_dynamics output for its forward dynamics");
    Eigen::MatrixXd M;
    Eigen::VectorXd b;
    mass_matrix_and_bias(q, qd, params, M, b);
    qdd = cholesky_forward_dynamics(M, Eigen::VectorXd(Q - b), name_, pivots, scaled_pivots);
  }
  check_forward_dynamics(pivots, scaled_pivots, qdd, name_);
  return qdd;
}

Eigen::VectorXd CompiledModel::gear_ratios(const Eigen::VectorXd& params) const {
  return call("gear_ratios", {{Size::num_links, Size::one}}, {}, params)[0];
}

void check_forward_dynamics(const std::vector<Eigen::MatrixXd>& results,
                            std::string_view model_name) {
  check_forward_dynamics(Eigen::VectorXd(results[1]), Eigen::VectorXd(results[2]),
                         Eigen::VectorXd(results[0]), model_name);
}

bool LoadedSource::has(F f) const {
  switch (f) {
    case F::end_effector_pose:
      return m_->has(Output::end_effector_pose);
    case F::end_effector_jacobian:
      return m_->has(Output::end_effector_jacobian);
    case F::mass_matrix_and_bias:
      return m_->has(Output::mass_matrix) && m_->has(Output::bias_forces);
    case F::forward_dynamics:
      return m_->has_forward_dynamics();
    case F::forward_dynamics_derivatives:
      return m_->has(Output::forward_dynamics_derivatives);
    case F::kinetic_energy:
      return m_->has(Output::kinetic_energy);
    case F::potential_energy:
      return m_->has(Output::potential_energy);
    case F::friction_forces:
      return m_->has(Output::friction_forces);
    case F::momentum:
      return m_->has(Output::momentum);
  }
  return false;
}

DynamicModelFacts LoadedSource::facts() const {
  DynamicModelFacts f;
  f.name = m_->name();
  f.nq = m_->nq();
  f.nv = m_->nv();
  f.num_links = m_->num_links();
  f.free_floating = m_->free_floating();
  f.coordinate_names = m_->coordinate_names();
  f.gear_ratios = m_->gear_ratios(params_);  // checks params (sizes, finite, ranges) once
  f.actuated_coordinates = m_->actuated_coordinates();
  f.motor_angle_slots = m_->motor_angle_slots();
  f.passive_forces = m_->passive_forces();
  f.base_velocities = m_->num_base();
  f.quaternion_offset = m_->quaternion_offset();
  return f;
}

}  // namespace spacearm
