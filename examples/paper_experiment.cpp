// The paper's experiment (Section 3): plan a straight end-effector line for the reference
// model with zero momentum, compute the joint torques (eq. 5), replay them as motor torques
// tau/p (eq. 14) in open loop into the geared model for several gear ratios with RK4 at
// 0.01 s, and compare the final end-effector positions with the reference replay (Table 2).
// Units: SI (m, rad, s, N m). Writes a table (terminal + CSV), time series (CSV) and
// figures (PNG through gnuplot) into --out.
#include <CLI/CLI.hpp>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>

#include "paper_geared.hpp"
#include "paper_reference.hpp"
#include "simulation.hpp"
#include "torque_signal.hpp"
#include "trajectory_planning.hpp"

using namespace spacearm;
using Ref = Model<models::paper_reference::Model>;
using Geared = Model<models::paper_geared::Model>;

namespace {

void write_series(const std::string& path, const Trajectory<models::paper_geared::Model>& tr,
                  const Geared& g) {
  std::ofstream out(path);
  out << "t,ee_x,ee_y,ee_phi,x0,y0,q0,qd1,qd2,qd3,Px,Py,L,kinetic_energy,work,cond_M\n";
  out.precision(12);
  for (size_t k = 0; k < tr.t.size(); ++k) {
    const auto& q = tr.q[k];
    const auto& qd = tr.qd[k];
    const auto& x = tr.end_effector[k];
    const auto& h = tr.momentum[k];
    out << tr.t[k] << "," << x[0] << "," << x[1] << "," << x[2] << "," << q[0] << "," << q[1] << ","
        << q[2];
    // Link-side joint velocities qd = qd_m / p.
    for (int j = 0; j < 3; ++j) out << "," << qd[3 + j] / g.gear_ratios()[j];
    out << "," << h[0] << "," << h[1] << "," << h[2] << "," << tr.kinetic_energy[k] << ","
        << tr.work[k] << "," << tr.condition_number[k] << "\n";
  }
}

// Arm drawn as a polyline: base CoM, joints 1..3, tip; one block per configuration.
template <class M>
void write_arm(std::ostream& out, const M& model, const typename M::Vector& q,
               const std::string& label) {
  Eigen::Matrix<double, 2, 4> P;
  using G = std::conditional_t<std::is_same_v<M, Ref>, models::paper_reference::Model,
                               models::paper_geared::Model>;
  G::joint_positions(q, model.parameters(), P);
  out << "# " << label << "\n" << q[0] << " " << q[1] << "\n";
  for (int k = 0; k < 4; ++k) out << P(0, k) << " " << P(1, k) << "\n";
  out << "\n\n";
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "The paper's experiment: straight-line plan, torque replay into geared models, Table 2"};
  StraightLineTask task;
  std::vector<double> ratios{1, 1.05, 1.1, 1.25, 1.5, 2, 2.5, 5, 10};
  double motor_inertia = 1e-5;
  std::string interpolation = "linear", law = "quintic", integrator = "rk4", out_dir = "out/paper";
  double dt = 0.01;
  bool plots = true;
  app.add_option("--duration", task.duration, "Manoeuvre duration T [s]")
      ->check(CLI::PositiveNumber);
  app.add_option("--elbow", task.elbow, "Elbow branch of the initial pose: +1 or -1")
      ->check(CLI::IsMember({-1, 1}));
  app.add_option("--time-law", law, "Time law along the line: quintic or cubic");
  app.add_option("--interpolation", interpolation, "Torque between plan samples: linear or hold");
  app.add_option("--ratios", ratios, "Gear ratios to replay")->delimiter(',');
  app.add_option("--motor-inertia", motor_inertia, "Motor inertia I_m [kg m^2]")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--dt", dt, "Plan grid and RK4 step [s]")->check(CLI::PositiveNumber);
  app.add_option("--integrator", integrator, "rk4, dopri5, rkf78 or implicit_midpoint");
  app.add_option("--out", out_dir, "Output folder");
  app.add_flag("!--no-plots", plots, "Skip the gnuplot figures");
  CLI11_PARSE(app, argc, argv);

  try {
    task.dt = dt;
    task.law = time_law_from_string(law);
    const Interpolation mode = interpolation_from_string(interpolation);
    IntegratorOptions opt;
    opt.method = method_from_string(integrator);
    opt.dt = dt;
    std::filesystem::create_directories(out_dir);

    std::printf(
        "Paper experiment: end-effector (%.3g, %.3g, %.4g) -> (%.3g, %.3g, %.4g), T = %g s, %s "
        "time law,\n"
        "elbow branch %+d, base at the origin with q0 = 0 at rest, torques %s between samples,\n"
        "%s with dt = %g s, I_m = %g kg m^2 (link inertia reduced by I_m).\n\n",
        task.start[0], task.start[1], task.start[2], task.goal[0], task.goal[1], task.goal[2],
        task.duration, law.c_str(), task.elbow,
        interpolation == "linear" ? "interpolated linearly" : "held", integrator.c_str(), dt,
        motor_inertia);

    // 1. Plan with the reference model.
    const Ref ref;
    const auto plan = plan_straight_line(ref, task);
    std::printf(
        "plan: %zu samples, max path error %.2e, max |momentum| %.2e, max base force (eq. 5 base "
        "rows) %.2e\n",
        plan.t.size(), plan.max_path_error, plan.max_momentum, plan.max_base_residual);
    {
      std::ofstream out(out_dir + "/plan.csv");
      out.precision(12);
      out << "t,x0,y0,q0,q1,q2,q3,tau1,tau2,tau3\n";
      for (size_t k = 0; k < plan.t.size(); ++k) {
        out << plan.t[k];
        for (int i = 0; i < 6; ++i) out << "," << plan.q[k][i];
        for (int i = 0; i < 3; ++i) out << "," << plan.tau[k][i];
        out << "\n";
      }
    }
    {
      std::ofstream arm(out_dir + "/arm_plan.dat");
      for (size_t k = 0; k < plan.t.size(); k += (plan.t.size() - 1) / 5)
        write_arm(arm, ref, plan.q[k], "t = " + std::to_string(plan.t[k]));
    }
    const TorqueSignal<3> tau(0.0, task.dt, plan.tau, mode);

    // 2. Reference replay (torques on the links).
    const auto q_start = plan.q.front();
    const auto ref_traj = simulate<models::paper_reference::Model>(
        ref, q_start, Ref::Vector::Zero(), tau, task.duration, task.dt, opt);
    const Eigen::Vector3d ref_end = ref_traj.end_effector.back();
    const Eigen::Vector3d plan_end = ref.end_effector_pose(plan.q.back());
    std::printf("reference replay: final end-effector error vs plan %.2e m\n\n",
                (ref_end - plan_end).head<2>().norm());

    // 3. Geared replays: q_m(0) = p q(0), torques tau / p.
    std::ofstream table(out_dir + "/table2.csv");
    table << "p,x_error_m,y_error_m,error_norm_m,base_x_dev_m,base_y_dev_m,base_angle_dev_rad,max_"
             "momentum_drift\n";
    std::printf("%8s %14s %14s %14s %12s %12s %12s %12s\n", "p", "X error [m]", "Y error [m]",
                "norm [m]", "base dx [m]", "base dy [m]", "base dq0[rad]", "|h| drift");
    for (double p : ratios) {
      Geared g;
      g.set_parameter("p", p);
      g.set_parameter("Im", motor_inertia);
      Geared::Vector qm = q_start;
      qm.tail<3>() *= p;
      const auto traj = simulate<models::paper_geared::Model>(g, qm, Geared::Vector::Zero(), tau,
                                                              task.duration, task.dt, opt);
      const Eigen::Vector3d e = traj.end_effector.back() - ref_end;
      const auto& qf = traj.q.back();
      const auto& qr = ref_traj.q.back();
      double drift = 0;
      for (const auto& h : traj.momentum)
        drift = std::max(drift, (h - traj.momentum.front()).cwiseAbs().maxCoeff());
      std::printf("%8g %14.6e %14.6e %14.6e %12.3e %12.3e %12.3e %12.2e\n", p, e[0], e[1],
                  e.head<2>().norm(), qf[0] - qr[0], qf[1] - qr[1], qf[2] - qr[2], drift);
      table << p << "," << e[0] << "," << e[1] << "," << e.head<2>().norm() << "," << qf[0] - qr[0]
            << "," << qf[1] - qr[1] << "," << qf[2] - qr[2] << "," << drift << "\n";
      char name[64];
      std::snprintf(name, sizeof name, "/replay_p%g.csv", p);
      write_series(out_dir + name, traj, g);
      {
        std::ofstream arm(out_dir + "/arm_final.dat",
                          p == ratios.front() ? std::ios::trunc : std::ios::app);
        write_arm(arm, g, qf, "p = " + std::to_string(p));
      }
    }
    table.close();
    std::printf("\nwrote %s/table2.csv, plan.csv, replay_p*.csv\n", out_dir.c_str());
    if (plots) std::printf("figures: run scripts/plot_paper.sh %s\n", out_dir.c_str());
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "paper_experiment: error: " << e.what() << "\n";
    return 1;
  }
}
