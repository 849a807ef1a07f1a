// One run of a study, set up for integration, and the metrics it reduces to: shared by the
// reference path (integrate_motion on the run's DynamicModel, sweep.cpp) and the lockstep path
// (lockstep_runs.cpp), so that both observe the same states through the same code and write
// the same bytes. Private to the sweep library.
#pragma once

#include <Eigen/Core>

#include <memory>
#include <string>
#include <vector>

#include "compiled_model.hpp"
#include "study.hpp"
#include "torque_signal.hpp"

namespace spacearm {

// What StudyRunner loads once: the compiled run scene, the planned (or given) torques and the
// start, link side.
struct LoadedStudy {
  CompiledModel model;
  std::unique_ptr<TorqueSignal<Eigen::Dynamic>> tau;
  Eigen::VectorXd base, angles, base_rate, rates;  // the start, link side
  Eigen::VectorXd nominal_ratios;                  // p at the scene's nominal parameters
};

// A run ready to integrate: its parameters, its model and its start. Throws (a parameter out of
// range: std::invalid_argument) where the run fails before it moves.
struct RunSetup {
  RunSetup(const Study& s, const LoadedStudy& loaded, long run);
  long run;
  Eigen::VectorXd params;
  DynamicModel model;
  Eigen::VectorXd q0, qd0;
  // The link-side torque is scale .* tau(t): 1, or p_run / p_nominal when the motors are
  // commanded with the nominal ratio (model.generalized_forces divides by p_run).
  Eigen::VectorXd scale;
};

// The metrics of one run, observed at every integrator step, and its time series.
class RunMetrics {
 public:
  RunMetrics(const Study& s, const DynamicModel& model, bool series);
  // The state at t, its end-effector pose, the base's momentum (unused for a fixed base) and
  // the link-side torques there.
  void observe(double t, const Eigen::VectorXd& q, const Eigen::VectorXd& qd,
               const Eigen::VectorXd& pose, const Eigen::VectorXd& h, const Eigen::VectorXd& tau);
  // The metrics' fields (",v,v,...", %.17g); DynamicsError naming them if one is not finite.
  std::string measured() const;
  // The time series CSV with its header (empty unless asked).
  std::string series() const;

 private:
  const Study& s_;
  const DynamicModel& model_;
  bool series_;
  bool limits_;  // the scene's URDF has limits (limit_metrics): their peaks are tracked
  Eigen::VectorXd base0_, h0_, pose_;
  // Per joint, link side, for the URDF's limits: peak |tau| and |q'|, least and greatest angle.
  Eigen::VectorXd tau_peak_, rate_peak_, angle_min_, angle_max_;
  double base_drift_ = 0, base_rotation_ = 0, momentum_drift_ = 0, tau_squares_ = 0;
  long samples_ = 0;
  std::string csv_;
};

// The URDF's joint limits as metrics, one place for the header and the rows: per joint with a
// <limit effort> the peak |tau| / effort ("effort_use_J", J the joint's number from 1), then with
// a <limit velocity> the peak |q'| / velocity ("velocity_use_J"), then with a <limit lower upper>
// the peak |q - centre| / half the range ("angle_use_J", as plan's ranges line); link side.
struct LimitMetric {
  enum Kind { effort, velocity, angle };
  int joint;
  Kind kind;
  double limit;       // the effort, the velocity or half the range
  double centre = 0;  // an angle's: the range's middle
  std::string name() const {
    const char* prefix[] = {"effort_use_", "velocity_use_", "angle_use_"};
    return prefix[kind] + std::to_string(joint + 1);
  }
};
std::vector<LimitMetric> limit_metrics(const StudyScene& scene);

// ",v" with v printed %.17g (every number of a row).
void append_number(std::string& row, double v);

// Rows of runs integrated in lockstep, `lanes` at a time (1 or 4), with fixed-step RK4
// (lockstep_runs.cpp). rows[k] (sized as runs) receives run k's row where the lockstep path
// finished it, and stays empty where the run failed or could not be set up: the caller takes
// the reference path there, which writes the failure's message.
struct LockstepRequest {
  const Study& study;
  const LoadedStudy& loaded;
  const std::vector<long>& runs;
  const std::string& ratio;  // the rows' command_ratio field
  std::vector<std::string>& rows;
  std::vector<std::string>* series;  // receives each run's series where asked, else null
  int lanes;
};
void run_lockstep(const LockstepRequest& request);

// Whether the lockstep path can run this study: fixed-step RK4 and an emitted forward_dynamics.
bool lockstep_applies(const Study& s, const CompiledModel& model);

// The row of a run whose metrics are `measured`.
std::string ok_row(long run, const Eigen::VectorXd& params, const std::string& measured,
                   const std::string& ratio);

}  // namespace spacearm
