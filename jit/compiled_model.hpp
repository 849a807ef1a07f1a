// Compile-and-load: generate a scene's C++ with the generator, compile it with the system
// C++ compiler into a shared library, load it with dlopen, and cache the result by the
// content hash of scene + generator version + compiler + flags + libraries, so that an unchanged
// scene is neither regenerated nor recompiled.
#pragma once

#include <Eigen/Core>

#include <atomic>
#include <cstddef>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "dynamic_model.hpp"
#include "interpreter.hpp"
#include "model_cache.hpp"
#include "model_recipe.hpp"
#include "planar_scene.hpp"

namespace spacearm {

// sin and cos through glibc's vector math library, which the generated code uses where its
// macro is defined (cpp_printer.cpp, kTrigBatchHelper): the macro, and the library to link
// after the source (libm's linker script pulls in libmvec). On where CMake's
// SPACEARM_VECTOR_TRIG is (cmake/spacearmAddModel.cmake), as for linked models.
#if SPACEARM_JIT_VECTOR_TRIG
inline constexpr const char* kVectorTrigFlag = " -DSPACEARM_VECTOR_TRIG";
inline constexpr const char* kVectorTrigLibraries = "-lm";
#else
inline constexpr const char* kVectorTrigFlag = "";
inline constexpr const char* kVectorTrigLibraries = "";
#endif

// The compile flags at an optimization level (kDefaultOptimization by default): a shared,
// position-independent C++17 library, with the vector sin/cos where the build has them.
// -fexpensive-optimizations: -O1's register allocation spills the spatial arms' long programs
// (space_arm7's forward dynamics 1245 ns at -O1, 595 ns with it, 589 ns at -O2; bench_spatial),
// for 6 % more compile time.
inline constexpr const char* kDefaultOptimization = "-O1 -fexpensive-optimizations";

// The vector instruction set a library is built for ("avx512f", "avx2" or "sse2", the x86-64
// base; "sse2" stands for the base elsewhere). By default the widest one of the CPU that builds
// (and runs) it: the three-operand encodings, and AVX-512's 32 registers, shrink the long
// straight-line programs, which run at the speed their instructions are fetched (space_arm7's
// forward dynamics with armature: 37 KB and 673 ns in SSE2, 26 KB and 557 ns with -mavx2, 27 KB
// and 500 ns with -mavx512f, and 20 % less compile time). No contraction into FMA
// (compile_flags: -ffp-contract=off): every instruction set gives the bits of SSE2, so an entry
// built for any set this CPU runs may stand in for another (a read-only cache, no compiler).
std::string host_instruction_set();
bool cpu_runs(const std::string& instruction_set);
std::string instruction_set_flags(const std::string& instruction_set);  // " -mavx2", or ""

inline std::string compile_flags(const std::string& optimization = kDefaultOptimization) {
  return optimization + " -ffp-contract=off -std=c++17 -fPIC -shared" + kVectorTrigFlag;
}

// Which engine serves a model's calls (--engine).
//  automatic: the compiled library where the cache holds one; else the interpreter at once
//    (interpreter.hpp, the same numbers) while the compiler builds the library in the
//    background, whose functions serve every call made after it loads; the model's destruction
//    waits for that compile, so that the next run finds the library in the cache.
//  interpreter: the interpreter only; no compiler runs.
//  compiled: the compiled library, built first where the cache has none (waits for it).
enum class Engine { automatic, interpreter, compiled };
const char* engine_name(Engine e);  // "auto", "interpreter", "compiled"
// std::invalid_argument naming `option` and the value when it is none of those three.
Engine parse_engine(const std::string& text, const std::string& option = "--engine");

// Whether a stage message of CompileOptions::progress is worth saying without --verbose: a compile
// the user waits for, or a failure. A compile in the background (Engine::automatic) says its
// stages with the prefix "background: ", for --verbose alone.
inline bool worth_saying(const std::string& message) {
  return message.rfind("background: ", 0) != 0 && message.find("compiling") != std::string::npos;
}

struct CompileOptions {
  std::string cache_dir;  // empty: $SPACEARM_CACHE_DIR, else $XDG_CACHE_HOME/spacearm, else
                          // ~/.cache/spacearm
  std::string compiler;   // empty: $CXX, else c++ (one program, run without a shell)
  // -O1 (with -fexpensive-optimizations): as fast per call as -O2 (bench_first_use,
  // bench_spatial) and up to 40 % quicker to compile.
  // Split at spaces.
  std::string flags = compile_flags();
  std::string libraries = kVectorTrigLibraries;          // after the source, split at spaces
  std::string instruction_set = host_instruction_set();  // added to the flags; cpu_runs it
  int jobs = 0;  // compilers at once (the library in as many units); 0: the CPUs we may use, <= 4
  // Stage messages (may be empty). Engine::automatic calls it from the compile's thread too,
  // until the compile ends (finish_background_compiles): capture by value.
  std::function<void(const std::string&)> progress;
  // The API's default waits for the compiled library; the commands and Python take automatic.
  Engine engine = Engine::compiled;
  // Engine::automatic: the functions the caller calls first (C names without "spacearm_",
  // 4-lane ones ending in "_x4"; names the scene lacks are skipped). They compile in a unit of
  // their own, first, and serve as soon as it is built (from a library of their own, not cached);
  // the rest serves when the whole library loads.
  std::vector<std::string> first_functions;
  void call_first(Output o, bool lanes = false);  // adds output o's function (its 4-lane one)
  // The largest emitted C++ compiled [MB] (compile_estimate): past it the load is refused
  // before the compiler starts, naming the size, the estimated time and memory. 0: read when a
  // compile needs it, $SPACEARM_MAX_CODE_MB or else 8 (default_max_code_mb).
  double max_code_mb = 0;
  static double default_max_code_mb();
};

// What compiling emitted C++ at -O1 costs at least, from measurements (docs/performance.md):
// the seconds and peak memory of the compiler of the largest unit.
struct CompileEstimate {
  double seconds = 0, memory_mb = 0;
};
CompileEstimate compile_estimate(size_t largest_unit_bytes);

// What a load did, stage by stage (for --verbose and for the cache tests).
struct StageReport {
  bool generated = false, compiled = false;
  double derive_ms = 0, emit_ms = 0, compile_ms = 0, load_ms = 0;
  // The interpreter serves the first calls (Engine): its code was read in interpret_ms; with
  // Engine::automatic the compile then runs in the background (compile_ms stays 0).
  bool interpreted = false;
  bool compiling_in_background = false;  // else the interpreter serves alone
  double interpret_ms = 0;
  std::string cache_entry;  // folder of the cached model
};

// One function of a model, called as cpp_printer.hpp says (no checks): the compiled library's
// where it has loaded, else the interpreter's (interpreter.hpp), whose numbers are the same. Each
// call reads which one anew, so a caller that holds it switches at its next call when the
// library loads in the background (Engine::automatic).
class ModelFunction {
 public:
  using Raw = void (*)(const double* const*, const double*, double* const*);
  // What a model holds for each function: the compiled one, set once it has loaded, and the
  // interpreted code that serves until then.
  struct Slot {
    std::atomic<Raw> compiled{nullptr};
    const InterpretedFunction* interpreted = nullptr;
    bool lanes = false;  // the 4-lane version
    TrigSource trig;
    mutable std::atomic<long> interpreted_calls{0};
  };
  ModelFunction() = default;
  ModelFunction(std::nullptr_t) {}
  explicit ModelFunction(const Slot* slot) : slot_(slot) {}
  void operator()(const double* const* in, const double* params, double* const* out) const {
    if (const Raw f = slot_->compiled.load(std::memory_order_acquire)) return f(in, params, out);
    interpret_call(in, params, out);
  }
  explicit operator bool() const { return slot_ != nullptr; }
  bool operator==(const ModelFunction& o) const { return slot_ == o.slot_; }
  bool operator!=(const ModelFunction& o) const { return slot_ != o.slot_; }
  // The compiled function serves it now.
  bool compiled() const { return slot_ && slot_->compiled.load(std::memory_order_acquire); }

 private:
  void interpret_call(const double* const* in, const double* params, double* const* out) const;
  const Slot* slot_ = nullptr;
};

struct EmittedEntry;  // compiled_model.cpp: a cache work folder with emitted C++

// The stages as --verbose says them: "cache ENTRY (hit); derive 1.0 ms, emit ..., compile ...,
// load ...", or which engine serves while the compile runs in the background.
std::string stage_line(const StageReport& rep);

// A generated model loaded from a shared library, with a dynamic-size interface.
class CompiledModel {
 public:
  // A scene of either kind (model_recipe.hpp).
  static CompiledModel load(const ModelRecipe& recipe, const CompileOptions& options,
                            StageReport* report = nullptr);
  static CompiledModel load(const Scene& scene, const CompileOptions& options,
                            StageReport* report = nullptr) {
    return load(ModelRecipe(scene), options, report);
  }
  ~CompiledModel();
  CompiledModel(CompiledModel&&) noexcept;
  CompiledModel& operator=(CompiledModel&&) noexcept;

  const std::string& name() const { return name_; }
  int nq() const { return dims_.nq; }
  int nv() const { return dims_.nv; }
  int num_links() const { return dims_.num_links; }
  const Dimensions& dimensions() const { return dims_; }
  bool has(Output o) const;
  const std::vector<std::string>& coordinate_names() const { return coordinate_names_; }
  // A tree's end effectors (by link where the scene gives them; empty for one end effector).
  const std::vector<std::string>& end_effector_names() const { return end_effector_names_; }
  const std::vector<std::string>& parameter_names() const { return parameter_names_; }
  const std::vector<double>& nominal_parameters() const { return nominal_; }
  bool free_floating() const { return free_floating_; }
  // The base's velocities (0 for a fixed base), and where a quaternion sits in q (-1: none).
  int num_base() const { return num_base_; }
  int quaternion_offset() const { return quaternion_offset_; }
  // Per joint, the velocity index its torque drives (DynamicModel::actuated_coordinates).
  const std::vector<int>& actuated_coordinates() const { return actuated_; }
  // Per joint, whether its slot in q holds the motor angle qm = p q (a rigid gear, eq. 12).
  const std::vector<bool>& motor_angle_slots() const { return motor_angle_slots_; }
  // Springs, dampers or friction besides M qdd + b.
  bool passive_forces() const { return passive_forces_; }

  // The results of an output (registry order and shapes, outputs.hpp) at its inputs, given
  // in the registry's order. Inputs are checked (sizes, finiteness, the parameters' ranges)
  // and errors name the argument and value.
  std::vector<Eigen::MatrixXd> evaluate(Output o, const std::vector<Eigen::VectorXd>& inputs,
                                        const Eigen::VectorXd& params) const;
  // Output o for k states at once, for callers with arrays of states (the Python binding):
  // inputs[i] points at k consecutive vectors of the registry's i-th input, results[r] at room
  // for k consecutive results r, each rows x cols in row-major order. The parameters are checked
  // once; each state's inputs as evaluate() does, forward_dynamics' results by
  // check_forward_dynamics and every result for overflow (DynamicsError). With k > 1 an error
  // names its state ("state s: ..."). lanes = 4: four states per call where the output has a
  // 4-lane function (the same bits); 1: one state per call. A null results[r]: result r is
  // computed and checked but not kept (forward_dynamics' pivots, which serve the checks).
  void evaluate_batch(Output o, long k, const std::vector<const double*>& inputs,
                      const Eigen::VectorXd& params, const std::vector<double*>& results,
                      int lanes = 4) const;
  // The checks every call makes of the parameters (size, finiteness, the scene's ranges):
  // std::invalid_argument naming the one that fails.
  void check_parameters(const Eigen::VectorXd& params) const;
  // "" or, where the model's numbers at these parameters span six decades or more, the span by
  // field ("25 decades, from links[6].mass (mp) = 1e-25 to base.mass = 500"): what a failure of
  // the dynamics at run time names, as the generator's self-check does (value_span.hpp).
  std::string value_span(const Eigen::VectorXd& params) const;
  // "" unless these parameters widen the span past the nominal one (which the generator's
  // self-check passed) by a decade or more; else a sentence to append to a run's failure that
  // names the new span.
  std::string span_note(const Eigen::VectorXd& params) const;
  // Shorthands of evaluate() for the outputs the simulate command reads.
  Eigen::MatrixXd mass_matrix(const Eigen::VectorXd& q, const Eigen::VectorXd& params) const;
  Eigen::VectorXd bias_forces(const Eigen::VectorXd& q, const Eigen::VectorXd& qd,
                              const Eigen::VectorXd& params) const;
  // M and b in one call (the exported mass_matrix_and_bias).
  void mass_matrix_and_bias(const Eigen::VectorXd& q, const Eigen::VectorXd& qd,
                            const Eigen::VectorXd& params, Eigen::MatrixXd& M,
                            Eigen::VectorXd& b) const;
  double kinetic_energy(const Eigen::VectorXd& q, const Eigen::VectorXd& qd,
                        const Eigen::VectorXd& params) const;
  Eigen::VectorXd momentum(const Eigen::VectorXd& q, const Eigen::VectorXd& qd,
                           const Eigen::VectorXd& params) const;
  Eigen::VectorXd end_effector_pose(const Eigen::VectorXd& q, const Eigen::VectorXd& params) const;
  Eigen::MatrixXd end_effector_jacobian(const Eigen::VectorXd& q,
                                        const Eigen::VectorXd& params) const;
  double potential_energy(const Eigen::VectorXd& q, const Eigen::VectorXd& params) const;
  Eigen::VectorXd friction_forces(const Eigen::VectorXd& qd, const Eigen::VectorXd& params) const;
  Eigen::VectorXd gear_ratios(const Eigen::VectorXd& params) const;
  // forward_dynamics works: the scene emits it, or M and b with nothing acting besides them.
  bool has_forward_dynamics() const;
  // qdd = M^-1 (Q - b): the emitted solve if the scene has forward_dynamics, else a Cholesky
  // factorization of M; with the checks of runtime/dynamics_checks.hpp (DynamicsError).
  Eigen::VectorXd forward_dynamics(const Eigen::VectorXd& q, const Eigen::VectorXd& qd,
                                   const Eigen::VectorXd& Q, const Eigen::VectorXd& params) const;
  // forward_dynamics() for a caller that calls it many times at one parameter set (an
  // integration): the emitted function called directly on storage of its own, the checks of
  // inputs and results as one pass/fail test. A call that fails it is made again by
  // forward_dynamics(), which throws the error that names what failed. So results and errors are
  // forward_dynamics()'s, and nothing is allocated per call (where the scene emits
  // forward_dynamics; the Cholesky path allocates). The parameters are checked once, here. Not
  // reentrant: one per thread. Refers to this model: keep it alive and in place.
  class ForwardDynamicsCall {
   public:
    ForwardDynamicsCall(const CompiledModel& m, Eigen::VectorXd params);
    // q: nq entries; qd, Q and qdd: nv.
    void operator()(const double* q, const double* qd, const double* Q, double* qdd);

   private:
    const CompiledModel* m_;
    Eigen::VectorXd params_, pivots_, scaled_pivots_;
    // The emitted function (Function below); empty: the Cholesky path.
    ModelFunction emitted_;
  };
  // The state Jacobian dqdd/dq (on q's tangent space), dqdd/dqd at constant Q, and where given
  // dqdd/dtau (by the link-side joint torques); returns qdd. DynamicsError where a result is not
  // finite (as Model<G>'s).
  Eigen::VectorXd forward_dynamics_derivatives(const Eigen::VectorXd& q, const Eigen::VectorXd& qd,
                                               const Eigen::VectorXd& Q,
                                               const Eigen::VectorXd& params,
                                               Eigen::MatrixXd& dqdd_dq, Eigen::MatrixXd& dqdd_dqd,
                                               Eigen::MatrixXd* dqdd_dtau = nullptr) const;

  // The exported C function of an output, called as cpp_printer.hpp says, with no checks:
  // for callers that check their inputs once and then call it many times (benchmarks). Valid
  // while this model lives; it calls the compiled function once that has loaded, else the
  // interpreter (ModelFunction).
  using Function = ModelFunction;
  Function function(Output o) const;
  // By its exported name without the prefix: an output's, or mass_matrix_and_bias.
  Function function(const std::string& name) const;
  // The output's 4-lane version (four states per call, lanes interleaved: entry i of lane l at
  // [4 i + l] of every input, parameter and result), or nullptr where the library has none.
  Function lanes_function(Output o) const;

  // Which engine serves calls now ("compiled" or "interpreter"), and, for --verbose, a line
  // that says so: how many calls the interpreter served, when the compiled library loaded, or
  // why the background compile failed.
  const char* engine() const;
  std::string engine_report() const;
  // Waits for a background compile (Engine::automatic) to end; true if the compiled library
  // serves now.
  bool wait_for_compiled() const;

 private:
  CompiledModel() = default;
  class BatchCall;
  struct Library;  // the function slots, the loaded library, the background compile
  std::shared_ptr<Library> library_;
  Dimensions dims_;
  std::string name_;
  unsigned long outputs_ = 0;
  std::map<std::string, Function> functions_;        // by name, without the "spacearm_" prefix
  std::map<std::string, Function> lanes_functions_;  // the 4-lane versions, where emitted
  // The library's parameter_error() (cpp_printer.cpp), or the interpreter's: nullptr or what is
  // wrong.
  const char* parameter_error(const double* params) const;
  std::vector<std::string> coordinate_names_, parameter_names_, end_effector_names_;
  std::vector<double> nominal_;
  std::vector<int> actuated_;
  std::vector<bool> motor_angle_slots_;
  std::vector<SpanField> span_fields_;
  bool free_floating_ = false, passive_forces_ = false;
  int num_base_ = 0, quaternion_offset_ = -1;
  // partial: a library of some functions only (CompileOptions::first_functions).
  static CompiledModel open_verified(const ModelRecipe& recipe, const Fd& library, StageReport& rep,
                                     std::string& why, bool partial = false);
  static CompiledModel interpreted(const ModelRecipe& recipe, const CompileOptions& options,
                                   StageReport& rep, const std::string& no_library,
                                   std::shared_ptr<const InterpretedModel> code = nullptr);
  static CompiledModel in_background(const ModelRecipe& recipe, CacheFolder cache,
                                     const std::string& entry, EmittedEntry emitted,
                                     const std::pair<std::string, std::string>& compiler,
                                     const CompileOptions& options, StageReport& rep);
  static CompiledModel load_built(const ModelRecipe& recipe, const CacheFolder& cache,
                                  const std::string& source, const std::string& preferred,
                                  const std::string& no_compiler, StageReport& rep);
  std::string mismatch_with(const ModelFacts& expected) const;
  void check(const char* what, Eigen::Ref<const Eigen::VectorXd> v, int size) const;
  std::vector<Eigen::MatrixXd> call(const std::string& function,
                                    const std::vector<std::pair<Size, Size>>& shapes,
                                    const std::vector<const double*>& inputs,
                                    const Eigen::VectorXd& params) const;
};

// A loaded model at the parameter values `params` as a source of dynamic_model_of
// (runtime/dynamic_model.hpp): its facts as the library states them, its functions by name.
class LoadedSource {
 public:
  using F = DynamicModel::Function;
  using V = Eigen::VectorXd;
  using Mx = Eigen::MatrixXd;
  LoadedSource(const CompiledModel& m, Eigen::VectorXd params)
      : m_(&m), params_(std::move(params)) {}
  bool has(F f) const;
  DynamicModelFacts facts() const;  // checks the parameters (sizes, finite, ranges)
  V end_effector_pose(const V& q) const { return m_->end_effector_pose(q, params_); }
  Mx end_effector_jacobian(const V& q) const { return m_->end_effector_jacobian(q, params_); }
  void mass_matrix_and_bias(const V& q, const V& qd, Mx& M, V& b) const {
    m_->mass_matrix_and_bias(q, qd, params_, M, b);
  }
  V forward_dynamics(const V& q, const V& qd, const V& Q) const {
    return m_->forward_dynamics(q, qd, Q, params_);
  }
  V forward_dynamics_derivatives(const V& q, const V& qd, const V& Q, Mx& dq, Mx& dqd,
                                 Mx* dtau = nullptr) const {
    return m_->forward_dynamics_derivatives(q, qd, Q, params_, dq, dqd, dtau);
  }
  DynamicModel::ForwardDynamicsCall forward_dynamics_call() const {
    return [call = CompiledModel::ForwardDynamicsCall(*m_, params_)](
               const double* q, const double* qd, const double* Q, double* qdd) mutable {
      call(q, qd, Q, qdd);
    };
  }
  double kinetic_energy(const V& q, const V& qd) const {
    return m_->kinetic_energy(q, qd, params_);
  }
  double potential_energy(const V& q) const { return m_->potential_energy(q, params_); }
  V friction_forces(const V& qd) const { return m_->friction_forces(qd, params_); }
  V momentum(const V& q, const V& qd) const { return m_->momentum(q, qd, params_); }

 private:
  const CompiledModel* m_;
  Eigen::VectorXd params_;
};

// The runtime's dynamic-size model (runtime/dynamic_model.hpp) of a loaded model at the
// parameter values `params` (checked here). The result refers to m: keep m alive and in place.
inline DynamicModel dynamic_model(const CompiledModel& m, const Eigen::VectorXd& params) {
  return dynamic_model_of(LoadedSource(m, params));
}

// Models dropped while their library compiled in the background (Engine::automatic) leave the
// compile to finish before the process ends, so that the next run finds it in the cache: how
// many still run, and a wait for them all (a command's last step, after its output; the process's
// exit waits too).
int background_compiles_running();
void finish_background_compiles();

// runtime/dynamics_checks.hpp's checks on the results of evaluate(Output::forward_dynamics, ...)
// (qdd, pivots, scaled_pivots: the registry's order); DynamicsError when one fails.
void check_forward_dynamics(const std::vector<Eigen::MatrixXd>& results,
                            std::string_view model_name);

// The cache folder in use: options.cache_dir, else $SPACEARM_CACHE_DIR, else
// $XDG_CACHE_HOME/spacearm, else $HOME/.cache/spacearm; a CompileError naming what to set if
// none is given (there is no shared fallback under /tmp: another user could plant it).
std::string cache_directory(const CompileOptions& options);

}  // namespace spacearm
