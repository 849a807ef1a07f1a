// Runs of a study integrated L at a time in lockstep (fixed-step RK4, LockstepRk4): the generated
// functions are called directly on caller-owned, interleaved workspaces (a 4-lane function
// evaluates four runs per instruction), nothing is allocated per step, and each lane computes
// exactly what the reference path (StudyRunner::row's integrate_motion) computes for its run,
// so the rows are the same bytes. The checks the reference path makes on every call set a flag
// here instead of throwing: a flagged run (or one that fails to set up, or whose metrics are not
// finite) is left to the reference path, which writes its failure's message.
#include <array>
#include <limits>
#include <optional>

#include "integrators.hpp"
#include "lockstep_rk4.hpp"
#include "outputs.hpp"
#include "simulation.hpp"
#include "study_run.hpp"

namespace spacearm {

bool lockstep_applies(const Study& s, const CompiledModel& m) {
  return s.integrator.method == Method::rk4 && m.has(Output::forward_dynamics) &&
         m.has(Output::end_effector_pose) && (!m.free_floating() || m.has(Output::momentum));
}

namespace {

// A loaded function for L states at once, lanes interleaved: the library's 4-lane version
// where it has one, else the scalar function on each lane in turn (through scratch arrays).
template <int L>
class LaneFunction {
 public:
  LaneFunction(const CompiledModel& m, Output o)
      : scalar_(m.function(o)), lanes_(L == 4 ? m.lanes_function(o) : nullptr) {
    const Dimensions& d = m.dimensions();
    for (Input i : info(o).inputs) in_sizes_.push_back(d(info(i).size));
    for (const ResultInfo& r : info(o).results) out_sizes_.push_back(d(r.rows) * d(r.cols));
    params_.resize(m.nominal_parameters().size());
    for (int n : in_sizes_) in_.emplace_back(n);
    for (int n : out_sizes_) out_.emplace_back(n);
    for (auto& v : in_) in_data_.push_back(v.data());
    for (auto& v : out_) out_data_.push_back(v.data());
  }
  void operator()(const double* const* in, const double* params, double* const* out) {
    if (L == 1) return scalar_(in, params, out);
    if (lanes_) return lanes_(in, params, out);
    for (int l = 0; l < L; ++l) {
      for (size_t k = 0; k < in_.size(); ++k)
        for (int i = 0; i < in_sizes_[k]; ++i) in_[k][i] = in[k][i * L + l];
      for (size_t j = 0; j < params_.size(); ++j) params_[j] = params[j * L + l];
      scalar_(in_data_.data(), params_.data(), out_data_.data());
      for (size_t k = 0; k < out_.size(); ++k)
        for (int i = 0; i < out_sizes_[k]; ++i) out[k][i * L + l] = out_[k][i];
    }
  }

 private:
  CompiledModel::Function scalar_, lanes_;
  std::vector<int> in_sizes_, out_sizes_;
  std::vector<double> params_;
  std::vector<std::vector<double>> in_, out_;
  std::vector<const double*> in_data_;
  std::vector<double*> out_data_;
};

// Lane l of an interleaved array (n entries per lane) into v, and back.
template <int L>
void lane_out(const double* a, int l, Eigen::VectorXd& v) {
  for (Eigen::Index i = 0; i < v.size(); ++i) v[i] = a[i * L + l];
}
template <int L>
void lane_in(const Eigen::VectorXd& v, int l, double* a) {
  for (Eigen::Index i = 0; i < v.size(); ++i) a[i * L + l] = v[i];
}

// The reference path's per-call checks on one lane (dynamics_checks.hpp, CompiledModel's
// evaluate): finite inputs and accelerations, positive and well-scaled pivots, and in 3D a
// quaternion of a norm the model takes. True where they pass.
template <int L>
bool lane_passes(const double* x, const double* Q, const double* qdd, const double* pivots,
                 const double* scaled, int nq, int nv, int l) {
  double sum = 0;
  for (int i = 0; i < nq + nv; ++i) sum += x[i * L + l] - x[i * L + l];
  bool ok = true;
  for (int i = 0; i < nv; ++i) {
    const double q = Q[i * L + l], a = qdd[i * L + l];
    sum += (q - q) + (a - a);
    ok &= pivot_within_bounds(pivots[i * L + l], scaled[i * L + l]);
  }
  return ok && sum == 0;
}

template <int L>
class Lockstep {
 public:
  Lockstep(const LockstepRequest& r, const std::vector<long>& runs, size_t first);
  void run();

 private:
  void rhs(const double* x, double* dxdt, double t);
  void project_and_accept();
  void observe(double t);
  bool quaternion_ok(const Eigen::VectorXd& q) const;

  const LockstepRequest& r_;
  size_t first_;
  std::vector<std::optional<RunSetup>> setups_;
  std::array<const RunSetup*, L> lane_{};
  std::array<bool, L> live_{};  // a run of the request that has not failed (yet)
  int nq_ = 0, nv_ = 0, num_links_ = 0, quaternion_ = -1;
  IntegratorOptions opt_;
  std::optional<TorqueReplay<Eigen::Dynamic>> replay_;
  LaneFunction<L> forward_dynamics_, pose_;
  std::optional<LaneFunction<L>> momentum_;
  std::vector<double> x_, params_, Q_, qdd_, pivots_, scaled_, pose_out_, h_out_;
  Eigen::VectorXd signal_;
  double forces_at_ = std::numeric_limits<double>::quiet_NaN();  // the time Q_ holds
  std::array<Eigen::VectorXd, L> q_, qd_, rate_, tau_, pose_l_, h_l_;
  std::vector<RunMetrics> metrics_;
};

template <int L>
Lockstep<L>::Lockstep(const LockstepRequest& r, const std::vector<long>& runs, size_t first)
    : r_(r),
      first_(first),
      setups_(L),
      forward_dynamics_(r.loaded.model, Output::forward_dynamics),
      pose_(r.loaded.model, Output::end_effector_pose) {
  // Each lane's run; a lane without one (past the end, or failing to set up) repeats another,
  // so that its arithmetic stays harmless, and is not read.
  int donor = -1;
  for (int l = 0; l < L && first + l < runs.size(); ++l) try {
      setups_[l].emplace(r.study, r.loaded, runs[first + l]);
      live_[l] = true;
      if (donor < 0) donor = l;
    } catch (const std::exception&) {  // the reference path writes the message
    }
  if (donor < 0) return;
  for (int l = 0; l < L; ++l) lane_[l] = setups_[l] ? &*setups_[l] : &*setups_[donor];
  const DynamicModel& m = lane_[0]->model;
  nq_ = m.nq, nv_ = m.nv, num_links_ = m.num_links, quaternion_ = m.quaternion_offset;
  if (m.num_base()) momentum_.emplace(r.loaded.model, Output::momentum);
  const int np = static_cast<int>(lane_[0]->params.size());
  x_.resize((nq_ + nv_) * L), params_.resize(np * L), Q_.resize(nv_ * L);
  qdd_.resize(nv_ * L), pivots_.resize(nv_ * L), scaled_.resize(nv_ * L);
  const Dimensions& d = r.loaded.model.dimensions();
  pose_out_.resize(d(info(Output::end_effector_pose).results[0].rows) * L);
  h_out_.resize(d(info(Output::momentum).results[0].rows) * L);
  signal_ = Eigen::VectorXd::Zero(num_links_);
  for (int l = 0; l < L; ++l) {
    const RunSetup& s = *lane_[l];
    for (int j = 0; j < np; ++j) params_[j * L + l] = s.params[j];
    q_[l] = s.q0, qd_[l] = s.qd0, rate_[l] = Eigen::VectorXd::Zero(nq_);
    tau_[l] = Eigen::VectorXd::Zero(num_links_);
    pose_l_[l] = Eigen::VectorXd::Zero(pose_out_.size() / L);
    h_l_[l] = Eigen::VectorXd::Zero(h_out_.size() / L);
    metrics_.emplace_back(r.study, s.model, r.series != nullptr);
  }
}

template <int L>
bool Lockstep<L>::quaternion_ok(const Eigen::VectorXd& q) const {
  if (quaternion_ < 0) return true;
  return ConfigurationSpace::takes_quaternion_norm(q.segment(quaternion_, 4).norm());
}

// dx/dt of every lane (integrate_motion's right-hand side): dq/dt, and qdd from the generalized
// forces of the run's torques scale .* tau(t) (eq. 14).
template <int L>
void Lockstep<L>::rhs(const double* x, double* dxdt, double t) {
  // Q at t: the same for a step's two stages at its midpoint (the step's hold does not change
  // within it: step() clears forces_at_).
  if (!(t == forces_at_)) {
    replay_->evaluate(t, signal_);
    for (int l = 0; l < L; ++l) {
      const DynamicModel& m = lane_[l]->model;
      const double* scale = lane_[l]->scale.data();
      for (int i = 0; i < nv_; ++i) Q_[i * L + l] = 0;
      for (int i = 0; i < num_links_; ++i)  // tau = scale .* signal, Q = tau / p (eq. 14)
        Q_[m.actuated_coordinates[i] * L + l] = (scale[i] * signal_[i]) / m.gear_ratios[i];
    }
    forces_at_ = t;
  }
  if (quaternion_ < 0) {
    for (int i = 0; i < nq_ * L; ++i) dxdt[i] = x[nq_ * L + i];
  } else {
    for (int l = 0; l < L; ++l) {
      lane_out<L>(x, l, q_[l]);
      lane_out<L>(x + nq_ * L, l, qd_[l]);
      lane_[l]->model.configuration_space().rate(q_[l], qd_[l], rate_[l]);
      lane_in<L>(rate_[l], l, dxdt);
      live_[l] = live_[l] && quaternion_ok(q_[l]);
    }
  }
  const double* in[] = {x, x + nq_ * L, Q_.data()};
  double* out[] = {qdd_.data(), pivots_.data(), scaled_.data()};
  forward_dynamics_(in, params_.data(), out);
  for (int i = 0; i < nv_ * L; ++i) dxdt[nq_ * L + i] = qdd_[i];
  for (int l = 0; l < L; ++l)
    live_[l] = live_[l] && lane_passes<L>(x, Q_.data(), qdd_.data(), pivots_.data(), scaled_.data(),
                                          nq_, nv_, l);
}

// After a step: the quaternion back on the unit sphere (as integrate_motion's projection), and
// a lane whose state is not finite has failed (as the integrator's accept()).
template <int L>
void Lockstep<L>::project_and_accept() {
  for (int l = 0; l < L; ++l) {
    if (quaternion_ >= 0) {
      lane_out<L>(x_.data(), l, q_[l]);
      lane_[l]->model.configuration_space().project(q_[l]);
      lane_in<L>(q_[l], l, x_.data());
    }
    double sum = 0;
    for (int i = 0; i < nq_ + nv_; ++i) sum += x_[i * L + l] - x_[i * L + l];
    live_[l] = live_[l] && sum == 0;
  }
}

// The sweep's observation at t (StudyRunner::row's observe): pose, momentum and torques.
template <int L>
void Lockstep<L>::observe(double t) {
  const double* q_in[] = {x_.data()};
  double* pose_out[] = {pose_out_.data()};
  pose_(q_in, params_.data(), pose_out);
  if (momentum_) {
    const double* in[] = {x_.data(), x_.data() + nq_ * L};
    double* out[] = {h_out_.data()};
    (*momentum_)(in, params_.data(), out);
  }
  r_.loaded.tau->evaluate(t, signal_);
  for (int l = 0; l < L; ++l) {
    if (!live_[l]) continue;
    lane_out<L>(x_.data(), l, q_[l]);
    lane_out<L>(x_.data() + nq_ * L, l, qd_[l]);
    lane_out<L>(pose_out_.data(), l, pose_l_[l]);
    lane_out<L>(h_out_.data(), l, h_l_[l]);
    tau_[l] = lane_[l]->scale.cwiseProduct(signal_);
    live_[l] = quaternion_ok(q_[l]);  // as evaluate()'s check of q
    metrics_[l].observe(t, q_[l], qd_[l], pose_l_[l], h_l_[l], tau_[l]);
  }
}

// integrate()'s fixed steps from t = 0 to the study's end, observing after every output step.
template <int L>
void Lockstep<L>::run() {
  if (!lane_[0]) return;
  try {
    opt_ = r_.study.integrator;
    replay_.emplace(*r_.loaded.tau, opt_, "integrator.dt");  // sets the steps' hold
    const double dt_out = r_.study.integrator.dt, t0 = 0.0;
    const long outputs = detail::check_integration(opt_, t0, r_.study.t_end, dt_out);
    for (int l = 0; l < L; ++l) {
      lane_in<L>(lane_[l]->q0, l, x_.data());
      lane_in<L>(lane_[l]->qd0, l, x_.data() + nq_ * L);
    }
    project_and_accept();
    observe(t0);
    LockstepRk4<L> rk4(nq_ + nv_);
    auto slope = [this](const double* x, double* dxdt, double t) { rhs(x, dxdt, t); };
    const long per = std::lround(dt_out / opt_.dt);
    for (long k = 0; k < outputs; ++k) {
      for (long s = 0; s < per; ++s) {
        const double t = t0 + (k * per + s) * opt_.dt;
        if (opt_.step_begin) opt_.step_begin(t, t + opt_.dt);
        forces_at_ = std::numeric_limits<double>::quiet_NaN();
        rk4.step(slope, x_.data(), t, opt_.dt);
        project_and_accept();
      }
      observe(t0 + (k + 1) * dt_out);
      if (std::none_of(live_.begin(), live_.end(), [](bool b) { return b; })) return;
    }
  } catch (const std::exception&) {  // e.g. torques outside their samples: every lane's
    return;
  }
  for (int l = 0; l < L; ++l) {
    if (!live_[l]) continue;
    try {
      const std::string measured = metrics_[l].measured();
      r_.rows[first_ + l] = ok_row(lane_[l]->run, lane_[l]->params, measured, r_.ratio);
      if (r_.series) (*r_.series)[first_ + l] = metrics_[l].series();
    } catch (const DynamicsError&) {  // a metric not finite: the reference path says which
    }
  }
}

}  // namespace

void run_lockstep(const LockstepRequest& r) {
  for (size_t first = 0; first < r.runs.size(); first += r.lanes) {
    if (r.lanes == 4) {
      Lockstep<4>(r, r.runs, first).run();
    } else {
      Lockstep<1>(r, r.runs, first).run();
    }
  }
}

}  // namespace spacearm
