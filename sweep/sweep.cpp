#include "sweep.hpp"

#include <algorithm>
#include <optional>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "consistent_start.hpp"
#include "model_recipe.hpp"
#include "plan_replay.hpp"
#include "simulation.hpp"
#include "text_numbers.hpp"

namespace spacearm {

namespace {

void append(std::string& row, double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, ",%.17g", v);
  row += buf;
}

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

// The metrics of one run, observed at every integrator step.
struct Metrics {
  Eigen::VectorXd base0, h0, pose;
  double base_drift = 0, base_rotation = 0, momentum_drift = 0, tau_squares = 0;
  long samples = 0;
};

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

struct StudyRunner::Loaded {
  CompiledModel model;
  std::unique_ptr<TorqueSignal<Eigen::Dynamic>> tau;
  Eigen::VectorXd base, angles, base_rate, rates;  // the start, link side
  Eigen::VectorXd nominal_ratios;                  // p at the scene's nominal parameters
};

StudyRunner::StudyRunner(Study study, const CompileOptions& options) : study_(std::move(study)) {
  const Study& s = study_;
  check_outputs(s);
  loaded_ = std::make_unique<Loaded>(
      Loaded{CompiledModel::load(recipe(s.scene), options), {}, {}, {}, {}, {}, {}});
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
    std::optional<CompiledModel> own;
    if (s.plan_scene) own.emplace(CompiledModel::load(recipe(*s.plan_scene), options));
    const CompiledModel& pm = own ? *own : loaded_->model;
    const DynamicModel planner =
        dynamic_model(pm, Eigen::Map<const Eigen::VectorXd>(
                              pm.nominal_parameters().data(),
                              static_cast<Eigen::Index>(pm.nominal_parameters().size())));
    const Plan plan = plan_straight_line(planner, *s.plan);
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
  // The header: one place names the columns, row() follows it.
  header_ = "run,status";
  for (const auto& n : s.parameter_names()) header_ += "," + n;
  header_ += pose_columns(f.is_spatial());
  if (s.target.size()) header_ += ",ee_error";
  if (f.is_spatial() && s.target.size() == 7) header_ += ",ee_angle_error";
  if (f.free_floating) header_ += ",base_drift,base_rotation,momentum_drift";
  header_ += ",torque_rms,command_ratio,message\n";
}

StudyRunner::~StudyRunner() = default;

std::string StudyRunner::row(long run, std::string* series) const {
  const Study& s = study_;
  const Eigen::VectorXd params = s.parameters(run);
  std::string r = std::to_string(run);
  std::string values;
  for (double v : params) append(values, v);
  const long metrics = std::count(header_.begin(), header_.end(), ',') - 3 - params.size();
  const std::string ratio = command_ratio_text();
  try {
    const DynamicModel model = dynamic_model(loaded_->model, params);
    Eigen::VectorXd q0 = model.from_joint_angles(loaded_->base, loaded_->angles);
    Eigen::VectorXd qd0 = model.from_joint_rates(loaded_->base_rate, loaded_->rates);
    IntegratorOptions opt = s.integrator;
    const TorqueSignal<Eigen::Dynamic>& signal = *loaded_->tau;
    const TorqueReplay<Eigen::Dynamic> replay(signal, opt, "integrator.dt");
    // The link-side torque the run's joints get: tau, or tau p_run / p_nominal when the motors
    // are commanded with the nominal ratio (model.generalized_forces divides by p_run).
    const Eigen::VectorXd scale =
        s.command_ratio == Study::CommandRatio::run
            ? Eigen::VectorXd(Eigen::VectorXd::Ones(model.num_links))
            : Eigen::VectorXd(model.gear_ratios.cwiseQuotient(loaded_->nominal_ratios));
    auto tau = [&](double t) -> Eigen::VectorXd { return scale.cwiseProduct(signal(t)); };
    if (s.scene.features & needs::springs) consistent_start(model, q0, qd0, tau(0.0));
    // Metrics at every step; the time series every series_every steps.
    Metrics m;
    const int nb = model.num_base();
    std::string csv;
    auto observe = [&](double t, const Eigen::VectorXd& q, const Eigen::VectorXd& qd) {
      m.pose = model.end_effector_pose(q);
      if (nb) {  // the base's drift (its origin) and turn (angle, or 3D the rotation's angle)
        const Eigen::VectorXd h = model.momentum(q, qd);
        const int moves = model.spatial ? 3 : 2;
        if (m.samples == 0) m.base0 = q.head(moves + (model.spatial ? 4 : 1)), m.h0 = h;
        m.base_drift = std::max(m.base_drift, (q.head(moves) - m.base0.head(moves)).norm());
        m.base_rotation = std::max(
            m.base_rotation, model.spatial ? angle_between(q.segment<4>(3), m.base0.segment<4>(3))
                                           : std::abs(q[2] - m.base0[2]));
        m.momentum_drift = std::max(m.momentum_drift, (h - m.h0).cwiseAbs().maxCoeff());
      }
      m.tau_squares += tau(t).squaredNorm();
      if (series && s.series_every && m.samples % s.series_every == 0) {
        char buf[32];
        std::snprintf(buf, sizeof buf, "%.17g", t);
        csv += buf;
        for (double v : q) append(csv, v);
        for (double v : qd) append(csv, v);
        for (double v : m.pose) append(csv, v);
        csv += "\n";
      }
      ++m.samples;
    };
    integrate_motion(
        model, q0, qd0, [&](double t) -> Eigen::VectorXd { return scale.cwiseProduct(replay(t)); },
        s.t_end, s.integrator.dt, opt, observe);
    std::vector<double> measures(m.pose.data(), m.pose.data() + m.pose.size());
    const int position = model.spatial ? 3 : 2;
    if (s.target.size())
      measures.push_back((m.pose.head(position) - s.target.head(position)).norm());
    if (model.spatial && s.target.size() == 7)
      measures.push_back(angle_between(m.pose.tail<4>(), s.target.tail<4>()));
    if (nb) measures.insert(measures.end(), {m.base_drift, m.base_rotation, m.momentum_drift});
    measures.push_back(std::sqrt(m.tau_squares / static_cast<double>(m.samples * model.num_links)));
    std::string measured;
    for (double v : measures) append(measured, v);
    for (double v : measures)  // nan or inf: no metric to trust
      if (!std::isfinite(v))
        throw DynamicsError("a metric is not finite (" + measured.substr(1) + ")");
    values += measured;
    if (series && s.series_every) {
      std::string head = "t";
      for (const auto& n : model.coordinate_names) head += "," + n;
      for (const auto& n : model.velocity_names()) head += "," + n;
      *series = head + pose_columns(model.spatial) + "\n" + csv;
    }
    return r + ",ok" + values + "," + ratio + ",\n";
  } catch (const std::exception& e) {
    return r + ",failed" + values + std::string(metrics, ',') + "," + ratio + "," +
           csv_text(e.what()) + "\n";
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
