// Work-precision of the paper's manoeuvre (issue: speed against accuracy). The straight-line
// torques of the paper's experiment are replayed into the geared model at p = 1.05, 10 and
// 100 by every integrator over a ladder of steps or tolerances. For each run: right-hand-
// side evaluations, wall time, and the errors at the end of the manoeuvre against a tight
// RKF78 reference: end-effector position, momentum (zero from rest: torques are internal)
// and energy balance (kinetic energy minus the work of the torques, integrated with the
// state). Then float vs double vs long double for RK4, and the armature approximation of the
// rotors against the exact coupling (the modelling error to set against the integration
// error). Then the stiff case: the same torques into the paper's system with flexible joints
// and friction (k = 1e4 N m/rad, a steep friction velocity scale), where the explicit methods
// are held to tiny steps by stability and rosenbrock4 (with the emitted state Jacobian) is not.
// Writes work_precision.csv, precision.csv, armature.csv, flexible.csv;
// scripts/work_precision.sh draws the figures.
#include <CLI/CLI.hpp>

#include <Eigen/Cholesky>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>

#include "consistent_start.hpp"
#include "paper_flexible.hpp"
#include "paper_geared.hpp"
#include "paper_geared_armature.hpp"
#include "paper_reference.hpp"
#include "simulation.hpp"
#include "torque_signal.hpp"
#include "trajectory_planning.hpp"

using namespace spacearm;
using Ref = Model<models::paper_reference::Model>;

namespace {

struct Outcome {
  long evaluations = 0, jacobian_evaluations = 0;
  double seconds = 0;
  double ee_error = 0, momentum_error = 0, energy_error = 0;
  Eigen::Vector2d ee = Eigen::Vector2d::Zero();
};

// One run, state (q, qd, W) with dW/dt = Q . qd, so the energy balance T(t) - T(0) - W(t)
// is known at the end without sampling. Best wall time of `repeats` identical runs.
template <class G>
Outcome run(const Model<G>& model, const typename Model<G>::Vector& q0, const TorqueSignal<3>& tau,
            double T, const IntegratorOptions& opt, int repeats) {
  using M = Model<G>;
  constexpr int n = M::kNq;
  using State = Eigen::Matrix<double, 2 * n + 1, 1>;
  auto f = [&](const State& s, State& d, double t) {
    const typename M::Vector qd = s.template segment<n>(n);
    const typename M::Vector Q = model.generalized_forces(tau(t));
    d.template head<n>() = qd;
    d.template segment<n>(n) = model.forward_dynamics(s.template head<n>(), qd, Q);
    d[2 * n] = Q.dot(qd);
  };
  IntegratorOptions options = opt;
  if constexpr (M::kHasStateJacobian)  // rosenbrock4: the motion's Jacobian, and W's row
    if (opt.method == Method::rosenbrock4) {
      const auto motion = detail::motion_jacobian(model, tau, n, n, 0);
      options.jacobian = [motion, &model, &tau](const Eigen::VectorXd& s, double t,
                                                Eigen::MatrixXd& J, Eigen::VectorXd& dfdt) {
        Eigen::MatrixXd Jm;
        Eigen::VectorXd dm;
        motion(s.head(2 * n), t, Jm, dm);
        J = Eigen::MatrixXd::Zero(2 * n + 1, 2 * n + 1);
        J.topLeftCorner(2 * n, 2 * n) = Jm;
        const typename M::Vector Q = model.generalized_forces(tau(t));
        J.block(2 * n, n, 1, n) = Q.transpose();
        dfdt = Eigen::VectorXd::Zero(2 * n + 1);
        dfdt.head(2 * n) = dm;
        dfdt[2 * n] = detail::force_slope(model, tau, t, Q).dot(s.segment(n, n));
      };
    }
  Outcome o;
  o.seconds = 1e300;
  State x;
  for (int r = 0; r < repeats; ++r) {
    x.setZero();
    x.template head<n>() = q0;
    const auto start = std::chrono::steady_clock::now();
    const auto stats =
        integrate(options, f, x, 0.0, T, T, [](const State&, double) {});  // only the end
    o.seconds = std::min(
        o.seconds, std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
    o.evaluations = stats.rhs_evaluations;
    o.jacobian_evaluations = stats.jacobian_evaluations;
  }
  const typename M::Vector q = x.template head<n>(), qd = x.template segment<n>(n);
  o.ee = model.end_effector_pose(q).template head<2>();
  o.momentum_error = model.momentum(q, qd).cwiseAbs().maxCoeff();
  o.energy_error = std::abs(model.kinetic_energy(q, qd) - x[2 * n]);
  return o;
}

// Odeint's RK4 in scalar S with the generated functions instantiated for S (constants stay
// double).
template <class S>
Eigen::Vector2d rk4_in(const Model<models::paper_geared::Model>& g,
                       const Eigen::Matrix<double, 6, 1>& q0, const TorqueSignal<3>& tau, double T,
                       double dt) {
  namespace m = models::paper_geared;
  using Vec = Eigen::Matrix<S, 12, 1>;
  const m::Parameters<S> params = g.parameters().cast<S>();
  const Eigen::Matrix<S, 3, 1> ratios = g.gear_ratios().cast<S>();
  auto f = [&](const Vec& x, Vec& d, S t) {
    m::MassMatrix<S> M;
    m::Coordinates<S> b, Q = m::Coordinates<S>::Zero();
    m::mass_matrix_and_bias<S>(x.template head<6>(), x.template tail<6>(), params, M, b);
    Q.template tail<3>() = tau(static_cast<double>(t)).cast<S>().cwiseQuotient(ratios);
    d << x.template tail<6>(), Eigen::LLT<m::MassMatrix<S>>(M).solve(Q - b);
  };
  Vec x = Vec::Zero();
  x.template head<6>() = q0.cast<S>();
  boost::numeric::odeint::runge_kutta4<Vec, S, Vec, S, boost::numeric::odeint::vector_space_algebra>
      stepper;
  const long steps = std::lround(T / dt);
  for (long k = 0; k < steps; ++k)
    stepper.do_step(f, x, static_cast<S>(k * dt), static_cast<S>(dt));
  m::Pose<S> pose;
  m::end_effector_pose<S>(x.template head<6>(), params, pose);
  return pose.template head<2>().template cast<double>();
}

// A reference run: rkf78 at tolerance tol (atol tol / 10), landing every `every` seconds.
IntegratorOptions rkf78_reference(double tol, double every) {
  IntegratorOptions o;
  o.method = Method::rkf78;
  o.rtol = tol;
  o.atol = tol / 10;
  o.breakpoint_interval = every;
  return o;
}

// The stiff case: the plan's torques into the flexible model from the consistent start
// (springs carrying the initial torques), every method over its ladder; a run that fails (an
// explicit method past its stability limit) is recorded with an error of inf.
template <class Plan>
void flexible_case(const std::string& out_dir, const StraightLineTask& task, const Plan& plan,
                   const TorqueSignal<3>& tau, bool quick, int repeats) {
  using Flex = Model<models::paper_flexible::Model>;
  Flex m;
  const double vs = 0.01;  // rad/s: friction slope Fs / vs / I_m = 1.5e4 1/s at rest
  m.set_parameter("vs", vs);
  Flex::Vector q0 = Flex::Vector::Zero();
  Flex::Velocity qd0 = Flex::Velocity::Zero();
  q0.head<6>() = plan.q.front();
  consistent_start(m, q0, qd0, tau(0.0));
  const double T = quick ? 1.0 : task.duration;
  const Outcome reference = run(m, q0, tau, T, rkf78_reference(1e-12, task.dt / 4), 1);
  std::printf(
      "\nflexible joints (k = %g N m/rad, friction vs = %g rad/s), %g s: reference "
      "(rkf78, 1e-12) %ld evaluations\n",
      m.parameters()[2], vs, T, reference.evaluations);
  std::ofstream csv(out_dir + "/flexible.csv");
  csv.precision(6);
  csv << "method,setting,evaluations,jacobians,wall_s,ee_error_m,energy_error_J\n";
  auto record = [&](const std::string& method, double setting, const IntegratorOptions& opt) {
    Outcome o;
    long jacobians = 0;
    double ee = std::numeric_limits<double>::infinity();
    try {
      o = run(m, q0, tau, T, opt, repeats);
      jacobians = o.jacobian_evaluations;
      ee = (o.ee - reference.ee).norm();
    } catch (const std::exception& e) {  // unstable: the state overflowed or M broke down
      o.seconds = std::numeric_limits<double>::quiet_NaN();
    }
    std::printf("%-18s %10g %12ld %9ld %11.3f %11.2e\n", method.c_str(), setting, o.evaluations,
                jacobians, o.seconds * 1e3, ee);
    csv << method << "," << setting << "," << o.evaluations << "," << jacobians << "," << o.seconds
        << "," << ee << "," << o.energy_error << "\n";
  };
  std::printf("%-18s %10s %12s %9s %11s %11s\n", "method", "setting", "evaluations", "Jacobians",
              "wall [ms]", "ee err [m]");
  for (double dt : quick ? std::vector<double>{0.01, 1e-4}
                         : std::vector<double>{0.01, 1e-3, 2e-4, 1e-4, 5e-5}) {
    IntegratorOptions opt;
    opt.method = Method::rk4;
    opt.dt = dt;
    record("rk4", dt, opt);
  }
  for (Method method : {Method::dopri5, Method::rkf78, Method::rosenbrock4})
    for (double tol :
         quick ? std::vector<double>{1e-6} : std::vector<double>{1e-4, 1e-6, 1e-8, 1e-10}) {
      IntegratorOptions opt;
      opt.method = method;
      opt.rtol = opt.atol = tol;
      record(to_string(method), tol, opt);
      if (method != Method::rosenbrock4) continue;
      opt.breakpoint_interval = task.dt;  // steps land on the torque samples
      record("rosenbrock4+samples", tol, opt);
    }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Work-precision of the paper's manoeuvre with the geared model"};
  std::vector<double> ratios{1.05, 10, 100};
  std::string out_dir = "out/work_precision";
  int repeats = 3;
  bool quick = false;
  app.add_option("--ratios", ratios, "Gear ratios")->delimiter(',');
  app.add_option("--out", out_dir, "Output folder");
  app.add_option("--repeats", repeats, "Runs per setting; the best wall time is kept")
      ->check(CLI::PositiveNumber);
  app.add_flag("--quick", quick, "A short ladder (for the test)");
  CLI11_PARSE(app, argc, argv);
  try {
    std::filesystem::create_directories(out_dir);
    StraightLineTask task;  // the paper's manoeuvre, as in examples/paper_experiment
    const Ref ref;
    const auto plan = plan_straight_line(ref, task);
    const TorqueSignal<3> tau(0.0, task.dt, plan.tau, Interpolation::linear);
    const double T = task.duration;

    const std::vector<double> steps =
        quick ? std::vector<double>{0.02, 0.01}
              : std::vector<double>{0.04, 0.02, 0.01, 0.005, 0.0025, 0.00125};
    const std::vector<double> tolerances =
        quick ? std::vector<double>{1e-6, 1e-8}
              : std::vector<double>{1e-4, 1e-6, 1e-8, 1e-10, 1e-12};

    std::ofstream csv(out_dir + "/work_precision.csv");
    csv.precision(6);
    csv << "p,method,setting,evaluations,wall_s,ee_error_m,momentum_error,energy_error_J\n";
    std::ofstream precision(out_dir + "/precision.csv");
    precision << "p,dt,float_error_m,double_error_m,long_double_error_m\n";
    std::ofstream armature(out_dir + "/armature.csv");
    armature << "p,armature_minus_exact_ee_m\n";
    for (double p : ratios) {
      Model<models::paper_geared::Model> g;
      g.set_parameter("p", p);
      Model<models::paper_geared_armature::Model> a;
      a.set_parameter("p", p);
      Eigen::Matrix<double, 6, 1> qm = plan.q.front();
      qm.tail<3>() *= p;
      // The torques are linear between the plan's samples, so their derivative jumps every
      // task.dt: the reference lands on every sample time, so that none of its steps
      // straddles a kink, and takes 8 steps per sample interval (a computation none of the
      // runs below repeats).
      const IntegratorOptions tight = rkf78_reference(1e-13, task.dt / 8);
      const Outcome reference = run(g, qm, tau, T, tight, 1);
      std::printf(
          "\np = %g: reference (rkf78, tolerance 1e-13): %ld evaluations, momentum %.1e, energy "
          "balance %.1e J\n",
          p, reference.evaluations, reference.momentum_error, reference.energy_error);
      std::printf("%-18s %10s %12s %11s %11s %11s\n", "method", "setting", "evaluations",
                  "wall [ms]", "ee err [m]", "energy [J]");
      auto record = [&](const std::string& method, double setting, const Outcome& o) {
        const double ee = (o.ee - reference.ee).norm();
        std::printf("%-18s %10g %12ld %11.3f %11.2e %11.2e\n", method.c_str(), setting,
                    o.evaluations, o.seconds * 1e3, ee, o.energy_error);
        csv << p << "," << method << "," << setting << "," << o.evaluations << "," << o.seconds
            << "," << ee << "," << o.momentum_error << "," << o.energy_error << "\n";
      };
      for (Method m : {Method::rk4, Method::implicit_midpoint}) {
        for (double dt : steps) {
          if (m == Method::implicit_midpoint && dt < 0.005 && quick) continue;
          IntegratorOptions opt;
          opt.method = m;
          opt.dt = dt;
          record(to_string(m), dt, run(g, qm, tau, T, opt, repeats));
        }
      }
      for (Method m : {Method::dopri5, Method::rkf78})
        for (bool breaks : {false, true})
          for (double tol :
               breaks ? std::vector<double>{1e-8} : tolerances) {  // with samples, one step each
            IntegratorOptions opt;
            opt.method = m;
            opt.rtol = opt.atol = tol;
            // "+samples": steps land on the torque samples, where the torque's slope jumps.
            if (breaks) opt.breakpoint_interval = task.dt;
            record(to_string(m) + (breaks ? "+samples" : ""), tol,
                   run(g, qm, tau, T, opt, repeats));
          }
      // Precision: the same RK4 steps in float, double and long double.
      for (double dt : steps) {
        const double ef = (rk4_in<float>(g, qm, tau, T, dt) - reference.ee).norm();
        const double ed = (rk4_in<double>(g, qm, tau, T, dt) - reference.ee).norm();
        const double el = (rk4_in<long double>(g, qm, tau, T, dt) - reference.ee).norm();
        precision << p << "," << dt << "," << ef << "," << ed << "," << el << "\n";
        std::printf(
            "rk4 dt = %-8g end-effector error: float %.2e, double %.2e, long double %.2e m\n", dt,
            ef, ed, el);
      }
      // Modelling error of the armature approximation, both integrated tightly.
      const Outcome arm = run(a, qm, tau, T, tight, 1);
      const double model_error = (arm.ee - reference.ee).norm();
      armature << p << "," << model_error << "\n";
      std::printf(
          "armature approximation instead of the exact rotor coupling: end-effector differs by "
          "%.2e m\n",
          model_error);
    }
    flexible_case(out_dir, task, plan, tau, quick, repeats);
    std::printf("\nwrote %s/work_precision.csv, precision.csv, armature.csv, flexible.csv\n",
                out_dir.c_str());
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "work_precision: error: " << e.what() << "\n";
    return 1;
  }
}
