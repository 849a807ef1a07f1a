#include "sweep.hpp"

#include <algorithm>
#include <optional>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "consistent_start.hpp"
#include "model_recipe.hpp"
#include "optimal_plan.hpp"
#include "plan_limits.hpp"
#include "plan_replay.hpp"
#include "simulation.hpp"
#include "study_run.hpp"
#include "text_numbers.hpp"

namespace spacearm {

namespace {

// A CSV field that holds any text: quoted, quotes doubled, line breaks as spaces.
std::string csv_text(std::string s) {
  std::replace(s.begin(), s.end(), '\n', ' ');
  std::replace(s.begin(), s.end(), '\r', ' ');
  std::string out = "\"";
  for (char c : s) out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

// What the sweep reads from a scene, with an error naming the field if it is missing.
void check_outputs(const Study& s) {
  const StudyScene& sc = s.scene;
  auto fail = [&](const std::string& why) {
    throw StudyError("study '" + s.source_path + "', field 'scene': scene '" + sc.source_path +
                     "' " + why + " (field 'outputs')");
  };
  if (!has_forward_dynamics([&sc](Output o) { return sc.wants(o); },
                            has_passive_forces(sc.features)))
    fail("must emit forward_dynamics (or mass_matrix and bias_forces without springs)");
  if (!sc.wants(Output::end_effector_pose)) fail("must emit end_effector_pose");
  if (sc.free_floating && !sc.wants(Output::momentum)) fail("must emit momentum (free base)");
  if (s.integrator.method == Method::rosenbrock4 && !sc.wants(Output::forward_dynamics_derivatives))
    fail("must emit forward_dynamics_derivatives for integrator.method rosenbrock4");
}

// The model of a study's scene (derived, lowered and printed by the cache when it compiles).
ModelRecipe recipe(const StudyScene& s) {
  return s.spatial ? ModelRecipe(*s.spatial) : ModelRecipe(*s.planar);
}

// The end effector's pose columns: [x, y, phi], in 3D [x, y, z, w, qx, qy, qz] (the output's).
std::string pose_columns(bool spatial) {
  return spatial ? ",ee_x,ee_y,ee_z,ee_qw,ee_qx,ee_qy,ee_qz" : ",ee_x,ee_y,ee_phi";
}

// The angle between two orientations (quaternions w, x, y, z of any nonzero norm), in [0, pi].
double angle_between(const Eigen::Vector4d& a, const Eigen::Vector4d& b) {
  const double c = std::abs(a.dot(b)) / (a.norm() * b.norm());
  return 2 * std::acos(std::min(1.0, c));
}

}  // namespace

std::vector<LimitMetric> limit_metrics(const StudyScene& scene) {
  std::vector<LimitMetric> metrics;
  if (!scene.is_spatial()) return metrics;
  const std::vector<spatial::JointLimits>& limits = scene.spatial->joint_limits;
  for (size_t j = 0; j < limits.size(); ++j)
    if (limits[j].has_effort())
      metrics.push_back({static_cast<int>(j), LimitMetric::effort, limits[j].effort});
  for (size_t j = 0; j < limits.size(); ++j)
    if (limits[j].has_velocity())
      metrics.push_back({static_cast<int>(j), LimitMetric::velocity, limits[j].velocity});
  for (size_t j = 0; j < limits.size(); ++j)
    if (limits[j].has_range())
      metrics.push_back({static_cast<int>(j), LimitMetric::angle,
                         (limits[j].upper - limits[j].lower) / 2,
                         (limits[j].upper + limits[j].lower) / 2});
  return metrics;
}

void append_number(std::string& row, double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, ",%.17g", v);
  row += buf;
}

RunSetup::RunSetup(const Study& s, const LoadedStudy& loaded, long r)
    : run(r), params(s.parameters(r)), model(dynamic_model(loaded.model, params)) {
  q0 = model.from_joint_angles(loaded.base, loaded.angles);
  qd0 = model.from_joint_rates(loaded.base_rate, loaded.rates);
  scale = s.command_ratio == Study::CommandRatio::run
              ? Eigen::VectorXd(Eigen::VectorXd::Ones(model.num_links))
              : Eigen::VectorXd(model.gear_ratios.cwiseQuotient(loaded.nominal_ratios));
  if (s.scene.features & needs::springs)
    consistent_start(model, q0, qd0, scale.cwiseProduct((*loaded.tau)(0.0)));
}

RunMetrics::RunMetrics(const Study& s, const DynamicModel& model, bool series)
    : s_(s),
      model_(model),
      series_(series && s.series_every),
      limits_(!limit_metrics(s.scene).empty()) {}

void RunMetrics::observe(double t, const Eigen::VectorXd& q, const Eigen::VectorXd& qd,
                         const Eigen::VectorXd& pose, const Eigen::VectorXd& h,
                         const Eigen::VectorXd& tau) {
  // A study measures one end effector (the one its manoeuvre plans): a tree's pose holds one
  // block per end effector.
  const Eigen::Index values = model_.spatial ? 7 : 3;
  pose_ = pose.segment(values * s_.end_effector, values);
  if (model_.num_base()) {  // the base's drift (its origin) and turn (angle, or 3D the rotation's)
    const bool spatial = model_.spatial;
    const int moves = spatial ? 3 : 2;
    if (samples_ == 0) base0_ = q.head(moves + (spatial ? 4 : 1)), h0_ = h;
    base_drift_ = std::max(base_drift_, (q.head(moves) - base0_.head(moves)).norm());
    base_rotation_ =
        std::max(base_rotation_, spatial ? angle_between(q.segment<4>(3), base0_.segment<4>(3))
                                         : std::abs(q[2] - base0_[2]));
    momentum_drift_ = std::max(momentum_drift_, (h - h0_).cwiseAbs().maxCoeff());
  }
  tau_squares_ += tau.squaredNorm();
  // Peak link-side |tau| and |q'| and the angles' extremes per joint, in place (a step allocates
  // nothing), where the scene has limits to measure them against.
  if (limits_) {
    const int n = model_.num_links;
    if (samples_ == 0) {
      tau_peak_.setZero(n), rate_peak_.setZero(n);
      angle_min_.setConstant(n, INFINITY), angle_max_.setConstant(n, -INFINITY);
    }
    for (int j = 0; j < n; ++j) {
      tau_peak_[j] = std::max(tau_peak_[j], std::abs(tau[j]));
      rate_peak_[j] = std::max(rate_peak_[j], std::abs(model_.joint_rate(qd, j)));
      const double a = model_.joint_angle(q, j);
      angle_min_[j] = std::min(angle_min_[j], a), angle_max_[j] = std::max(angle_max_[j], a);
    }
  }
  if (series_ && samples_ % s_.series_every == 0) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.17g", t);
    csv_ += buf;
    for (double v : q) append_number(csv_, v);
    for (double v : qd) append_number(csv_, v);
    for (double v : pose_) append_number(csv_, v);
    csv_ += "\n";
  }
  ++samples_;
}

std::string RunMetrics::measured() const {
  std::vector<double> measures(pose_.data(), pose_.data() + pose_.size());
  const bool spatial = model_.spatial;
  const int position = spatial ? 3 : 2;
  if (s_.target.size())
    measures.push_back((pose_.head(position) - s_.target.head(position)).norm());
  if (spatial && s_.target.size() == 7)
    measures.push_back(angle_between(pose_.tail<4>(), s_.target.tail<4>()));
  if (model_.num_base())
    measures.insert(measures.end(), {base_drift_, base_rotation_, momentum_drift_});
  measures.push_back(std::sqrt(tau_squares_ / static_cast<double>(samples_ * model_.num_links)));
  for (const LimitMetric& m : limit_metrics(s_.scene)) {
    const int j = m.joint;
    const double peak = m.kind == LimitMetric::effort ? tau_peak_[j]
                        : m.kind == LimitMetric::velocity
                            ? rate_peak_[j]
                            : std::max(angle_max_[j] - m.centre, m.centre - angle_min_[j]);
    measures.push_back(peak / m.limit);
  }
  std::string measured;
  for (double v : measures) append_number(measured, v);
  for (double v : measures)  // nan or inf: no metric to trust
    if (!std::isfinite(v))
      throw DynamicsError("a metric is not finite (" + measured.substr(1) + ")");
  return measured;
}

std::string RunMetrics::series() const {
  if (!series_) return "";
  std::string head = "t";
  for (const auto& n : model_.coordinate_names) head += "," + n;
  for (const auto& n : model_.velocity_names()) head += "," + n;
  return head + pose_columns(model_.spatial) + "\n" + csv_;
}

std::string ok_row(long run, const Eigen::VectorXd& params, const std::string& measured,
                   const std::string& ratio) {
  std::string values;
  for (double v : params) append_number(values, v);
  return std::to_string(run) + ",ok" + values + measured + "," + ratio + ",\n";
}

struct StudyRunner::Loaded : LoadedStudy {};

StudyRunner::StudyRunner(Study study, const CompileOptions& options) : study_(std::move(study)) {
  const Study& s = study_;
  check_outputs(s);
  // The runs' functions compile first (lockstep_applies: four runs at once under rk4).
  CompileOptions first = options;
  const bool lanes = s.integrator.method == Method::rk4;
  for (Output o : {Output::forward_dynamics, Output::end_effector_pose, Output::momentum})
    first.call_first(o, lanes);
  loaded_ = std::make_unique<Loaded>(
      Loaded{{CompiledModel::load(recipe(s.scene), first), {}, {}, {}, {}, {}, {}}});
  // The run scene at its nominal parameters: what a controller believes (its p, its friction).
  const std::vector<double>& nominal = loaded_->model.nominal_parameters();
  const DynamicModel believed = dynamic_model(
      loaded_->model,
      Eigen::Map<const Eigen::VectorXd>(nominal.data(), static_cast<Eigen::Index>(nominal.size())));
  loaded_->nominal_ratios = believed.gear_ratios;
  const StudyScene& f = s.scene;
  const int N = f.num_links;
  if (s.plan) {
    // Planned once, with the plan scene's nominal parameters (the paper's experiment).
    const StudyScene& pf = s.plan_scene ? *s.plan_scene : f;
    if (pf.num_links != N || pf.free_floating != f.free_floating ||
        pf.is_spatial() != f.is_spatial())
      throw StudyError("study '" + s.source_path + "', field 'manoeuvre.plan.scene': scene '" +
                       pf.source_path + "' must have the run scene's base and joints");
    // A point-to-point plan as `plan --objective` makes it: within the URDF's limits, its steps'
    // Jacobians from the exact state Jacobian (the plan scene compiled with it where it lacks it).
    StraightLineTask task = *s.plan;
    const ModelRecipe plan_recipe = recipe(pf);
    if (point_to_point(task.objective)) set_plan_limits(plan_recipe, task);
    const std::optional<ModelRecipe> with_derivatives = planning_recipe(plan_recipe, task);
    std::optional<CompiledModel> own;
    if (with_derivatives || s.plan_scene)
      own.emplace(CompiledModel::load(with_derivatives.value_or(plan_recipe), options));
    const CompiledModel& pm = own ? *own : loaded_->model;
    const DynamicModel planner =
        dynamic_model(pm, Eigen::Map<const Eigen::VectorXd>(
                              pm.nominal_parameters().data(),
                              static_cast<Eigen::Index>(pm.nominal_parameters().size())));
    const Plan plan = plan_task(planner, task);
    plan_report_ = plan_checks_text(plan);
    // Friction fed forward is the believed one; each run's own friction may differ.
    PlanSamples samples = plan_samples(plan, planner);
    if (s.feedforward_friction) feed_friction_forward(believed, samples);
    loaded_->tau = std::make_unique<TorqueSignal<Eigen::Dynamic>>(
        0.0, s.plan->dt, samples.torques.samples, s.interpolation);
    loaded_->base = samples.base.front();
    loaded_->angles = samples.angles.front();
    loaded_->base_rate = samples.base_rate.front();
    loaded_->rates = samples.rates.front();
  } else {
    loaded_->tau = std::make_unique<TorqueSignal<Eigen::Dynamic>>(
        s.torques->t0, s.torques->dt, s.torques->samples, s.interpolation);
    loaded_->base = s.q0.head(s.q0.size() - N);
    loaded_->angles = s.q0.tail(N);
    loaded_->base_rate = Eigen::VectorXd::Zero(f.free_floating ? (f.is_spatial() ? 6 : 3) : 0);
    loaded_->rates = Eigen::VectorXd::Zero(N);
  }
  if (const std::string gap =
          coverage_gap(loaded_->tau->t_first(), loaded_->tau->t_last(), s.t_end);
      !gap.empty())
    throw StudyError("study '" + s.source_path + "', field 'integrator.t_end': the torques cover " +
                     gap);
  // Four runs per call where the library has the 4-lane functions.
  lanes_ = loaded_->model.lanes_function(Output::forward_dynamics) ? 4 : 1;
  // The header: one place names the columns, row() follows it.
  header_ = "run,status";
  for (const auto& n : s.parameter_names()) header_ += "," + n;
  header_ += pose_columns(f.is_spatial());
  if (s.target.size()) header_ += ",ee_error";
  if (f.is_spatial() && s.target.size() == 7) header_ += ",ee_angle_error";
  if (f.free_floating) header_ += ",base_drift,base_rotation,momentum_drift";
  header_ += ",torque_rms";
  for (const LimitMetric& m : limit_metrics(f)) header_ += "," + m.name();
  header_ += ",command_ratio,message\n";
}

StudyRunner::~StudyRunner() = default;

const CompiledModel& StudyRunner::model() const { return loaded_->model; }
const TorqueSignal<Eigen::Dynamic>& StudyRunner::torques() const { return *loaded_->tau; }
Eigen::VectorXd StudyRunner::start_link_side() const {
  Eigen::VectorXd x(loaded_->base.size() + loaded_->angles.size());
  x << loaded_->base, loaded_->angles;
  return x;
}

std::string StudyRunner::row(long run, std::string* series) const {
  std::vector<std::string> one_series;
  const std::vector<std::string> out = rows({run}, series ? &one_series : nullptr);
  if (series) *series = std::move(one_series[0]);
  return out[0];
}

std::vector<std::string> StudyRunner::rows(const std::vector<long>& runs,
                                           std::vector<std::string>* series) const {
  std::vector<std::string> out(runs.size());
  if (series) series->assign(runs.size(), "");
  const std::string ratio = command_ratio_text();
  if (lanes_ > 0 && lockstep_applies(study_, loaded_->model))
    run_lockstep({study_, *loaded_, runs, ratio, out, series, lanes_});
  for (size_t k = 0; k < runs.size(); ++k)
    if (out[k].empty()) out[k] = reference_row(runs[k], series ? &(*series)[k] : nullptr);
  return out;
}

std::string StudyRunner::integration_text() const {
  if (lanes_ == 0 || !lockstep_applies(study_, loaded_->model))
    return "runs integrated one at a time (" + to_string(study_.integrator.method) +
           (lanes_ == 0 ? ")" : "; runs in lockstep need rk4 and the output forward_dynamics)");
  return lanes_ == 4 ? "runs integrated four at a time in lockstep (rk4, the 4-lane functions)"
                     : "runs integrated one at a time in lockstep (rk4)";
}

void StudyRunner::set_lanes(int lanes) {
  if (lanes != 0 && lanes != 1 && lanes != 4)
    throw std::invalid_argument("lanes: 0, 1 or 4, got " + std::to_string(lanes));
  lanes_ = lanes;
}

std::string StudyRunner::reference_row(long run, std::string* series) const {
  const Study& s = study_;
  const Eigen::VectorXd params = s.parameters(run);
  std::string values;
  for (double v : params) append_number(values, v);
  const long metrics = std::count(header_.begin(), header_.end(), ',') - 3 - params.size();
  const std::string ratio = command_ratio_text();
  try {
    const RunSetup run_setup(s, *loaded_, run);
    const DynamicModel& model = run_setup.model;
    IntegratorOptions opt = s.integrator;
    const TorqueSignal<Eigen::Dynamic>& signal = *loaded_->tau;
    const TorqueReplay<Eigen::Dynamic> replay(signal, opt, "integrator.dt");
    const Eigen::VectorXd& scale = run_setup.scale;
    RunMetrics record(s, model, series != nullptr);
    const Eigen::VectorXd none;
    auto observe = [&](double t, const Eigen::VectorXd& q, const Eigen::VectorXd& qd) {
      record.observe(t, q, qd, model.end_effector_pose(q),
                     model.num_base() ? model.momentum(q, qd) : none,
                     scale.cwiseProduct(signal(t)));
    };
    // The replayed torques times the run's scale (into the integrator's workspace: nothing
    // allocated per evaluation).
    struct ScaledTorque {
      const TorqueReplay<Eigen::Dynamic>& replay;
      const Eigen::VectorXd& scale;
      Eigen::VectorXd operator()(double t) const { return scale.cwiseProduct(replay(t)); }
      void evaluate(double t, Eigen::VectorXd& tau) const {
        replay.evaluate(t, tau);
        tau.array() *= scale.array();
      }
    } torque{replay, scale};
    integrate_motion(model, run_setup.q0, run_setup.qd0, torque, s.t_end, s.integrator.dt, opt,
                     observe);
    const std::string row = ok_row(run, params, record.measured(), ratio);
    if (series) *series = record.series();
    return row;
  } catch (const std::exception& e) {
    return std::to_string(run) + ",failed" + values + std::string(metrics, ',') + "," + ratio +
           "," + csv_text(e.what()) + "\n";
  }
}

std::string StudyRunner::row_problem(const std::string& row, long* run) const {
  const size_t comma = row.find(',');
  if (comma == 0 || comma > 11 || row.find_first_not_of("0123456789") != comma)
    return "does not start with a run number";
  const long r = std::stol(row.substr(0, comma));
  if (r >= study_.num_runs()) return "run " + std::to_string(r) + " is not a run of the study";
  if (run) *run = r;
  // The fields before the message: run, status, parameters, metrics.
  const long fields = std::count(header_.begin(), header_.end(), ','),
             params = static_cast<long>(study_.scene.parameter_names.size());
  std::vector<std::string> f;
  size_t at = 0;
  for (long k = 0; k < fields; ++k) {
    const size_t next = row.find(',', at);
    if (next == std::string::npos) return "has fewer fields than the header";
    f.push_back(row.substr(at, next - at));
    at = next + 1;
  }
  const std::string message = row.substr(at, row.size() - 1 - at);
  const bool ok = f[1] == "ok";
  if (!ok && f[1] != "failed") return "status is neither ok nor failed";
  if (f[fields - 1] != command_ratio_text()) return "its command_ratio is not the study's";
  for (long k = 2; k < fields - 1; ++k) {
    const bool metric = k >= 2 + params;
    if (!ok && metric) {
      if (!f[k].empty()) return "a failed run with a metric";
      continue;
    }
    // As row() prints them (%.17g): decimal and finite; never nan, inf or hexadecimal.
    char* end = nullptr;
    const double v = std::strtod(f[k].c_str(), &end);
    if (f[k].empty() || *end != '\0' || !std::isfinite(v) ||
        f[k].find_first_not_of("0123456789+-.e") != std::string::npos)
      return "field " + std::to_string(k + 1) + " is not a finite number";
  }
  const bool quoted = message.size() >= 2 && message.front() == '"' && message.back() == '"';
  if (ok ? !message.empty() : !quoted) return "its message field is not what a run writes";
  if (row.back() != '\n') return "has no line end";
  return "";
}

Shard parse_shard(const std::string& text) {
  const size_t slash = text.find('/');
  auto fail = [&] {
    throw std::invalid_argument("--shard " + quoted_text(text) +
                                ": expected i/n with whole numbers 1 <= i <= n, e.g. 2/8");
  };
  if (slash == std::string::npos) fail();
  Shard s;
  try {
    const double i = parse_number(text.substr(0, slash), "--shard");
    const double n = parse_number(text.substr(slash + 1), "--shard");
    if (!(i >= 1 && i <= n && n <= 1e6 && i == std::floor(i) && n == std::floor(n))) fail();
    s.index = static_cast<long>(i);
    s.count = static_cast<long>(n);
  } catch (const std::invalid_argument&) {
    fail();
  }
  return s;
}

}  // namespace spacearm
