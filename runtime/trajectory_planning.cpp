// The planner (trajectory_planning.hpp): compiled once here. Its linear algebra and the
// integration are most of the compile time of any file that includes the header.
#include "trajectory_planning.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <Eigen/QR>

#include <charconv>
#include <sstream>

#include "integrators.hpp"

namespace spacearm {

int check_task(const DynamicModel& m, const StraightLineTask& task, const TaskNames& names) {
  const int values = static_cast<int>(task.start.size()), rows = task_rows(m, values);
  auto fail = [&](const std::string& why) {
    throw std::invalid_argument("planner, model " + m.name + ": " + why);
  };
  auto text = [](double v) {  // shortest text that reads back as v
    char buf[32];
    const auto r = std::to_chars(buf, buf + sizeof buf, v);
    return std::string(buf, r.ptr);
  };
  const int position = m.spatial ? 3 : 2;
  // A line's start and goal: a position or a pose, as many values each, finite and below 1e6,
  // a pose's quaternion nonzero (of any size: it is a rotation).
  auto check_line = [&](const Eigen::VectorXd& start, const Eigen::VectorXd& goal,
                        const std::string& start_name, const std::string& goal_name) {
    const int values = static_cast<int>(start.size());
    if (values != position && values != (m.spatial ? 7 : 3))
      fail(start_name +
           (m.spatial ? " must be x,y,z (position) or x,y,z,qw,qx,qy,qz (pose), got "
                      : " must be x,y (position) or x,y,phi (pose), got ") +
           std::to_string(values) + " values");
    if (goal.size() != values)
      fail(goal_name + " has " + std::to_string(goal.size()) + " values and " + start_name + " " +
           std::to_string(values));
    for (const auto& [v, name] : {std::make_pair(&start, start_name), {&goal, goal_name}})
      for (Eigen::Index i = 0; i < v->size(); ++i)
        if (!(std::abs((*v)[i]) < 1e6))
          fail(name + " value " + std::to_string(i + 1) +
               " must be finite and below 1e6 in size, got " + text((*v)[i]));
    if (values == 7)
      for (const auto& [v, name] : {std::make_pair(&start, start_name), {&goal, goal_name}})
        if (!(v->tail<4>().norm() > 1e-6))
          fail(name + "'s quaternion (values 4 to 7) must be nonzero, got norm " +
               text(v->tail<4>().norm()));
  };
  // Line k's start or goal: the task's own is line 0, more_lines[k - 1] line k.
  auto line_name = [&](const std::string& base, size_t k) {
    if (names.lines_indexed) return base + "[" + std::to_string(k) + "]";
    return k == 0 ? base : base + " " + std::to_string(k + 1);  // the CLI's K-th line
  };
  check_line(task.start, task.goal, line_name(names.start, 0), line_name(names.goal, 0));
  if (m.num_links < rows)
    fail("a " + std::to_string(m.num_links) + "-link arm cannot follow a " +
         (rows > position ? "pose" : "position") + " (" + std::to_string(rows) +
         " task coordinates)" +
         (m.num_links >= position ? ": give " + std::string(m.spatial ? "x,y,z" : "x,y") +
                                        " only in " + names.start + " and " + names.goal
                                  : ""));
  if (m.nq != m.nv && m.quaternion_offset < 0)
    fail("needs nq == nv or a base quaternion (it integrates dq/dt = f(q, qd))");
  if (!(task.duration > 0) || !std::isfinite(task.duration))
    fail(names.duration + " must be positive and finite, got " + text(task.duration));
  if (!(task.dt > 0)) fail(names.dt + " must be positive, got " + text(task.dt));
  const double steps = task.duration / task.dt;
  if (!(steps + 1 <= kMaxPlanSamples))
    fail(names.duration + " / " + names.dt + " = " + text(steps) + " samples; at most " +
         text(kMaxPlanSamples) + " are planned at once (a larger " + names.dt + ")");
  if (std::abs(steps - std::round(steps)) > 1e-9 * std::max(1.0, steps))
    fail(names.duration + " (" + text(task.duration) + " s) must be a whole multiple of " +
         names.dt + " (" + text(task.dt) + " s)");
  if (task.q0.size() != 0 && (task.q0.size() != m.nq || !task.q0.allFinite()))
    fail(names.q0 + " must have " + std::to_string(m.nq) + " finite values, got " +
         std::to_string(task.q0.size()));
  if (task.q0.size() != 0 && m.quaternion_offset >= 0) {
    const int k = m.quaternion_offset;
    const double norm = task.q0.segment<4>(k).stableNorm();  // no overflow for 1e300
    if (!ConfigurationSpace::takes_quaternion_norm(norm))
      fail(names.q0 + " values " + std::to_string(k + 1) + " to " + std::to_string(k + 4) +
           ", the base's quaternion, must have a norm in [1e-6, 1e6], got " + text(norm));
  }
  std::vector<int> moving = {task.end_effector};
  int all_rows = rows;
  for (size_t k = 0; k < task.more_lines.size(); ++k) {
    const auto& line = task.more_lines[k];
    check_line(line.start, line.goal, line_name(names.start, k + 1), line_name(names.goal, k + 1));
    moving.push_back(line.end_effector);
    all_rows += task_rows(m, static_cast<int>(line.start.size()));
  }
  for (size_t k = 0; k < moving.size(); ++k) {
    if (moving[k] < 0 || moving[k] >= m.num_end_effectors())
      fail(names.end_effector + " must name one of the model's " +
           std::to_string(m.num_end_effectors()) + " end effectors, got index " +
           std::to_string(moving[k]));
    if (std::count(moving.begin(), moving.begin() + long(k), moving[k]))
      fail(names.end_effector + ": end effector " + std::to_string(moving[k] + 1) +
           " is given two lines");
  }
  if (m.num_links < all_rows)
    fail("a " + std::to_string(m.num_links) + "-joint tree cannot follow " +
         std::to_string(all_rows) + " task coordinates at once");
  if (task.objective == Objective::reactionless && m.num_base() == 0)
    fail("objective reactionless keeps a free base from turning; this model's base is fixed");
  if (task.q0.size() == 0 && task.elbow != 1 && task.elbow != -1)
    fail(names.elbow + " must be +1 or -1, got " + std::to_string(task.elbow));
  return rows;
}

namespace detail {

// Minimum-norm solutions of A x = r for a full-row-rank A (m x n, m <= n) through a QR
// factorization of A^T = Q R P^T: x = A^T lambda with A A^T lambda = r. Exact for square A.
struct MinimumNorm {
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr;
  explicit MinimumNorm(const Eigen::MatrixXd& A) : qr(A.transpose()) {}
  // Ratio of the smallest to the largest |R_ii|: an estimate of 1 / cond(A).
  double rcond() const {
    const auto d = qr.matrixR().diagonal().cwiseAbs();
    const Eigen::Index m = qr.cols();
    return d.head(m).minCoeff() / d.head(m).maxCoeff();
  }
  // The rows' rank in effect: |R_ii| above 1e-6 of the largest (the rates grow as the inverse
  // of the others, and the planner's steps shrink to nothing before rcond reaches its margin).
  int rank() const {
    const auto d = qr.matrixR().diagonal().cwiseAbs();
    const Eigen::Index m = qr.cols();
    return int((d.head(m).array() > 1e-6 * d.head(m).maxCoeff()).count());
  }
  // y = R^-T P^T r; x = Q y; lambda = P R^-1 y.
  Eigen::VectorXd y(const Eigen::VectorXd& r) const {
    const Eigen::Index m = qr.cols();
    const auto R = qr.matrixR().topLeftCorner(m, m).template triangularView<Eigen::Upper>();
    return R.transpose().solve(Eigen::VectorXd(qr.colsPermutation().transpose() * r));
  }
  Eigen::VectorXd x(const Eigen::VectorXd& y) const {
    Eigen::MatrixXd Q = qr.householderQ();
    return Q.leftCols(y.size()) * y;
  }
  Eigen::VectorXd lambda(const Eigen::VectorXd& y) const {
    const Eigen::Index m = qr.cols();
    const auto R = qr.matrixR().topLeftCorner(m, m).template triangularView<Eigen::Upper>();
    return qr.colsPermutation() * Eigen::VectorXd(R.solve(y));
  }
};

// The task in the link-side joint rates z (qd_joint = p z, eq. 9) at q. A free base's rates
// follow from zero momentum, M_bb qd_b + M_bj qd_j = 0 (the base rows of the generalized
// momentum: zero linear and angular momentum, L = M_q0,: qd + x0 Py - y0 Px), so
// qd = E z with E = [-M_bb^-1 M_bj P; P], and the task velocity is A z with A = J_task E,
// the generalized Jacobian (Umetani-Yoshida) on the link side. Fixed base: E = P.
struct TaskMap {
  Eigen::MatrixXd A, E;
};
// The moving end effectors' lines: the task's own, then a tree's more_lines.
std::vector<StraightLineTask::Line> lines_of(const StraightLineTask& task) {
  std::vector<StraightLineTask::Line> lines = {
      {task.end_effector, task.start, task.goal, task.law}};
  lines.insert(lines.end(), task.more_lines.begin(), task.more_lines.end());
  return lines;
}

// The task's rows of A: each moving end effector's (rows of its Jacobian block), then what a
// tree holds: the other end effectors' Jacobian rows (velocity 0), or a unit row per held joint
// (z_j = 0).
struct TaskShape {
  struct Block {              // a moving end effector's
    int rows = 0;             // task rows
    int jacobian_offset = 0;  // its first row in the stacked Jacobians
    int pose_offset = 0;      // its first value in the stacked poses
    int values = 0;           // its line's values (position or pose)
  };
  std::vector<Block> moving;
  std::vector<int> held_end_effectors, held_joints;
  // Reactionless: the base's angular velocities (their indices in v), held at zero.
  std::vector<int> base_attitude;
  int per_end_effector = 6;  // Jacobian rows (3 in the plane)
  int moving_rows() const {
    int r = 0;
    for (const Block& b : moving) r += b.rows;
    return r;
  }
  int held_rows() const {
    return per_end_effector * int(held_end_effectors.size()) + int(held_joints.size()) +
           int(base_attitude.size());
  }
  int total() const { return moving_rows() + held_rows(); }
};
TaskShape task_shape(const DynamicModel& m, const StraightLineTask& task,
                     const Eigen::VectorXd& q) {
  TaskShape shape;
  const int per = m.spatial ? 6 : 3, E = m.num_end_effectors();
  shape.per_end_effector = per;
  std::vector<bool> moves(E, false);
  for (const auto& line : lines_of(task)) {
    const int values = static_cast<int>(line.start.size());
    shape.moving.push_back({task_rows(m, values), per * line.end_effector,
                            (m.spatial ? 7 : 3) * line.end_effector, values});
    moves[line.end_effector] = true;
  }
  if (task.objective == Objective::reactionless)
    shape.base_attitude = m.spatial ? std::vector<int>{3, 4, 5} : std::vector<int>{2};
  if (E == 1) return shape;
  if (task.hold == Hold::pose) {
    for (int e = 0; e < E; ++e)
      if (!moves[e]) shape.held_end_effectors.push_back(e);
    return shape;
  }
  // A joint carries an end effector where its Jacobian column's angular part, its unit axis in
  // the world, is not zero; the columns of joints on other branches are exact zeros.
  const Eigen::MatrixXd J = m.end_effector_jacobian(q);
  for (int j = 0; j < m.num_links; ++j) {
    bool carries = false;
    for (const auto& b : shape.moving)
      carries = carries || !J.block(b.jacobian_offset + (m.spatial ? 3 : 2), m.num_base() + j,
                                    m.spatial ? 3 : 1, 1)
                                .isZero(0);
    if (!carries) shape.held_joints.push_back(j);
  }
  return shape;
}

// The minimum-norm rates need no more task rows than joints: what moves and what is held.
void check_shape(const DynamicModel& m, const TaskShape& shape) {
  if (shape.total() <= m.num_links) return;
  const int attitude = int(shape.base_attitude.size()), others = shape.held_rows() - attitude;
  std::string held;
  if (others > 0)
    held +=
        " and " + std::to_string(others) + " held (the other end effectors' or joints', --hold)";
  if (attitude > 0)
    held += " and the base's " + std::to_string(attitude) +
            " angular velocities held at zero (reactionless)";
  throw std::invalid_argument("planner, model " + m.name + ": " +
                              std::to_string(shape.moving_rows()) + " task coordinates" + held +
                              " are " + std::to_string(shape.total()) + " rows, more than its " +
                              std::to_string(m.num_links) + " joints can follow");
}

TaskMap task_map(const DynamicModel& m, const TaskShape& shape, const Eigen::VectorXd& q) {
  const int nb = m.num_base(), n = m.num_links;
  TaskMap t;
  t.E = Eigen::MatrixXd::Zero(m.nv, n);
  t.E.bottomRows(n) = m.gear_ratios.asDiagonal();
  if (nb > 0) {
    Eigen::MatrixXd M;
    Eigen::VectorXd b;
    m.mass_matrix_and_bias(q, Eigen::VectorXd::Zero(m.nv), M, b);
    t.E.topRows(nb) =
        -M.topLeftCorner(nb, nb).ldlt().solve(M.topRightCorner(nb, n)) * m.gear_ratios.asDiagonal();
  }
  const Eigen::MatrixXd J = m.end_effector_jacobian(q);
  t.A.resize(shape.total(), n);
  int row = 0;
  for (const auto& b : shape.moving) {
    t.A.middleRows(row, b.rows) = J.middleRows(b.jacobian_offset, b.rows) * t.E;
    row += b.rows;
  }
  for (int e : shape.held_end_effectors) {
    t.A.middleRows(row, shape.per_end_effector) =
        J.middleRows(shape.per_end_effector * e, shape.per_end_effector) * t.E;
    row += shape.per_end_effector;
  }
  for (int j : shape.held_joints) t.A.row(row++) = Eigen::RowVectorXd::Unit(n, j);
  for (int v : shape.base_attitude) t.A.row(row++) = t.E.row(v);  // reaction null space
  return t;
}

// Rows of A scaled to unit length: the same solutions, and an rcond that does not depend on
// the units of the task coordinates.
Eigen::VectorXd row_scales(const Eigen::MatrixXd& A) {
  Eigen::VectorXd s(A.rows());
  for (Eigen::Index i = 0; i < A.rows(); ++i) s[i] = A.row(i).norm() > 0 ? 1 / A.row(i).norm() : 1;
  return s;
}

// The straight line's desired pose (the pose output's values), velocity and acceleration (task
// rows) at t.
struct Desired {
  Eigen::VectorXd x, v, a;
};
Eigen::Quaterniond quaternion_of(const Eigen::VectorXd& v, int at) {  // (w, x, y, z)
  return Eigen::Quaterniond(v[at], v[at + 1], v[at + 2], v[at + 3]).normalized();
}
Desired desired(const DynamicModel& m, const StraightLineTask::Line& task, double T, double t) {
  const Eigen::Vector3d s = time_law(task.law, t / T);
  if (!(m.spatial && task.start.size() == 7)) {
    const Eigen::VectorXd d = task.goal - task.start;
    return {task.start + s[0] * d, s[1] / T * d, s[2] / (T * T) * d};
  }
  // 3D pose: the position on the line; the orientation turned from the start's to the goal's
  // about one axis u by s theta (slerp, the shorter way), so the angular velocity in the world
  // is s' theta R_start u.
  const Eigen::Vector3d d = task.goal.head<3>() - task.start.head<3>();
  const Eigen::Quaterniond q0 = quaternion_of(task.start, 3), q1 = quaternion_of(task.goal, 3);
  Eigen::Quaterniond turn = q0.conjugate() * q1;
  if (turn.w() < 0) turn.coeffs() = -turn.coeffs();
  const Eigen::AngleAxisd total(turn);
  const Eigen::Quaterniond q = q0 * Eigen::AngleAxisd(s[0] * total.angle(), total.axis());
  const Eigen::Vector3d w = q0 * (total.angle() * total.axis());
  Desired out{Eigen::VectorXd(7), Eigen::VectorXd(6), Eigen::VectorXd(6)};
  out.x << task.start.head<3>() + s[0] * d, q.w(), q.x(), q.y(), q.z();
  out.v << s[1] / T * d, s[1] / T * w;
  out.a << s[2] / (T * T) * d, s[2] / (T * T) * w;
  return out;
}

// How far the end effector's pose is from the desired one, in task rows: the difference in the
// plane; in 3D the position's difference and the rotation vector of R_desired R^T (in the world,
// as the Jacobian's angular rows).
Eigen::VectorXd pose_error(const DynamicModel& m, int rows, const Eigen::VectorXd& pose,
                           const Eigen::VectorXd& desired_pose) {
  if (!(m.spatial && rows == 6)) return desired_pose.head(rows) - pose.head(rows);
  Eigen::VectorXd e(6);
  const Eigen::AngleAxisd turn(quaternion_of(desired_pose, 3) * quaternion_of(pose, 3).conjugate());
  e << desired_pose.head<3>() - pose.head<3>(), turn.angle() * turn.axis();
  return e;
}

// Every line's desired pose, velocity and acceleration at t, stacked in the lines' order.
Desired desired(const DynamicModel& m, const StraightLineTask& task, double t) {
  Desired all;
  for (const auto& line : lines_of(task)) {
    const Desired d = desired(m, line, task.duration, t);
    for (auto [to, from] : {std::pair{&all.x, &d.x}, {&all.v, &d.v}, {&all.a, &d.a}}) {
      to->conservativeResize(to->size() + from->size());
      to->tail(from->size()) = *from;
    }
  }
  return all;
}

// The moving end effectors' errors from their desired poses (stacked as Desired::x), in task rows,
// from every end effector's pose (the model's end_effector_pose).
Eigen::VectorXd moving_error(const DynamicModel& m, const TaskShape& shape,
                             const Eigen::VectorXd& poses, const Eigen::VectorXd& desired_x) {
  Eigen::VectorXd e(shape.moving_rows());
  int row = 0, at = 0;
  for (const auto& b : shape.moving) {
    e.segment(row, b.rows) = pose_error(m, b.rows, poses.segment(b.pose_offset, b.values),
                                        desired_x.segment(at, b.values));
    row += b.rows;
    at += b.values;
  }
  return e;
}
// The task's velocity or acceleration with zeros for what is held.
Eigen::VectorXd padded(const TaskShape& shape, const Eigen::VectorXd& x) {
  Eigen::VectorXd out = Eigen::VectorXd::Zero(shape.total());
  out.head(x.size()) = x;
  return out;
}

// What lost rank near a singularity: the generalized Jacobian's rows (the task's and what is
// held), and for a reactionless plan the reaction null space's.
std::string rank_text(const TaskShape& shape, const MinimumNorm& mn) {
  std::ostringstream msg;
  msg << (shape.base_attitude.empty()
              ? "generalized Jacobian singular: its "
              : "reaction null space lost: the task's and the base's attitude rows, ")
      << shape.total() << " rows, have rank " << mn.rank() << " in effect (rcond " << mn.rcond()
      << ")";
  return msg.str();
}

// One sample's rates: z = A^+ v (minimum norm on the link side), qd = E z.
struct Rates {
  TaskMap map;
  Eigen::VectorXd scale, z, lambda, qd;
  double rcond = 0;  // of the row-scaled map (MinimumNorm::rcond)
};
Rates rates(const DynamicModel& m, const TaskShape& shape, const Eigen::VectorXd& q,
            const Eigen::VectorXd& v, double t) {
  Rates r{task_map(m, shape, q), {}, {}, {}, {}};
  r.scale = row_scales(r.map.A);
  const MinimumNorm mn(r.scale.asDiagonal() * r.map.A);
  r.rcond = mn.rcond();
  // Near a singularity of the generalized Jacobian (the arm stretched or folded at the edge
  // of the workspace) the joint rates blow up: stop with a reason instead of integrating noise.
  if (!(r.rcond > kMinJacobianRcond)) {
    std::ostringstream msg;
    msg << "planner, model " << m.name << ": " << rank_text(shape, mn) << " at t = " << t
        << " s: the path leaves the workspace or crosses a singularity";
    throw std::runtime_error(msg.str());
  }
  const Eigen::VectorXd y = mn.y(r.scale.cwiseProduct(padded(shape, v)));
  r.z = mn.x(y);
  r.lambda = r.scale.asDiagonal() * mn.lambda(y);  // z = A^T lambda for the unscaled A
  r.qd = r.map.E * r.z;
  return r;
}

// The time derivative of the minimum-norm rates z = A^T lambda: zd = Adot^T lambda + A^T mu
// with A zd = a - Adot z. Adot by central differences in time along dq/dt (a step of 1e-6 in
// q whatever the speed; a quaternion off the sphere by O(h^2) is a rotation all the same). Then
// qdd_j = P zd and the base from no force on it (eq. 5 base rows, M_bb qdd_b = -b_b - M_bj qdd_j);
// on a zero-momentum motion this is the derivative of the base rates, since b_b - (Mdot qd)_b =
// -dT/dq_b = 0 there (dT/dx0 = dT/dy0 = 0, dT/dq0 = -r0d x P).
Eigen::VectorXd accelerations(const DynamicModel& m, const TaskShape& shape,
                              const Eigen::VectorXd& q, const Rates& r, const Eigen::VectorXd& a,
                              const Eigen::MatrixXd& M, const Eigen::VectorXd& b) {
  const int nb = m.num_base(), n = m.num_links;
  const Eigen::VectorXd qdot = m.configuration_rate(q, r.qd);
  const double speed = qdot.cwiseAbs().maxCoeff();
  Eigen::MatrixXd Adot = Eigen::MatrixXd::Zero(shape.total(), n);
  if (speed > 0) {
    const double h = 1e-6 / speed;
    Adot = (task_map(m, shape, q + h * qdot).A - task_map(m, shape, q - h * qdot).A) / (2 * h);
  }
  const MinimumNorm mn(r.scale.asDiagonal() * r.map.A);
  const Eigen::VectorXd At_lambda_dot = Adot.transpose() * r.lambda;
  const Eigen::VectorXd rhs = padded(shape, a) - Adot * r.z - r.map.A * At_lambda_dot;
  const Eigen::VectorXd zd = At_lambda_dot + mn.x(mn.y(r.scale.cwiseProduct(rhs)));
  Eigen::VectorXd qdd(m.nv);
  qdd.tail(n) = m.gear_ratios.cwiseProduct(zd);
  if (nb > 0)
    qdd.head(nb) =
        M.topLeftCorner(nb, nb).ldlt().solve(-b.head(nb) - M.topRightCorner(nb, n) * qdd.tail(n));
  return qdd;
}

// How far what a tree holds has moved from where it started: the held end effectors' poses
// (position, and the angle of R R_start^T), or the held joints' link-side angles.
double hold_error(const DynamicModel& m, const TaskShape& shape, const Eigen::VectorXd& poses,
                  const Eigen::VectorXd& angles, const Eigen::VectorXd& start_poses,
                  const Eigen::VectorXd& start_angles) {
  double worst = 0;
  const int values = m.spatial ? 7 : 3;
  for (int e : shape.held_end_effectors)
    worst = std::max(worst, pose_error(m, shape.per_end_effector, poses.segment(values * e, values),
                                       start_poses.segment(values * e, values))
                                .cwiseAbs()
                                .maxCoeff());
  for (int j : shape.held_joints) worst = std::max(worst, std::abs(angles[j] - start_angles[j]));
  return worst;
}

double generalized_jacobian_rcond(const DynamicModel& m, const StraightLineTask& task,
                                  const Eigen::VectorXd& q) {
  const TaskMap map = task_map(m, task_shape(m, task, q), q);
  return MinimumNorm(row_scales(map.A).asDiagonal() * map.A).rcond();
}

// The angle the base turned from q_start's attitude to q's (0 for a fixed base).
double base_rotation(const DynamicModel& m, const Eigen::VectorXd& q,
                     const Eigen::VectorXd& q_start) {
  if (m.num_base() == 0) return 0;
  if (!m.spatial) return std::abs(q[2] - q_start[2]);  // x0, y0, q0
  const Eigen::Quaterniond turn = quaternion_of(q, m.quaternion_offset) *
                                  quaternion_of(q_start, m.quaternion_offset).conjugate();
  return 2 * std::atan2(turn.vec().norm(), std::abs(turn.w()));
}

// Independent checks of a plan: qdd by central differences of the planned qd, and the forces
// on the base (eq. 5 base rows) with those.
void check_by_central_differences(const DynamicModel& m, Plan& plan, int kinks_every) {
  using Eigen::VectorXd;
  const int nb = m.num_base();
  for (size_t k = 1; k + 1 < plan.t.size(); ++k) {
    if (kinks_every > 1 && k % kinks_every == 0) continue;  // every sample a knot: check all
    const VectorXd qdd_fd = (plan.qd[k + 1] - plan.qd[k - 1]) / (plan.t[k + 1] - plan.t[k - 1]);
    plan.max_acceleration_mismatch =
        std::max(plan.max_acceleration_mismatch, (qdd_fd - plan.qdd[k]).cwiseAbs().maxCoeff());
    if (nb == 0) continue;
    Eigen::MatrixXd Mk;
    VectorXd b;
    m.mass_matrix_and_bias(plan.q[k], plan.qd[k], Mk, b);
    plan.max_base_residual =
        std::max(plan.max_base_residual, (Mk * qdd_fd + b).head(nb).cwiseAbs().maxCoeff());
  }
}

}  // namespace detail

Eigen::VectorXd initial_configuration(const DynamicModel& m, const StraightLineTask& task) {
  check_task(m, task);
  const int jv = m.num_base(), n = m.num_links;
  const int jq = m.q_index(jv);
  const Eigen::VectorXd p = m.gear_ratios;
  Eigen::VectorXd q = m.neutral_configuration();
  if (task.q0.size() != 0) {
    q = task.q0;
    m.configuration_space().project(q);
  } else {
    // Link-side angles; a geared model's coordinates are the motor angles qm = p q (eq. 12).
    for (int i = 0; i < n; ++i)
      q[jq + i] = p[i] * task.elbow *
                  (m.spatial ? 0.4
                   : i == 0  ? -0.3
                   : i == 1  ? 1.2
                             : -0.5 / (n - 2));
    // A joint's range (a point-to-point plan's task has them) keeps the seed inside it: its
    // centre where the seed is outside.
    for (int i = 0; i < n; ++i)
      if (task.has_range(i)) {
        const double angle = q[jq + i] / p[i];
        if (angle < task.lower[i] || angle > task.upper[i])
          q[jq + i] = p[i] * (task.lower[i] + task.upper[i]) / 2;
      }
  }
  const Eigen::VectorXd seed = q.segment(jq, n).cwiseQuotient(p);  // link side
  const detail::TaskShape shape = detail::task_shape(m, task, q);
  detail::check_shape(m, shape);
  const Eigen::VectorXd starts = detail::desired(m, task, 0.0).x;
  auto error = [&](const Eigen::VectorXd& x) {
    return detail::moving_error(m, shape, m.end_effector_pose(x), starts);
  };
  for (int it = 0; it < 300; ++it) {
    const Eigen::VectorXd err = error(q);
    const Eigen::MatrixXd J_all = m.end_effector_jacobian(q);
    Eigen::MatrixXd J(shape.moving_rows(), n);
    int row = 0;
    for (const auto& b : shape.moving) {
      J.middleRows(row, b.rows) = J_all.block(b.jacobian_offset, jv, b.rows, n) * p.asDiagonal();
      row += b.rows;
    }
    const auto cod = J.completeOrthogonalDecomposition();
    const Eigen::VectorXd pull = seed - q.segment(jq, n).cwiseQuotient(p);
    const Eigen::VectorXd null_pull = pull - cod.solve(J * pull);
    Eigen::VectorXd step = cod.solve(err) + 0.5 * null_pull;
    if (!step.allFinite()) break;
    if (err.norm() < 1e-14 && null_pull.norm() < 1e-10) break;
    if (step.norm() > 0.5) step *= 0.5 / step.norm();  // stay near the seed's branch
    q.segment(jq, n) += p.cwiseProduct(step);
  }
  const bool branch_ok = task.q0.size() != 0 || m.spatial || q[jq + 1] * task.elbow > 0;
  if (!(error(q).norm() < 1e-12) || !branch_ok) {
    std::string pose;
    for (Eigen::Index i = 0; i < task.start.size(); ++i)
      pose += (i ? ", " : "") + number_text(task.start[i]);
    throw std::runtime_error("planner, model " + m.name + ": no start configuration " +
                             (task.q0.size() ? std::string("near the given q0")
                                             : "on elbow branch " + std::to_string(task.elbow)) +
                             " puts the end-effector at (" + pose + ")" +
                             (task.q0.size() ? "" : "; give a guess with q0"));
  }
  return q;
}

Plan plan_straight_line(const DynamicModel& m, const StraightLineTask& task) {
  using Eigen::VectorXd;
  if (m.passive_forces)
    throw std::invalid_argument("planner, model " + m.name +
                                ": plans models without springs, dampers or friction; plan on the "
                                "scene without them and start the full model from that plan");
  if (point_to_point(task.objective))
    throw std::invalid_argument("planner, model " + m.name +
                                ": a point-to-point objective is planned by plan_task "
                                "(optimal_plan.hpp), not along a line");
  check_task(m, task);
  const int nb = m.num_base(), n = m.num_links;
  if (!m.end_effector_pose || !m.end_effector_jacobian || !m.mass_matrix_and_bias)
    throw std::invalid_argument("planner, model " + m.name +
                                ": needs end_effector_pose, end_effector_jacobian, mass_matrix "
                                "and bias_forces among the scene's outputs");

  // Integrate q' = qd(q, t) on the grid.
  Plan plan;
  VectorXd q = initial_configuration(m, task);
  const detail::TaskShape shape = detail::task_shape(m, task, q);
  const VectorXd start_poses = m.end_effector_pose(q), start_angles = m.joint_angles(q);
  IntegratorOptions opt;
  opt.method = Method::rkf78;
  opt.rtol = 1e-13;
  opt.atol = 1e-14;
  const ConfigurationSpace space = m.configuration_space();
  opt.project = [space](Eigen::Ref<VectorXd> x) { space.project(x); };
  auto f = [&](const VectorXd& s, VectorXd& dsdt, double t) {
    dsdt = space.rate(s, detail::rates(m, shape, s, detail::desired(m, task, t).v, t).qd);
  };
  auto observe = [&](const VectorXd& s, double t) {
    plan.t.push_back(t);
    plan.q.push_back(s);
  };
  try {
    integrate(opt, f, q, 0.0, task.duration, task.dt, observe);
  } catch (const IntegrationError& e) {
    const detail::TaskMap map = detail::task_map(m, shape, e.state());
    const detail::MinimumNorm mn(detail::row_scales(map.A).asDiagonal() * map.A);
    std::ostringstream msg;
    msg << "planner, model " << m.name << ": cannot follow the line beyond t = " << e.t()
        << " s: " << detail::rank_text(shape, mn)
        << " there (the arm is stretched or folded, or the line leaves the workspace): the "
        << "planner's steps shrank to nothing there. Shorten the line or move its start.";
    throw std::runtime_error(msg.str());
  }

  // Rates, accelerations and torques per sample.
  plan.max_momentum = m.momentum || nb == 0 ? 0.0 : std::numeric_limits<double>::quiet_NaN();
  for (size_t k = 0; k < plan.t.size(); ++k) {
    const VectorXd& qk = plan.q[k];
    const detail::Desired d = detail::desired(m, task, plan.t[k]);
    const detail::Rates r = detail::rates(m, shape, qk, d.v, plan.t[k]);
    if (r.rcond < plan.min_jacobian_rcond)
      plan.min_jacobian_rcond = r.rcond, plan.min_jacobian_rcond_t = plan.t[k];
    Eigen::MatrixXd Mk;
    VectorXd b;
    m.mass_matrix_and_bias(qk, r.qd, Mk, b);
    const VectorXd qdd = detail::accelerations(m, shape, qk, r, d.a, Mk, b);
    const VectorXd Q = Mk * qdd + b;  // eq. 5
    plan.qd.push_back(r.qd);
    plan.qdd.push_back(qdd);
    plan.tau.push_back(Q.tail(n).cwiseProduct(m.gear_ratios));
    if (nb > 0) plan.base_residual.push_back(Q.head(nb).cwiseAbs().maxCoeff());
    const VectorXd poses = m.end_effector_pose(qk);  // once per sample, for both checks
    plan.max_path_error = std::max(
        plan.max_path_error, detail::moving_error(m, shape, poses, d.x).cwiseAbs().maxCoeff());
    if (shape.held_rows() > 0)
      plan.max_hold_error = std::max(
          plan.max_hold_error,
          detail::hold_error(m, shape, poses, m.joint_angles(qk), start_poses, start_angles));
    plan.final_base_rotation = detail::base_rotation(m, qk, plan.q.front());
    plan.max_base_rotation = std::max(plan.max_base_rotation, plan.final_base_rotation);
    if (m.momentum && nb > 0)
      plan.max_momentum = std::max(plan.max_momentum, m.momentum(qk, r.qd).cwiseAbs().maxCoeff());
  }
  // A plan off its line is an error, never a table (a step over a whole short span once gave
  // one 0.6 m off with exit 0); good plans are within 1e-13 of it.
  double scale = 1;
  for (const auto& line : detail::lines_of(task))
    scale = std::max({scale, line.start.cwiseAbs().maxCoeff(), line.goal.cwiseAbs().maxCoeff()});
  if (!(plan.max_path_error <= 1e-8 * scale))
    throw std::runtime_error("planner, model " + m.name + ": the plan misses the line by " +
                             detail::format(plan.max_path_error) +
                             " (integration failed to follow it; a bug: please report it)");
  plan.held = !shape.held_end_effectors.empty() || !shape.held_joints.empty();
  if (plan.held && !(plan.max_hold_error <= 1e-8 * scale))
    throw std::runtime_error("planner, model " + m.name + ": what the plan holds moves by " +
                             detail::format(plan.max_hold_error) +
                             " (integration failed to hold it; a bug: please report it)");
  if (task.objective == Objective::reactionless && !(plan.max_base_rotation <= 1e-8))
    throw std::runtime_error("planner, model " + m.name +
                             ": the reactionless plan turns the base by " +
                             detail::format(plan.max_base_rotation) +
                             " rad (integration failed to hold it; a bug: please report it)");
  // Rates and torques grow as 1/duration and 1/duration^2: a duration of 1e-300 s overflows.
  for (size_t k = 0; k < plan.t.size(); ++k)
    if (!plan.qd[k].allFinite() || !plan.qdd[k].allFinite() || !plan.tau[k].allFinite())
      throw std::runtime_error("planner, model " + m.name + ": the rates or torques at t = " +
                               detail::format(plan.t[k]) + " s overflow double precision (a " +
                               detail::format(task.duration) + " s manoeuvre is too fast)");
  detail::check_by_central_differences(m, plan);
  return plan;
}

PlanTable plan_table(const Plan& plan, const DynamicModel& m, bool geared) {
  PlanTable table{{"t"}, {}};
  table.names.insert(table.names.end(), m.coordinate_names.begin(), m.coordinate_names.end());
  for (const char* suffix : {"", "d"})  // a coordinate's rate is its name + d (3D: vx0..wz0)
    for (const auto& name : m.velocity_names()) table.names.push_back(name + suffix);
  // A motor slot's joint also gets its link-side angle and rate (q_j = qm_j / p_j), so that
  // simulate --plan can replay the plan into a scene with other gears (plan_replay.hpp).
  std::vector<int> motor_slots;
  for (int j = 0; j < m.num_links; ++j)
    if (m.slot_holds_motor(j)) motor_slots.push_back(j);
  for (const char* suffix : {"", "d"})
    for (int j : motor_slots) table.names.push_back("q" + std::to_string(j + 1) + suffix);
  for (int j = 1; j <= m.num_links; ++j) table.names.push_back("tau" + std::to_string(j));
  if (geared)
    for (int j = 1; j <= m.num_links; ++j) table.names.push_back("tau_motor" + std::to_string(j));
  const bool free_base = !plan.base_residual.empty();
  if (free_base) table.names.push_back("base_residual");
  // The end effector's pose, so that a replay can tell whether its arm is this one
  // (plan_replay.hpp: check_plan_kinematics).
  const std::vector<std::string> pose = end_effector_columns(m);
  table.names.insert(table.names.end(), pose.begin(), pose.end());
  for (size_t k = 0; k < plan.t.size(); ++k) {
    std::vector<double> row{plan.t[k]};
    for (const auto* v : {&plan.q[k], &plan.qd[k], &plan.qdd[k]})
      row.insert(row.end(), v->data(), v->data() + v->size());
    const Eigen::VectorXd angles = m.joint_angles(plan.q[k]), rates = m.joint_rates(plan.qd[k]);
    for (int j : motor_slots) row.push_back(angles[j]);
    for (int j : motor_slots) row.push_back(rates[j]);
    row.insert(row.end(), plan.tau[k].data(), plan.tau[k].data() + plan.tau[k].size());
    if (geared)
      for (int j = 0; j < m.num_links; ++j) row.push_back(plan.tau[k][j] / m.gear_ratios[j]);
    if (free_base) row.push_back(plan.base_residual[k]);
    if (!pose.empty()) {
      const Eigen::VectorXd x = m.end_effector_pose(plan.q[k]);
      row.insert(row.end(), x.data(), x.data() + x.size());
    }
    table.rows.push_back(std::move(row));
  }
  return table;
}

}  // namespace spacearm
