// A free base's state in other tools' conventions, and back (the C++ side of Python's
// spacearm.states; `spacearm eval --state-from/--state-to`). spacearm's is MuJoCo's free joint:
// q = [p_o (the base frame's origin, world), w x y z, joints], v = [dp_o/dt (world), omega (base
// frame), joint rates]. The others, flattened to two vectors of the same sizes:
//   pinocchio (JointModelFreeFlyer): q = [p_o, x y z w, joints], v = [R^T dp_o/dt, omega (base
//     frame), joint rates];
//   spacedyn (Yoshida): q = [R0 (the base's centre of mass, world), Q0 (w x y z), joints],
//     v = [v0 = dR0/dt (world), w0 (omega in the world), joint rates];
//   spart: q = [r0 (the centre of mass, world), R0 as a quaternion (w x y z), joints],
//     v = [u0 = (omega in the base frame, dr0/dt (world)), joint rates].
// The others take link angles: where spacearm's slot holds a rigid gear's motor angle qm = p q,
// `ratios` holds p (1 elsewhere). `base_com` is the base's centre of mass in the base frame.
// Each pair round-trips to rounding (tests/runtime/test_state_conventions.cpp).
#pragma once

#include <Eigen/Geometry>

#include <stdexcept>
#include <string>

namespace spacearm {

enum class StateConvention { spacearm, pinocchio, spacedyn, spart };

// "spacearm", "pinocchio", "spacedyn" or "spart"; anything else is refused naming `option`.
inline StateConvention state_convention(const std::string& name, const std::string& option) {
  if (name == "spacearm") return StateConvention::spacearm;
  if (name == "pinocchio") return StateConvention::pinocchio;
  if (name == "spacedyn") return StateConvention::spacedyn;
  if (name == "spart") return StateConvention::spart;
  throw std::invalid_argument(option + ": expected spacearm, pinocchio, spacedyn or spart, got '" +
                              name + "'");
}

struct BaseState {
  Eigen::VectorXd q, v;
};

namespace detail {

// The base's rotation from spacearm's quaternion (w x y z), normalized as the model does.
inline Eigen::Matrix3d base_rotation(const Eigen::Vector4d& wxyz) {
  const double n = wxyz.norm();
  if (!(n > 0)) throw std::invalid_argument("the base's quaternion is zero");
  return Eigen::Quaterniond(wxyz[0] / n, wxyz[1] / n, wxyz[2] / n, wxyz[3] / n).toRotationMatrix();
}

inline void check_sizes(const Eigen::VectorXd& q, const Eigen::VectorXd& v,
                        const Eigen::VectorXd& ratios) {
  if (q.size() < 7 || v.size() != q.size() - 1 || ratios.size() != q.size() - 7)
    throw std::invalid_argument(
        "state conversion: expected a free base's q (7 + N), v (6 + N) "
        "and N ratios, got " +
        std::to_string(q.size()) + ", " + std::to_string(v.size()) + " and " +
        std::to_string(ratios.size()));
}

}  // namespace detail

// spacearm's state in `to`'s convention.
inline BaseState to_convention(StateConvention to, const Eigen::VectorXd& q,
                               const Eigen::VectorXd& v, const Eigen::Vector3d& base_com,
                               const Eigen::VectorXd& ratios) {
  detail::check_sizes(q, v, ratios);
  const Eigen::Index n = ratios.size();
  BaseState out{q, v};
  if (to == StateConvention::spacearm) return out;
  const Eigen::Vector4d quaternion = q.segment<4>(3);
  const Eigen::Matrix3d R = detail::base_rotation(quaternion);
  const Eigen::Vector3d omega = v.segment<3>(3), c = R * base_com;
  out.q.tail(n) = q.tail(n).cwiseQuotient(ratios);
  out.v.tail(n) = v.tail(n).cwiseQuotient(ratios);
  switch (to) {
    case StateConvention::pinocchio:
      out.q.segment<4>(3) << quaternion[1], quaternion[2], quaternion[3], quaternion[0];
      out.v.head<3>() = R.transpose() * v.head<3>();
      break;
    case StateConvention::spacedyn:
      out.q.head<3>() = q.head<3>() + c;
      out.q.segment<4>(3) = quaternion / quaternion.norm();
      out.v.head<3>() = v.head<3>() + (R * omega).cross(c);
      out.v.segment<3>(3) = R * omega;
      break;
    default:  // spart
      out.q.head<3>() = q.head<3>() + c;
      out.q.segment<4>(3) = quaternion / quaternion.norm();
      out.v.head<3>() = omega;
      out.v.segment<3>(3) = v.head<3>() + R * omega.cross(base_com);
  }
  return out;
}

// A state in `from`'s convention as spacearm's.
inline BaseState from_convention(StateConvention from, const Eigen::VectorXd& q,
                                 const Eigen::VectorXd& v, const Eigen::Vector3d& base_com,
                                 const Eigen::VectorXd& ratios) {
  detail::check_sizes(q, v, ratios);
  const Eigen::Index n = ratios.size();
  BaseState out{q, v};
  if (from == StateConvention::spacearm) return out;
  out.q.tail(n) = q.tail(n).cwiseProduct(ratios);
  out.v.tail(n) = v.tail(n).cwiseProduct(ratios);
  if (from == StateConvention::pinocchio) {
    const Eigen::Vector4d wxyz(q[6], q[3], q[4], q[5]);
    out.q.segment<4>(3) = wxyz;
    out.v.head<3>() = detail::base_rotation(wxyz) * v.head<3>();
    return out;
  }
  const Eigen::Matrix3d R = detail::base_rotation(q.segment<4>(3));
  const Eigen::Vector3d c = R * base_com;
  out.q.head<3>() = q.head<3>() - c;
  if (from == StateConvention::spacedyn) {
    const Eigen::Vector3d w_world = v.segment<3>(3);
    out.v.head<3>() = v.head<3>() - w_world.cross(c);
    out.v.segment<3>(3) = R.transpose() * w_world;
  } else {  // spart
    const Eigen::Vector3d omega = v.head<3>();
    out.v.head<3>() = v.segment<3>(3) - R * omega.cross(base_com);
    out.v.segment<3>(3) = omega;
  }
  return out;
}

}  // namespace spacearm
