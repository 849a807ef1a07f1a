// The configuration space of a model whose base may float in 3D: q holds the base's orientation
// as a quaternion (w, x, y, z) at `quaternion_offset` (MuJoCo's free joint: origin, quaternion,
// joints; nq = nv + 1), v its angular velocity in the base's own frame. dq/dt is then not v:
//   d(origin)/dt = v[0..2] (the origin's velocity in the world), dq_quat/dt = 1/2 q (0, omega),
// and the joints' coordinates move at their rates. Without a quaternion (every planar model)
// dq/dt = v. The integrators keep the quaternion on the unit sphere by project() after every
// step: 1/2 q (0, omega) is tangent to the sphere, so a step drifts off it only by the method's
// own error, which the projection removes.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

namespace spacearm {

struct ConfigurationSpace {
  int nq = 0, nv = 0;
  int quaternion_offset = -1;  // -1: none, nq = nv

  // dq/dt at (q, v).
  Eigen::VectorXd rate(const Eigen::Ref<const Eigen::VectorXd>& q,
                       const Eigen::Ref<const Eigen::VectorXd>& v) const {
    Eigen::VectorXd qdot(nq);
    rate(q, v, qdot);
    return qdot;
  }
  // The same into qdot (nq entries): no allocation.
  void rate(const Eigen::Ref<const Eigen::VectorXd>& q, const Eigen::Ref<const Eigen::VectorXd>& v,
            Eigen::Ref<Eigen::VectorXd> qdot) const {
    const int k = quaternion_offset;
    if (k < 0) {
      qdot = v;
      return;
    }
    qdot.head(k) = v.head(k);
    const Eigen::Vector4d dquat = quaternion_matrix(q.segment<4>(k)) * v.segment<3>(k);
    qdot.segment<4>(k) = dquat;
    qdot.tail(nq - k - 4) = v.tail(nv - k - 3);
  }

  // d(dq/dt)/dq (nq x nq) and d(dq/dt)/dv (nq x nv) at (q, v), for an implicit method's Jacobian.
  void rate_jacobians(const Eigen::Ref<const Eigen::VectorXd>& q,
                      const Eigen::Ref<const Eigen::VectorXd>& v, Eigen::MatrixXd& by_q,
                      Eigen::MatrixXd& by_v) const {
    const int k = quaternion_offset;
    by_q = Eigen::MatrixXd::Zero(nq, nq);
    by_v = Eigen::MatrixXd::Zero(nq, nv);
    if (k < 0) {
      by_v.setIdentity();
      return;
    }
    by_v.topLeftCorner(k, k).setIdentity();
    by_v.block<4, 3>(k, k) = quaternion_matrix(q.segment<4>(k));
    by_v.bottomRightCorner(nq - k - 4, nv - k - 3).setIdentity();
    // 1/2 q (0, omega) = 1/2 Omega(omega) q, linear in q.
    const double ox = v[k], oy = v[k + 1], oz = v[k + 2];
    Eigen::Matrix4d Omega;
    Omega << 0, -ox, -oy, -oz,  //
        ox, 0, oz, -oy,         //
        oy, -oz, 0, ox,         //
        oz, oy, -ox, 0;
    by_q.block<4, 4>(k, k) = 0.5 * Omega;
  }

  // q ⊕ delta: q moved by delta (nv values) on its tangent space, the origin and the joints by
  // their entries, the quaternion turned by delta's omega in the base's own frame, q exp(omega /
  // 2) (MuJoCo's mj_integratePos over unit time, Pinocchio's integrate). The convention of the
  // derivatives with respect to q (forward_dynamics_derivatives' dqdd_dq).
  Eigen::VectorXd integrate(const Eigen::Ref<const Eigen::VectorXd>& q,
                            const Eigen::Ref<const Eigen::VectorXd>& delta) const {
    const int k = quaternion_offset;
    if (k < 0) return q + delta;
    Eigen::VectorXd out(nq);
    out.head(k) = q.head(k) + delta.head(k);
    const Eigen::Vector3d omega = delta.segment<3>(k);
    const double angle = omega.norm();
    const Eigen::Quaterniond turn =
        angle > 0 ? Eigen::Quaterniond(Eigen::AngleAxisd(angle, omega / angle))
                  : Eigen::Quaterniond::Identity();
    const Eigen::Quaterniond turned = Eigen::Quaterniond(q[k], q[k + 1], q[k + 2], q[k + 3]) * turn;
    out.segment<4>(k) << turned.w(), turned.x(), turned.y(), turned.z();
    out.tail(nq - k - 4) = q.tail(nq - k - 4) + delta.tail(nv - k - 3);
    return out;
  }

  // q1 ⊖ q0: the tangent delta with q0 ⊕ delta = q1 (Pinocchio's difference), the shorter of
  // the two turns; quaternions of any nonzero norm.
  Eigen::VectorXd difference(const Eigen::Ref<const Eigen::VectorXd>& q0,
                             const Eigen::Ref<const Eigen::VectorXd>& q1) const {
    const int k = quaternion_offset;
    if (k < 0) return q1 - q0;
    Eigen::VectorXd delta(nv);
    delta.head(k) = q1.head(k) - q0.head(k);
    const Eigen::Quaterniond a = Eigen::Quaterniond(q0[k], q0[k + 1], q0[k + 2], q0[k + 3]);
    const Eigen::Quaterniond b = Eigen::Quaterniond(q1[k], q1[k + 1], q1[k + 2], q1[k + 3]);
    const Eigen::AngleAxisd turn(a.normalized().conjugate() * b.normalized());  // angle in [0, pi]
    delta.segment<3>(k) = turn.angle() * turn.axis();
    delta.tail(nv - k - 3) = q1.tail(nq - k - 4) - q0.tail(nq - k - 4);
    return delta;
  }

  // W (nv x nq): the tangent d(delta) = W dq that a change dq of the coordinates makes, for a
  // function of q that ignores the quaternion's norm (every model's: spatial_chain.cpp). A
  // Jacobian J on the tangent space is J W with respect to the coordinates (an implicit
  // integrator's). Its quaternion block is 4 G(q)^T / |q|^2, G's left inverse on the tangent.
  Eigen::MatrixXd tangent_map(const Eigen::Ref<const Eigen::VectorXd>& q) const {
    const int k = quaternion_offset;
    Eigen::MatrixXd W = Eigen::MatrixXd::Zero(nv, nq);
    if (k < 0) {
      W.setIdentity();
      return W;
    }
    W.topLeftCorner(k, k).setIdentity();
    const Eigen::Vector4d quat = q.segment<4>(k);
    W.block<3, 4>(k, k) = 4 / quat.squaredNorm() * quaternion_matrix(quat).transpose();
    W.bottomRightCorner(nv - k - 3, nq - k - 4).setIdentity();
    return W;
  }

  // d(dq/dt, qdd)/d(q, v) in q's coordinates ((nq + nv) square), for an implicit method or a
  // linearisation of the motion: the rate's rows (rate_jacobians) above the dynamics' rows, whose
  // dqdd/dq (on the tangent space, nv x nv: forward_dynamics_derivatives) turns into q's
  // coordinates by tangent_map.
  Eigen::MatrixXd motion_jacobian(const Eigen::Ref<const Eigen::VectorXd>& q,
                                  const Eigen::Ref<const Eigen::VectorXd>& v,
                                  const Eigen::Ref<const Eigen::MatrixXd>& dqdd_dq,
                                  const Eigen::Ref<const Eigen::MatrixXd>& dqdd_dv) const {
    Eigen::MatrixXd by_q, by_v, J(nq + nv, nq + nv);
    rate_jacobians(q, v, by_q, by_v);
    J << by_q, by_v, dqdd_dq * tangent_map(q), dqdd_dv;
    return J;
  }

  // The configuration at rest: zeros, and the identity rotation (w = 1) for a quaternion.
  Eigen::VectorXd neutral() const {
    Eigen::VectorXd q = Eigen::VectorXd::Zero(nq);
    if (quaternion_offset >= 0) q[quaternion_offset] = 1;
    return q;
  }

  // Whether the model takes a base quaternion of this norm: it normalizes the quaternion
  // (spatial_chain.hpp), so any norm that squares without under- or overflow is a rotation.
  static bool takes_quaternion_norm(double norm) { return norm >= 1e-6 && norm <= 1e6; }

  // Angles beyond 1e6 rad keep few digits in sin and cos (none at 1e16 in double): the one
  // rule for every input of angles (eval --q, simulate --q0, plan files, Python's q0), as the
  // planner bounds its own. first_angle: the first coordinate that is an angle (the joints, and
  // a planar free base's q0; positions and the quaternion are not). Empty when q keeps it, else
  // "what[i] (name) = value rad: ...".
  static constexpr double kMaxAngle = 1e6;
  // The first coordinate of q that is an angle: a fixed base's first joint, a planar free
  // base's own angle q0 (after x0, y0), a spatial base's first joint (after the origin and the
  // quaternion).
  static int first_angle(bool free_floating, bool spatial) {
    return !free_floating ? 0 : spatial ? 7 : 2;
  }
  static std::string angle_error(const Eigen::Ref<const Eigen::VectorXd>& q, int first_angle,
                                 const std::string& what, const std::vector<std::string>& names) {
    for (Eigen::Index i = first_angle; i < q.size(); ++i) {
      if (std::abs(q[i]) <= kMaxAngle) continue;
      char value[32];
      std::snprintf(value, sizeof value, "%g", q[i]);
      const size_t k = static_cast<size_t>(i);
      return what + "[" + std::to_string(i) + "]" +
             (k < names.size() ? " (" + names[k] + ")" : "") + " = " + value +
             " rad: angles must lie within +-1e6 rad (beyond, sin and cos of them keep no digits)";
    }
    return "";
  }

  // The configuration on the manifold: the quaternion scaled to unit norm (nothing else moves).
  void project(Eigen::Ref<Eigen::VectorXd> q) const {
    if (quaternion_offset < 0) return;
    const double norm = q.segment<4>(quaternion_offset).norm();
    if (norm > 0) q.segment<4>(quaternion_offset) /= norm;
  }

 private:
  // 1/2 q (0, omega) = G(q) omega for the quaternion q = (w, x, y, z).
  static Eigen::Matrix<double, 4, 3> quaternion_matrix(const Eigen::Vector4d& quat) {
    const double w = quat[0], x = quat[1], y = quat[2], z = quat[3];
    Eigen::Matrix<double, 4, 3> G;
    G << -x, -y, -z,  //
        w, -z, y,     //
        z, w, -x,     //
        -y, x, w;
    return 0.5 * G;
  }
};

}  // namespace spacearm
