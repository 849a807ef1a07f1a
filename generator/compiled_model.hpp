// Compile-and-load: generate a scene's C++ with the generator, compile it with the system
// C++ compiler into a shared library, load it with dlopen, and cache the result by the
// content hash of scene + generator version + compiler + flags, so that an unchanged
// scene is neither regenerated nor recompiled.
#pragma once

#include <Eigen/Core>

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "model_cache.hpp"
#include "scene.hpp"

namespace spacearm {

struct CompileOptions {
  std::string cache_dir;  // empty: $SPACEARM_CACHE_DIR, else $XDG_CACHE_HOME/spacearm, else ~/.cache/spacearm
  std::string compiler;   // empty: $CXX, else c++ (one program, run without a shell)
  std::string flags = "-O2 -std=c++17 -fPIC -shared";  // split at spaces
  std::function<void(const std::string&)> progress;  // stage messages (may be empty)
};

// What a load did, stage by stage (for --verbose and for the cache tests).
struct StageReport {
  bool generated = false, compiled = false;
  double derive_ms = 0, emit_ms = 0, compile_ms = 0, load_ms = 0;
  std::string cache_entry;  // folder of the cached model
};

// A generated model loaded from a shared library, with a dynamic-size interface.
class CompiledModel {
 public:
  static CompiledModel load(const Scene& scene, const CompileOptions& options, StageReport* report = nullptr);
  ~CompiledModel();
  CompiledModel(CompiledModel&&) noexcept;
  CompiledModel& operator=(CompiledModel&&) noexcept;

  int nq() const { return nq_; }
  int num_links() const { return num_links_; }
  bool has(Output o) const;
  const std::vector<std::string>& coordinate_names() const { return coordinate_names_; }
  const std::vector<std::string>& parameter_names() const { return parameter_names_; }
  const std::vector<double>& nominal_parameters() const { return nominal_; }

  // Inputs are checked (sizes, finiteness) and errors name the argument and value.
  Eigen::MatrixXd mass_matrix(const Eigen::VectorXd& q, const Eigen::VectorXd& params) const;
  Eigen::MatrixXd coriolis_matrix(const Eigen::VectorXd& q, const Eigen::VectorXd& qd,
                                  const Eigen::VectorXd& params) const;
  Eigen::VectorXd bias_forces(const Eigen::VectorXd& q, const Eigen::VectorXd& qd, const Eigen::VectorXd& params) const;
  double kinetic_energy(const Eigen::VectorXd& q, const Eigen::VectorXd& qd, const Eigen::VectorXd& params) const;
  Eigen::Vector3d momentum(const Eigen::VectorXd& q, const Eigen::VectorXd& qd, const Eigen::VectorXd& params) const;
  Eigen::Vector3d end_effector_pose(const Eigen::VectorXd& q, const Eigen::VectorXd& params) const;
  Eigen::VectorXd gear_ratios(const Eigen::VectorXd& params) const;

 private:
  CompiledModel() = default;
  struct Api;
  std::unique_ptr<Api> api_;
  void* handle_ = nullptr;
  int nq_ = 0, num_links_ = 0;
  unsigned outputs_ = 0;
  std::vector<std::string> coordinate_names_, parameter_names_;
  std::vector<double> nominal_;
  static CompiledModel open_verified(const Scene& scene, const Fd& library, StageReport& rep, std::string& why);
  void check(const char* what, const Eigen::VectorXd& v, int size) const;
  void require(Output o) const;
};

// The cache folder in use: options.cache_dir, else $SPACEARM_CACHE_DIR, else
// $XDG_CACHE_HOME/spacearm, else $HOME/.cache/spacearm; a CompileError naming what to set if
// none is given (there is no shared fallback under /tmp: another user could plant it).
std::string cache_directory(const CompileOptions& options);

}  // namespace spacearm
