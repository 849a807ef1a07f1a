// The point-to-point planner (optimal_plan.hpp): direct multiple shooting with IPOPT.
#include "optimal_plan.hpp"

#include <IpIpoptApplication.hpp>
#include <IpSolveStatistics.hpp>
#include <IpTNLP.hpp>

#include <Eigen/SparseCholesky>

#include <chrono>
#include <functional>
#include <mutex>
#include <cstdlib>
#include <cmath>
#include <limits>

#include "integrators_detail.hpp"
#include "simulation.hpp"
#include "step_jacobian.hpp"
#include "torque_signal.hpp"

namespace spacearm {
namespace {

using Eigen::VectorXd;
using Ipopt::Index;
using Ipopt::Number;

constexpr double kInfinity = 1e19;  // IPOPT's "no bound"

// The problem's sizes and layout: per knot k = 0..K the block [x_k (nq + nv), u_k (N)].
struct Layout {
  int nq, nv, N, K, nx, block;
  double h;
  int x(int k) const { return k * block; }
  int u(int k) const { return k * block + nx; }
  int variables() const { return (K + 1) * block; }
};

// The end effector's position at q and its derivative by q's coordinates (the Jacobian's
// position rows, by v, times the tangent map).
struct Goal {
  int rows = 3, offset = 0;  // task rows; the end effector's first row in pose and Jacobian
};

struct Guess {
  VectorXd x, line;  // the first guess; the straight line's knots (empty: none)
  // The straight line's largest base rotation and integral of |tau|^2 (NaN: no line).
  double line_rotation = NAN, line_effort = NAN;
};

class MultipleShooting : public Ipopt::TNLP {
 public:
  MultipleShooting(const DynamicModel& m, const StraightLineTask& task, Layout layout,
                   const Guess& guess, VectorXd q_start)
      : m_(m), task_(task), L_(layout), guess_(guess.x), q_start_(std::move(q_start)) {
    goal_.rows = m.spatial ? 3 : 2;
    goal_.offset = (m.spatial ? 6 : 3) * task.end_effector;
    pose_offset_ = (m.spatial ? 7 : 3) * task.end_effector;
    omega_ = m.spatial ? std::vector<int>{3, 4, 5} : std::vector<int>{2};
    if (m.num_base() == 0) omega_.clear();
    steps_.resize(L_.K);
    variable_scales_ = variable_scales();
    // The cost's two sums relative to the straight line's rotation (else the guess's) and the
    // guess's effort, so that it starts near 1 (IPOPT's tolerances are absolute). For the least
    // rotation, task.effort_weight of the effort keeps the torques determined where the
    // rotation does not care, and the problem well enough conditioned to solve.
    // Without a straight line (or where it needs none), the scales are 1e-2 rad/s and 1 N m
    // over the duration.
    const VectorXd& scale = guess.line.size() ? guess.line : guess.x;
    double rotation = sum(scale.data(), true), effort = sum(guess.x.data(), false);
    if (!(rotation > 1e-12 * task.duration)) rotation = 1e-4 * task.duration;
    if (!(effort > 1e-12 * task.duration)) effort = task.duration;
    if (task.objective == Objective::min_effort) {
      w_effort_ = 1 / effort;
    } else {
      w_rotation_ = 1 / rotation;
      w_effort_ = task.effort_weight / effort;
    }
  }

  VectorXd solution;
  double cost = 0;
  // Asked at every iteration: true stops the solve (User_Requested_Stop).
  std::function<bool()> interrupted;

  bool intermediate_callback(Ipopt::AlgorithmMode, Index, Number, Number, Number, Number, Number,
                             Number, Number, Number, Index, const Ipopt::IpoptData*,
                             Ipopt::IpoptCalculatedQuantities*) override {
    return !(interrupted && interrupted());
  }

  // Moves the solution the least distance (on the link side) that joins its knots and meets the
  // goal within kJoined, by Gauss-Newton steps on the constraints with every variable at a bound
  // held: IPOPT stops with its defects within 1e-6 (acceptable_constr_viol_tol), and the plan's
  // knots are then one RK4 step apart but for rounding, its cost changed as little. Where the
  // steps do not converge in kPolishSteps, or one would move a variable by more than kPolishMove
  // (link side: not a polish), the solution stays as IPOPT left it (the flight then measures it).
  static constexpr double kJoined = 1e-11, kPolishMove = 1e-4;
  static constexpr int kPolishSteps = 5;
  void polish_solution() {
    const int n = L_.variables(), m = L_.K * L_.nx + goal_.rows;
    VectorXd x = solution, lo(n), hi(n), g_lo(m), g_hi(m), g(m), values(jacobian_nonzeros());
    get_bounds_info(n, lo.data(), hi.data(), m, g_lo.data(), g_hi.data());
    std::vector<Index> rows(values.size()), cols(values.size());
    structure(rows.data(), cols.data());
    for (int step = 0;; ++step) {
      if (!eval_g(n, x.data(), true, m, g.data())) return;
      double worst = 0;
      for (int r = 0; r < m; ++r) worst = std::max(worst, std::abs(g[r]) * row_scale(r));
      if (worst <= kJoined) {
        solution = x;
        eval_f(n, x.data(), false, cost);
        return;
      }
      if (step == kPolishSteps ||
          !eval_jac_g(n, x.data(), false, m, 0, nullptr, nullptr, values.data()))
        return;
      // The least-norm step in the scaled variables, J~^T (J~ J~^T)^-1 (-g), J~ = J D^-1.
      std::vector<Eigen::Triplet<double>> free;
      for (size_t e = 0; e < rows.size(); ++e) {
        const int c = cols[e];
        const double d = variable_scales_[c];
        if ((x[c] - lo[c]) * d > 1e-7 && (hi[c] - x[c]) * d > 1e-7)
          free.emplace_back(rows[e], c, values[e] / d);
      }
      Eigen::SparseMatrix<double> J(m, n);
      J.setFromTriplets(free.begin(), free.end());
      const Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> JJt(J * J.transpose());
      if (JJt.info() != Eigen::Success) return;
      const VectorXd move = J.transpose() * JJt.solve(-g);  // scaled
      if (!(move.cwiseAbs().maxCoeff() <= kPolishMove)) return;
      x = (x + move.cwiseQuotient(variable_scales_)).cwiseMax(lo).cwiseMin(hi);
    }
  }

  bool get_nlp_info(Index& n, Index& m, Index& nnz_jac, Index& nnz_h,
                    IndexStyleEnum& style) override {
    n = L_.variables();
    m = L_.K * L_.nx + goal_.rows;
    nnz_jac = jacobian_nonzeros();
    nnz_h = 0;  // a limited-memory Hessian
    style = C_STYLE;
    return true;
  }

  bool get_bounds_info(Index n, Number* lo, Number* hi, Index m, Number* g_lo,
                       Number* g_hi) override {
    std::fill(lo, lo + n, -kInfinity);
    std::fill(hi, hi + n, kInfinity);
    // At rest at q_start at t = 0, the joints at rest at T. A free base's rest at T follows from
    // the momentum, zero at the start and conserved (its rates are the joints' times -H_b^-1
    // H_bm): held too, its rows would be nearly dependent on the defects' (exactly, but for the
    // RK4 steps' drift of the momentum), and IPOPT's multipliers would grow without bound.
    for (int i = 0; i < L_.nq; ++i) lo[i] = hi[i] = q_start_[i];
    for (int i = 0; i < L_.nv; ++i) lo[L_.nq + i] = hi[L_.nq + i] = 0;
    for (int i = m_.num_base(); i < L_.nv; ++i)
      lo[L_.x(L_.K) + L_.nq + i] = hi[L_.x(L_.K) + L_.nq + i] = 0;
    // The joints' limits on the link side: a motor slot's angle and rate are p q and p q'.
    for (int k = 0; k <= L_.K; ++k)
      for (int j = 0; j < L_.N; ++j) {
        const double p = m_.slot_holds_motor(j) ? m_.gear_ratios[j] : 1;
        if (task_.effort.size() && task_.effort[j] > 0)
          lo[L_.u(k) + j] = -task_.effort[j], hi[L_.u(k) + j] = task_.effort[j];
        if (task_.velocity.size() && task_.velocity[j] > 0 && k > 0 && k < L_.K) {
          const int at = L_.x(k) + L_.nq + m_.joint_v_offsets[j];
          lo[at] = -std::abs(p) * task_.velocity[j], hi[at] = std::abs(p) * task_.velocity[j];
        }
        if (task_.has_range(j) && k > 0) {
          const int at = L_.x(k) + m_.joint_q_offsets[j];
          lo[at] = std::min(p * task_.lower[j], p * task_.upper[j]);
          hi[at] = std::max(p * task_.lower[j], p * task_.upper[j]);
        }
      }
    std::fill(g_lo, g_lo + m, 0.0);
    std::fill(g_hi, g_hi + m, 0.0);
    return true;
  }

  bool get_starting_point(Index n, bool, Number* x, bool, Number*, Number*, Index, bool,
                          Number*) override {
    std::copy(guess_.data(), guess_.data() + n, x);
    return true;
  }

  // A geared slot's angle and rate are the motor's, p times the link's: the problem is scaled
  // to the link side, so that every joint's variables and defects are alike in size.
  bool get_scaling_parameters(Number& obj_scaling, bool& use_x_scaling, Index n, Number* x_scaling,
                              bool& use_g_scaling, Index m, Number* g_scaling) override {
    obj_scaling = 1;
    use_x_scaling = use_g_scaling = true;
    std::copy(variable_scales_.data(), variable_scales_.data() + n, x_scaling);
    for (int r = 0; r < m; ++r) g_scaling[r] = row_scale(r);
    return true;
  }

  bool eval_f(Index, const Number* x, bool, Number& f) override {
    f = w_rotation_ * sum(x, true) + w_effort_ * sum(x, false);
    return true;
  }

  bool eval_grad_f(Index n, const Number* x, bool, Number* grad) override {
    std::fill(grad, grad + n, 0.0);
    for (int k = 0; k <= L_.K; ++k) {
      const double w = weight(k);
      for (int i : omega_) grad[L_.x(k) + L_.nq + i] = 2 * w * w_rotation_ * x[L_.x(k) + L_.nq + i];
      for (int j = 0; j < L_.N; ++j) grad[L_.u(k) + j] = 2 * w * w_effort_ * x[L_.u(k) + j];
    }
    return true;
  }

  bool eval_g(Index, const Number* x, bool new_x, Index, Number* g) override {
    if (!update(x, new_x, false)) return false;
    for (int k = 0; k < L_.K; ++k)
      for (int r = 0; r < L_.nx; ++r) g[k * L_.nx + r] = x[L_.x(k + 1) + r] - steps_[k].x[r];
    const VectorXd pose = m_.end_effector_pose(Eigen::Map<const VectorXd>(x + L_.x(L_.K), L_.nq));
    for (int r = 0; r < goal_.rows; ++r)
      g[L_.K * L_.nx + r] = pose[pose_offset_ + r] - task_.goal[r];
    return true;
  }

  bool eval_jac_g(Index, const Number* x, bool new_x, Index, Index, Index* rows, Index* cols,
                  Number* values) override {
    if (values == nullptr) {
      structure(rows, cols);
      return true;
    }
    if (!update(x, new_x, true)) return false;
    Index e = 0;
    for (int k = 0; k < L_.K; ++k) {
      const CoordinateStep& s = steps_[k];
      for (int r = 0; r < L_.nx; ++r) {
        for (int c = 0; c < L_.nx; ++c) values[e++] = -s.X(r, c);
        for (int c = 0; c < L_.N; ++c) values[e++] = -s.U_start(r, c);
        for (int c = 0; c < L_.N; ++c) values[e++] = -s.U_end(r, c);
        values[e++] = 1;
      }
    }
    const VectorXd q = Eigen::Map<const VectorXd>(x + L_.x(L_.K), L_.nq);
    const Eigen::MatrixXd dp = m_.end_effector_jacobian(q).middleRows(goal_.offset, goal_.rows) *
                               m_.configuration_space().tangent_map(q);
    for (int r = 0; r < goal_.rows; ++r)
      for (int c = 0; c < L_.nq; ++c) values[e++] = dp(r, c);
    return true;
  }

  void finalize_solution(Ipopt::SolverReturn, Index n, const Number* x, const Number*,
                         const Number*, Index, const Number*, const Number*, Number f,
                         const Ipopt::IpoptData*, Ipopt::IpoptCalculatedQuantities*) override {
    solution = Eigen::Map<const VectorXd>(x, n);
    cost = f;
  }

 private:
  int jacobian_nonzeros() const {
    return L_.K * L_.nx * (L_.block + L_.N + 1) + goal_.rows * L_.nq;
  }

  // The solver's scaling of the variables: a geared slot's angle and rate are the motor's, p
  // times the link's, so the problem is scaled to the link side.
  VectorXd variable_scales() const {
    VectorXd scale = VectorXd::Ones(L_.variables());
    for (int j = 0; j < L_.N; ++j) {
      if (!m_.slot_holds_motor(j)) continue;
      const double s = 1 / std::abs(m_.gear_ratios[j]);
      const int q = m_.joint_q_offsets[j], v = L_.nq + m_.joint_v_offsets[j];
      for (int k = 0; k <= L_.K; ++k) scale[L_.x(k) + q] = scale[L_.x(k) + v] = s;
    }
    return scale;
  }
  // A constraint's scale: a defect's is its state's; the goal's rows are in metres.
  double row_scale(int r) const {
    return r < L_.K * L_.nx ? variable_scales_[L_.x(1) + r % L_.nx] : 1.0;
  }

  // Trapezoidal weights of the knots in the integrals over [0, T].
  double weight(int k) const { return (k == 0 || k == L_.K ? 0.5 : 1.0) * L_.h; }
  // The integral of |omega_base|^2 (rotation) or |u|^2 (effort) over the knots.
  double sum(const Number* x, bool rotation) const {
    double s = 0;
    for (int k = 0; k <= L_.K; ++k) {
      double at = 0;
      if (rotation)
        for (int i : omega_) at += x[L_.x(k) + L_.nq + i] * x[L_.x(k) + L_.nq + i];
      else
        for (int j = 0; j < L_.N; ++j) at += x[L_.u(k) + j] * x[L_.u(k) + j];
      s += weight(k) * at;
    }
    return s;
  }

  // The steps of every interval at x, their ends alone or with their Jacobians (once per new
  // point: g and its Jacobian share them; a line search's trial points need only the ends).
  bool update(const Number* x, bool new_x, bool jacobians) {
    if (new_x) have_ends_ = have_jacobians_ = false;
    if (have_jacobians_ || (have_ends_ && !jacobians)) return true;
    try {
      for (int k = 0; k < L_.K; ++k) {
        const VectorXd xk = Eigen::Map<const VectorXd>(x + L_.x(k), L_.nx);
        const auto u0 = Eigen::Map<const VectorXd>(x + L_.u(k), L_.N);
        const auto u1 = Eigen::Map<const VectorXd>(x + L_.u(k + 1), L_.N);
        if (jacobians)
          steps_[k] = rk4_step_in_coordinates(m_, xk, u0, u1, L_.h);
        else
          steps_[k].x = rk4_step_end(m_, xk, u0, u1, L_.h);
        if (!steps_[k].x.allFinite() || (jacobians && !steps_[k].X.allFinite())) return false;
      }
    } catch (const std::exception&) {
      return false;  // IPOPT then tries a shorter step
    }
    have_ends_ = true;
    have_jacobians_ = jacobians;
    return true;
  }

  // The Jacobian's pattern, in eval_jac_g's order: per defect row, x_k and u_k (contiguous),
  // u_{k+1}, and x_{k+1}'s own entry; then the goal's rows by q_K.
  void structure(Index* rows, Index* cols) const {
    Index e = 0;
    for (int k = 0; k < L_.K; ++k)
      for (int r = 0; r < L_.nx; ++r) {
        const Index row = k * L_.nx + r;
        for (int c = 0; c < L_.block; ++c) rows[e] = row, cols[e++] = L_.x(k) + c;
        for (int c = 0; c < L_.N; ++c) rows[e] = row, cols[e++] = L_.u(k + 1) + c;
        rows[e] = row, cols[e++] = L_.x(k + 1) + r;
      }
    for (int r = 0; r < goal_.rows; ++r)
      for (int c = 0; c < L_.nq; ++c) rows[e] = L_.K * L_.nx + r, cols[e++] = L_.x(L_.K) + c;
  }

  const DynamicModel& m_;
  const StraightLineTask& task_;
  Layout L_;
  VectorXd guess_, q_start_;
  Goal goal_;
  int pose_offset_ = 0;
  std::vector<int> omega_;  // the base's angular velocities in v
  double w_rotation_ = 0, w_effort_ = 0;
  std::vector<CoordinateStep> steps_;
  VectorXd variable_scales_;
  bool have_ends_ = false, have_jacobians_ = false;
};

// The first guess: a straight line's knots (its grid holds them), for the least rotation the
// reactionless line's where the arm can follow it; or rest at the start where no line can be
// followed.
Guess first_guess(const DynamicModel& m, const StraightLineTask& task, const Layout& L,
                  const VectorXd& q_start) {
  Guess g;
  auto knots = [&](Objective objective) {
    StraightLineTask line = task;
    line.objective = objective;
    VectorXd x(L.variables());
    try {
      const Plan p = plan_straight_line(m, line);
      if (objective == Objective::line)
        g.line_rotation = p.max_base_rotation, g.line_effort = plan_effort(p);
      const int per = static_cast<int>(std::lround(L.h / task.dt));
      for (int k = 0; k <= L.K; ++k) {
        x.segment(L.x(k), L.nq) = p.q[k * per];
        x.segment(L.x(k) + L.nq, L.nv) = p.qd[k * per];
        x.segment(L.u(k), L.N) = p.tau[k * per];
      }
    } catch (const std::exception&) {
      x.resize(0);
    }
    return x;
  };
  g.line = knots(Objective::line);
  if (task.objective == Objective::min_base_rotation) g.x = knots(Objective::reactionless);
  if (g.x.size() == 0) g.x = g.line;
  if (g.x.size() == 0) {
    g.x = VectorXd::Zero(L.variables());
    for (int k = 0; k <= L.K; ++k) g.x.segment(L.x(k), L.nq) = q_start;
  }
  return g;
}

// The plan's rows: the solver's torques (linear between knots) flown from rest at q_start by
// rkf78, sampled on the output grid, with its checks.
Plan fly(const DynamicModel& m, const StraightLineTask& task, const Layout& L,
         const VectorXd& solution, const VectorXd& q_start) {
  const int samples = static_cast<int>(std::lround(task.duration / task.dt)) + 1;
  std::vector<VectorXd> tau(samples);
  for (int i = 0; i < samples; ++i) {
    const double s = i * task.dt / L.h;
    const int k = std::min(static_cast<int>(s), L.K - 1);
    const double a = std::clamp(s - k, 0.0, 1.0);
    tau[i] = (1 - a) * solution.segment(L.u(k), L.N) + a * solution.segment(L.u(k + 1), L.N);
  }
  const TorqueSignal<Eigen::Dynamic> signal(0.0, task.dt, tau, Interpolation::linear);
  IntegratorOptions opt;
  opt.method = Method::rkf78;
  opt.rtol = 1e-12;
  opt.atol = 1e-13;
  Plan plan;
  integrate_motion(m, q_start, VectorXd::Zero(m.nv), signal, task.duration, task.dt, opt,
                   [&](double t, const VectorXd& q, const VectorXd& v) {
                     plan.t.push_back(t);
                     plan.q.push_back(q);
                     plan.qd.push_back(v);
                   });
  const int per = static_cast<int>(std::lround(L.h / task.dt)), nb = m.num_base();
  for (size_t i = 0; i < plan.t.size(); ++i) {
    const VectorXd Q = m.generalized_forces(tau[i]);
    plan.qdd.push_back(m.forward_dynamics(plan.q[i], plan.qd[i], Q));
    plan.tau.push_back(tau[i]);
    Eigen::MatrixXd M;
    VectorXd b;
    m.mass_matrix_and_bias(plan.q[i], plan.qd[i], M, b);
    if (nb > 0)
      plan.base_residual.push_back((M * plan.qdd[i] + b - Q).head(nb).cwiseAbs().maxCoeff());
    if (i % per == 0) {
      const int k = static_cast<int>(i) / per;
      VectorXd knot = solution.segment(L.x(k), L.nx), flown(L.nx);
      flown << plan.q[i], plan.qd[i];
      plan.max_knot_error = std::max(plan.max_knot_error, (knot - flown).cwiseAbs().maxCoeff());
    }
  }
  return plan;
}

// The plan's own checks, as a line's: singularity, momentum, the base's rotation, the goal.
void check(const DynamicModel& m, const StraightLineTask& task, Plan& plan) {
  plan.max_momentum =
      m.momentum || m.num_base() == 0 ? 0.0 : std::numeric_limits<double>::quiet_NaN();
  for (size_t i = 0; i < plan.t.size(); ++i) {
    const double rcond = detail::generalized_jacobian_rcond(m, task, plan.q[i]);
    if (rcond < plan.min_jacobian_rcond)
      plan.min_jacobian_rcond = rcond, plan.min_jacobian_rcond_t = plan.t[i];
    plan.final_base_rotation = detail::base_rotation(m, plan.q[i], plan.q.front());
    plan.max_base_rotation = std::max(plan.max_base_rotation, plan.final_base_rotation);
    if (m.momentum && m.num_base() > 0)
      plan.max_momentum =
          std::max(plan.max_momentum, m.momentum(plan.q[i], plan.qd[i]).cwiseAbs().maxCoeff());
  }
  const int rows = m.spatial ? 3 : 2, at = (m.spatial ? 7 : 3) * task.end_effector;
  plan.goal_error =
      (m.end_effector_pose(plan.q.back()).segment(at, rows) - task.goal.head(rows)).norm();
  detail::check_by_central_differences(
      m, plan, static_cast<int>(std::lround(task.duration / task.knots / task.dt)));
}

}  // namespace

void check_point_to_point(const DynamicModel& m, const StraightLineTask& task,
                          const TaskNames& names) {
  check_task(m, task, names);
  auto fail = [&](const std::string& why) {
    throw std::invalid_argument("planner, model " + m.name + ": " + why);
  };
  const std::string objective =
      task.objective == Objective::min_effort ? "min_effort" : "min_base_rotation";
  if (task.start.size() != (m.spatial ? 3 : 2))
    fail("objective " + objective + " plans to a position: give " + (m.spatial ? "x,y,z" : "x,y") +
         " in " + names.start + " and " + names.goal);
  if (!task.more_lines.empty()) fail("objective " + objective + " moves one end effector");
  if (m.num_end_effectors() > 1)
    fail("objective " + objective +
         " plans a chain: on a tree it would move every arm, holding none (plan a tree with "
         "objective line or reactionless)");
  if (task.objective == Objective::min_base_rotation && m.num_base() == 0)
    fail("objective min_base_rotation spares a free base; this model's base is fixed");
  if (m.passive_forces)
    fail("plans models without springs, dampers or friction; plan on the scene without them");
  if (!(task.knots >= 1 && task.knots <= 1000))
    fail(names.knots + " must be from 1 to 1000, got " + std::to_string(task.knots));
  const double per = task.duration / task.dt / task.knots;
  if (std::abs(per - std::round(per)) > 1e-9 * per || std::round(per) < 1)
    fail(names.duration + " / " + names.dt + " (" + number_text(task.duration / task.dt, 6) +
         " samples) must be a whole multiple of " + names.knots + " (" +
         std::to_string(task.knots) + "), so that the knots lie on the output grid");
  if (!(task.effort_weight >= 0 && task.effort_weight <= 1e6))
    fail(names.effort_weight + " must be from 0 to 1e6, got " + number_text(task.effort_weight, 6));
  for (const auto& [v, name] : {std::pair{&task.effort, "effort"},
                                {&task.velocity, "velocity"},
                                {&task.lower, "lower"},
                                {&task.upper, "upper"}}) {
    if (v->size() != 0 && v->size() != m.num_links)
      fail(std::string(name) + " limits: " + std::to_string(m.num_links) + " values, got " +
           std::to_string(v->size()));
    const bool angle = v == &task.lower || v == &task.upper;
    for (Eigen::Index j = 0; j < v->size(); ++j)
      if (angle ? !std::isfinite((*v)[j]) : !((*v)[j] >= 0))
        fail(std::string(name) + " limit of joint " + std::to_string(j + 1) +
             (angle ? " must be finite" : " must be 0 (none) or positive") + ", got " +
             number_text((*v)[j], 6));
  }
  if (task.lower.size() != task.upper.size()) fail("lower and upper limits: give both or neither");
  for (Eigen::Index j = 0; j < task.lower.size(); ++j)
    if (task.lower[j] > task.upper[j])
      fail("lower limit of joint " + std::to_string(j + 1) + " (" + number_text(task.lower[j], 6) +
           ") is above its upper limit (" + number_text(task.upper[j], 6) + ")");
}

namespace {

// The plan starts inside every joint's range: IPOPT would seek a plan from outside in vain.
void check_start_in_range(const DynamicModel& m, const StraightLineTask& task,
                          const VectorXd& q_start) {
  const VectorXd angles = m.joint_angles(q_start);
  for (int j = 0; j < m.num_links; ++j)
    if (task.has_range(j) && !(angles[j] >= task.lower[j] && angles[j] <= task.upper[j]))
      throw std::invalid_argument(
          "planner, model " + m.name + ": joint " + std::to_string(j + 1) + " starts at " +
          number_text(angles[j], 6) + " rad, outside its range [" + number_text(task.lower[j], 6) +
          ", " + number_text(task.upper[j], 6) +
          "] (the URDF's <limit lower upper>): start from another configuration (q0, or the "
          "other elbow)");
}

// A state's largest rate on the link side: the base's, and the joints' (a motor slot's is p q').
double largest_rate(const DynamicModel& m, const VectorXd& v) {
  return std::max(v.head(m.num_base()).lpNorm<Eigen::Infinity>(),
                  m.joint_rates(v).lpNorm<Eigen::Infinity>());  // 0 where empty (a fixed base)
}
constexpr double kRestAtEnd = 1e-3;  // a flown plan's rates at T, at most, of their peak

// IPOPT's statuses that end without a plan, in words.
std::string status_text(Ipopt::ApplicationReturnStatus status) {
  switch (status) {
    case Ipopt::Maximum_Iterations_Exceeded:
      return "no convergence in 1000 iterations";
    case Ipopt::Maximum_CpuTime_Exceeded:
      return "no convergence in 300 s";
    case Ipopt::Restoration_Failed:
      return "its restoration phase found no feasible point";
    case Ipopt::Infeasible_Problem_Detected:
      return "the problem looks infeasible";
    case Ipopt::Invalid_Number_Detected:
      return "the dynamics gave a number that is not finite";
    case Ipopt::Search_Direction_Becomes_Too_Small:
      return "its steps became too small";
    case Ipopt::Diverging_Iterates:
      return "its iterates diverged";
    default:
      return "IPOPT status " + std::to_string(static_cast<int>(status));
  }
}

// IPOPT's solver (MUMPS, sequential) keeps global state: one solve at a time in a process.
std::mutex& solver_mutex() {
  static std::mutex m;
  return m;
}

// The flight is what a replay does: one that misses the goal, or is not at rest at T, is
// refused, never a table. The solver holds the joints' rates at zero at T, and the base's follow
// through the momentum, zero and conserved, which its RK4 steps conserve only nearly: the flown
// rates at T (link side) may be at most kRestAtEnd of their peak. A plan worse than the straight
// line at what it minimises is a poor local minimum, refused too.
void refuse_a_poor_flight(const DynamicModel& m, const StraightLineTask& task, const Plan& plan,
                          const Guess& guess) {
  const double scale =
      std::max({1.0, task.start.cwiseAbs().maxCoeff(), task.goal.cwiseAbs().maxCoeff()});
  const double at_end = largest_rate(m, plan.qd.back());
  double peak = 0;
  for (const VectorXd& v : plan.qd) peak = std::max(peak, largest_rate(m, v));
  std::string missed;
  if (!(plan.goal_error <= 1e-5 * scale))
    missed = number_text(plan.goal_error, 3) + " m from the goal";
  if (!(at_end <= kRestAtEnd * peak))
    missed += (missed.empty() ? "" : " and ") + std::string("with rates up to ") +
              number_text(at_end, 3) + " (" + number_text(at_end / peak, 3) +
              " of their peak), not at rest";
  if (!missed.empty())
    throw std::runtime_error("planner, model " + m.name + ": the flown plan ends " + missed + " (" +
                             number_text(plan.max_knot_error, 3) +
                             " from the solver's knots: more knots make its steps finer)");
  // Worse than the straight line at what it minimises: a poor local minimum, refused.
  const bool rotation = task.objective == Objective::min_base_rotation;
  const double got = rotation ? plan.max_base_rotation : plan_effort(plan),
               line = rotation ? guess.line_rotation : guess.line_effort;
  if (got > line)
    throw std::runtime_error("planner, model " + m.name + ": the plan " +
                             (rotation ? "turns the base by " + number_text(got, 3) + " rad"
                                       : "takes an effort of " + number_text(got, 3)) +
                             ", more than the straight line's " + number_text(line, 3) +
                             " (a poor local minimum): plan with objective line or reactionless, "
                             "or move the start");
}

}  // namespace

Plan plan_point_to_point(const DynamicModel& m, const StraightLineTask& task,
                         const std::function<bool()>& interrupted) {
  check_point_to_point(m, task);
  if (!m.end_effector_pose || !m.end_effector_jacobian || !m.mass_matrix_and_bias ||
      !m.forward_dynamics)
    throw std::invalid_argument("planner, model " + m.name +
                                ": needs end_effector_pose, end_effector_jacobian, mass_matrix, "
                                "bias_forces and forward_dynamics among the scene's outputs");
  Layout L{m.nq,
           m.nv,
           m.num_links,
           task.knots,
           m.nq + m.nv,
           m.nq + m.nv + m.num_links,
           task.duration / task.knots};
  const VectorXd q_start = initial_configuration(m, task);
  check_start_in_range(m, task, q_start);
  const Guess guess = first_guess(m, task, L, q_start);
  Ipopt::SmartPtr<MultipleShooting> nlp = new MultipleShooting(m, task, L, guess, q_start);
  nlp->interrupted = interrupted;
  const std::lock_guard<std::mutex> one_at_a_time(solver_mutex());
  Ipopt::SmartPtr<Ipopt::IpoptApplication> app = IpoptApplicationFactory();
  app->Options()->SetIntegerValue("print_level", 0);  // nothing on stdout (-o - is the CSV)
  app->Options()->SetStringValue("sb", "yes");
  app->Options()->SetStringValue("option_file_name", "");  // no ipopt.opt from the folder
  // The Lagrangian's Hessian would need the dynamics' second derivatives: a limited-memory
  // quasi-Newton one instead (a Gauss-Newton one, the cost's alone, diverged here).
  app->Options()->SetStringValue("hessian_approximation", "limited-memory");
  app->Options()->SetStringValue("nlp_scaling_method", "user-scaling");
  app->Options()->SetStringValue("mu_strategy", "adaptive");
  app->Options()->SetNumericValue("tol", 1e-8);
  app->Options()->SetNumericValue("constr_viol_tol", 1e-10);
  // A quasi-Newton Hessian leaves the dual infeasibility slow to fall: a plan is also taken
  // once its knots join within 1e-6, its scaled optimality error is below 0.1 and its cost has
  // changed by less than 1e-3 of max(1, cost) for 10 iterations. The flight below measures what
  // that leaves at the goal, and a plan that misses it is refused.
  app->Options()->SetNumericValue("acceptable_tol", 0.1);
  app->Options()->SetNumericValue("acceptable_constr_viol_tol", 1e-6);
  app->Options()->SetNumericValue("acceptable_obj_change_tol", 1e-3);
  app->Options()->SetIntegerValue("acceptable_iter", 10);
  app->Options()->SetIntegerValue("max_iter", 1000);
  app->Options()->SetNumericValue("max_cpu_time", 300);
  if (app->Initialize() != Ipopt::Solve_Succeeded)
    throw std::runtime_error("planner: IPOPT failed to start");
  const auto start = std::chrono::steady_clock::now();
  const Ipopt::ApplicationReturnStatus status = app->OptimizeTNLP(nlp);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const int iterations = IsValid(app->Statistics()) ? app->Statistics()->IterationCount() : 0;
  if (status == Ipopt::User_Requested_Stop)
    throw std::runtime_error("planner, model " + m.name + ": interrupted");
  if (status != Ipopt::Solve_Succeeded && status != Ipopt::Solved_To_Acceptable_Level)
    throw std::runtime_error("planner, model " + m.name + ": IPOPT found no plan after " +
                             std::to_string(iterations) + " iterations (" + status_text(status) +
                             "): the goal may be out of reach in " + number_text(task.duration, 6) +
                             " s or within the limits, or the knots too few (" +
                             std::to_string(task.knots) + ")");

  nlp->polish_solution();
  Plan plan = fly(m, task, L, nlp->solution, q_start);
  plan.knots = task.knots;
  plan.iterations = iterations;
  plan.solve_seconds = seconds;
  plan.cost = nlp->cost;
  check(m, task, plan);
  refuse_a_poor_flight(m, task, plan, guess);
  return plan;
}

}  // namespace spacearm
