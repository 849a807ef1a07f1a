// q ⊕ delta on a free base's tangent space, written with Eigen alone for tests (no code shared
// with the runtime's ConfigurationSpace or the chains): the origin and the joints move by delta,
// the base's quaternion (q[3..6], w x y z) turns by delta's omega in its own frame, q exp(omega/2).
#pragma once

#include <Eigen/Geometry>

namespace spacearm::test {

inline Eigen::VectorXd moved_along_tangent(const Eigen::VectorXd& q, const Eigen::VectorXd& delta) {
  Eigen::VectorXd out = q;
  out.head<3>() += delta.head<3>();
  const Eigen::Vector3d omega = delta.segment<3>(3);
  const Eigen::Quaterniond turned =
      Eigen::Quaterniond(q[3], q[4], q[5], q[6]) *
      Eigen::Quaterniond(Eigen::AngleAxisd(omega.norm(), omega.normalized()));
  out.segment<4>(3) << turned.w(), turned.x(), turned.y(), turned.z();
  out.tail(q.size() - 7) += delta.tail(delta.size() - 6);
  return out;
}

}  // namespace spacearm::test
