// The paper's experiment in 3D, on models/space_arm7 (a 7-joint arm on a free-floating base,
// from its URDF): plan a straight end-effector line with the orientation slerped about one axis
// and zero momentum on the arm without gears, replay the planned joint torques in open loop into
// geared models (motor torques tau / p, eq. 14; q_m(0) = p q(0)) whose rotors are coupled exactly
// (each rotor a body on the previous link: its gyroscopic torques and angular momentum) or as
// armature (I_axial on the motor coordinate only, MuJoCo's, Drake's and Pinocchio's model), over
// the same gear ratios, and compare the final end-effector pose with the replay into the model
// without gears. Every model is compiled through the compile-and-load cache (the first run
// compiles three: the gearless arm and one per coupling, whose ratio p is a run-time parameter;
// later runs load them). Writes a table (terminal + CSV)
// and the figure's data into --out; scripts/plot_spatial.sh draws the figure.
#include <CLI/CLI.hpp>

#include <Eigen/Geometry>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

#include "compiled_model.hpp"
#include "simulation.hpp"
#include "torque_signal.hpp"
#include "trajectory_planning.hpp"

using namespace spacearm;

namespace {

// The scene at path (models/space_arm7.yaml) with its gears replaced: none (coupling ""), or the
// run-time ratio p with the shipped rotor inertias and the given coupling.
ModelRecipe arm7(const std::string& path, const std::string& coupling, const std::string& outputs) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read " + path);
  std::stringstream text;
  text << in.rdbuf();
  std::string scene = text.str();
  const size_t gears = scene.find("\ngears:");
  if (gears == std::string::npos) throw std::runtime_error(path + " has no gears: line");
  scene.erase(gears + 1);
  if (!coupling.empty())
    scene += "gears: {ratio: p, rotor_inertia: [1.2e-4, 7.0e-5], rotor_coupling: " + coupling +
             "}\nparameters: {p: 1}\n";
  scene += "outputs: [" + outputs + "]\n";
  return ModelRecipe::parse(scene, path);
}

struct Replay {
  Eigen::VectorXd q, qd;  // at the end
  double momentum_drift = 0;
};

// The planned torques into model m from q0 at rest, by rkf78 at tight tolerances (the error
// measured is the model's, not the integrator's).
Replay replay(const DynamicModel& m, const Eigen::VectorXd& q0, const Plan& plan, double dt) {
  const TorqueSignal<Eigen::Dynamic> tau(0.0, dt, plan.tau, Interpolation::linear);
  IntegratorOptions opt;
  opt.method = Method::rkf78;
  opt.rtol = 1e-11;
  opt.atol = 1e-12;
  Replay r;
  Eigen::VectorXd h0;
  integrate_motion(m, q0, Eigen::VectorXd::Zero(m.nv), tau, plan.t.back(), dt, opt,
                   [&](double, const Eigen::VectorXd& q, const Eigen::VectorXd& qd) {
                     const Eigen::VectorXd h = m.momentum(q, qd);
                     if (h0.size() == 0) h0 = h;
                     r.momentum_drift = std::max(r.momentum_drift, (h - h0).cwiseAbs().maxCoeff());
                     r.q = q, r.qd = qd;
                   });
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "The paper's experiment in 3D: plan on space_arm7, replay into exact and armature "
      "rotors over the gear ratios"};
  std::vector<double> ratios{1, 2, 5, 10, 20, 50, 100};
  double duration = 4, dt = 0.01;
  std::string out_dir = "out/spatial", scene = "models/space_arm7.yaml";
  app.add_option("--ratios", ratios, "Gear ratios to replay")->delimiter(',');
  app.add_option("--duration", duration, "Manoeuvre duration T [s]")->check(CLI::PositiveNumber);
  app.add_option("--dt", dt, "Plan grid [s]")->check(CLI::PositiveNumber);
  app.add_option("--out", out_dir, "Output folder");
  app.add_option("--scene", scene, "The arm's scene (its last line gives the gears)");
  CLI11_PARSE(app, argc, argv);
  try {
    std::filesystem::create_directories(out_dir);
    CompileOptions options;  // the user's cache
    // 1. Plan on the arm without gears: from a bent pose, 0.1 m x, -0.08 m y, -0.1 m z, and a
    // turn of 0.5 rad about (1, 2, -1) in the end effector's frame.
    const CompiledModel reference =
        CompiledModel::load(arm7(scene, "",
                                 "mass_matrix, bias_forces, forward_dynamics, end_effector_pose, "
                                 "end_effector_jacobian, momentum"),
                            options);
    const DynamicModel ref = dynamic_model(reference, Eigen::VectorXd(0));
    StraightLineTask task;
    task.q0 = ref.neutral_configuration();
    task.q0.tail(7) << 0.3, 0.5, -0.2, -1.6, 0.4, 0.9, 0.1;
    task.start = ref.end_effector_pose(task.q0);
    const Eigen::Quaterniond q_start(task.start[3], task.start[4], task.start[5], task.start[6]);
    const Eigen::Quaterniond q_goal =
        q_start * Eigen::AngleAxisd(0.5, Eigen::Vector3d(1, 2, -1).normalized());
    task.goal = task.start;
    task.goal.head<3>() += Eigen::Vector3d(0.1, -0.08, -0.1);
    task.goal.tail<4>() << q_goal.w(), q_goal.x(), q_goal.y(), q_goal.z();
    task.duration = duration;
    task.dt = dt;
    const Plan plan = plan_straight_line(ref, task);
    std::printf("3D experiment on space_arm7 (7 joints, free base): T = %g s, %zu samples\n",
                duration, plan.t.size());
    std::printf("plan: max path error %.2e, max |momentum| %.2e\n", plan.max_path_error,
                plan.max_momentum);

    // 2. The replay into the arm without gears, the pose every geared one is compared with.
    const Replay base = replay(ref, plan.q.front(), plan, dt);
    const Eigen::VectorXd ref_pose = ref.end_effector_pose(base.q);
    std::printf("replay without gears: final position off the goal by %.2e m\n\n",
                (ref_pose.head<3>() - task.goal.head<3>()).norm());
    auto orientation = [](const Eigen::VectorXd& pose) {
      return Eigen::Quaterniond(pose[3], pose[4], pose[5], pose[6]).normalized();
    };

    // 3. Geared replays, exact and armature, at each ratio.
    std::ofstream table(out_dir + "/spatial_table.csv");
    table << "p,exact_position_error_m,exact_angle_error_rad,armature_position_error_m,"
             "armature_angle_error_rad,exact_vs_armature_m,exact_momentum_drift\n";
    table.precision(10);
    std::printf("%6s %15s %15s %15s %15s %15s\n", "p", "exact [m]", "exact [rad]", "armature [m]",
                "armature [rad]", "|exact-arm.| [m]");
    const CompiledModel geared[2] = {
        CompiledModel::load(arm7(scene, "exact", "forward_dynamics, end_effector_pose, momentum"),
                            options),
        CompiledModel::load(
            arm7(scene, "armature", "forward_dynamics, end_effector_pose, momentum"), options)};
    for (double p : ratios) {
      Eigen::VectorXd pose[2];
      double drift = 0;
      for (int k = 0; k < 2; ++k) {
        const DynamicModel m = dynamic_model(geared[k], Eigen::VectorXd::Constant(1, p));
        Eigen::VectorXd qm = plan.q.front();
        qm.tail(7) *= p;  // motor angles q_m = p q
        const Replay r = replay(m, qm, plan, dt);
        pose[k] = m.end_effector_pose(r.q);
        if (k == 0) drift = r.momentum_drift;
      }
      double e[2], a[2];
      for (int k = 0; k < 2; ++k) {
        e[k] = (pose[k].head<3>() - ref_pose.head<3>()).norm();
        a[k] = orientation(pose[k]).angularDistance(orientation(ref_pose));
      }
      const double between = (pose[0].head<3>() - pose[1].head<3>()).norm();
      std::printf("%6g %15.6e %15.6e %15.6e %15.6e %15.6e\n", p, e[0], a[0], e[1], a[1], between);
      table << p << "," << e[0] << "," << a[0] << "," << e[1] << "," << a[1] << "," << between
            << "," << drift << "\n";
    }
    std::printf("\nwrote %s/spatial_table.csv; the figure: scripts/plot_spatial.sh %s\n",
                out_dir.c_str(), out_dir.c_str());
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "spatial_experiment: error: " << e.what() << "\n";
    return 1;
  }
}
