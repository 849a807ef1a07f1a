// Closed-loop study (the paper's future work: "analysis of motor driving torques in the
// closed-loop system for the manipulator equipped with gears"). The paper's straight line
// (Table 1, I_m = 1e-5, the plan of examples/paper_experiment) is tracked in closed loop by a
// computed-torque controller sampled at 1 kHz, built either on the reference model (what the
// paper's controller would use) or on the plant's own model, against
//   - rigid geared plants over the paper's gear ratios, and
//   - flexible-joint plants (with motor friction) over the joint stiffness k.
// Per run: end-effector tracking error (max, final), torque effort (RMS over joints and time,
// peak of any joint) and the extra torque beyond the plan's open-loop torques, with where it
// peaks. Writes
// closed_loop_ratios.csv, closed_loop_stiffness.csv and closed_loop_torques.csv (the torque
// histories at one ratio); scripts/closed_loop.sh draws the figures.
#include <CLI/CLI.hpp>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>

#include "consistent_start.hpp"
#include "joint_control.hpp"
#include "paper_flexible.hpp"
#include "paper_geared.hpp"
#include "paper_reference.hpp"
#include "torque_signal.hpp"
#include "trajectory_planning.hpp"

using namespace spacearm;

namespace {

using Ref = Model<models::paper_reference::Model>;

// The manoeuvre: the plan of the reference model, its joint trajectory, and the desired
// end-effector position at the plan's samples.
struct Manoeuvre {
  StraightLineTask task;
  Ref ref;
  BasicPlan<Ref::Vector, Ref::JointVector> plan;
  SampledJointTrajectory target;
  std::vector<Eigen::Vector2d> ee;

  explicit Manoeuvre(const StraightLineTask& t)
      : task(t), plan(plan_straight_line(ref, t)), target(joint_trajectory(plan, t.dt)) {
    for (const auto& q : plan.q) ee.push_back(ref.end_effector_pose(q).head<2>());
  }
  static SampledJointTrajectory joint_trajectory(const BasicPlan<Ref::Vector, Ref::JointVector>& p,
                                                 double dt) {
    std::vector<Eigen::VectorXd> q, qd, qdd;
    for (size_t k = 0; k < p.q.size(); ++k) {
      q.push_back(p.q[k].tail<3>());
      qd.push_back(p.qd[k].tail<3>());
      qdd.push_back(p.qdd[k].tail<3>());
    }
    return SampledJointTrajectory(0.0, dt, q, qd, qdd);
  }
  // The plan's open-loop torque (linear between samples, as the paper replays it).
  TorqueSignal<3> plan_torque{0.0, task.dt, plan.tau, Interpolation::linear, Extrapolation::hold};
};

struct Metrics {
  double ee_max = 0, ee_final = 0, tau_rms = 0, tau_peak = 0;
  double extra_rms = 0, extra_peak = 0, extra_peak_t = 0;
  int extra_peak_joint = 0;
  std::string failure;  // empty: the run reached the end
};

struct TorqueRow {
  double t;
  Eigen::Vector3d tau, plan;
};

// One closed-loop run from the plan's start (flexible plants: springs pre-deflected for the
// controller's first torque), sampled every `period`.
Metrics run_loop(const Manoeuvre& m, const DynamicModel& plant, const DynamicModel& control,
                 double omega, double period, const IntegratorOptions& opt,
                 std::vector<TorqueRow>* series = nullptr) {
  const ComputedTorqueController ct(control, JointGains::critically_damped(3, omega));
  const int nv = plant.nv;
  auto decide = [&](double t, const Eigen::VectorXd& q, const Eigen::VectorXd& qd) {
    const JointTarget target = m.target(t);
    const Eigen::VectorXd q_joints = plant.joint_angles(q);
    // A loop gone unstable: stop instead of chasing a growing oscillation.
    if ((q_joints - target.q).cwiseAbs().maxCoeff() > 0.1)
      throw std::runtime_error("unstable: joint error above 0.1 rad at t = " + std::to_string(t));
    return ct.torque(target, q.head(3), qd.head(3), q_joints, plant.joint_rates(qd));
  };
  Eigen::VectorXd q0 = Eigen::VectorXd::Zero(nv), qd0 = Eigen::VectorXd::Zero(nv);
  q0.head(3) = m.plan.q.front().head<3>();
  for (int j = 0; j < 3; ++j)
    q0[3 + j] = m.plan.q.front()[3 + j] *
                (plant.actuated_coordinates[j] == 3 + j ? plant.gear_ratios[j] : 1.0);
  consistent_start(plant, q0, qd0, decide(0.0, q0, qd0));
  Metrics r;
  double tau2 = 0, extra2 = 0;
  long samples = 0, applied = 0;
  const long per_plan_sample = std::lround(m.task.dt / period);  // main checks: a whole number
  const long last = std::lround(m.task.duration / period);
  auto record = [&](double t, const Eigen::VectorXd& q, const Eigen::VectorXd&,
                    const Eigen::VectorXd& tau) {
    const Eigen::Vector3d extra = tau - m.plan_torque(t);
    if (samples == last) {  // the torque decided at T is never applied: the end-effector only
      const double e = (plant.end_effector_pose(q).head<2>() - m.ee.back()).norm();
      r.ee_max = std::max(r.ee_max, e);
      r.ee_final = e;
      return;
    }
    ++applied;
    tau2 += tau.squaredNorm() / 3;  // per joint: the RMS of the joints' torques
    extra2 += extra.squaredNorm() / 3;
    r.tau_peak = std::max(r.tau_peak, tau.cwiseAbs().maxCoeff());
    Eigen::Index j;
    if (extra.cwiseAbs().maxCoeff(&j) > r.extra_peak) {
      r.extra_peak = std::abs(extra[j]);
      r.extra_peak_t = t;
      r.extra_peak_joint = static_cast<int>(j) + 1;
    }
    if (samples % per_plan_sample == 0) {
      const double e = (plant.end_effector_pose(q).head<2>() -
                        m.ee.at(std::min<size_t>(samples / per_plan_sample, m.ee.size() - 1)))
                           .norm();
      r.ee_max = std::max(r.ee_max, e);
      r.ee_final = e;
    }
    if (series) series->push_back({t, tau, m.plan_torque(t)});
    ++samples;
  };
  try {
    integrate_closed_loop(plant, q0, qd0, decide, period, m.task.duration, opt, record);
  } catch (const std::exception& e) {  // diverged: the state or the dynamics broke down
    r.failure = e.what();
  }
  r.tau_rms = std::sqrt(tau2 / std::max<long>(applied, 1));
  r.extra_rms = std::sqrt(extra2 / std::max<long>(applied, 1));
  return r;
}

void write_header(std::ofstream& csv, const char* sweep) {
  csv << sweep
      << ",controller,ee_max_m,ee_final_m,tau_rms_Nm,tau_peak_Nm,extra_rms_Nm,"
         "extra_peak_Nm,extra_peak_t_s,extra_peak_joint,failed\n";
}
void write_row(std::ofstream& csv, double x, const std::string& controller, const Metrics& r) {
  csv << x << "," << controller << "," << r.ee_max << "," << r.ee_final << "," << r.tau_rms << ","
      << r.tau_peak << "," << r.extra_rms << "," << r.extra_peak << "," << r.extra_peak_t << ","
      << r.extra_peak_joint << "," << (r.failure.empty() ? 0 : 1) << "\n";
  std::printf("%10g %-10s %10.3e %10.3e %10.3e %10.3e %10.3e %10.3e %6.2f %2d %s\n", x,
              controller.c_str(), r.ee_max, r.ee_final, r.tau_rms, r.tau_peak, r.extra_rms,
              r.extra_peak, r.extra_peak_t, r.extra_peak_joint,
              r.failure.empty() ? "" : ("FAILED: " + r.failure.substr(0, 60)).c_str());
}
void print_columns(const char* sweep) {
  std::printf("%10s %-10s %10s %10s %10s %10s %10s %10s %6s %2s\n", sweep, "controller",
              "ee max [m]", "ee end [m]", "tau rms", "tau peak", "extra rms", "extra peak",
              "at [s]", "j");
}

// The study's settings (command-line options).
struct Study {
  std::vector<double> ratios{1, 1.05, 1.1, 1.25, 1.5, 2, 2.5, 5, 10};
  std::vector<double> stiffnesses{1e2, 3e2, 1e3, 3e3, 1e4, 2.5e4, 1e5, 1e6};
  double p_flexible = 10, damping = 1, rate = 1000, omega = 20, series_ratio = 10;
  std::string out_dir = "out/closed_loop";
  StraightLineTask task;
};

// Rigid geared plants over the ratios, RK4 at the control period; the torque histories of
// both controllers at the series ratio go to closed_loop_torques.csv.
void ratio_sweep(const Study& s, const Manoeuvre& m, const DynamicModel& reference) {
  const double period = 1 / s.rate;
  IntegratorOptions opt;
  opt.method = Method::rk4;
  opt.dt = period;
  std::ofstream csv(s.out_dir + "/closed_loop_ratios.csv");
  write_header(csv, "p");
  std::printf("\nrigid geared plants\n");
  print_columns("p");
  std::vector<TorqueRow> series_ref, series_match;
  for (double p : s.ratios) {
    Model<models::paper_geared::Model> geared;
    geared.set_parameter("p", p);
    const DynamicModel plant = dynamic_model(geared);
    const bool keep = p == s.series_ratio;
    write_row(csv, p, "reference",
              run_loop(m, plant, reference, s.omega, period, opt, keep ? &series_ref : nullptr));
    write_row(csv, p, "matching",
              run_loop(m, plant, plant, s.omega, period, opt, keep ? &series_match : nullptr));
  }
  std::ofstream torques(s.out_dir + "/closed_loop_torques.csv");
  torques << "t,plan1,plan2,plan3,reference1,reference2,reference3,matching1,matching2,matching3\n";
  for (size_t i = 0; i < series_ref.size() && i < series_match.size(); ++i) {
    torques << series_ref[i].t;
    for (const auto* v : {&series_ref[i].plan, &series_ref[i].tau, &series_match[i].tau})
      for (int j = 0; j < 3; ++j) torques << "," << (*v)[j];
    torques << "\n";
  }
}

// Flexible plants over the stiffnesses: stiff, so rosenbrock4 with the plant's Jacobian.
void stiffness_sweep(const Study& s, const Manoeuvre& m, const DynamicModel& reference) {
  const double period = 1 / s.rate;
  IntegratorOptions opt;
  opt.method = Method::rosenbrock4;
  opt.rtol = opt.atol = 1e-8;
  std::ofstream csv(s.out_dir + "/closed_loop_stiffness.csv");
  write_header(csv, "k");
  std::printf(
      "\nflexible plants, p = %g, d = %g N m s/rad, motor friction of "
      "models/paper_flexible.yaml\n",
      s.p_flexible, s.damping);
  print_columns("k");
  for (double k : s.stiffnesses) {
    Model<models::paper_flexible::Model> flex;
    flex.set_parameter("p", s.p_flexible);
    flex.set_parameter("k", k);
    flex.set_parameter("d", s.damping);
    const DynamicModel plant = dynamic_model(flex);
    write_row(csv, k, "reference", run_loop(m, plant, reference, s.omega, period, opt));
    write_row(csv, k, "matching", run_loop(m, plant, plant, s.omega, period, opt));
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Closed-loop tracking of the paper's straight line with geared and flexible arms"};
  Study s;
  app.add_option("--ratios", s.ratios, "Gear ratios of the rigid geared plants")->delimiter(',');
  app.add_option("--stiffnesses", s.stiffnesses,
                 "Joint stiffnesses k of the flexible plants [N m/rad]")
      ->delimiter(',');
  app.add_option("--flexible-ratio", s.p_flexible, "Gear ratio of the flexible plants");
  app.add_option("--damping", s.damping, "Joint damping d of the flexible plants [N m s/rad]")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--rate", s.rate, "Controller sampling rate [Hz]")->check(CLI::PositiveNumber);
  app.add_option("--omega", s.omega, "Closed-loop natural frequency [rad/s] (critically damped)")
      ->check(CLI::PositiveNumber);
  app.add_option("--duration", s.task.duration, "Manoeuvre duration T [s]")
      ->check(CLI::PositiveNumber);
  app.add_option("--series-ratio", s.series_ratio, "Ratio whose torque histories are written");
  app.add_option("--out", s.out_dir, "Output folder");
  CLI11_PARSE(app, argc, argv);
  const double per_sample = s.task.dt * s.rate;  // control samples per plan sample
  if (std::abs(per_sample - std::round(per_sample)) > 1e-9 * per_sample || per_sample < 0.5) {
    std::cerr << "closed_loop: error: --rate " << s.rate << " Hz: the plan's step (" << s.task.dt
              << " s) must be a whole number of control periods\n";
    return 1;
  }
  try {
    std::filesystem::create_directories(s.out_dir);
    const Manoeuvre m(s.task);
    const DynamicModel reference = dynamic_model(m.ref);
    std::printf(
        "Closed loop: computed torque at %g Hz, omega = %g rad/s, the paper's line in %g "
        "s (plan: %zu samples)\n",
        s.rate, s.omega, s.task.duration, m.plan.t.size());
    ratio_sweep(s, m, reference);
    stiffness_sweep(s, m, reference);
    std::printf(
        "\nwrote %s/closed_loop_ratios.csv, closed_loop_stiffness.csv, "
        "closed_loop_torques.csv\n",
        s.out_dir.c_str());
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "closed_loop: error: " << e.what() << "\n";
    return 1;
  }
}
