#include "spatial_chain.hpp"

namespace spacearm::spatial {

RigidInertia<double> rigid_inertia(const Link& l) {
  const Vec3<double> c = {l.com[0], l.com[1], l.com[2]};
  const auto& i = l.inertia;  // ixx, ixy, ixz, iyy, iyz, izz about the com
  // Parallel axes: I_o = I_c + m (|c|^2 1 - c c^T).
  const double cc = dot(c, c);
  Mat3<double> I = {i[0], i[1], i[2], i[1], i[3], i[4], i[2], i[4], i[5]};
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 3; ++k) I[3 * r + k] += l.mass * ((r == k ? cc : 0.0) - c[r] * c[k]);
  return {l.mass, scaled(c, l.mass), I};
}

Chain::Chain(const ChainDescription& d, const std::vector<double>& q, const std::vector<double>& v)
    : d_(d), n_(static_cast<int>(d.links.size())) {
  if (static_cast<int>(q.size()) != d.nq() || static_cast<int>(v.size()) != d.nv())
    throw std::invalid_argument("spatial chain: q needs " + std::to_string(d.nq()) + " and v " +
                                std::to_string(d.nv()) + " values");
  const int jq = d.free_base ? 7 : 0, jv = d.num_base();
  // The base: its pose from q, its velocity in its own frame (omega_b, R^T v_world).
  X_.resize(n_ + 1);
  I_.push_back(rigid_inertia(d.base));
  if (d.free_base) {
    p_.push_back({q[0], q[1], q[2]});
    R_.push_back(quaternion_rotation(q[3], q[4], q[5], q[6], 1.0));
    V_.push_back({{v[3], v[4], v[5]}, transposed_times(R_[0], Vec3<double>{v[0], v[1], v[2]})});
  } else {
    p_.push_back({0, 0, 0});
    R_.push_back({1, 0, 0, 0, 1, 0, 0, 0, 1});
    V_.push_back({{0, 0, 0}, {0, 0, 0}});
  }
  axis_.push_back({0, 0, 0});
  qd_.push_back(0);
  // Each link: the joint frame from its origin, turned by q_i about the axis (Rodrigues).
  for (int i = 1; i <= n_; ++i) {
    const Link& l = d.links[i - 1];
    const double len = std::sqrt(dot(Vec3<double>(l.axis), Vec3<double>(l.axis)));
    if (!(len > 0))
      throw std::invalid_argument("spatial chain: joint " + std::to_string(i) + " has a zero axis");
    const Vec3<double> a = scaled(Vec3<double>(l.axis), 1 / len);
    const double angle = q[jq + i - 1];
    const Mat3<double> R = product(rpy_rotation(l.origin_rpy),
                                   axis_rotation(a, std::cos(angle), std::sin(angle), 1.0));
    Mat3<double> E;
    for (int r = 0; r < 3; ++r)
      for (int k = 0; k < 3; ++k) E[3 * r + k] = R[3 * k + r];
    X_[i] = {E, {l.origin_xyz[0], l.origin_xyz[1], l.origin_xyz[2]}};
    R_.push_back(product(R_[i - 1], R));
    p_.push_back(p_[i - 1] + times(R_[i - 1], X_[i].r));
    axis_.push_back(a);
    qd_.push_back(v[jv + i - 1]);
    const Motion<double> S = {a, {0, 0, 0}};
    Motion<double> Vi = X_[i].apply(V_[i - 1]);
    Vi.w = Vi.w + scaled(S.w, qd_[i]);
    V_.push_back(Vi);
    I_.push_back(rigid_inertia(l));
  }
}

Motion<double> Chain::base_unit(int k) const {
  Vec3<double> e = {0, 0, 0};
  e[k % 3] = 1;
  if (k < 3) return {{0, 0, 0}, transposed_times(R_[0], e)};  // world linear velocity
  return {e, {0, 0, 0}};                                      // body angular velocity
}

// M = sum over bodies of J_b^T I_b J_b, with each body's Jacobian (in its frame) carried down
// the chain: O(N^3), the composite-rigid-body algorithm's O(N^2) to come.
std::vector<double> Chain::mass_matrix() const {
  const int nv = d_.nv(), nb = d_.num_base();
  std::vector<double> M(nv * nv, 0.0);
  std::vector<Motion<double>> J(nv, Motion<double>{{0, 0, 0}, {0, 0, 0}});
  auto add = [&](int b) {
    for (int k = 0; k < nv; ++k) {
      const Force<double> F = I_[b] * J[k];
      for (int l = 0; l < nv; ++l) M[k * nv + l] += power(F, J[l]);
    }
  };
  for (int k = 0; k < nb; ++k) J[k] = base_unit(k);
  if (d_.free_base) add(0);
  for (int i = 1; i <= n_; ++i) {
    for (int k = 0; k < nb + i - 1; ++k) J[k] = X_[i].apply(J[k]);
    J[nb + i - 1] = {axis_[i], {0, 0, 0}};
    add(i);
  }
  return M;
}

// Recursive Newton-Euler (Featherstone, Algorithm 5.1) with the free base as joint 0: its
// acceleration in its frame is (omega_dot, R^T vdot_world - omega x v_b), and its generalized
// force is (R f, n) in v's order (the power f . v_b = (R f) . v_world).
std::vector<double> Chain::inverse_dynamics(const std::vector<double>& vdot) const {
  const int nv = d_.nv(), nb = d_.num_base();
  if (static_cast<int>(vdot.size()) != nv)
    throw std::invalid_argument("spatial chain: vdot needs " + std::to_string(nv) + " values");
  std::vector<Motion<double>> A(n_ + 1);
  std::vector<Force<double>> F(n_ + 1);
  A[0] = {{0, 0, 0}, {0, 0, 0}};
  if (d_.free_base)
    A[0] = {
        {vdot[3], vdot[4], vdot[5]},
        transposed_times(R_[0], Vec3<double>{vdot[0], vdot[1], vdot[2]}) - cross(V_[0].w, V_[0].v)};
  F[0] = I_[0] * A[0] + cross_force(V_[0], I_[0] * V_[0]);
  for (int i = 1; i <= n_; ++i) {
    const Motion<double> S = {axis_[i], {0, 0, 0}};
    Motion<double> a = X_[i].apply(A[i - 1]);
    const Motion<double> c = cross_motion(V_[i], S);
    a.w = a.w + scaled(S.w, vdot[nb + i - 1]) + scaled(c.w, qd_[i]);
    a.v = a.v + scaled(c.v, qd_[i]);
    A[i] = a;
    F[i] = I_[i] * A[i] + cross_force(V_[i], I_[i] * V_[i]);
  }
  std::vector<double> Q(nv, 0.0);
  for (int i = n_; i >= 1; --i) {
    Q[nb + i - 1] = dot(axis_[i], F[i].n);
    const Force<double> up = X_[i].apply_transpose(F[i]);
    F[i - 1].n = F[i - 1].n + up.n;
    F[i - 1].f = F[i - 1].f + up.f;
  }
  if (d_.free_base) {
    const Vec3<double> f_world = times(R_[0], F[0].f);
    for (int k = 0; k < 3; ++k) {
      Q[k] = f_world[k];
      Q[3 + k] = F[0].n[k];
    }
  }
  return Q;
}

double Chain::kinetic_energy() const {
  double T = 0;
  for (int b = d_.free_base ? 0 : 1; b <= n_; ++b) T += 0.5 * power(I_[b] * V_[b], V_[b]);
  return T;
}

std::array<double, 6> Chain::momentum() const {
  std::array<double, 6> h{};
  for (int b = d_.free_base ? 0 : 1; b <= n_; ++b) {
    const Force<double> F = I_[b] * V_[b];  // about the body's origin, in its frame
    const Vec3<double> P = times(R_[b], F.f);
    const Vec3<double> L = times(R_[b], F.n) + cross(p_[b], P);
    for (int k = 0; k < 3; ++k) {
      h[k] += P[k];
      h[3 + k] += L[k];
    }
  }
  return h;
}

std::vector<double> Chain::configuration_rate(const ChainDescription& d,
                                              const std::vector<double>& q,
                                              const std::vector<double>& v) {
  std::vector<double> qdot;
  int jv = 0;
  if (d.free_base) {
    const double w = q[3], x = q[4], y = q[5], z = q[6], ox = v[3], oy = v[4], oz = v[5];
    // q' = 1/2 q (0, omega), omega in the base frame.
    qdot = {v[0],
            v[1],
            v[2],
            -0.5 * (x * ox + y * oy + z * oz),
            0.5 * (w * ox + y * oz - z * oy),
            0.5 * (w * oy + z * ox - x * oz),
            0.5 * (w * oz + x * oy - y * ox)};
    jv = 6;
  }
  for (size_t i = jv; i < v.size(); ++i) qdot.push_back(v[i]);
  return qdot;
}

}  // namespace spacearm::spatial
