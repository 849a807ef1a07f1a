#include "compiled_model.hpp"

#include <dlfcn.h>
#include <link.h>
#include <sched.h>
#include <unistd.h>

#include <atomic>
#include <condition_variable>
#include <mutex>
#include <thread>
#include <cerrno>
#include <cstdint>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <new>
#include <optional>
#include <system_error>

#include <Eigen/Cholesky>

#include <sstream>
#include <tuple>

#include "dynamics_checks.hpp"

#include "cpp_emitter.hpp"
#include "outputs.hpp"
#include "text_numbers.hpp"

namespace spacearm {

namespace fs = std::filesystem;

namespace {
double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}
}  // namespace

// A work folder holding the scene's emitted C++, ready to compile (compile_entry), and what the
// compile will cost.
struct EmittedEntry {
  WorkFolder work;
  EmittedModel emitted;
  std::vector<std::string> sources;
  CompileEstimate cost;
  std::string cost_line;  // checked_cost's; cost_error: past the bound on the code's size
  std::string cost_error;
  bool first_unit = false;  // unit 0 holds the first functions (CompileOptions), linked first
};

// A model's functions as slots (ModelFunction), the library that the compiled ones come from,
// the interpreted code that serves until then, and the compile that builds the library in the
// background (Engine::automatic).
struct CompiledModel::Library {
  std::map<std::string, std::unique_ptr<ModelFunction::Slot>> slots;  // 4-lane: name + "_x4"
  std::shared_ptr<const InterpretedModel> code;
  std::atomic<const char* (*)(const double*)> parameter_error{nullptr};
  // The interpreter's parameter_error(): the scene's messages (ModelFacts::checks) and "not
  // finite" per parameter.
  std::vector<std::string> check_messages, not_finite;
  std::vector<bool> check_strict;
  void* handle = nullptr;
  void* first_handle = nullptr;  // the first functions' library, until the process ends
  std::atomic<bool> all_compiled{false};
  std::chrono::steady_clock::time_point started;
  std::mutex mutex;  // guards the three below
  std::mutex joining;
  std::thread compile;
  std::string compile_error;
  double loaded_after_ms = -1;
  double first_after_ms = -1;             // the first functions' library served from then on
  std::vector<std::string> first_served;  // its functions
  bool background = false;                // a compile was started
  std::atomic<bool> done{false};          // and has ended

  ModelFunction add_slot(const std::string& name, ModelFunction::Raw compiled,
                         const InterpretedFunction* interpreted, bool lanes, TrigSource trig) {
    auto slot = std::make_unique<ModelFunction::Slot>();
    slot->compiled.store(compiled);
    slot->interpreted = interpreted;
    slot->lanes = lanes;
    slot->trig = trig;
    const ModelFunction f(slot.get());
    slots[name] = std::move(slot);
    return f;
  }
  // The compiled library's functions, from a model just loaded, serve from now on: every one
  // is found before any is published.
  void take(Library& loaded) {
    for (const auto& [name, slot] : slots)
      if (!loaded.slots.count(name))
        throw CompileError("the compiled library lacks spacearm_" + name);
    publish(loaded);
    all_compiled = true;
    const std::lock_guard<std::mutex> lock(mutex);
    std::swap(handle, loaded.handle);
    loaded_after_ms = ms_since(started);
  }
  // The first functions' library (a part of the model's): the functions it has serve from now
  // on. Its handle stays open (a caller may be inside one of them when the whole library loads).
  void take_first(Library& loaded) {
    const std::vector<std::string> names = publish(loaded);
    const std::lock_guard<std::mutex> lock(mutex);
    std::swap(first_handle, loaded.handle);
    first_after_ms = ms_since(started);
    first_served = names;
  }
  // The loaded library's functions (and parameter check) serve in our slots of the same names;
  // those names.
  std::vector<std::string> publish(const Library& loaded) {
    parameter_error.store(loaded.parameter_error.load());
    std::vector<std::string> names;
    for (const auto& [name, slot] : loaded.slots)
      if (const auto ours = slots.find(name); ours != slots.end()) {
        ours->second->compiled.store(slot->compiled.load(), std::memory_order_release);
        names.push_back(name);
      }
    return names;
  }
  void join() {
    const std::lock_guard<std::mutex> lock(joining);
    if (compile.joinable()) compile.join();
  }
  ~Library() {
    if (compile.joinable()) compile.join();
    if (handle) dlclose(handle);
    if (first_handle) dlclose(first_handle);
  }
};

namespace {

// The libraries of models dropped while their compile ran: each compile finishes (and lands in
// the cache for the next run) before the process ends, here or in finish_background_compiles.
// The compile's statics are made before its thread starts (in_background), so they outlive this.
class PendingCompiles {
 public:
  static PendingCompiles& instance() {
    static PendingCompiles pending;
    return pending;
  }
  void keep(std::shared_ptr<void> library, std::function<bool()> done) {
    const std::lock_guard<std::mutex> lock(mutex_);
    // Those already ended are let go (their threads join at once).
    for (size_t k = 0; k < libraries_.size();)
      if (libraries_[k].second())
        libraries_.erase(libraries_.begin() + static_cast<long>(k));
      else
        ++k;
    libraries_.emplace_back(std::move(library), std::move(done));
  }
  int running() {
    const std::lock_guard<std::mutex> lock(mutex_);
    int n = 0;
    for (const auto& [library, done] : libraries_) n += !done();
    return n;
  }
  void finish() {
    std::vector<std::pair<std::shared_ptr<void>, std::function<bool()>>> waiting;
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      waiting.swap(libraries_);
    }
    waiting.clear();  // each Library's destructor joins its compile
  }
  ~PendingCompiles() { finish(); }

 private:
  std::mutex mutex_;
  std::vector<std::pair<std::shared_ptr<void>, std::function<bool()>>> libraries_;
};

}  // namespace

void ModelFunction::interpret_call(const double* const* in, const double* params,
                                   double* const* out) const {
  slot_->interpreted_calls.fetch_add(1, std::memory_order_relaxed);
  (slot_->lanes ? interpret_lanes : interpret)(*slot_->interpreted, slot_->trig, in, params, out);
}

const char* engine_name(Engine e) {
  switch (e) {
    case Engine::automatic:
      return "auto";
    case Engine::interpreter:
      return "interpreter";
    case Engine::compiled:
      return "compiled";
  }
  return "";
}

Engine parse_engine(const std::string& text, const std::string& option) {
  for (Engine e : {Engine::automatic, Engine::interpreter, Engine::compiled})
    if (text == engine_name(e)) return e;
  throw std::invalid_argument(option + ": expected auto, interpreter or compiled, got " +
                              quoted_text(text));
}

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

// The file this code was linked into: the executable, or a shared object such as the Python
// extension (where /proc/self/exe is the interpreter, the same whatever the generator). The
// loader lists the main program with an empty name.
std::string own_binary() {
  struct Search {
    std::uintptr_t address;
    std::string file = "/proc/self/exe";
  } search{reinterpret_cast<std::uintptr_t>(&own_binary)};
  dl_iterate_phdr(
      [](dl_phdr_info* object, size_t, void* data) {
        auto* s = static_cast<Search*>(data);
        for (int k = 0; k < object->dlpi_phnum; ++k) {
          const ElfW(Phdr)& h = object->dlpi_phdr[k];
          const std::uintptr_t start = object->dlpi_addr + h.p_vaddr;
          if (h.p_type != PT_LOAD || s->address < start || s->address >= start + h.p_memsz)
            continue;
          if (object->dlpi_name != nullptr && object->dlpi_name[0] == '/')
            s->file = object->dlpi_name;
          return 1;
        }
        return 0;
      },
      &search);
  return search.file;
}

// Identity of the running generator: a hash of the binary that holds it, so that a rebuilt
// generator (which may emit different code under the same version number) gets new entries.
const std::string& generator_identity() {
  static const std::string id =
      sha256_hex(read_file(own_binary())) + "-abi" + std::to_string(kCInterfaceVersion);
  return id;
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
                                                 "spacearm_slot_holds_motor",
                                                 "spacearm_num_span_fields",
                                                 "spacearm_span_field",
                                                 "spacearm_span_value",
                                                 "spacearm_span_parameter"};
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

// A command as compile_command.txt shows it.
std::string shown_command(const std::vector<std::string>& argv) {
  std::string command;
  for (const auto& a : argv) command += (command.empty() ? "" : " ") + a;
  return command;
}

// Runs the compilers (at most max_running at once, in order; on_success as
// run_all_interruptible's), their messages (kept in memory: they survive a full disk) added
// to `log_text`; the first nonzero exit status (-1: one could not start), or 0.
int run_compilers(const std::vector<std::vector<std::string>>& commands, int dir,
                  std::string& log_text, const std::function<void()>& on_interrupt,
                  const std::string& compiler, const std::string& model, bool own_signals,
                  int max_running = 0, const std::function<void(size_t)>& on_success = {}) {
  std::vector<Fd> logs;
  std::vector<int> fds;
  for (size_t k = 0; k < commands.size(); ++k) {
    logs.push_back(memory_file("spacearm-compile-log"));
    fds.push_back(logs.back().get());
  }
  const std::vector<RunResult> runs =
      run_all_interruptible(commands, dir, fds, on_interrupt, own_signals, max_running, on_success);
  int failed = 0;
  for (size_t k = 0; k < runs.size(); ++k) {
    if (runs[k].interrupted) throw CompileError("compiling model '" + model + "' was interrupted");
    if (runs[k].status == 0 || runs[k].stopped) continue;
    log_text +=
        runs[k].status < 0 ? cannot_run(compiler, runs[k].start_error) + "\n" : read_log(logs[k]);
    if (failed == 0) failed = runs[k].status;
  }
  return failed;
}

// The CPUs a cgroup v2 quota grants (cpu.max: "QUOTA PERIOD", or "max"), rounded up; 0: no
// quota (docker --cpus sets one without changing the affinity).
int cgroup_cpus() {
  std::ifstream in("/sys/fs/cgroup/cpu.max");
  std::string quota;
  double period = 0;
  if (!(in >> quota >> period) || quota == "max" || !(period > 0)) return 0;
  char* end = nullptr;
  const double q = std::strtod(quota.c_str(), &end);
  if (end == quota.c_str() || !(q > 0) || !(q / period < 1e6)) return 0;
  return static_cast<int>(std::ceil(q / period));
}

// How many compilers a library is built by at once: the CPUs this process may run on (its
// affinity, and a cgroup quota), at most 4 (each unit costs a compiler start and <cmath>, about
// 0.1 s, and a compiler's memory).
int compile_jobs(const CompileOptions& options) {
  if (options.jobs > 0) return options.jobs;
  cpu_set_t set;
  CPU_ZERO(&set);
  int cpus = ::sched_getaffinity(0, sizeof set, &set) == 0 ? CPU_COUNT(&set) : 1;
  if (const int quota = cgroup_cpus(); quota > 0) cpus = std::min(cpus, quota);
  return std::clamp(cpus, 1, 4);
}

}  // namespace

void CompileOptions::call_first(Output o, bool lanes) {
  first_functions.push_back(info(o).name + (lanes ? std::string(kLanesSuffix) : ""));
}

double CompileOptions::default_max_code_mb() {
  const char* text = std::getenv("SPACEARM_MAX_CODE_MB");
  if (!text || !*text) return 8;
  try {
    const double v = parse_number(text, "SPACEARM_MAX_CODE_MB");
    if (v > 0) return v;
  } catch (const std::invalid_argument&) {
  }
  throw CompileError(std::string("SPACEARM_MAX_CODE_MB: expected a positive number of MB, got ") +
                     quoted_text(text));
}

// Seconds and peak megabytes of one g++ 12 -O1 per MB of a unit, a floor: the units of
// space_arm7, dual_arm7 and the planar N = 30 chain, with and without the state Jacobian (0.17 to
// 1.4 MB a unit, in parts of 200 statements), each compiled alone on an AMD EPYC (2026-11-29),
// took 0.25 s + 3.5 to 4.0 s/MB and 60 MB + 235 to 360 MB/MB.
constexpr double kCompileSecondsPerMb = 3.5, kCompileMemoryMbPerMb = 230;

CompileEstimate compile_estimate(size_t largest_unit_bytes) {
  const double mb = static_cast<double>(largest_unit_bytes) / 1e6;
  return {kCompileSecondsPerMb * mb + 0.2, kCompileMemoryMbPerMb * mb + 60};
}

namespace {

// Says "still compiling" every 30 s until destroyed: a long compile is not silent.
class CompileHeartbeat {
 public:
  CompileHeartbeat(const std::function<void(const std::string&)>& say, const std::string& model,
                   double expected_s)
      : thread_([this, say, model, expected_s] {
          std::unique_lock<std::mutex> lock(mutex_);
          for (int elapsed = 30;
               !cv_.wait_for(lock, std::chrono::seconds(30), [this] { return done_; });
               elapsed += 30) {
            char line[200];
            std::snprintf(line, sizeof line, "still compiling %s: %d s (about %.0f s expected)",
                          model.c_str(), elapsed, expected_s);
            if (say) say(line);
          }
        }) {}
  ~CompileHeartbeat() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      done_ = true;
    }
    cv_.notify_all();
    thread_.join();
  }

 private:
  std::mutex mutex_;
  std::condition_variable cv_;
  bool done_ = false;
  std::thread thread_;
};

// The emitted code's size and compile cost as a line ("0.52 MB of C++: at least ..."); a
// CompileError past the bound on the code's size.
CompileEstimate checked_cost(const ModelRecipe& recipe, const EmittedModel& emitted,
                             const CompileOptions& options, std::string& line) {
  const size_t units = emitted.c_units.size();
  size_t bytes = 0, largest = 0;
  for (const auto& unit : emitted.c_units)
    bytes += unit.size(), largest = std::max(largest, unit.size());
  const CompileEstimate cost = compile_estimate(largest);
  const size_t at_once = std::min(units, static_cast<size_t>(compile_jobs(options)));
  const std::string parts = units > at_once ? std::to_string(units) + " units, " : "";
  char text[400];
  std::snprintf(text, sizeof text,
                "%.2f MB of C++: at least %.0f s and %.0f MB of memory (%s%zu compilers at once)",
                static_cast<double>(bytes) / 1e6, cost.seconds, cost.memory_mb, parts.c_str(),
                at_once);
  line = text;
  const double max_mb =
      options.max_code_mb > 0 ? options.max_code_mb : CompileOptions::default_max_code_mb();
  char bound[32];
  std::snprintf(bound, sizeof bound, "%g", max_mb);
  if (static_cast<double>(bytes) > max_mb * 1e6)
    throw CompileError("model '" + recipe.name() + "': " + line + ", past the bound of " + bound +
                       " MB; raise it (SPACEARM_MAX_CODE_MB, or CompileOptions::max_code_mb), "
                       "or emit fewer outputs (field 'outputs') or fewer joints");
  return cost;
}

// The compiler's commands: one unit compiled and linked by one command; several each to an
// object (`compiles`, in order, as many at once as the caller runs), then linked (`link`);
// `link_first` links unit 0's object alone (EmittedEntry::first_unit).
struct CompilePlan {
  std::vector<std::vector<std::string>> compiles;
  std::vector<std::string> objects, link, link_first;

  CompilePlan(const std::vector<std::string>& sources, const std::string& compiler,
              const std::string& flags, const std::string& libraries) {
    const auto argv = [&](const std::vector<std::string>& middle, bool with_libraries) {
      std::vector<std::string> a{compiler};
      for (const auto& f : split_flags(flags)) a.push_back(f);
      a.insert(a.end(), middle.begin(), middle.end());
      if (with_libraries)
        for (const auto& l : split_flags(libraries)) a.push_back(l);
      return a;
    };
    if (sources.size() == 1) {
      compiles.push_back(argv({"libmodel.cpp", "-o", "libmodel.so"}, true));
    } else {
      for (const auto& src : sources) {
        objects.push_back(src.substr(0, src.size() - 3) + "o");
        compiles.push_back(argv({"-c", src, "-o", objects.back()}, false));
      }
    }
    std::vector<std::string> middle = objects;
    middle.insert(middle.end(), {"-o", "libmodel.so"});
    link = argv(middle, true);
    if (!objects.empty()) link_first = argv({objects[0], "-o", kFirstLibrary}, true);
  }
  static constexpr const char* kFirstLibrary = "libfirst.so";
  // The commands as a shell would run them (compile_command.txt).
  std::string shown() const {
    const bool several = compiles.size() > 1;
    std::string command;
    for (const auto& c : compiles) command += "\n" + shown_command(c) + (several ? " &" : "");
    if (several) command += "\nwait\n" + shown_command(link);
    return command;
  }
};

// Generates the scene into a new work folder (with the interpreter's code too where asked).
// Every file is written relative to the folder's descriptor. The code's size is checked against
// its bound: past it, cost_error says why (the caller refuses to compile).
EmittedEntry emit_entry(const ModelRecipe& recipe, const CacheFolder& cache,
                        const std::string& entry, const CompileOptions& options, StageReport& rep,
                        bool interpreted) {
  if (options.progress) options.progress("deriving " + recipe.name());
  EmittedEntry e{cache.make_work_folder(entry), {}, {}, {}, {}, {}};
  const std::string shown = cache.path() + "/" + e.work.name;
  try {
    const auto t0 = std::chrono::steady_clock::now();
    EmitOptions eo;
    eo.scene_path = recipe.source_path();
    eo.command = "spacearm (compile-and-load cache)";
    eo.c_units = compile_jobs(options);
    eo.interpreted = interpreted;
    // The first functions in unit 0 where the interpreter serves meanwhile.
    if (interpreted && !options.first_functions.empty())
      eo.leading_units = {options.first_functions};
    e.emitted = recipe.emit(eo, &rep.derive_ms);
    e.first_unit = !eo.leading_units.empty() && e.emitted.c_units.size() > 1 &&
                   !e.emitted.c_unit_functions[0].empty();
    const size_t units = e.emitted.c_units.size();
    for (size_t u = 0; u < units; ++u) {
      e.sources.push_back(units == 1 ? "libmodel.cpp" : "libmodel_" + std::to_string(u) + ".cpp");
      write_new_file_at(e.work.fd.get(), e.sources[u], e.emitted.c_units[u],
                        shown + "/" + e.sources[u]);
    }
    rep.emit_ms = ms_since(t0) - rep.derive_ms;
    rep.generated = true;
    try {
      e.cost = checked_cost(recipe, e.emitted, options, e.cost_line);
    } catch (const CompileError& error) {
      e.cost_error = error.what();
    }
    return e;
  } catch (const FolderError& error) {
    cache.remove(e.work);
    throw CompileError(error.what());
  } catch (...) {
    cache.remove(e.work);
    throw;
  }
}

// Compiles an emitted entry's sources inside its work folder, with relative names (nothing goes
// through the cache's path again), and writes its COMPLETE marker: ready to install. On failure
// the folder is kept for inspection (compile errors) or removed, and a CompileError says why.
// first_built (with EmittedEntry::first_unit): called on this thread with the folder's
// descriptor once unit 0 is compiled and linked alone as CompilePlan::kFirstLibrary, while the
// other units compile; its failure only delays those functions to the whole library.
void compile_entry(const ModelRecipe& recipe, const CacheFolder& cache, const std::string& entry,
                   EmittedEntry& e, const std::string& compiler, const std::string& compiler_id,
                   const CompileOptions& options, StageReport& rep, bool own_signals,
                   const std::function<void(int dir)>& first_built = {}) {
  auto say = [&](const std::string& m) {
    if (options.progress) options.progress(m);
  };
  const WorkFolder& work = e.work;
  const std::string shown = cache.path() + "/" + work.name;
  const int dir = work.fd.get();
  try {
    if (!e.cost_error.empty()) throw CompileError(e.cost_error);
    say("compiling with " + compiler + ": " + e.cost_line);
    const CompileHeartbeat heartbeat(options.progress, recipe.name(), e.cost.seconds);
    const auto t1 = std::chrono::steady_clock::now();
    const std::string flags = options.flags + instruction_set_flags(options.instruction_set);
    const CompilePlan plan(e.sources, compiler, flags, options.libraries);
    const auto& [compiles, objects, link, link_first] = plan;
    write_new_file_at(dir, "compile_command.txt", "cd " + shown + plan.shown() + "\n",
                      shown + "/compile_command.txt");
    std::string log_text;
    const auto remove = [&] { cache.remove(work); };
    // Nothing thrown from here: the other compilers are still running (run_all_interruptible
    // would leave them unwaited for).
    const auto unit_built = [&](size_t k) {
      if (k != 0 || !e.first_unit || !first_built) return;
      try {
        std::string first_log;
        if (run_compilers({link_first}, dir, first_log, remove, compiler, recipe.name(),
                          own_signals) == 0)
          first_built(dir);
        else
          say("linking the first functions failed; they wait for the whole library: " + first_log);
      } catch (const std::exception& error) {
        say(std::string("the first functions wait for the whole library: ") + error.what());
      }
      ::unlinkat(dir, CompilePlan::kFirstLibrary, 0);  // loaded, or of no use: never installed
    };
    int failed = run_compilers(compiles, dir, log_text, remove, compiler, recipe.name(),
                               own_signals, compile_jobs(options), unit_built);
    if (failed == 0 && e.sources.size() > 1)
      failed = run_compilers({link}, dir, log_text, remove, compiler, recipe.name(), own_signals);
    rep.compile_ms = ms_since(t1);
    if (failed != 0) {
      try {
        write_new_file_at(dir, "compile.log", log_text, shown + "/compile.log");
      } catch (const FolderError&) {  // a full disk: the message below still has the log
      }
      const std::string kept = cache.keep_failed(work, entry);
      throw CompileError("compiling model '" + recipe.name() + "' failed" +
                         (log_text.empty()
                              ? " without a message (exit status " + std::to_string(failed) + ")"
                              : "") +
                         ":\n" + log_text + "sources and command: " + kept);
    }
    for (const auto& object : objects)  // in the library now
      ::unlinkat(dir, object.c_str(), 0);
    rep.compiled = true;
    // The marker, written last, records the library's SHA-256 on its first line.
    const Fd library =
        open_private_at(dir, "libmodel.so", false, shown + "/libmodel.so", "compiled library");
    if (!library.valid()) throw CompileError("the compiler wrote no '" + shown + "/libmodel.so'");
    write_new_file_at(dir, "COMPLETE",
                      "sha256 " + sha256_hex(read_all(library.get(), shown + "/libmodel.so")) +
                          "\ngenerator " + kGeneratorVersion + "\ncompiler " + compiler_id +
                          "\nflags " + flags + "\nlibraries " + options.libraries + "\n",
                      shown + "/COMPLETE");
  } catch (const FolderError& error) {
    cache.remove(work);
    throw CompileError(error.what());
  } catch (...) {  // a failed build was kept as failed/ENTRY first
    cache.remove(work);
    throw;
  }
}

}  // namespace

std::string host_instruction_set() {
#if defined(__x86_64__) && defined(__GNUC__)
  __builtin_cpu_init();  // also safe before the constructors have run (a static's initializer)
  if (__builtin_cpu_supports("avx512f")) return "avx512f";
  if (__builtin_cpu_supports("avx2")) return "avx2";
#endif
  return "sse2";
}

bool cpu_runs(const std::string& instruction_set) {
  if (instruction_set == "sse2") return true;
#if defined(__x86_64__) && defined(__GNUC__)
  __builtin_cpu_init();
  if (instruction_set == "avx2") return __builtin_cpu_supports("avx2");
  if (instruction_set == "avx512f") return __builtin_cpu_supports("avx512f");
#endif
  return false;
}

std::string instruction_set_flags(const std::string& instruction_set) {
  if (instruction_set == "sse2") return "";
  if (instruction_set == "avx2" || instruction_set == "avx512f") return " -m" + instruction_set;
  throw CompileError("instruction set " + quoted_text(instruction_set) +
                     " is not one of avx512f, avx2, sse2");
}

std::string cache_directory(const CompileOptions& options) {
  if (!options.cache_dir.empty()) return options.cache_dir;
  if (const char* d = std::getenv("SPACEARM_CACHE_DIR"); d && *d) return d;
  if (const char* d = std::getenv("XDG_CACHE_HOME"); d && *d) return std::string(d) + "/spacearm";
  if (const char* h = std::getenv("HOME"); h && *h) return std::string(h) + "/.cache/spacearm";
  throw CompileError(
      "no cache folder for compiled models: set HOME, XDG_CACHE_HOME or SPACEARM_CACHE_DIR, or "
      "pass --cache-dir");
}

// Entries are named SCENE-SOURCE-SET-COMPILER: the hash of what the code is made from (scene,
// generator, flags, libraries), the instruction set, then the hash of the compiler's identity.
// Without a compiler (a Dask worker's image), or in a cache folder that cannot be written, an
// entry of the same source built by any compiler for any set this CPU runs loads.
CompiledModel CompiledModel::load(const ModelRecipe& recipe, const CompileOptions& options,
                                  StageReport* report) {
  StageReport local;
  StageReport& rep = report ? *report : local;
  auto say = [&](const std::string& m) {
    if (options.progress) options.progress(m);
  };
  if (options.engine == Engine::interpreter) return interpreted(recipe, options, rep, "");
  if (!(options.max_code_mb > 0)) CompileOptions::default_max_code_mb();  // a bad value: an error
  const bool automatic = options.engine == Engine::automatic;
  std::optional<CacheFolder> opened;
  try {
    opened.emplace(cache_directory(options));
  } catch (const CompileError& e) {  // no cache folder: automatic serves by the interpreter
    if (!automatic) throw;
    return interpreted(recipe, options, rep, e.what());
  }
  CacheFolder& cache = *opened;
  cache.remove_stale_work();
  std::string compiler = options.compiler;
  if (compiler.empty())
    compiler = std::getenv("CXX") && *std::getenv("CXX") ? std::getenv("CXX") : "c++";
  const std::string source =
      recipe.name() + "-" +
      sha256_hex(recipe.content() + '\0' + kGeneratorVersion + '\0' + generator_identity() + '\0' +
                 options.flags + '\0' + options.libraries)
          .substr(0, 24) +
      "-";
  // No compiler, or a cache that cannot be written: a library built before, else (automatic)
  // the interpreter.
  const auto built_before = [&](const std::string& why) {
    if (!automatic) return load_built(recipe, cache, source, options.instruction_set, why, rep);
    try {
      return load_built(recipe, cache, source, options.instruction_set, why, rep);
    } catch (const CompileError& e) {
      return interpreted(recipe, options, rep, e.what());
    }
  };
  std::string no_compiler;
  const std::string compiler_id = compiler_identity(compiler, cache.fd(), no_compiler);
  if (compiler_id.empty()) return built_before(no_compiler);
  const std::string entry =
      source + options.instruction_set + "-" + sha256_hex(compiler_id).substr(0, 8);
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
      std::optional<EmittedEntry> emitted;
      try {
        emitted.emplace(emit_entry(recipe, cache, entry, options, rep, automatic));
      } catch (const CompileError& e) {
        // Nothing generated: the folder cannot be written (a read-only cache); another entry?
        if (rep.generated) throw;
        return built_before(e.what());
      }
      if (automatic && !emitted->emitted.interpreted)
        say("the interpreter cannot read " + recipe.name() +
            "'s code (please report: " + emitted->emitted.interpreted_error + "): compiling first");
      if (automatic && emitted->emitted.interpreted)
        return in_background(recipe, std::move(cache), entry, std::move(*emitted),
                             {compiler, compiler_id}, options, rep);
      compile_entry(recipe, cache, entry, *emitted, compiler, compiler_id, options, rep, true);
      cache.install(emitted->work, entry);
      continue;
    }
    std::string why;
    CompiledModel m = open_verified(recipe, library, rep, why);
    if (why.empty()) return m;
    if (attempt > 0 || rep.compiled)
      throw CompileError("cannot load '" + rep.cache_entry + "/libmodel.so': " + why);
    say("cache entry " + rep.cache_entry + " is corrupted (" + why + "): rebuilding");
    cache.discard(entry);
  }
}

// The model served by its interpreted code (emitted here unless given), its facts the scene's.
CompiledModel CompiledModel::interpreted(const ModelRecipe& recipe, const CompileOptions& options,
                                         StageReport& rep, const std::string& no_library,
                                         std::shared_ptr<const InterpretedModel> code) {
  if (!code) {
    EmitOptions eo;
    eo.scene_path = recipe.source_path();
    eo.interpreted = true;
    const auto t0 = std::chrono::steady_clock::now();
    const EmittedModel emitted = recipe.emit(eo, &rep.derive_ms);
    if (!emitted.interpreted)
      throw CompileError("the interpreter cannot read " + recipe.name() + "'s code (please " +
                         "report): " + emitted.interpreted_error);
    code = emitted.interpreted;
    rep.emit_ms = ms_since(t0) - rep.derive_ms;
    rep.generated = true;
  }
  const auto t0 = std::chrono::steady_clock::now();
  const ModelFacts& facts = recipe.facts();
  CompiledModel m;
  m.library_ = std::make_shared<Library>();
  Library& lib = *m.library_;
  lib.code = code;
  lib.started = t0;
  if (!no_library.empty()) lib.compile_error = no_library;
  m.name_ = facts.name;
  m.dims_ = facts.dims;
  m.num_base_ = facts.num_base;
  m.free_floating_ = facts.free_floating;
  m.passive_forces_ = facts.has_passive_forces();
  m.quaternion_offset_ = facts.quaternion_offset;
  m.outputs_ = output_mask(facts.outputs);
  m.coordinate_names_ = facts.coordinate_names;
  if (facts.dims.num_end_effectors > 1) m.end_effector_names_ = facts.end_effector_names;
  m.parameter_names_ = facts.parameter_names;
  m.nominal_ = facts.nominal_parameters;
  m.actuated_ = spacearm::actuated_coordinates(facts);
  m.motor_angle_slots_ = facts.motor_angle_slots;
  m.span_fields_ = facts.span_fields;
  for (const auto& c : facts.checks)
    lib.check_messages.push_back(c.message), lib.check_strict.push_back(c.strict);
  for (const auto& p : facts.parameter_names)
    lib.not_finite.push_back("parameter '" + p + "' is not finite");
  // The compiled sin and cos: libmvec's where the flags define the macro (kVectorTrigFlag).
  const TrigSource trig{(" " + options.flags + " ").find(" -DSPACEARM_VECTOR_TRIG ") !=
                        std::string::npos};
  for (const std::string& name : exported_functions(m.outputs_)) {
    const auto f = std::find_if(code->functions.begin(), code->functions.end(),
                                [&](const InterpretedFunction& g) { return g.name == name; });
    if (f == code->functions.end())
      throw std::logic_error("interpreted code of " + m.name_ + " lacks " + name);
    m.functions_[name] = lib.add_slot(name, nullptr, &*f, false, trig);
    if (f->lanes)
      m.lanes_functions_[name] = lib.add_slot(name + kLanesSuffix, nullptr, &*f, true, trig);
  }
  rep.interpreted = true;
  rep.interpret_ms = ms_since(t0);
  return m;
}

// Served by the interpreter now; the library compiled on a thread of its own, installed in the
// cache and loaded, then its functions swapped in (Library::take).
CompiledModel CompiledModel::in_background(const ModelRecipe& recipe, CacheFolder cache,
                                           const std::string& entry, EmittedEntry emitted,
                                           const std::pair<std::string, std::string>& compiler,
                                           const CompileOptions& options, StageReport& rep) {
  CompiledModel m = interpreted(recipe, options, rep, "", emitted.emitted.interpreted);
  Library* lib = m.library_.get();
  const auto say = options.progress;
  const auto no_compile = [&](const std::string& why) {
    cache.remove(emitted.work);
    lib->compile_error = why;
    if (say)
      say("compiling " + recipe.name() +
          " in the background failed; the interpreter serves on: " + why);
    return std::move(m);
  };
  if (!emitted.cost_error.empty()) return no_compile(emitted.cost_error);  // past the bound
  description_symbols();           // the compile's statics, made before PendingCompiles (which
  PendingCompiles::instance();     // they must outlive: it joins the compile at exit)
  CompileOptions quiet = options;  // its stages, for --verbose (worth_saying)
  if (say) quiet.progress = [say](const std::string& m) { say("background: " + m); };
  try {
    lib->background = true;
    rep.compiling_in_background = true;
    lib->compile = std::thread([lib, recipe, cache = std::move(cache), entry,
                                e = std::move(emitted), compiler, options = quiet, say]() mutable {
      StageReport background;
      try {
        // The first functions serve from their own library as soon as it is linked.
        const auto first_built = [&](int dir) {
          std::string why;
          StageReport first;
          const Fd part = open_private_at(dir, CompilePlan::kFirstLibrary, false,
                                          CompilePlan::kFirstLibrary, "compiled library");
          CompiledModel loaded;
          if (part.valid()) loaded = open_verified(recipe, part, first, why, true);
          if (!part.valid() || !why.empty()) {
            if (say) say("the first functions' library does not load: " + why);
            return;
          }
          lib->take_first(*loaded.library_);
          if (say) say("the first functions of " + recipe.name() + " compiled: they serve now");
        };
        compile_entry(recipe, cache, entry, e, compiler.first, compiler.second, options, background,
                      false, first_built);
        cache.install(e.work, entry);
        std::string problem, why;
        const Fd library = cache.open_library(entry, problem);
        if (!library.valid())
          throw CompileError("cache entry '" + entry + "' is " + problem + " after a fresh build");
        CompiledModel loaded = open_verified(recipe, library, background, why);
        if (!why.empty()) throw CompileError("cannot load the library of '" + entry + "': " + why);
        lib->take(*loaded.library_);
        if (say) say("the compiled library of " + recipe.name() + " serves from now on");
      } catch (const std::exception& error) {
        {
          const std::lock_guard<std::mutex> lock(lib->mutex);
          lib->compile_error = error.what();
        }
        if (say)
          say("compiling " + recipe.name() + " in the background failed; the interpreter serves " +
              "on: " + error.what());
      }
      lib->done = true;
    });
  } catch (const std::system_error& e) {  // no thread: the interpreter serves alone
    lib->background = rep.compiling_in_background = false;
    // Its work folder, unlocked now, is removed as stale by a later load.
    lib->compile_error = std::string("no thread for the compile: ") + e.what();
  }
  return m;
}

std::string stage_line(const StageReport& rep) {
  const char* state = !rep.interpreted              ? (rep.compiled ? "built" : "hit")
                      : rep.compiling_in_background ? "missed: the interpreter serves while the "
                                                      "library compiles"
                      : rep.cache_entry.empty()     ? "not used: the interpreter serves"
                                                    : "no library: the interpreter serves";
  char line[300];
  std::snprintf(
      line, sizeof line,
      "; derive %.1f ms, emit %.1f ms, compile %.1f ms, load %.1f ms, interpreter %.1f ms",
      rep.derive_ms, rep.emit_ms, rep.compile_ms, rep.load_ms, rep.interpret_ms);
  return "cache " + (rep.cache_entry.empty() ? std::string("-") : rep.cache_entry) + " (" + state +
         ")" + line;
}

const char* CompiledModel::engine() const {
  return !library_->code || library_->all_compiled ? "compiled" : "interpreter";
}

bool CompiledModel::wait_for_compiled() const {
  library_->join();
  return std::string_view(engine()) == "compiled";
}

std::string CompiledModel::engine_report() const {
  long calls = 0;
  for (const auto& [name, slot] : library_->slots)
    calls += slot->interpreted_calls.load(std::memory_order_relaxed);
  const std::lock_guard<std::mutex> lock(library_->mutex);
  const std::string interpreted =
      "the interpreter served " + std::to_string(calls) + (calls == 1 ? " call" : " calls");
  char loaded[120];
  std::snprintf(loaded, sizeof loaded, "; the compiled library loaded %.2f s after the start",
                library_->loaded_after_ms / 1e3);
  if (!library_->code) return "engine: compiled";
  std::string first;
  if (library_->first_after_ms >= 0) {
    for (const auto& name : library_->first_served) first += (first.empty() ? "" : ", ") + name;
    char after[80];
    std::snprintf(after, sizeof after, " compiled first, serving %.2f s after the start",
                  library_->first_after_ms / 1e3);
    first = "; " + first + after;
  }
  if (library_->loaded_after_ms >= 0)
    return "engine: " + interpreted + first + loaded + " and served the rest";
  if (!library_->compile_error.empty())
    return "engine: " + interpreted + " (no compiled library: " + library_->compile_error + ")";
  return "engine: " + interpreted + first +
         (library_->background ? "; the compile goes on in the background" : "");
}

const char* CompiledModel::parameter_error(const double* params) const {
  if (const auto compiled = library_->parameter_error.load()) return compiled(params);
  const Library& lib = *library_;
  for (size_t i = 0; i < lib.not_finite.size(); ++i)
    if (!std::isfinite(params[i])) return lib.not_finite[i].c_str();
  const size_t n = lib.check_messages.size();
  if (n == 0) return nullptr;
  thread_local std::vector<double> values;
  values.resize(n);
  std::vector<double*> out(n);
  for (size_t k = 0; k < n; ++k) out[k] = &values[k];
  interpret(lib.code->check_values, {}, nullptr, params, out.data());
  for (size_t k = 0; k < n; ++k)
    if (!(lib.check_strict[k] ? values[k] > 0 : values[k] >= 0))
      return lib.check_messages[k].c_str();
  return nullptr;
}

// A complete, verified entry of `source` built before by any compiler for an instruction set
// this CPU runs (`preferred` first, then the others widest first); nothing is written.
CompiledModel CompiledModel::load_built(const ModelRecipe& recipe, const CacheFolder& cache,
                                        const std::string& source, const std::string& preferred,
                                        const std::string& no_compiler, StageReport& rep) {
  std::string last;
  // The entries for a set this CPU runs, `preferred` first, then the widest set.
  auto set_of = [&](const std::string& entry) {
    return entry.substr(source.size(), entry.find('-', source.size()) - source.size());
  };
  const std::vector<std::string> order = {preferred, "avx512f", "avx2", "sse2"};
  auto rank = [&](const std::string& entry) {
    return std::find(order.begin(), order.end(), set_of(entry)) - order.begin();
  };
  std::vector<std::string> entries;
  for (const auto& entry : cache.entries_starting_with(source)) {
    if (cpu_runs(set_of(entry)))
      entries.push_back(entry);
    else
      last = "; '" + cache.path() + "/" + entry + "' is built for " + quoted_text(set_of(entry)) +
             ", which this CPU does not run";
  }
  std::stable_sort(entries.begin(), entries.end(),
                   [&](const std::string& a, const std::string& b) { return rank(a) < rank(b); });
  for (const auto& entry : entries) {
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
    CompiledModel m = open_verified(recipe, library, rep, why);
    if (why.empty()) return m;
    last = "; '" + rep.cache_entry + "/libmodel.so' cannot be loaded: " + why;
  }
  throw CompileError(no_compiler + ", and the cache folder '" + cache.path() +
                     "' holds no complete build of model '" + recipe.name() + "' to load instead" +
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
CompiledModel CompiledModel::open_verified(const ModelRecipe& recipe, const Fd& library,
                                           StageReport& rep, std::string& why, bool partial) {
  const auto t0 = std::chrono::steady_clock::now();
  CompiledModel m;
  m.library_ = std::make_shared<Library>();
  void*& handle = m.library_->handle;
  handle = dlopen(never_used_path(library.get()).c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!handle) {
    const char* e = dlerror();
    why = e ? e : "dlopen failed";
    return m;
  }
  for (const auto& name : description_symbols())
    if (!dlsym(handle, name.c_str())) {
      why = "the library lacks the symbol " + name;
      return m;
    }
  auto sym = [&](const std::string& name) { return dlsym(handle, name.c_str()); };
  auto number = [&](const char* name) { return reinterpret_cast<int (*)()>(sym(name))(); };
  if (number("spacearm_abi_version") != kCInterfaceVersion) {
    why = "wrong interface version";
    return m;
  }
  // The library of this scene, not another one the process has loaded (dlopen matches names).
  const std::string hash = reinterpret_cast<const char* (*)()>(sym("spacearm_scene_hash"))();
  if (hash != recipe.facts().scene_hash) {
    why = "it was built from another scene (" + hash + ")";
    return m;
  }
  // The model's facts, as the library states them.
  m.name_ = reinterpret_cast<const char* (*)()>(sym("spacearm_name"))();
  m.dims_ = {number("spacearm_nq"), number("spacearm_nv"), number("spacearm_num_links"),
             number("spacearm_spatial") != 0, number("spacearm_num_end_effectors")};
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
  if (m.dims_.nq < 0 || m.dims_.nv < 0 || m.dims_.num_links < 0 || np < 0 ||
      m.dims_.num_end_effectors < 1) {
    why = "it states negative sizes";
    return m;
  }
  for (int i = 0; i < m.dims_.nq; ++i) m.coordinate_names_.push_back(coordinate(i));
  // A tree's end effectors are named as the scene names them (the hash says it is this scene's).
  if (m.dims_.num_end_effectors > 1) m.end_effector_names_ = recipe.facts().end_effector_names;
  for (int i = 0; i < np; ++i) {
    m.parameter_names_.push_back(parameter(i));
    m.nominal_.push_back(nominal(i));
  }
  auto motor_on_slot = reinterpret_cast<int (*)(int)>(sym("spacearm_slot_holds_motor"));
  for (int j = 0; j < m.dims_.num_links; ++j) {
    m.actuated_.push_back(actuated(j));
    m.motor_angle_slots_.push_back(motor_on_slot(j) != 0);
  }
  auto span_field = reinterpret_cast<const char* (*)(int)>(sym("spacearm_span_field"));
  auto span_value = reinterpret_cast<double (*)(int)>(sym("spacearm_span_value"));
  auto span_parameter = reinterpret_cast<int (*)(int)>(sym("spacearm_span_parameter"));
  for (int i = 0, n = number("spacearm_num_span_fields"); i < n; ++i) {
    const int p = span_parameter(i);
    m.span_fields_.push_back({span_field(i), span_value(i), p >= 0 && p < np ? p : -1});
  }
  // A cross-check only: the hash already names the scene.
  why = m.mismatch_with(recipe.facts());
  if (!why.empty()) return m;
  m.library_->parameter_error =
      reinterpret_cast<const char* (*)(const double*)>(sym("spacearm_parameter_error"));
  for (const auto& f : exported_functions(m.outputs_)) {
    const auto compiled = reinterpret_cast<ModelFunction::Raw>(sym("spacearm_" + f));
    if (!compiled && !partial) {
      why = "the library lacks the symbol spacearm_" + f;
      return m;
    }
    if (compiled) m.functions_[f] = m.library_->add_slot(f, compiled, nullptr, false, {});
    // The 4-lane version beside it (cpp_printer.hpp), where the printer emitted one.
    if (auto lanes = reinterpret_cast<ModelFunction::Raw>(sym("spacearm_" + f + kLanesSuffix)))
      m.lanes_functions_[f] = m.library_->add_slot(f + kLanesSuffix, lanes, nullptr, true, {});
  }
  rep.load_ms = ms_since(t0);
  return m;
}

// The first fact the library states differently from the scene ("" if none). Every index the
// runtime uses (the base, the actuated coordinates) is among them.
std::string CompiledModel::mismatch_with(const ModelFacts& expected) const {
  if (name_ != expected.name || dims_.nq != expected.dims.nq || dims_.nv != expected.dims.nv ||
      dims_.num_links != expected.dims.num_links || dims_.spatial != expected.dims.spatial ||
      dims_.num_end_effectors != expected.dims.num_end_effectors ||
      parameter_names_ != expected.parameter_names || outputs_ != output_mask(expected.outputs) ||
      free_floating_ != expected.free_floating)
    return "its facts do not match the scene";
  if (num_base_ != expected.num_base || quaternion_offset_ != expected.quaternion_offset ||
      passive_forces_ != expected.has_passive_forces())
    return "its layout does not match the scene";
  const std::vector<int> actuated = spacearm::actuated_coordinates(expected);
  for (int j = 0; j < dims_.num_links; ++j)
    if (actuated_.at(j) != actuated.at(j) ||
        motor_angle_slots_.at(j) != expected.motor_angle_slots.at(j))
      return "its joint " + std::to_string(j + 1) + " does not match the scene";
  return "";
}

void finish_background_compiles() { PendingCompiles::instance().finish(); }

int background_compiles_running() { return PendingCompiles::instance().running(); }

// A model dropped while its library compiles leaves the compile to finish (PendingCompiles).
CompiledModel::~CompiledModel() {
  if (!library_ || !library_->background || library_->done) return;
  Library* lib = library_.get();
  PendingCompiles::instance().keep(std::move(library_), [lib] { return lib->done.load(); });
}
CompiledModel::CompiledModel(CompiledModel&& o) noexcept = default;
// Assigned over, a model hands its compile over as its destruction does (not a wait): destroyed,
// then made anew from o.
CompiledModel& CompiledModel::operator=(CompiledModel&& o) noexcept {
  if (this != &o) {
    this->~CompiledModel();
    new (this) CompiledModel(std::move(o));
  }
  return *this;
}

}  // namespace spacearm
