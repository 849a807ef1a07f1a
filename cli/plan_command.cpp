#include "plan_command.hpp"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <string>

#include "provenance.hpp"
#include "cli_input.hpp"
#include "joint_limits.hpp"
#include "compiled_model.hpp"
#include "row_writer.hpp"
#include "optimal_plan.hpp"
#include "plan_limits.hpp"
#include "trajectory_planning.hpp"

namespace spacearm {

namespace {

void check_outputs(const ModelFacts& facts) {
  std::string missing;
  for (Output o : {Output::end_effector_pose, Output::end_effector_jacobian, Output::mass_matrix,
                   Output::bias_forces})
    if (std::find(facts.outputs.begin(), facts.outputs.end(), o) == facts.outputs.end())
      missing += (missing.empty() ? "" : ", ") + to_string(o);
  if (!missing.empty())
    throw std::invalid_argument("plan: scene '" + facts.name + "' does not emit " + missing +
                                " (add them to its field 'outputs')");
}

void append(std::string& row, double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, row.empty() ? "%.17g" : ",%.17g", v);
  row += buf;
}

void write_plan(const PlanTable& table, const std::string& path) {
  RowWriter out(path);
  std::string head;
  for (const auto& name : table.names) head += (head.empty() ? "" : ",") + name;
  out.row(head + "\n");
  for (const auto& values : table.rows) {
    std::string row;
    for (double v : values) append(row, v);
    out.row(row + "\n");
  }
  out.close();
}

// t, tau1..N: the torque file simulate --torques reads.
void write_torques(const Plan& plan, const std::string& path) {
  RowWriter out(path, "--torque-file");
  std::string head = "t";
  for (long j = 1; j <= plan.tau.front().size(); ++j) head += ",tau" + std::to_string(j);
  out.row(head + "\n");
  for (size_t k = 0; k < plan.t.size(); ++k) {
    std::string row;
    append(row, plan.t[k]);
    for (double x : plan.tau[k]) append(row, x);
    out.row(row + "\n");
  }
  out.close();
}

// -o and --torque-file must be two places (both standard output, or one file, would mix them).
void refuse_same_outputs(const PlanArgs& a) {
  if (a.torque_file.empty()) return;
  auto is_stdout = [](const std::string& p) { return p.empty() || p == "-"; };
  bool same = is_stdout(a.output_file) && is_stdout(a.torque_file);
  if (!is_stdout(a.output_file) && !is_stdout(a.torque_file)) {
    std::error_code e1, e2;
    same = std::filesystem::weakly_canonical(a.output_file, e1) ==
           std::filesystem::weakly_canonical(a.torque_file, e2);
  }
  if (same)
    throw std::invalid_argument("--torque-file '" + a.torque_file + "' is also the -o output '" +
                                (is_stdout(a.output_file) ? "-" : a.output_file) +
                                "': give two different files");
}

// The task from the options, checked against the scene's sizes before anything is compiled.
// A tree's end effector by name: its index among the model's.
int end_effector_index(const std::string& name, const ModelFacts& facts) {
  if (facts.dims.num_end_effectors == 1)
    throw std::invalid_argument("--end-effector: scene '" + facts.name +
                                "' has one end effector: --end-effector names one of a tree's");
  try {
    return spacearm::end_effector_index(facts.end_effector_names, name, facts.name);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(std::string("--end-effector: ") + e.what());
  }
}

Eigen::VectorXd numbers(const std::string& text, const std::string& option) {
  const std::vector<double> x = parse_number_list(text, option);
  return Eigen::Map<const Eigen::VectorXd>(x.data(), static_cast<Eigen::Index>(x.size()));
}

// An option the objective does not use (uses_knots, ...) is an error, not silently dropped.
void refuse_unused_options(const PlanArgs& a, Objective objective) {
  auto fail = [&a](const std::string& option, const std::string& why) {
    throw std::invalid_argument(option + ": not used by --objective " + a.objective + " (" + why +
                                ")");
  };
  if (a.knots_given && !uses_knots(objective))
    fail("--knots", "it is min_base_rotation's and min_effort's");
  if (a.effort_weight_given && !uses_effort_weight(objective))
    fail("--effort-weight", objective == Objective::min_effort
                                ? "min_effort minimises the effort alone; the weight is "
                                  "min_base_rotation's"
                                : "it is min_base_rotation's");
  if (!a.time_laws.empty() && !uses_time_law(objective))
    fail("--time-law",
         "a point-to-point plan goes by any path; the time law is the straight line's");
}

StraightLineTask task_from_options(const PlanArgs& a, const ModelFacts& facts) {
  StraightLineTask task;
  // One line per --end-effector (or one line without it): --from, --to and --time-law in the
  // same order (one --time-law serves every line).
  const size_t lines = std::max<size_t>(1, a.end_effectors.size());
  for (const auto& [given, option] : {std::pair{&a.from_text, "--from"}, {&a.to_text, "--to"}})
    if (given->size() != lines)
      throw std::invalid_argument(std::string(option) + ": given " + std::to_string(given->size()) +
                                  " times for " + std::to_string(lines) +
                                  " end effector line(s) (one " + option +
                                  " per --end-effector, in the same order)");
  if (a.time_laws.size() > 1 && a.time_laws.size() != lines)
    throw std::invalid_argument("--time-law: given " + std::to_string(a.time_laws.size()) +
                                " times for " + std::to_string(lines) +
                                " end effector lines (once for all, or once per --end-effector)");
  auto law = [&a](size_t k) {
    return a.time_laws.empty()
               ? TimeLaw::quintic
               : time_law_from_string(a.time_laws[std::min(k, a.time_laws.size() - 1)]);
  };
  task.start = numbers(a.from_text[0], "--from");
  task.goal = numbers(a.to_text[0], "--to");
  task.law = law(0);
  if (!a.end_effectors.empty()) task.end_effector = end_effector_index(a.end_effectors[0], facts);
  for (size_t k = 1; k < lines; ++k)
    task.more_lines.push_back({end_effector_index(a.end_effectors[k], facts),
                               numbers(a.from_text[k], "--from"), numbers(a.to_text[k], "--to"),
                               law(k)});
  task.duration = a.duration;
  task.dt = a.dt;
  task.elbow = a.elbow;
  if (!a.q0_text.empty()) task.q0 = cli::parse_vector(a.q0_text, "--q0", facts.dims.nq);
  task.hold = hold_from_string(a.hold);
  task.objective = objective_from_string(a.objective);
  task.knots = a.knots;
  task.effort_weight = a.effort_weight;
  refuse_unused_options(a, task.objective);
  DynamicModel sizes;
  sizes.name = facts.name;
  sizes.nq = facts.dims.nq;
  sizes.nv = facts.dims.nv;
  sizes.num_links = facts.dims.num_links;
  sizes.free_floating = facts.free_floating;
  sizes.spatial = facts.dims.spatial;
  if (facts.dims.num_end_effectors > 1) sizes.end_effector_names = facts.end_effector_names;
  sizes.set_layout(facts.num_base, facts.quaternion_offset);
  const TaskNames names{"--from", "--to",           "--duration", "--dt",           "--elbow",
                        "--q0",   "--end-effector", "--knots",    "--effort-weight"};
  check_task(sizes, task, names);
  if (point_to_point(task.objective)) check_point_to_point(sizes, task, names);
  return task;
}

}  // namespace

// A line passes near a singularity where the rates spike to this many times their median
// along it. Measured with plan --verbose: the plans of the tests, the paper and space_arm7 peak
// at 1.4 to 2.0 times it; a line 2 um from a folded arm's shoulder at 4.3e5 times.
constexpr double kSpike = 100;

int run_plan(const PlanArgs& a) {
  const ModelRecipe scene = cli::load_scene(a.scene_path);
  check_outputs(scene.facts());
  StraightLineTask task = task_from_options(a, scene.facts());
  // A point-to-point plan keeps the URDF's effort, velocity and angle limits, and takes its step
  // Jacobians from the exact state Jacobian: the scene compiled with it where it lacks it.
  const ModelRecipe recipe = planning_recipe(scene, task).value_or(scene);
  const ModelFacts& facts = recipe.facts();
  if (point_to_point(task.objective)) set_plan_limits(recipe, task);
  refuse_same_outputs(a);
  const Eigen::VectorXd params = cli::parse_parameters(a.param_assignments, facts);

  CompileOptions options;
  options.cache_dir = a.cache_dir;
  options.engine = parse_engine(a.engine);
  // By value: a compile in the background says its last stage after this function returns.
  options.progress = [verbose = a.verbose](const std::string& msg) {
    if (verbose || worth_saying(msg)) std::fprintf(stderr, "spacearm: %s\n", msg.c_str());
  };
  const auto model = CompiledModel::load(recipe, options);
  const DynamicModel dynamic = dynamic_model(model, params);
  const Plan plan = plan_task(dynamic, task);

  const auto inputs = cli::scene_inputs(a.scene_path, recipe);
  refuse_input_as_output(a.output_file, inputs);
  refuse_input_as_output(a.torque_file, inputs, "--torque-file");
  write_plan(plan_table(plan, dynamic, facts.geared), a.output_file);
  cli::write_provenance(a.output_file, cli::run_provenance(a.command_line, a.scene_path,
                                                           facts.parameter_names, params));
  if (!a.torque_file.empty()) write_torques(plan, a.torque_file);
  std::fprintf(stderr, "spacearm: %s\n", plan_checks_text(plan).c_str());
  double qdd_peak = 0, tau_peak = 0;
  std::vector<double> rate(plan.t.size());  // per sample, the largest |qd|
  for (size_t k = 0; k < plan.t.size(); ++k) {
    qdd_peak = std::max(qdd_peak, plan.qdd[k].cwiseAbs().maxCoeff());
    tau_peak = std::max(tau_peak, plan.tau[k].cwiseAbs().maxCoeff());
    rate[k] = plan.qd[k].cwiseAbs().maxCoeff();
  }
  // Near a singularity the rates spike: say where and why, which "--dt is coarse" alone did
  // not. (The planner's own stop, a singular row-scaled Jacobian, misses a row that is merely
  // small, as a folded arm's is 2 um from its shoulder.)
  const size_t spike = std::max_element(rate.begin(), rate.end()) - rate.begin();
  std::vector<double> sorted = rate;
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
  const double median = sorted[sorted.size() / 2];
  if (a.verbose)
    std::fprintf(stderr, "spacearm: peak rate %.3g rad/s at t = %.6g s, %.3g times the median\n",
                 rate[spike], plan.t[spike], rate[spike] / median);
  if (rate[spike] > kSpike * median)
    std::fprintf(stderr,
                 "spacearm: warning: the line passes near a singularity of the arm at t = %.6g s: "
                 "the rates reach %.3g rad/s there, %.3g times their median along the line, and "
                 "the torques %.3g N m; move the line away from it, or plan with another --elbow "
                 "or start\n",
                 plan.t[spike], rate[spike], rate[spike] / median, tau_peak);
  else if (plan.max_acceleration_mismatch > 1e-3 * qdd_peak)
    std::fprintf(stderr,
                 "spacearm: warning: the planned qdd and the central differences of qd differ by "
                 "%.2e (largest |qdd| %.2e): --dt is coarse for this motion, or the plan is "
                 "inaccurate\n",
                 plan.max_acceleration_mismatch, qdd_peak);
  std::vector<Eigen::VectorXd> rates, angles;  // link side: q' = qm' / p where the slot holds qm
  for (const auto& qd : plan.qd) rates.push_back(dynamic.joint_rates(qd));
  for (const auto& q : plan.q) angles.push_back(dynamic.joint_angles(q));
  cli::report_limit_use(cli::limit_use(recipe, plan.tau, rates, angles));
  if (!plan.base_residual.empty())
    std::fprintf(stderr,
                 "spacearm: free base: max |momentum| %.2e, max force on the base (eq. 5 base "
                 "rows, qdd by central "
                 "differences) %.2e\n",
                 plan.max_momentum, plan.max_base_residual);
  return 0;
}

}  // namespace spacearm
