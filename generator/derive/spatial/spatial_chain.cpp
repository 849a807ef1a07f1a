#include "spatial_chain.hpp"

#include <algorithm>

namespace spacearm::spatial {

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

// A body's own inertial about its origin (about_origin): in double where every number is a
// literal (a recorded program then holds only the results, as constants).
template <class T>
RigidInertia<T> Chain<T>::rigid_inertia(const Inertial& b) const {
  if (!b.uses_parameter()) {
    const auto c = b.com_values();
    const RigidInertia<double> I = about_origin(b.mass.value, Vec3<double>{c[0], c[1], c[2]},
                                                b.inertia_values(), [](double x) { return x; });
    return {num(I.m), num(I.h), num(I.I)};
  }
  Vec3<T> c;
  for (int k = 0; k < 3; ++k) c[k] = value(b.com[k]);
  std::array<T, 6> i;
  for (int k = 0; k < 6; ++k) i[k] = value(b.inertia[k]);
  return about_origin(value(b.mass), c, i, [this](double x) { return num(x); });
}

template <class T>
RigidInertia<T> Chain<T>::body_inertia(const Link& l) const {
  RigidInertia<T> I = rigid_inertia(l);
  for (const Part& part : l.parts) {
    const Transform<double> X = part_frame(part, d_.exact_right_angles);
    I = I + in_parent(Transform<T>{num(X.E), num(X.r)}, rigid_inertia(part.inertial));
  }
  return I;
}

namespace {

// A rotor's inertia tensor about its axis a through its origin: transverse (1 - a a^T) + axial
// a a^T.
template <class T>
Mat3<T> rotor_tensor(const T& transverse, const T& axial, const Vec3<double>& a) {
  Mat3<T> I;
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 3; ++k)
      I[3 * r + k] = transverse * ((r == k ? 1.0 : 0.0) - a[r] * a[k]) + axial * a[r] * a[k];
  return I;
}

}  // namespace

// An exact rotor's inertia about joint i's origin; in double where both inertias are literals.
template <class T>
Mat3<T> Chain<T>::rotor_inertia(int i, const Vec3<double>& a) const {
  const Gear& g = d_.links[i - 1].gear;
  if (!g.axial.is_parameter() && !g.transverse.is_parameter())
    return num(rotor_tensor(g.transverse.value, g.axial.value, a));
  return rotor_tensor(value(g.transverse), axial(i), a);
}

template <class T>
T Chain<T>::ratio_times_axial(int i, int power) const {
  const Gear& g = d_.links[i - 1].gear;
  if (literal_ratio(i) && !g.axial.is_parameter()) {
    const double p = ratio_value(i);
    return num(power == 1 ? p * g.axial.value : p * p * g.axial.value);
  }
  return power == 1 ? ratio(i) * axial(i) : ratio(i) * ratio(i) * axial(i);
}

template <class T>
Chain<T>::Chain(const ChainDescription& d, Values<T> values)
    : d_(d), values_(std::move(values)), n_(static_cast<int>(d.links.size())) {
  const int jq = d.free_base ? 7 : 0, jv = d.num_base();
  auto q = [this](int i) { return values_.input("q", i); };
  auto v = [this](int i) { return values_.input("qd", i); };
  // The base: its pose from q, its velocity in its own frame (omega_b, R^T v_world).
  parent_.resize(n_ + 1, 0);
  for (int i = 1; i <= n_; ++i) {
    parent_[i] = d.parent(i);
    if (parent_[i] < 0 || parent_[i] >= i)
      throw std::invalid_argument("spatial chain: link " + std::to_string(i) + "'s parent " +
                                  std::to_string(parent_[i]) + " is not a body before it");
  }
  for (int e = 0; e < d.num_end_effectors(); ++e)
    if (d.end_effector_body(e) > n_)
      throw std::invalid_argument("spatial chain: end effector " + std::to_string(e) +
                                  " is on body " + std::to_string(d.end_effector_body(e)) +
                                  ", past the last link");
  X_.resize(n_ + 1);
  turns_.resize(n_ + 1);
  parent_w_.resize(n_ + 1, zero3());
  I_.push_back(body_inertia(d.base));
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
  motor_.push_back(-1);
  motor_qd_.push_back(T{});
  // Each link: the joint frame from its origin, turned by q_i = qm_i / p_i about the axis
  // (Rodrigues); an exact rotor in the joint frame at q = 0, turning at qd_m about the axis.
  S_.push_back(zero_motion());
  rotor_X_.resize(n_ + 1);
  rotor_I_.resize(n_ + 1);
  rotor_V_.resize(n_ + 1, zero_motion());
  for (int i = 1; i <= n_; ++i) {
    const Link& l = d.links[i - 1];
    const Vec3<double> a = unit_axis(l, i);
    const T qi = q(jq + i - 1), angle = qi * over_ratio(i, 1.0);
    const T s = sin(angle), c = cos(angle);  // in this order: the recorded nodes as before
    const Mat3<double> R_origin = rpy_rotation(l.origin_rpy, d.exact_right_angles);
    const Mat3<T> R =
        product(num(R_origin), axis_rotation(a, c, s, [this](double x) { return num(x); }));
    X_[i] = {transposed(R), num(l.origin_xyz)};
    turns_[i] = joint_turns(l, a, c, s);
    const int parent = parent_[i];
    R_.push_back(product(R_[parent], R));
    p_.push_back(p_[parent] + times(R_[parent], X_[i].r));
    axis_.push_back(num(a));
    qd_.push_back(v(jv + i - 1));
    motor_.push_back(d.motor_coordinate(i - 1));
    motor_qd_.push_back(flexible(i) ? v(motor_[i]) : qd_[i]);
    S_.push_back(
        {literal_ratio(i) ? num(scaled(a, 1 / ratio_value(i))) : scaled(num(a), over_ratio(i, 1.0)),
         zero3()});
    Motion<T> Vi = X_[i].apply(V_[parent]);
    parent_w_[i] = Vi.w;
    Vi.w = Vi.w + scaled(S_[i].w, qd_[i]);
    V_.push_back(Vi);
    I_.push_back(body_inertia(l));
    if (exact_rotor(i)) {
      rotor_X_[i] = {num(transposed(R_origin)), num(l.origin_xyz)};
      rotor_I_[i] = {T{}, zero3(), rotor_inertia(i, a)};
      if (coupled(i)) {  // c I_r turning exactly, (c^2 - c) I_r on the parent (massless)
        const T c = coupling(i);
        RigidInertia<T> parent_share = rotor_I_[i];
        for (int k = 0; k < 9; ++k) {
          rotor_I_[i].I[k] = c * rotor_I_[i].I[k];
          parent_share.I[k] = (c * c - c) * parent_share.I[k];
        }
        I_[parent] = I_[parent] + in_parent(rotor_X_[i], parent_share);
      }
      rotor_V_[i] = rotor_X_[i].apply(V_[parent]);
      rotor_V_[i].w = rotor_V_[i].w + scaled(axis_[i], motor_qd_[i]);
    }
  }
}

namespace {

// k where a is +-e_k, else -1.
int frame_axis(const Vec3<double>& a) {
  for (int k = 0; k < 3; ++k)
    if (std::abs(a[k]) == 1 && a[(k + 1) % 3] == 0 && a[(k + 2) % 3] == 0) return k;
  return -1;
}

}  // namespace

// The joint frame's rotation R_origin R_a(q) as turns: URDF's yaw, pitch and roll (R_origin = Rz
// Ry Rx; a zero angle left out), then the joint's turn about its axis (-e_k: by -q). A joint that
// turns about the axis of the origin's last turn takes it into its own angle (c c' - s s', ...).
template <class T>
std::vector<Turn<T>> Chain<T>::joint_turns(const Link& l, const Vec3<double>& a, const T& c,
                                           const T& s) const {
  std::vector<Turn<T>> turns;
  for (int k : {2, 1, 0})
    if (l.origin_rpy[k] != 0) {
      double c, s;
      cos_sin(l.origin_rpy[k], d_.exact_right_angles, c, s);
      turns.push_back({k, num(c), num(s), {}});
    }
  const int k = frame_axis(a);
  if (k < 0) {
    turns.push_back({-1, T{}, T{}, axis_rotation(a, c, s, [this](double x) { return num(x); })});
    return turns;
  }
  const T sk = a[k] > 0 ? s : -s;
  if (!turns.empty() && turns.back().k == k) {
    Turn<T>& o = turns.back();
    o = {k, o.c * c - o.s * sk, o.s * c + o.c * sk, {}};
  } else {
    turns.push_back({k, c, sk, {}});
  }
  return turns;
}

template <class T>
RigidInertia<T> Chain<T>::in_parent_of(int i, const RigidInertia<T>& I) const {
  RigidInertia<T> turned_I = I;
  for (auto t = turns_[i].rbegin(); t != turns_[i].rend(); ++t)
    turned_I = {turned_I.m, turned(*t, turned_I.h), turned(*t, turned_I.I)};
  return in_parent(shift(i), turned_I);
}

template <class T>
ArticulatedInertia<T> Chain<T>::in_parent_of(int i, const ArticulatedInertia<T>& I) const {
  ArticulatedInertia<T> turned_I = I;
  for (auto t = turns_[i].rbegin(); t != turns_[i].rend(); ++t)
    turned_I = {turned(*t, turned_I.A), turned(*t, turned_I.B), turned(*t, turned_I.C)};
  return in_parent(shift(i), turned_I);
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

// The composite-rigid-body algorithm (Featherstone, Algorithm 6.2): each joint's column as the
// force of its composite per unit rate, carried towards the base.
template <class T>
std::vector<T> Chain<T>::mass_matrix() const {
  const int nv = d_.nv(), nb = d_.num_base();
  std::vector<T> M(nv * nv, T{});
  auto set = [&](int a, int b, const T& x) { M[a * nv + b] = M[b * nv + a] = x; };
  const std::vector<RigidInertia<T>> Ic = composite_inertias();
  for (int i = n_; i >= 1; --i) {
    const int col = nb + i - 1;
    // Column i: link i's composite at S_i, and an exact rotor at its axis (on the parent) where
    // it turns on the slot; a flexible joint's rotor has a column of its own.
    Force<T> F = Ic[i] * S_[i];
    T Mii = power(F, S_[i]) + armature(i);
    Force<T> up = X_[i].apply_transpose(F);
    const Motion<T> Sr = {axis_[i], zero3()};
    if (exact_rotor(i) && !flexible(i)) {
      const Force<T> Fr = rotor_I_[i] * Sr;
      Mii += power(Fr, Sr);
      up = up + rotor_X_[i].apply_transpose(Fr);
    }
    M[col * nv + col] = Mii;
    fill_column(M, col, i, up);
    if (!flexible(i)) continue;
    const int m = motor_[i];
    if (!exact_rotor(i)) {
      M[m * nv + m] = motor_armature(i);
      continue;
    }
    const Force<T> Fr = rotor_I_[i] * Sr;
    M[m * nv + m] = power(Fr, Sr);
    fill_column(M, m, i, rotor_X_[i].apply_transpose(Fr));
  }
  for (int k = 0; k < nb; ++k) {
    const Force<T> F = Ic[0] * base_unit(k);
    for (int l = k; l < nb; ++l) set(k, l, power(F, base_unit(l)));
  }
  return M;
}

template <class T>
void Chain<T>::fill_column(std::vector<T>& M, int col, int i, Force<T> up) const {
  const int nv = d_.nv(), nb = d_.num_base();
  auto set = [&](int a, int b, const T& x) { M[a * nv + b] = M[b * nv + a] = x; };
  for (int j = parent_[i]; j >= 1; j = parent_[j]) {
    set(nb + j - 1, col, power(up, S_[j]));
    up = X_[j].apply_transpose(up);
  }
  for (int k = 0; k < nb; ++k) set(k, col, power(up, base_unit(k)));
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
    A[i] = joint_acceleration(X_[i], A[parent_[i]], V_[i], S_[i], vdot[col], qd_[i]);
    F[i] = I_[i] * A[i] + cross_force(V_[i], I_[i] * V_[i]);
    Q[col] = vdot[col] * armature(i);
    if (flexible(i) && !exact_rotor(i)) Q[motor_[i]] = vdot[motor_[i]] * motor_armature(i);
    if (exact_rotor(i)) {
      const Motion<T> S = {axis_[i], zero3()};
      const Motion<T> Ar = joint_acceleration(rotor_X_[i], A[parent_[i]], rotor_V_[i], S,
                                              vdot[motor_[i]], motor_qd_[i]);
      rotor_F[i] = rotor_I_[i] * Ar + cross_force(rotor_V_[i], rotor_I_[i] * rotor_V_[i]);
    }
  }
  // Backward: each joint's share, the rest to the parent.
  for (int i = n_; i >= 1; --i) {
    const int col = nb + i - 1;
    Q[col] += power(F[i], S_[i]);
    const int parent = parent_[i];
    F[parent] = F[parent] + X_[i].apply_transpose(F[i]);
    if (exact_rotor(i)) {
      Q[motor_[i]] += dot(axis_[i], rotor_F[i].n);
      F[parent] = F[parent] + rotor_X_[i].apply_transpose(rotor_F[i]);
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

// The bodies' composite inertias (each with everything it carries; an exact rotor with the body
// it sits on), about their origins in their frames.
template <class T>
std::vector<RigidInertia<T>> Chain<T>::composite_inertias() const {
  std::vector<RigidInertia<T>> Ic = I_;
  for (int i = n_; i >= 1; --i) {
    const int parent = parent_[i];
    if (parent == 0 && !d_.free_base) continue;  // a fixed base carries no coordinate
    Ic[parent] = Ic[parent] + in_parent_of(i, Ic[i]);
    if (exact_rotor(i)) Ic[parent] = Ic[parent] + in_parent(rotor_X_[i], rotor_I_[i]);
  }
  return Ic;
}

// M_ii alone, from the composite inertias: the base's total mass (its linear rows) and
// rotational inertia about its origin; each joint's S^T Ic S with its rotor's axial inertia.
template <class T>
std::vector<T> Chain<T>::mass_matrix_diagonal() const {
  const std::vector<RigidInertia<T>> Ic = composite_inertias();
  const int nb = d_.num_base();
  std::vector<T> diagonal(d_.nv());
  for (int k = 0; k < nb; ++k) diagonal[k] = k < 3 ? Ic[0].m : Ic[0].I[4 * (k - 3)];
  for (int i = 1; i <= n_; ++i) {
    diagonal[nb + i - 1] =
        power(Ic[i] * S_[i], S_[i]) + (exact_rotor(i) && !flexible(i) ? axial(i) : armature(i));
    if (flexible(i)) diagonal[motor_[i]] = axial(i);
  }
  return diagonal;
}

namespace {

// A x = b for each column b of B (A symmetric positive definite, n x n row-major, its lower
// triangle read; B n x m), by LDL^T without pivoting and one division per pivot D_j (written to
// pivots where given). The chain's small dense solves: the free base's 6 x 6, M_bb.
template <class T>
std::vector<T> ldlt_solve(const std::vector<T>& A, int n, std::vector<T> B, int m, const T& one,
                          T* pivots = nullptr) {
  std::vector<T> L(n * n), D(n), inverse(n);
  for (int j = 0; j < n; ++j) {
    T d = A[j * n + j];
    for (int k = 0; k < j; ++k) d -= L[j * n + k] * L[j * n + k] * D[k];
    D[j] = d;
    inverse[j] = one / d;
    if (pivots) pivots[j] = d;
    for (int i = j + 1; i < n; ++i) {
      T e = A[i * n + j];
      for (int k = 0; k < j; ++k) e -= L[i * n + k] * L[j * n + k] * D[k];
      L[i * n + j] = e * inverse[j];
    }
  }
  for (int c = 0; c < m; ++c) {
    for (int i = 0; i < n; ++i)
      for (int k = 0; k < i; ++k) B[i * m + c] -= L[i * n + k] * B[k * m + c];
    for (int i = n - 1; i >= 0; --i) {
      B[i * m + c] = B[i * m + c] * inverse[i];
      for (int k = i + 1; k < n; ++k) B[i * m + c] -= L[k * n + i] * B[k * m + c];
    }
  }
  return B;
}

// The rows x cols block of a row-major matrix with n columns at (r0, c0), row-major.
template <class T>
std::vector<T> block(const std::vector<T>& M, int n, int r0, int c0, int rows, int cols) {
  std::vector<T> b;
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) b.push_back(M[(r0 + r) * n + c0 + c]);
  return b;
}

// I^A a = rhs for the free base's 6 x 6 articulated inertia, in the order (linear, angular) of
// its own frame; its pivots are those of M with the base's linear rows turned into that frame
// (an orthogonal change of basis: their signs, and M_ii, are unchanged).
template <class T>
Motion<T> solve_base(const ArticulatedInertia<T>& I, const Force<T>& rhs, const T& one, T* pivots) {
  std::vector<T> A(36);  // the lower triangle
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 3; ++k) {
      A[6 * r + k] = I.C[3 * r + k];
      A[6 * (3 + r) + k] = I.B[3 * r + k];
      A[6 * (3 + r) + 3 + k] = I.A[3 * r + k];
    }
  const std::vector<T> x = ldlt_solve(
      A, 6, {rhs.f[0], rhs.f[1], rhs.f[2], rhs.n[0], rhs.n[1], rhs.n[2]}, 1, one, pivots);
  return {{x[3], x[4], x[5]}, {x[0], x[1], x[2]}};
}

}  // namespace

// An exact rotor's share of joint i's articulated step, in link i's frame: the rotor is symmetric
// about the joint axis a through the joint's origin, so its inertia there is the same as in its
// own frame, and it turns with the link's parent at omega' (link i's frame) plus a qd_m. With the
// link it is one cluster on the coordinate (Featherstone ch. 7 for a joint moving two bodies):
// U gains I_r a, D gains a . I_r a, the inertia passed on gains I_r, the bias gains the rotor's
// omega_r x I_r omega_r + I_r (omega' x a) qd_m. Its bias along a, a . (omega_r x I_r omega_r), and
// U_r . c_r = a . I_r (omega' x a) qd_m vanish for a rotor symmetric about a.
template <class T>
void Chain<T>::add_rotor(int i, ArticulatedInertia<T>& Ia, Force<T>& U, T& D, Force<T>& pa) const {
  const Mat3<T>& Ir = rotor_I_[i].I;
  const Vec3<T>& a = axis_[i];
  U.n = U.n + scaled(a, rotor_ratio_times_axial(i, 1));  // I_r a = J a, per unit link rate p a
  D += rotor_ratio_times_axial(i, 2);
  pa.n = pa.n + rotor_bias(i);
  for (int k = 0; k < 9; ++k) Ia.A[k] += Ir[k];
}

// With I_r = t (1 - a a^T) + J a a^T and omega_r = omega' + a qd_m, the bias's
// omega_r x I_r omega_r + I_r (omega' x a) qd_m is (omega' x a) ((J - t) a . omega' + J qd_m).
template <class T>
Vec3<T> Chain<T>::rotor_bias(int i) const {
  const Vec3<T>& a = axis_[i];
  const Vec3<T>& w_parent = parent_w_[i];
  const Gear& g = d_.links[i - 1].gear;
  T J = axial(i), t = value(g.transverse);
  if (coupled(i)) J = coupling(i) * J, t = coupling(i) * t;  // the exact rotor's share
  return scaled(cross(w_parent, a), (J - t) * dot(a, w_parent) + J * motor_qd_[i]);
}

// A flexible joint's rotor is a body of its own on the parent, on its own coordinate (S_r =
// (a, 0), U_r = (J a, 0), D_r = J): eliminated, it passes on I_r - U_r U_r^T / D_r = t (1 - a a^T)
// and p_r + I^a_r c_r + U_r u_r / D_r = rotor_bias + a Q_m, with u_r = Q_m (a . p_r and U_r . c_r
// vanish for a rotor symmetric about a). Both are unchanged by the joint's turn about a, so they
// are written in link i's frame and carried to the parent with the link's.
template <class T>
void Chain<T>::add_leaf_rotor(int i, const T& Q_m, ArticulatedInertia<T>& reduced,
                              Force<T>& pa) const {
  const Gear& g = d_.links[i - 1].gear;
  const Vec3<double> a = unit_axis(d_.links[i - 1], i);
  const Mat3<T> transverse = !g.transverse.is_parameter()
                                 ? num(rotor_tensor(g.transverse.value, 0.0, a))
                                 : rotor_tensor(value(g.transverse), T{}, a);
  for (int k = 0; k < 9; ++k) reduced.A[k] += transverse[k];
  pa.n = pa.n + rotor_bias(i) + scaled(axis_[i], Q_m);
}

template <class T>
std::vector<T> Chain<T>::friction_forces() const {
  using std::exp;
  using std::tanh;
  std::vector<T> f(nv(), T{});
  for (int i = 1; i <= n_; ++i) {
    const Friction& fr = d_.links[i - 1].friction;
    if (!fr.present) continue;
    const T w = motor_qd_[i];
    std::vector<T> terms;  // only the terms present: no recorded 0 * w
    if (fr.viscous.value != 0 || fr.viscous.is_parameter()) terms.push_back(value(fr.viscous) * w);
    if (fr.has_coulomb) {
      const T sign = tanh(w * inverse(fr.velocity_scale));
      const T Fc = value(fr.coulomb);
      if (fr.coulomb.value != 0 || fr.coulomb.is_parameter()) terms.push_back(Fc * sign);
      if (fr.has_stribeck) {
        const T r = w * inverse(fr.stribeck_velocity);
        const T hump = !fr.stribeck_static.is_parameter() && !fr.coulomb.is_parameter()
                           ? num(fr.stribeck_static.value - fr.coulomb.value)
                           : value(fr.stribeck_static) - Fc;
        terms.push_back(hump * exp(-(r * r)) * sign);
      }
    }
    if (terms.empty()) continue;
    T force = terms[0];
    for (size_t k = 1; k < terms.size(); ++k) force = force + terms[k];
    f[motor_[i]] = force;
  }
  return f;
}

template <class T>
T Chain<T>::deflection(int i, const std::string& array) const {
  const Gear& g = d_.links[i - 1].gear;
  auto at = [&](int v) { return values_.input(array, array == "q" ? d_.q_index(v) : v); };
  return at(motor_[i]) * inverse(g.ratio) - at(d_.joint_coordinate(i - 1));
}

// The spring pulls the link towards the gear's output and the motor back (both on the link side,
// so the motor's share is 1 / p of it), as in the plane (planar_chain.cpp).
template <class T>
std::vector<T> Chain<T>::spring_damper_forces() const {
  std::vector<T> f(nv(), T{});
  for (int i = 1; i <= n_; ++i) {
    if (!flexible(i)) continue;
    const Gear& g = d_.links[i - 1].gear;
    T force = value(g.stiffness) * deflection(i, "q");
    if (g.has_damping) force = force + value(g.damping) * deflection(i, "qd");
    f[d_.joint_coordinate(i - 1)] = -force;
    f[motor_[i]] = force * inverse(g.ratio);
  }
  return f;
}

template <class T>
T Chain<T>::potential_energy() const {
  T twice{};
  for (int i = 1; i <= n_; ++i) {
    if (!flexible(i)) continue;
    const Gear& g = d_.links[i - 1].gear;
    const T e = deflection(i, "q");
    twice = twice + value(g.stiffness) * e * e;
  }
  return twice * 0.5;
}

template <class T>
std::vector<T> Chain<T>::turned_about_base_axis(int k, const std::vector<T>& u) const {
  const Mat3<T>& R = R_[0];
  const Vec3<T> w = cross(Vec3<T>{R[k], R[3 + k], R[6 + k]}, Vec3<T>{u[0], u[1], u[2]});
  return {w[0], w[1], w[2]};
}

template <class T>
std::vector<T> Chain<T>::passive_forces() const {
  std::vector<T> f = friction_forces();
  if (d_.num_flexible() == 0) return f;
  const std::vector<T> springs = spring_damper_forces();
  for (int k = 0; k < nv(); ++k) f[k] = f[k] + springs[k];  // a recorded 0 folds away
  return f;
}

// The articulated-body algorithm (Featherstone, Algorithm 7.1) with the free base's 6 x 6 solve
// (his Table 9.6): from the tip, each joint's U = I^A S, D = S^T U and u, the reduced inertia
// and bias passed to the parent; the base's acceleration from I^A_0 a_0 = f_0 - p^A_0; then each
// joint's qdd outward. Its pivots: each joint's D (tip first), then the base's six.
template <class T>
std::vector<std::vector<T>> Chain<T>::forward_dynamics(const std::vector<T>& Q) const {
  const int nv = d_.nv(), nb = d_.num_base();
  if (static_cast<int>(Q.size()) != nv)
    throw std::invalid_argument("spatial chain: Q needs " + std::to_string(nv) + " values");
  const std::vector<T> passive = passive_forces();
  std::vector<ArticulatedInertia<T>> IA;
  std::vector<Force<T>> pA, U(n_ + 1);
  std::vector<Motion<T>> c(n_ + 1);
  std::vector<T> D(n_ + 1), inverse_D(n_ + 1), u(n_ + 1), qdd(nv), pivots(nv), Q_motor(n_ + 1);
  for (int b = 0; b <= n_; ++b) {
    IA.emplace_back(I_[b]);
    pA.push_back(cross_force(V_[b], I_[b] * V_[b]));
  }
  // Backward, per unit link rate (S = (a, 0): U a column of I^A, no 1 / p), so D, U and u are
  // p^2, p and p times the motor coordinate's: u = p Q - S^T p^A - U^T c (c the velocity
  // product, as a' = X a_parent + c).
  for (int i = n_; i >= 1; --i) {
    const int col = nb + i - 1;
    const Motion<T> S = {axis_[i], zero3()};
    c[i] = scaled(cross_motion(V_[i], S_[i]), qd_[i]);
    U[i] = IA[i] * S;
    D[i] = power(U[i], S) + armature_per_link_rate(i);
    u[i] = (Q[col] - passive[col]) * ratio(i) - power(pA[i], S) - power(U[i], c[i]);
    Force<T> pa = pA[i] + IA[i] * c[i];
    ArticulatedInertia<T> Ia = IA[i];
    if (exact_rotor(i) && !flexible(i)) add_rotor(i, Ia, U[i], D[i], pa);
    pivots[col] = D[i] * over_ratio(i, 1.0, 2);
    inverse_D[i] = num(1.0) / D[i];
    if (flexible(i)) {  // the rotor's coordinate: its net force and pivot J
      Q_motor[i] = Q[motor_[i]] - passive[motor_[i]];
      pivots[motor_[i]] = axial(i);
    }
    if (parent_[i] == 0 && !d_.free_base) continue;  // a fixed base takes nothing
    const Force<T> W = scaled(U[i], inverse_D[i]);
    ArticulatedInertia<T> reduced = Ia.minus_outer(U[i], W);
    // Without a gear on the slot, I^A - U U^T / D takes S to zero (U = I^A S, D = S^T U): row and
    // column k of A and row k of B for an axis +-e_k are zero, not rounding left over.
    const int k = turns_[i].back().k;  // the joint's own turn (-1: not about a frame axis)
    if (!slot_gear(i) && k >= 0)
      for (int m = 0; m < 3; ++m)
        reduced.A[3 * k + m] = reduced.A[3 * m + k] = reduced.B[3 * k + m] = T{};
    Force<T> passed = pa + scaled(W, u[i]);
    if (flexible(i) && exact_rotor(i)) add_leaf_rotor(i, Q_motor[i], reduced, passed);
    IA[parent_[i]] = IA[parent_[i]] + in_parent_of(i, reduced);
    pA[parent_[i]] = pA[parent_[i]] + X_[i].apply_transpose(passed);
  }
  // The base: f_0 in its frame is (n, R^T f_world); a_0 = (omega_dot, R^T vdot - omega x v).
  std::vector<Motion<T>> acceleration(n_ + 1, zero_motion());  // each body's, in its frame
  Motion<T>& a = acceleration[0];
  if (d_.free_base) {
    const Force<T> f0 = {
        Vec3<T>{Q[3] - passive[3], Q[4] - passive[4], Q[5] - passive[5]},
        transposed_times(R_[0], Vec3<T>{Q[0] - passive[0], Q[1] - passive[1], Q[2] - passive[2]})};
    a = solve_base(IA[0], {f0.n - pA[0].n, f0.f - pA[0].f}, num(1.0), pivots.data());
    const Vec3<T> linear = times(R_[0], a.v + cross(V_[0].w, V_[0].v));
    for (int k = 0; k < 3; ++k) qdd[k] = linear[k], qdd[3 + k] = a.w[k];
  }
  // Forward: the link's acceleration (u - U^T X a_parent) / D, a = X a_parent + c + S qdd, and
  // the motor's p times it.
  for (int i = 1; i <= n_; ++i) {
    const Motion<T> ap = X_[i].apply(acceleration[parent_[i]]);
    const T link = (u[i] - power(U[i], ap)) * inverse_D[i];
    qdd[nb + i - 1] = link * ratio(i);
    // A flexible joint's rotor: J (a . alpha_parent + qdd_m) = Q_m (armature: J qdd_m = Q_m).
    if (flexible(i)) {
      const Gear& g = d_.links[i - 1].gear;
      qdd[motor_[i]] = Q_motor[i] * inverse(g.axial);
      if (exact_rotor(i)) qdd[motor_[i]] = qdd[motor_[i]] - dot(axis_[i], ap.w);
    }
    Motion<T>& ai = acceleration[i];
    ai = ap + c[i];
    ai.w = ai.w + scaled(axis_[i], link);
  }
  const std::vector<T> diagonal = mass_matrix_diagonal();
  std::vector<T> scaled_pivots(nv);
  for (int k = 0; k < nv; ++k) scaled_pivots[k] = pivots[k] / diagonal[k];
  return {qdd, pivots, scaled_pivots};
}

// J* = J_m - J_b X with M_bb X = M_bm (Umetani and Yoshida): with M_bb v_b + M_bm qd = 0 the
// momentum is zero, and the end effector's twist is J_b v_b + J_m qd.
template <class T>
std::vector<T> Chain<T>::generalized_jacobian() const {
  if (!d_.free_base) throw std::logic_error("spatial chain: generalized Jacobian of a fixed base");
  if (d_.num_flexible() > 0)
    throw std::logic_error("spatial chain: generalized Jacobian with flexible joints");
  const int nv = d_.nv(), N = n_, rows = 6 * d_.num_end_effectors();
  const std::vector<T> M = mass_matrix(), J = end_effector_jacobian();
  const std::vector<T> X =
      ldlt_solve(block(M, nv, 0, 0, 6, 6), 6, block(M, nv, 0, 6, 6, N), N, num(1.0));
  std::vector<T> Jg(rows * N);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < N; ++c) {
      T x = J[r * nv + 6 + c];
      for (int k = 0; k < 6; ++k) x -= J[r * nv + k] * X[k * N + c];
      Jg[r * N + c] = x;
    }
  return Jg;
}

// M_bb a_b = -(M_bm a + b_b) with a = p qdd_joints (the motors'); tau = p (M_mb a_b + M_mm a +
// b_m).
template <class T>
std::vector<std::vector<T>> Chain<T>::free_base_inverse_dynamics(
    const std::vector<T>& qdd_joints) const {
  if (!d_.free_base)
    throw std::logic_error("spatial chain: free-base inverse dynamics of a fixed base");
  if (d_.num_flexible() > 0)
    throw std::logic_error("spatial chain: free-base inverse dynamics with flexible joints");
  const int nv = d_.nv(), N = n_;
  const std::vector<T> M = mass_matrix(), b = inverse_dynamics(std::vector<T>(nv, T{}));
  std::vector<T> a(N), rhs(6);
  for (int j = 0; j < N; ++j) a[j] = qdd_joints[j] * ratio(j + 1);
  for (int r = 0; r < 6; ++r) {
    T x = b[r];
    for (int c = 0; c < N; ++c) x += M[r * nv + 6 + c] * a[c];
    rhs[r] = -x;
  }
  const std::vector<T> base = ldlt_solve(block(M, nv, 0, 0, 6, 6), 6, rhs, 1, num(1.0));
  std::vector<T> tau(N);
  for (int j = 0; j < N; ++j) {
    T Q = b[6 + j];
    for (int k = 0; k < 6; ++k) Q += M[(6 + j) * nv + k] * base[k];
    for (int c = 0; c < N; ++c) Q += M[(6 + j) * nv + 6 + c] * a[c];
    tau[j] = Q * ratio(j + 1);
  }
  return {tau, base};
}

template <class T>
T Chain<T>::kinetic_energy() const {
  T twice{};
  for (int b = first_body(); b <= n_; ++b) twice += power(I_[b] * V_[b], V_[b]);
  for (int i = 1; i <= n_; ++i) {
    if (exact_rotor(i)) twice += power(rotor_I_[i] * rotor_V_[i], rotor_V_[i]);
    twice += qd_[i] * qd_[i] * armature(i);
    if (flexible(i) && !exact_rotor(i)) twice += motor_qd_[i] * motor_qd_[i] * motor_armature(i);
  }
  return twice * 0.5;
}

// M v from the bodies' momenta: each body's I V, carried to the base by the transposed
// transforms and read along each joint's axis (and the base's six directions).
template <class T>
std::vector<T> Chain<T>::generalized_momentum() const {
  const int nv = d_.nv(), nb = d_.num_base();
  std::vector<T> p(nv, T{});
  // carried[b]: the momenta of what body b carries, in its frame (its children's first, its own
  // added last, the order a chain's recording has always had).
  std::vector<Force<T>> carried(n_ + 1, {zero3(), zero3()});
  std::vector<bool> has_carried(n_ + 1, false);
  for (int i = n_; i >= 1; --i) {
    const int col = nb + i - 1;
    carried[i] = carried[i] + I_[i] * V_[i];
    p[col] = power(carried[i], S_[i]) + qd_[i] * armature(i);
    if (flexible(i) && !exact_rotor(i)) p[motor_[i]] = motor_qd_[i] * motor_armature(i);
    Force<T> up = X_[i].apply_transpose(carried[i]);
    if (exact_rotor(i)) {  // the rotor's momentum, in the parent's frame
      const Force<T> h = rotor_I_[i] * rotor_V_[i];
      p[motor_[i]] += dot(axis_[i], h.n);
      up = up + rotor_X_[i].apply_transpose(h);
    }
    const int parent = parent_[i];
    carried[parent] = has_carried[parent] ? carried[parent] + up : up;
    has_carried[parent] = true;
  }
  if (d_.free_base) {
    carried[0] = carried[0] + I_[0] * V_[0];
    for (int k = 0; k < nb; ++k) p[k] = power(carried[0], base_unit(k));
  }
  return p;
}

template <class T>
std::vector<T> Chain<T>::hamel_coupling(const std::vector<T>& M) const {
  const int nv = d_.nv();
  std::vector<T> H(nv * nv, T{});
  if (!d_.free_base) return H;
  const Vec3<T>& w = V_[0].w;
  for (int c = 0; c < nv; ++c) {  // rows 3..5: omega x (column c of M's angular rows)
    const Vec3<T> m = {M[3 * nv + c], M[4 * nv + c], M[5 * nv + c]}, h = cross(w, m);
    for (int k = 0; k < 3; ++k) H[(3 + k) * nv + c] = h[k];
  }
  return H;
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
      add(rotor_I_[i] * rotor_V_[i], product(R_[parent_[i]], transposed(rotor_X_[i].E)), p_[i]);
  return h;
}

template <class T>
std::vector<int> Chain<T>::path_to(int b) const {
  std::vector<int> path;
  for (int i = b; i >= 1; i = parent_[i]) path.push_back(i);
  std::reverse(path.begin(), path.end());
  return path;
}

template <class T>
Vec3<T> Chain<T>::end_effector_point(int e) const {
  const int b = d_.end_effector_body(e);
  return p_[b] + times(R_[b], num(d_.end_effectors[e].xyz));
}

template <class T>
std::vector<T> Chain<T>::end_effector_pose() const {
  std::vector<T> poses;
  const int jq = d_.free_base ? 7 : 0;
  for (int e = 0; e < d_.num_end_effectors(); ++e) {
    const Vec3<T> tip = end_effector_point(e);
    Quaternion<T> q = {num(1.0), T{}, T{}, T{}};
    if (d_.free_base)
      q = {values_.input("q", 3), values_.input("q", 4), values_.input("q", 5),
           values_.input("q", 6)};
    for (int i : path_to(d_.end_effector_body(e))) {
      const Link& l = d_.links[i - 1];
      const Quaternion<double> o = rpy_quaternion(l.origin_rpy);
      const T qi = values_.input("q", jq + i - 1), half = qi * over_ratio(i, 0.5);
      const T s = sin(half);
      q = q * Quaternion<T>{num(o[0]), num(o[1]), num(o[2]), num(o[3])} *
          Quaternion<T>{cos(half), s * axis_[i][0], s * axis_[i][1], s * axis_[i][2]};
    }
    const std::array<double, 3>& rpy = d_.end_effectors[e].rpy;
    if (rpy != std::array<double, 3>{}) {  // a welded end-effector frame's rotation
      const Quaternion<double> t = rpy_quaternion(rpy);
      q = q * Quaternion<T>{num(t[0]), num(t[1]), num(t[2]), num(t[3])};
    }
    poses.insert(poses.end(), {tip[0], tip[1], tip[2], q[0], q[1], q[2], q[3]});
  }
  return poses;
}

template <class T>
std::vector<T> Chain<T>::joint_angles() const {
  std::vector<T> angles;
  const int jq = d_.free_base ? 7 : 0;
  for (int i = 1; i <= n_; ++i)
    angles.push_back(values_.input("q", jq + i - 1) * over_ratio(i, 1.0));
  return angles;
}

template <class T>
std::vector<T> Chain<T>::joint_rates() const {
  std::vector<T> rates;
  for (int i = 1; i <= n_; ++i) rates.push_back(qd_[i] * over_ratio(i, 1.0));
  return rates;
}

template <class T>
std::vector<T> Chain<T>::joint_positions() const {
  const int E = d_.num_end_effectors(), cols = n_ + E;
  std::vector<T> P(3 * cols);
  std::vector<Vec3<T>> tips;
  for (int e = 0; e < E; ++e) tips.push_back(end_effector_point(e));
  for (int k = 0; k < 3; ++k) {
    for (int i = 1; i <= n_; ++i) P[k * cols + i - 1] = p_[i][k];
    for (int e = 0; e < E; ++e) P[k * cols + n_ + e] = tips[e][k];
  }
  return P;
}

template <class T>
std::vector<T> Chain<T>::body_frames() const {
  std::vector<T> frames;
  for (int b = 0; b <= n_; ++b) {
    frames.insert(frames.end(), p_[b].begin(), p_[b].end());
    frames.insert(frames.end(), R_[b].begin(), R_[b].end());
  }
  return frames;
}

template <class T>
std::vector<T> Chain<T>::end_effector_jacobian() const {
  const int nv = d_.nv(), nb = d_.num_base();
  std::vector<T> J(6 * nv * d_.num_end_effectors(), T{});
  for (int ee = 0; ee < d_.num_end_effectors(); ++ee) {
    const Vec3<T> tip = end_effector_point(ee);
    const int row = 6 * ee;
    auto column = [&](int c, const Vec3<T>& linear, const Vec3<T>& angular) {
      for (int k = 0; k < 3; ++k) {
        J[(row + k) * nv + c] = linear[k];
        J[(row + 3 + k) * nv + c] = angular[k];
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
    // Each joint from the root turns everything after it about its world axis, at qd_m / p.
    for (int i : path_to(d_.end_effector_body(ee))) {
      const Vec3<T> w = times(R_[i], S_[i].w);
      column(nb + i - 1, cross(w, tip - p_[i]), w);
    }
  }
  return J;
}

template class Chain<double>;
template class Chain<Dual<double>>;
template class Chain<Sym>;
template class Chain<Dual<Sym>>;

}  // namespace spacearm::spatial
