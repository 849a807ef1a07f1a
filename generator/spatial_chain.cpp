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

namespace {

// The joint's unit axis (URDF's may be of any length), or an error naming the joint.
Vec3<double> unit_axis(const Link& l, int joint) {
  const Vec3<double> a = {l.axis[0], l.axis[1], l.axis[2]};
  const double len = std::sqrt(dot(a, a));
  if (!(len > 0))
    throw std::invalid_argument("spatial chain: joint " + std::to_string(joint) +
                                " has a zero axis");
  return scaled(a, 1 / len);
}

}  // namespace

template <class T>
Mat3<T> Chain<T>::num(const Mat3<double>& A) const {
  Mat3<T> B;
  for (int k = 0; k < 9; ++k) B[k] = num(A[k]);
  return B;
}

template <class T>
Chain<T>::Chain(const ChainDescription& d, Values<T> values)
    : d_(d), values_(std::move(values)), n_(static_cast<int>(d.links.size())) {
  const int jq = d.free_base ? 7 : 0, jv = d.num_base();
  auto q = [this](int i) { return values_.input("q", i); };
  auto v = [this](int i) { return values_.input("qd", i); };
  auto inertia = [this](const Link& l) {
    const RigidInertia<double> I = rigid_inertia(l);
    return RigidInertia<T>{num(I.m), num(I.h), num(I.I)};
  };
  // The base: its pose from q, its velocity in its own frame (omega_b, R^T v_world).
  X_.resize(n_ + 1);
  I_.push_back(inertia(d.base));
  if (d.free_base) {
    p_.push_back({q(0), q(1), q(2)});
    // The base's quaternion need not be unit (an integrator's stage drifts off the sphere).
    const T norm2 = q(3) * q(3) + q(4) * q(4) + q(5) * q(5) + q(6) * q(6);
    R_.push_back(quaternion_rotation(q(3), q(4), q(5), q(6), num(1.0), num(2.0) / norm2));
    V_.push_back({{v(3), v(4), v(5)}, transposed_times(R_[0], Vec3<T>{v(0), v(1), v(2)})});
  } else {
    p_.push_back(zero3());
    R_.push_back(num(Mat3<double>{1, 0, 0, 0, 1, 0, 0, 0, 1}));
    V_.push_back(zero_motion());
  }
  axis_.push_back(zero3());
  qd_.push_back(T{});
  // Each link: the joint frame from its origin, turned by q_i = qm_i / p_i about the axis
  // (Rodrigues); an exact rotor in the joint frame at q = 0, turning at qd_m about the axis.
  S_.push_back(zero_motion());
  rotor_X_.resize(n_ + 1);
  rotor_I_.resize(n_ + 1);
  rotor_V_.resize(n_ + 1, zero_motion());
  for (int i = 1; i <= n_; ++i) {
    const Link& l = d.links[i - 1];
    const Vec3<double> a = unit_axis(l, i);
    const double p = l.gear.present ? l.gear.ratio : 1.0;
    const T angle = q(jq + i - 1) * (1 / p);
    const Mat3<double> R_origin = rpy_rotation(l.origin_rpy);
    const Mat3<T> R =
        product(num(R_origin), axis_rotation(num(a), cos(angle), sin(angle), num(1.0)));
    X_[i] = {transposed(R), num(l.origin_xyz)};
    R_.push_back(product(R_[i - 1], R));
    p_.push_back(p_[i - 1] + times(R_[i - 1], X_[i].r));
    axis_.push_back(num(a));
    qd_.push_back(v(jv + i - 1));
    S_.push_back({num(scaled(a, 1 / p)), zero3()});
    Motion<T> Vi = X_[i].apply(V_[i - 1]);
    Vi.w = Vi.w + scaled(S_[i].w, qd_[i]);
    V_.push_back(Vi);
    I_.push_back(inertia(l));
    if (exact_rotor(i)) {
      rotor_X_[i] = {num(transposed(R_origin)), num(l.origin_xyz)};
      Mat3<double> Ir;  // transverse (1 - a a^T) + axial a a^T
      for (int r = 0; r < 3; ++r)
        for (int k = 0; k < 3; ++k)
          Ir[3 * r + k] =
              l.gear.transverse * ((r == k ? 1.0 : 0.0) - a[r] * a[k]) + l.gear.axial * a[r] * a[k];
      rotor_I_[i] = {T{}, zero3(), num(Ir)};
      rotor_V_[i] = rotor_X_[i].apply(V_[i - 1]);
      rotor_V_[i].w = rotor_V_[i].w + scaled(axis_[i], qd_[i]);
    }
  }
}

template <class T>
T Chain<T>::configuration_rate(const ChainDescription& d, const Values<T>& values, int i) {
  auto q = [&values](int k) { return values.input("q", k); };
  auto v = [&values](int k) { return values.input("qd", k); };
  if (!d.free_base) return v(i);
  if (i < 3) return v(i);
  if (i >= 7) return v(i - 1);
  // q' = 1/2 q (0, omega), omega in the base frame.
  const T w = q(3), x = q(4), y = q(5), z = q(6), ox = v(3), oy = v(4), oz = v(5);
  switch (i) {
    case 3:
      return -(x * ox + y * oy + z * oz) * 0.5;
    case 4:
      return (w * ox + y * oz - z * oy) * 0.5;
    case 5:
      return (w * oy + z * ox - x * oz) * 0.5;
    default:
      return (w * oz + x * oy - y * ox) * 0.5;
  }
}

template <class T>
Motion<T> Chain<T>::base_unit(int k) const {
  Vec3<double> e = {0, 0, 0};
  e[k % 3] = 1;
  if (k < 3) return {zero3(), transposed_times(R_[0], num(e))};  // world linear
  return {num(e), zero3()};                                      // body angular
}

// The composite-rigid-body algorithm (Featherstone, Algorithm 6.2): each body's composite
// inertia with everything it carries (an exact rotor with the body it sits on), then each
// joint's column as the force of its composite per unit rate, carried towards the base.
template <class T>
std::vector<T> Chain<T>::mass_matrix() const {
  const int nv = d_.nv(), nb = d_.num_base();
  std::vector<T> M(nv * nv, T{});
  auto set = [&](int a, int b, const T& x) { M[a * nv + b] = M[b * nv + a] = x; };
  std::vector<RigidInertia<T>> Ic = I_;
  for (int i = n_; i >= 1; --i) {
    const int col = nb + i - 1;
    // Column i: link i's composite at S_i, and an exact rotor at its axis (on the parent).
    Force<T> F = Ic[i] * S_[i];
    T Mii = power(F, S_[i]) + num(armature(i));
    Force<T> up = X_[i].apply_transpose(F);
    if (exact_rotor(i)) {
      const Motion<T> Sr = {axis_[i], zero3()};
      const Force<T> Fr = rotor_I_[i] * Sr;
      Mii += power(Fr, Sr);
      up = up + rotor_X_[i].apply_transpose(Fr);
    }
    M[col * nv + col] = Mii;
    for (int j = i - 1; j >= 1; --j) {
      set(nb + j - 1, col, power(up, S_[j]));
      up = X_[j].apply_transpose(up);
    }
    for (int k = 0; k < nb; ++k) set(k, col, power(up, base_unit(k)));
    // The parent's composite takes link i's (and the rotor's).
    Ic[i - 1] = Ic[i - 1] + in_parent(X_[i], Ic[i]);
    if (exact_rotor(i)) Ic[i - 1] = Ic[i - 1] + in_parent(rotor_X_[i], rotor_I_[i]);
  }
  for (int k = 0; k < nb; ++k) {
    const Force<T> F = Ic[0] * base_unit(k);
    for (int l = k; l < nb; ++l) set(k, l, power(F, base_unit(l)));
  }
  return M;
}

namespace {

// A body's acceleration from its parent's over a joint of motion S at rate qd: X A_parent +
// S qdd + (V x S) qd.
template <class T>
Motion<T> joint_acceleration(const Transform<T>& X, const Motion<T>& A_parent, const Motion<T>& V,
                             const Motion<T>& S, const T& qdd, const T& qd) {
  Motion<T> a = X.apply(A_parent);
  const Motion<T> c = cross_motion(V, S);
  a.w = a.w + scaled(S.w, qdd) + scaled(c.w, qd);
  a.v = a.v + scaled(S.v, qdd) + scaled(c.v, qd);
  return a;
}

}  // namespace

// Recursive Newton-Euler (Featherstone, Algorithm 5.1) with the free base as joint 0: its
// acceleration in its frame is (omega_dot, R^T vdot_world - omega x v_b), and its generalized
// force is (R f, n) in v's order (the power f . v_b = (R f) . v_world).
template <class T>
std::vector<T> Chain<T>::inverse_dynamics(const std::vector<T>& vdot) const {
  const int nv = d_.nv(), nb = d_.num_base();
  if (static_cast<int>(vdot.size()) != nv)
    throw std::invalid_argument("spatial chain: vdot needs " + std::to_string(nv) + " values");
  std::vector<Motion<T>> A(n_ + 1, zero_motion());
  std::vector<Force<T>> F(n_ + 1);
  if (d_.free_base)
    A[0] = {{vdot[3], vdot[4], vdot[5]},
            transposed_times(R_[0], Vec3<T>{vdot[0], vdot[1], vdot[2]}) - cross(V_[0].w, V_[0].v)};
  F[0] = I_[0] * A[0] + cross_force(V_[0], I_[0] * V_[0]);
  // Forward: each link's acceleration and force; an exact rotor's, on its parent.
  std::vector<T> Q(nv, T{});
  std::vector<Force<T>> rotor_F(n_ + 1);
  for (int i = 1; i <= n_; ++i) {
    const int col = nb + i - 1;
    A[i] = joint_acceleration(X_[i], A[i - 1], V_[i], S_[i], vdot[col], qd_[i]);
    F[i] = I_[i] * A[i] + cross_force(V_[i], I_[i] * V_[i]);
    Q[col] = vdot[col] * num(armature(i));
    if (exact_rotor(i)) {
      const Motion<T> S = {axis_[i], zero3()};
      const Motion<T> Ar =
          joint_acceleration(rotor_X_[i], A[i - 1], rotor_V_[i], S, vdot[col], qd_[i]);
      rotor_F[i] = rotor_I_[i] * Ar + cross_force(rotor_V_[i], rotor_I_[i] * rotor_V_[i]);
    }
  }
  // Backward: each joint's share, the rest to the parent.
  for (int i = n_; i >= 1; --i) {
    const int col = nb + i - 1;
    Q[col] += power(F[i], S_[i]);
    F[i - 1] = F[i - 1] + X_[i].apply_transpose(F[i]);
    if (exact_rotor(i)) {
      Q[col] += dot(axis_[i], rotor_F[i].n);
      F[i - 1] = F[i - 1] + rotor_X_[i].apply_transpose(rotor_F[i]);
    }
  }
  if (d_.free_base) {
    const Vec3<T> f_world = times(R_[0], F[0].f);
    for (int k = 0; k < 3; ++k) {
      Q[k] = f_world[k];
      Q[3 + k] = F[0].n[k];
    }
  }
  return Q;
}

template <class T>
std::vector<std::vector<T>> Chain<T>::forward_dynamics(const std::vector<T>& Q) const {
  const int n = nv();
  if (static_cast<int>(Q.size()) != n)
    throw std::invalid_argument("spatial chain: Q needs " + std::to_string(n) + " values");
  const std::vector<T> M = mass_matrix(), b = inverse_dynamics(std::vector<T>(n, T{}));
  // M = L D L^T, L unit lower triangular (row-major, below the diagonal).
  std::vector<T> L(n * n, T{}), D(n), scaled(n);
  for (int j = 0; j < n; ++j) {
    T d = M[j * n + j];
    for (int k = 0; k < j; ++k) d -= L[j * n + k] * L[j * n + k] * D[k];
    D[j] = d;
    scaled[j] = d / M[j * n + j];
    for (int i = j + 1; i < n; ++i) {
      T x = M[i * n + j];
      for (int k = 0; k < j; ++k) x -= L[i * n + k] * L[j * n + k] * D[k];
      L[i * n + j] = x / d;
    }
  }
  // L z = Q - b, then D w = z, then L^T qdd = w.
  std::vector<T> x(n);
  for (int i = 0; i < n; ++i) {
    T z = Q[i] - b[i];
    for (int k = 0; k < i; ++k) z -= L[i * n + k] * x[k];
    x[i] = z;
  }
  for (int i = 0; i < n; ++i) x[i] = x[i] / D[i];
  for (int i = n - 1; i >= 0; --i)
    for (int k = i + 1; k < n; ++k) x[i] -= L[k * n + i] * x[k];
  return {x, D, scaled};
}

template <class T>
T Chain<T>::kinetic_energy() const {
  T twice{};
  for (int b = first_body(); b <= n_; ++b) twice += power(I_[b] * V_[b], V_[b]);
  for (int i = 1; i <= n_; ++i) {
    if (exact_rotor(i)) twice += power(rotor_I_[i] * rotor_V_[i], rotor_V_[i]);
    twice += qd_[i] * qd_[i] * num(armature(i));
  }
  return twice * 0.5;
}

// M v from the bodies' momenta: each body's I V, carried to the base by the transposed
// transforms and read along each joint's axis (and the base's six directions).
template <class T>
std::vector<T> Chain<T>::generalized_momentum() const {
  const int nv = d_.nv(), nb = d_.num_base();
  std::vector<T> p(nv, T{});
  Force<T> carried = {zero3(), zero3()};
  for (int i = n_; i >= 1; --i) {
    const int col = nb + i - 1;
    carried = carried + I_[i] * V_[i];
    p[col] = power(carried, S_[i]) + qd_[i] * num(armature(i));
    carried = X_[i].apply_transpose(carried);
    if (exact_rotor(i)) {  // the rotor's momentum, in the parent's frame
      const Force<T> h = rotor_I_[i] * rotor_V_[i];
      p[col] += dot(axis_[i], h.n);
      carried = carried + rotor_X_[i].apply_transpose(h);
    }
  }
  if (d_.free_base) {
    carried = carried + I_[0] * V_[0];
    for (int k = 0; k < nb; ++k) p[k] = power(carried, base_unit(k));
  }
  return p;
}

template <class T>
std::vector<T> Chain<T>::momentum() const {
  std::vector<T> h(6, T{});
  auto add = [&h](const Force<T>& F, const Mat3<T>& R, const Vec3<T>& origin) {
    const Vec3<T> P = times(R, F.f);  // F about the body's origin, in its frame
    const Vec3<T> L = times(R, F.n) + cross(origin, P);
    for (int k = 0; k < 3; ++k) {
      h[k] += P[k];
      h[3 + k] += L[k];
    }
  };
  for (int b = first_body(); b <= n_; ++b) add(I_[b] * V_[b], R_[b], p_[b]);
  // An exact rotor's angular momentum (armature drops it): its frame is the joint's at q = 0.
  for (int i = 1; i <= n_; ++i)
    if (exact_rotor(i))
      add(rotor_I_[i] * rotor_V_[i], product(R_[i - 1], transposed(rotor_X_[i].E)), p_[i]);
  return h;
}

template <class T>
std::vector<T> Chain<T>::end_effector_pose() const {
  const Vec3<T> tip = p_[n_] + times(R_[n_], num(d_.tip));
  Quaternion<T> q = {num(1.0), T{}, T{}, T{}};
  if (d_.free_base)
    q = {values_.input("q", 3), values_.input("q", 4), values_.input("q", 5),
         values_.input("q", 6)};
  const int jq = d_.free_base ? 7 : 0;
  for (int i = 1; i <= n_; ++i) {
    const Link& l = d_.links[i - 1];
    const Quaternion<double> o = rpy_quaternion(l.origin_rpy);
    const double p = l.gear.present ? l.gear.ratio : 1.0;
    const T half = values_.input("q", jq + i - 1) * (0.5 / p);
    const T s = sin(half);
    q = q * Quaternion<T>{num(o[0]), num(o[1]), num(o[2]), num(o[3])} *
        Quaternion<T>{cos(half), s * axis_[i][0], s * axis_[i][1], s * axis_[i][2]};
  }
  if (d_.tip_rpy != std::array<double, 3>{}) {  // a welded end-effector frame's rotation
    const Quaternion<double> t = rpy_quaternion(d_.tip_rpy);
    q = q * Quaternion<T>{num(t[0]), num(t[1]), num(t[2]), num(t[3])};
  }
  return {tip[0], tip[1], tip[2], q[0], q[1], q[2], q[3]};
}

template <class T>
std::vector<T> Chain<T>::end_effector_jacobian() const {
  const int nv = d_.nv(), nb = d_.num_base();
  const Vec3<T> tip = p_[n_] + times(R_[n_], num(d_.tip));
  std::vector<T> J(6 * nv, T{});
  auto column = [&](int c, const Vec3<T>& linear, const Vec3<T>& angular) {
    for (int k = 0; k < 3; ++k) {
      J[k * nv + c] = linear[k];
      J[(3 + k) * nv + c] = angular[k];
    }
  };
  // The base: its origin's world velocity moves the tip alike; its body angular velocity
  // turns the tip about the origin.
  for (int k = 0; k < nb; ++k) {
    Vec3<double> e = {0, 0, 0};
    e[k % 3] = 1;
    if (k < 3) {
      column(k, num(e), zero3());
    } else {
      const Vec3<T> w = times(R_[0], num(e));
      column(k, cross(w, tip - p_[0]), w);
    }
  }
  // Each joint turns everything after it about its world axis, at qd_m / p.
  for (int i = 1; i <= n_; ++i) {
    const Vec3<T> w = times(R_[i], S_[i].w);
    column(nb + i - 1, cross(w, tip - p_[i]), w);
  }
  return J;
}

template class Chain<double>;
template class Chain<Dual<double>>;
template class Chain<Sym>;
template class Chain<Dual<Sym>>;

}  // namespace spacearm::spatial
