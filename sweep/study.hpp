// A study (issue 15): one scene, one manoeuvre (a straight-line plan or a torque file), one
// integrator, and the runs' run-time parameters as a grid and/or random draws from named
// distributions with a seed. Read from an untrusted YAML file (generator/scene/yaml_reader.hpp):
// errors name the file, line and field. A run's parameters depend only on the study and the
// run's index, so that any split of the runs (threads, shards, Dask) computes the same numbers.
#pragma once

#include <Eigen/Core>

#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "integrator_options.hpp"
#include <memory>

#include "planar_scene.hpp"
#include "spatial_scene.hpp"
#include "torque_csv.hpp"
#include "torque_signal.hpp"
#include "trajectory_planning.hpp"

namespace spacearm {

class StudyError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// A named distribution of one parameter's random draws.
struct Distribution {
  enum class Kind { uniform, normal, log_uniform } kind = Kind::uniform;
  double a = 0, b = 0;  // uniform, log_uniform: [a, b); normal: mean a, standard deviation b
};

// A study's scene, planar or spatial (`space: spatial`), as read: what the study checks
// against it; the runner derives and compiles its model (sweep.cpp).
struct StudyScene {
  std::shared_ptr<const Scene> planar;
  std::shared_ptr<const SpatialScene> spatial;
  std::string name, source_path, content;
  std::vector<std::string> parameter_names;
  std::vector<double> nominal_parameters;
  bool free_floating = false, geared = false;
  int num_links = 0;
  int base_coordinates = 0;  // q's base entries: 3 (x0, y0, q0), 7 (origin, quaternion) or 0
  int quaternion_offset = -1;
  unsigned features = 0;  // needs:: bits (outputs.hpp)
  std::vector<Output> outputs;
  std::vector<std::string> end_effector_names;  // a spatial scene's, in its pose's order
  bool is_spatial() const { return spatial != nullptr; }
  bool wants(Output o) const;
};

// Reads and parses a scene file of either kind (SceneError naming the file and field).
StudyScene load_study_scene(const std::string& path);

struct Study {
  std::string source_path, content;  // the study file
  std::string identity;  // hash of the study, its scenes and its torque file (results/ checks it)
  StudyScene scene;      // the model of every run (planar, or spatial: a base floating in 3D)
  // The manoeuvre: a straight-line plan, computed once with the nominal parameters of
  // plan_scene (the run scene if not given) and replayed open loop into every run (the paper's
  // experiment, Section 3); or torques from a file, from q0.
  std::optional<StraightLineTask> plan;
  // The end effector measured (its pose, ee_error) and planned: an index into the scene's
  // end_effector_names (manoeuvre.end_effector), the first by default.
  int end_effector = 0;
  std::optional<StudyScene> plan_scene;
  std::optional<TorqueTable> torques;
  std::string torque_path;
  // Torque manoeuvre: the start, as the base pose and link-side joint angles (num_base + N).
  Eigen::VectorXd q0;
  // End-effector goal for ee_error: the plan's, or given; (x, y), in 3D (x, y, z) or the pose
  // (x, y, z, qw, qx, qy, qz), whose angle error is ee_angle_error.
  Eigen::VectorXd target;
  // Which gear ratio divides the link-side torques into motor commands: each run's own p
  // ("run": a different, known gearbox; the default) or the scene's nominal p ("nominal": the
  // real p is not the p the controller believes, so the link gets tau p_run / p_nominal).
  enum class CommandRatio { run, nominal } command_ratio = CommandRatio::run;
  // A plan's torques plus the friction that the run scene's nominal parameters predict along
  // the planned rates (plan_replay.hpp's friction_along; the scene must emit friction_forces).
  bool feedforward_friction = false;
  IntegratorOptions integrator;
  Interpolation interpolation = Interpolation::linear;
  double t_end = 0;
  // Runs: every grid point (last grid parameter fastest) times random.runs draws.
  std::vector<std::pair<int, std::vector<double>>> grid;  // parameter index, its values
  std::vector<std::pair<int, Distribution>> draws;        // in the study's order
  long draws_per_point = 1;
  std::uint64_t seed = 0;
  long series_every = 0;  // > 0: per-run time series, every this many integrator steps

  long num_runs() const;
  // The run's parameter values (the scene's order): nominal, then its grid point, then its
  // draws from a generator seeded with (seed, run) alone.
  Eigen::VectorXd parameters(long run) const;
  std::vector<std::string> parameter_names() const;
};

// Largest number of runs a study may have (merging the rows takes about 1 GB per million).
inline constexpr long kMaxRuns = 10'000'000;

Study parse_study(const std::string& yaml_text, const std::string& source_path);
Study load_study(const std::string& path);

}  // namespace spacearm
