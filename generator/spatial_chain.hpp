// A serial chain of revolute joints in space on a base that floats in all six degrees of freedom
// (or is fixed): forward kinematics, body velocities, the mass matrix (CRBA), recursive
// Newton-Euler, forward dynamics, kinetic energy, momentum and the end effector, written once
// over the scalar (double, and recorded_scalar.hpp's Sym and duals, as planar_chain.cpp is).
// Spatial algebra in body coordinates as Featherstone writes it (Rigid Body Dynamics Algorithms,
// 2008, ch. 2): a motion is (omega, v), a force (n, f), a transform from a parent frame to a child
// frame is (E, r).
//
// The free base follows MuJoCo's free joint, so a state passes between the two unconverted:
// q = [base origin in the world (3), unit quaternion w, x, y, z (4), joint angles],
// v = [velocity of the base origin in the world (3), angular velocity in the base frame (3),
// joint rates]; nq = nv + 1. Geared joints use motor angles qm = p q, their rotors exactly
// coupled or as armature (Gear).
#pragma once

#include <array>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "outputs.hpp"
#include "recorded_scalar.hpp"

namespace spacearm::spatial {

using spacearm::Dimensions;
using spacearm::Values;

// A number of the model may be a run-time parameter: its index in `params` beside it (-1: the
// number itself, a literal); the number is then the parameter's nominal value (what the scene's
// checks use). The chain reads the parameter, never the nominal value.
constexpr int kLiteral = -1;

// A joint's gear: a motor whose rotor turns at p times the joint's rate relative to the parent
// link, so the joint's coordinate is the motor angle qm = p q (eq. 12 in the plane) and its
// generalized force tau / p. The rotor is a body of revolution about the joint axis through
// the joint's origin (its mass belongs to the parent link's inertial). Exact coupling carries
// it on the parent, turning at omega_parent + qd_m a (its gyroscopic torques and angular
// momentum included); armature keeps only the axial inertia on the motor coordinate (MuJoCo's,
// Drake's and Pinocchio's model).
// A flexible joint (Spong's model, as in the plane) has a torsional spring of stiffness k and a
// damper d between the gear's output qm / p and the link angle q: its slot then holds q, and the
// motor angle qm a coordinate of its own after all the joints (ChainDescription::motor_coordinate).
struct Gear {
  bool present = false;
  double ratio = 1;
  double axial = 0, transverse = 0;  // the rotor's inertia about its axis and across it
  bool exact = true;
  int ratio_param = kLiteral, axial_param = kLiteral, transverse_param = kLiteral;
  bool flexible = false, has_damping = false;
  double stiffness = 0, damping = 0;
  int stiffness_param = kLiteral, damping_param = kLiteral;
};

// Friction on a joint's coordinate rate w (the motor's, qd_m, for a geared joint), opposing
// motion, as in the plane (scene.hpp's Friction): f(w) = b w + Fc tanh(w/vs)
// + (Fs - Fc) exp(-(w/vst)^2) tanh(w/vs). Each value a literal or a run-time parameter.
struct Friction {
  bool present = false;
  double viscous = 0, coulomb = 0, velocity_scale = 1, stribeck_static = 0, stribeck_velocity = 1;
  bool has_coulomb = false, has_stribeck = false;  // terms present (a parameter, or not 0)
  int viscous_param = kLiteral, coulomb_param = kLiteral, velocity_scale_param = kLiteral,
      stribeck_static_param = kLiteral, stribeck_velocity_param = kLiteral;
};

// A body's mass, centre of mass and inertia about it (ixx, ixy, ixz, iyy, iyz, izz), in its
// frame, each a literal or a run-time parameter.
struct Inertial {
  double mass = 0;
  std::array<double, 3> com{};
  std::array<double, 6> inertia{};
  int mass_param = kLiteral;
  std::array<int, 3> com_param{kLiteral, kLiteral, kLiteral};
  std::array<int, 6> inertia_param{kLiteral, kLiteral, kLiteral, kLiteral, kLiteral, kLiteral};
  bool uses_parameter() const;
};

// A body welded to a link at a fixed frame (its origin xyz and rpy in the link's frame): a
// URDF link whose inertial a scene gives (a parameter cannot be lumped in numbers).
struct Part {
  std::array<double, 3> xyz{}, rpy{};
  Inertial inertial;
};

// One link and the revolute joint that carries it (URDF's joint origin and axis; the link's
// inertial about its centre of mass, in the link frame), with the parts welded to it.
struct Link : Inertial {
  std::array<double, 3> origin_xyz{}, origin_rpy{};  // the joint frame in the parent link's
  std::array<double, 3> axis{1, 0, 0};               // unit, in the joint frame
  std::vector<Part> parts;
  Gear gear;
  Friction friction;
};

// The base (the root link, the satellite) and the links after it, each the child of the one
// before (a serial chain: branching is refused where chains are read).
struct ChainDescription {
  bool free_base = true;
  Link base;  // its mass, com and inertia; its origin and axis are unused
  std::vector<Link> links;
  std::array<double, 3> tip{};      // the end effector's point, in the last link's frame
  std::array<double, 3> tip_rpy{};  // its frame's orientation there (a welded URDF link's)
  int num_base() const { return free_base ? 6 : 0; }
  // The one place that lays out the velocities: the base's, one slot per joint (its link angle's
  // rate, or a rigid gear's motor rate), then the motor of each flexible joint; nq = nv + 1 with
  // a free base's quaternion.
  int num_flexible() const {
    int count = 0;
    for (const Link& l : links) count += l.gear.present && l.gear.flexible;
    return count;
  }
  int nv() const { return num_base() + static_cast<int>(links.size()) + num_flexible(); }
  int nq() const { return nv() + (free_base ? 1 : 0); }
  // The velocity index of joint j's slot (0-based j) and of the coordinate its torque drives
  // (as tau / p) and friction brakes: the slot, or a flexible joint's motor coordinate.
  int joint_coordinate(int j) const { return num_base() + j; }
  int motor_coordinate(int j) const {
    const Gear& g = links.at(j).gear;
    if (!(g.present && g.flexible)) return joint_coordinate(j);
    int before = 0;
    for (int k = 0; k < j; ++k) before += links[k].gear.present && links[k].gear.flexible;
    return num_base() + static_cast<int>(links.size()) + before;
  }
  // The index in q of velocity index v (past a free base's quaternion: v + 1).
  int q_index(int v) const { return free_base && v >= 6 ? v + 1 : v; }
};

template <class T>
using Vec3 = std::array<T, 3>;
// Row-major 3 x 3.
template <class T>
using Mat3 = std::array<T, 9>;

template <class T>
Vec3<T> operator+(const Vec3<T>& a, const Vec3<T>& b) {
  return {a[0] + b[0], a[1] + b[1], a[2] + b[2]};
}
template <class T>
Vec3<T> operator-(const Vec3<T>& a, const Vec3<T>& b) {
  return {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
}
template <class T, class K>
Vec3<T> scaled(const Vec3<T>& a, const K& k) {
  return {a[0] * k, a[1] * k, a[2] * k};
}
template <class T>
T dot(const Vec3<T>& a, const Vec3<T>& b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
template <class T>
Vec3<T> cross(const Vec3<T>& a, const Vec3<T>& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
template <class T>
Vec3<T> times(const Mat3<T>& A, const Vec3<T>& x) {  // A x
  return {A[0] * x[0] + A[1] * x[1] + A[2] * x[2], A[3] * x[0] + A[4] * x[1] + A[5] * x[2],
          A[6] * x[0] + A[7] * x[1] + A[8] * x[2]};
}
template <class T>
Vec3<T> transposed_times(const Mat3<T>& A, const Vec3<T>& x) {  // A^T x
  return {A[0] * x[0] + A[3] * x[1] + A[6] * x[2], A[1] * x[0] + A[4] * x[1] + A[7] * x[2],
          A[2] * x[0] + A[5] * x[1] + A[8] * x[2]};
}
template <class T>
Mat3<T> transposed(const Mat3<T>& A) {
  return {A[0], A[3], A[6], A[1], A[4], A[7], A[2], A[5], A[8]};
}
template <class T>
Mat3<T> product(const Mat3<T>& A, const Mat3<T>& B) {  // A B
  Mat3<T> C;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      C[3 * i + j] = A[3 * i] * B[j] + A[3 * i + 1] * B[3 + j] + A[3 * i + 2] * B[6 + j];
  return C;
}

template <class T>
struct Motion {
  Vec3<T> w, v;  // angular, linear (of the frame's origin)
};
template <class T>
struct Force {
  Vec3<T> n, f;  // moment about the frame's origin, force
};
template <class T>
Force<T> operator+(const Force<T>& a, const Force<T>& b) {
  return {a.n + b.n, a.f + b.f};
}
template <class T>
Motion<T> operator+(const Motion<T>& a, const Motion<T>& b) {
  return {a.w + b.w, a.v + b.v};
}
template <class T>
Motion<T> scaled(const Motion<T>& m, const T& k) {
  return {scaled(m.w, k), scaled(m.v, k)};
}
template <class T>
Force<T> scaled(const Force<T>& F, const T& k) {
  return {scaled(F.n, k), scaled(F.f, k)};
}
template <class T>
T power(const Force<T>& F, const Motion<T>& V) {
  return dot(F.n, V.w) + dot(F.f, V.v);
}
// V x m (Featherstone's crm) and V x* F (crf).
template <class T>
Motion<T> cross_motion(const Motion<T>& V, const Motion<T>& m) {
  return {cross(V.w, m.w), cross(V.w, m.v) + cross(V.v, m.w)};
}
template <class T>
Force<T> cross_force(const Motion<T>& V, const Force<T>& F) {
  return {cross(V.w, F.n) + cross(V.v, F.f), cross(V.w, F.f)};
}

// A rigid body's inertia about a frame's origin: mass m, first moment h = m c, rotational
// inertia I about the origin (row-major, symmetric).
template <class T>
struct RigidInertia {
  T m;
  Vec3<T> h;
  Mat3<T> I;
  Force<T> operator*(const Motion<T>& V) const {
    return {times(I, V.w) + cross(h, V.v), scaled(V.v, m) - cross(h, V.w)};
  }
  RigidInertia operator+(const RigidInertia& o) const {
    Mat3<T> sum;
    for (int k = 0; k < 9; ++k) sum[k] = I[k] + o.I[k];
    return {m + o.m, h + o.h, sum};
  }
};

// A body's inertia about its frame's origin from its mass m, centre c and inertia i about the
// centre (ixx, ixy, ixz, iyy, iyz, izz), by parallel axes: I_o = I_c + m (|c|^2 1 - c c^T),
// h = m c. number(x): x as a T.
template <class T, class Number>
RigidInertia<T> about_origin(const T& m, const Vec3<T>& c, const std::array<T, 6>& i,
                             const Number& number) {
  const T cc = dot(c, c);
  Mat3<T> I = {i[0], i[1], i[2], i[1], i[3], i[4], i[2], i[4], i[5]};
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 3; ++k) I[3 * r + k] += m * ((r == k ? cc : number(0.0)) - c[r] * c[k]);
  return {m, scaled(c, m), I};
}

// The transform from a parent frame to a child frame whose origin is r (parent coordinates) and
// whose axes are the columns of E^T (E maps parent coordinates to child coordinates).
template <class T>
struct Transform {
  Mat3<T> E;
  Vec3<T> r;
  Motion<T> apply(const Motion<T>& m) const {  // child coordinates of a parent motion
    return {times(E, m.w), times(E, m.v - cross(r, m.w))};
  }
  Force<T> apply_transpose(const Force<T>& F) const {  // parent coordinates of a child force
    const Vec3<T> f = transposed_times(E, F.f);
    return {transposed_times(E, F.n) + cross(r, f), f};
  }
};

// A child body's inertia in its parent's frame (X^T I X, Featherstone eq. 2.66): with h' = E^T h,
// h_p = h' + m r and I_p = E^T I E + m (|r|^2 1 - r r^T) + 2 (r . h') 1 - h' r^T - r h'^T
// (no division by m: a rotor has none).
template <class T>
RigidInertia<T> in_parent(const Transform<T>& X, const RigidInertia<T>& Ic) {
  const Mat3<T> Et = transposed(X.E);
  const Vec3<T> h = times(Et, Ic.h), r = X.r;
  Mat3<T> I = product(Et, product(Ic.I, X.E));
  const T rr = dot(r, r) * Ic.m, rh = dot(r, h) * 2.0;
  for (int a = 0; a < 3; ++a) {
    for (int b = 0; b < 3; ++b) I[3 * a + b] += -(r[a] * r[b] * Ic.m) - h[a] * r[b] - r[a] * h[b];
    I[4 * a] += rr + rh;
  }
  return {Ic.m, h + scaled(r, Ic.m), I};
}

// The skew matrix of r (r x y = skew(r) y), and a matrix whose lower triangle is its upper one:
// a symmetric result is computed once per entry, so a recorded program holds each entry once.
template <class T>
Mat3<T> skew(const Vec3<T>& r) {
  return {T{}, -r[2], r[1], r[2], T{}, -r[0], -r[1], r[0], T{}};
}
template <class T>
Mat3<T> upper_mirrored(Mat3<T> S) {
  S[3] = S[1], S[6] = S[2], S[7] = S[5];
  return S;
}

// An articulated-body inertia (Featherstone, ch. 7), the symmetric 6 x 6 [[A, B], [B^T, C]]
// acting on a motion as n = A w + B v, f = B^T w + C v (A and C symmetric).
template <class T>
struct ArticulatedInertia {
  Mat3<T> A, B, C;
  explicit ArticulatedInertia(const RigidInertia<T>& I)  // h x v = skew(h) v, C = m 1
      : A(I.I), B(skew(I.h)), C{I.m, T{}, T{}, T{}, I.m, T{}, T{}, T{}, I.m} {}
  ArticulatedInertia(const Mat3<T>& a, const Mat3<T>& b, const Mat3<T>& c) : A(a), B(b), C(c) {}
  Force<T> operator*(const Motion<T>& V) const {
    return {times(A, V.w) + times(B, V.v), transposed_times(B, V.w) + times(C, V.v)};
  }
  ArticulatedInertia operator+(const ArticulatedInertia& o) const {
    ArticulatedInertia sum = *this;
    for (int k = 0; k < 9; ++k) sum.A[k] += o.A[k], sum.B[k] += o.B[k], sum.C[k] += o.C[k];
    return sum;
  }
  // I - U W^T for W = U / D (the articulated body's reduction, Featherstone eq. 7.39).
  ArticulatedInertia minus_outer(const Force<T>& U, const Force<T>& W) const {
    Mat3<T> a = A, b = B, c = C;
    for (int r = 0; r < 3; ++r)
      for (int k = 0; k < 3; ++k) {
        a[3 * r + k] -= U.n[r] * W.n[k];
        b[3 * r + k] -= U.n[r] * W.f[k];
        c[3 * r + k] -= U.f[r] * W.f[k];
      }
    return {upper_mirrored(a), b, upper_mirrored(c)};
  }
};

// X^T I X: an articulated inertia in its parent's frame. Turned by E (A' = E^T A E, likewise B',
// C'), then moved to the parent's origin with rx = skew(r): A = A' - K - K^T - rx C' rx with
// K = B' rx, B = B' + rx C', C = C'.
template <class T>
ArticulatedInertia<T> in_parent(const Transform<T>& X, const ArticulatedInertia<T>& I) {
  const Mat3<T> Et = transposed(X.E), rx = skew(X.r);
  const Mat3<T> A = product(Et, product(I.A, X.E)), B = product(Et, product(I.B, X.E));
  const Mat3<T> C = upper_mirrored(product(Et, product(I.C, X.E)));
  const Mat3<T> K = product(B, rx), L = product(rx, C), N = product(L, rx);
  Mat3<T> Ap, Bp;
  for (int k = 0; k < 9; ++k) {
    Ap[k] = A[k] - K[k] - K[3 * (k % 3) + k / 3] - N[k];
    Bp[k] = B[k] + L[k];
  }
  return {upper_mirrored(Ap), Bp, C};
}

// One factor of a joint's rotation: a turn about the frame axis k (0, 1, 2) by the angle of cosine
// c and sine s, or (k = -1) the general rotation R. A turn about a frame axis changes a matrix or a
// vector in its plane alone: R B R^T by the double angle costs 18 operations for a symmetric B,
// where the product of dense matrices costs 54 (the articulated inertias' transforms, seven per
// joint).
template <class T>
struct Turn {
  int k = -1;
  T c, s;
  Mat3<T> R;
};
// R h.
template <class T>
Vec3<T> turned(const Turn<T>& t, const Vec3<T>& h) {
  if (t.k < 0) return times(t.R, h);
  const int i = (t.k + 1) % 3, j = (t.k + 2) % 3;
  Vec3<T> r = h;
  r[i] = t.c * h[i] - t.s * h[j];
  r[j] = t.s * h[i] + t.c * h[j];
  return r;
}
// R B R^T. In the turn's plane (i, j) by the double angle: with h = (c^2 - s^2) / 2 and cs = c s,
// B'_ii, B'_jj = (B_ii + B_jj) / 2 +- t1 and B'_ij, B'_ji = t2 +- (B_ij - B_ji) / 2, where
// t1 = (B_ii - B_jj) h - (B_ij + B_ji) cs and t2 = (B_ii - B_jj) cs + (B_ij + B_ji) h; row and
// column k as vectors. A symmetric B's mirrored entries are one value, so its result is too.
template <class T>
Mat3<T> turned(const Turn<T>& t, const Mat3<T>& B) {
  if (t.k < 0) return product(t.R, product(B, transposed(t.R)));
  const int i = (t.k + 1) % 3, j = (t.k + 2) % 3, k = t.k;
  auto at = [](int r, int c) { return 3 * r + c; };
  const T h = (t.c * t.c - t.s * t.s) * 0.5, cs = t.c * t.s;
  const T sum = B[at(i, i)] + B[at(j, j)], dif = B[at(i, i)] - B[at(j, j)];
  const T sym = B[at(i, j)] + B[at(j, i)], anti = (B[at(i, j)] - B[at(j, i)]) * 0.5;
  const T mean = sum * 0.5, t1 = dif * h - sym * cs, t2 = dif * cs + sym * h;
  Mat3<T> R = B;
  R[at(i, i)] = mean + t1;
  R[at(j, j)] = mean - t1;
  R[at(i, j)] = t2 + anti;
  R[at(j, i)] = t2 - anti;
  R[at(i, k)] = t.c * B[at(i, k)] - t.s * B[at(j, k)];
  R[at(j, k)] = t.s * B[at(i, k)] + t.c * B[at(j, k)];
  R[at(k, i)] = t.c * B[at(k, i)] - t.s * B[at(k, j)];
  R[at(k, j)] = t.s * B[at(k, i)] + t.c * B[at(k, j)];
  return R;
}

// The rotation (row-major) by an angle of cosine c and sine s about a unit axis a of numbers
// (Rodrigues: a a^T + c (1 - a a^T) + s skew(a)); a term whose coefficient is 0 is left out and
// one of +-1 is not multiplied, so that an axis along a frame's axis gives the plain rotation in
// that plane (and a recorded program no c + 1 - c). number(x): x as a T.
template <class T, class Number>
Mat3<T> axis_rotation(const Vec3<double>& a, const T& c, const T& s, const Number& number) {
  auto term = [](double k, const T& x) { return k == 0 ? T{} : k == 1 ? x : k == -1 ? -x : x * k; };
  const Mat3<double> ax = skew(a);
  Mat3<T> R;
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 3; ++k) {
      const double aa = a[r] * a[k];
      R[3 * r + k] = number(aa) + term((r == k ? 1.0 : 0.0) - aa, c) + term(ax[3 * r + k], s);
    }
  return R;
}
// The rotation of the unit quaternion (w, x, y, z) / |q| for two = 2 / |q|^2 (2 for a unit one):
// no square root, and any nonzero quaternion is a rotation (as in MuJoCo, which normalizes).
template <class T>
Mat3<T> quaternion_rotation(const T& w, const T& x, const T& y, const T& z, const T& one,
                            const T& two) {
  return {one - two * (y * y + z * z), two * (x * y - w * z),       two * (x * z + w * y),
          two * (x * y + w * z),       one - two * (x * x + z * z), two * (y * z - w * x),
          two * (x * z - w * y),       two * (y * z + w * x),       one - two * (x * x + y * y)};
}

// Quaternions (w, x, y, z) and their product.
template <class T>
using Quaternion = std::array<T, 4>;
template <class T>
Quaternion<T> operator*(const Quaternion<T>& a, const Quaternion<T>& b) {
  return {a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
          a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
          a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
          a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0]};
}
// URDF's roll-pitch-yaw as a quaternion: Rz(yaw) Ry(pitch) Rx(roll).
inline Quaternion<double> rpy_quaternion(const std::array<double, 3>& rpy) {
  auto half = [](double a, int axis) {
    Quaternion<double> q = {std::cos(a / 2), 0, 0, 0};
    q[1 + axis] = std::sin(a / 2);
    return q;
  };
  return half(rpy[2], 2) * half(rpy[1], 1) * half(rpy[0], 0);
}

// URDF's roll-pitch-yaw as a rotation matrix (R = Rz Ry Rx), from the quaternion the pose
// composes: one convention for the frames and for the pose. Inline: the scene readers use it
// without the chain's algorithms.
inline Mat3<double> rpy_rotation(const std::array<double, 3>& rpy) {
  const Quaternion<double> q = rpy_quaternion(rpy);
  return quaternion_rotation(q[0], q[1], q[2], q[3], 1.0, 2.0);
}

// A part's frame as the transform from the link's frame to the part's.
inline Transform<double> part_frame(const Part& p) {
  return {transposed(rpy_rotation(p.rpy)), {p.xyz[0], p.xyz[1], p.xyz[2]}};
}

// Defined in spatial_chain.cpp for double, Sym and their duals. The chain at one state over the
// scalar T (double, or recorded_scalar.hpp's Sym and Dual): its numbers come from Values (inputs
// "q" and "qd" by the registry's names, literals), so one definition serves the reference in double
// and the recorded programs. The members are those recursive_algorithms.hpp lists for a chain.
template <class T>
class Chain {
 public:
  // q has nq entries, v nv (the layout above). The quaternion must be of unit length.
  Chain(const ChainDescription& d, Values<T> values);

  static Dimensions dimensions(const ChainDescription& d) {
    return {d.nq(), d.nv(), static_cast<int>(d.links.size()), true};
  }
  // Entry i of qdot = f(q, v): the base origin's velocity, the quaternion's rate
  // 1/2 q (0, omega) with omega in the base frame, the joint rates.
  static T configuration_rate(const ChainDescription& d, const Values<T>& values, int i);
  int nq() const { return d_.nq(); }
  int nv() const { return d_.nv(); }
  T input(const std::string& array, int i) const { return values_.input(array, i); }
  std::vector<T> mass_matrix() const;  // row-major nv x nv
  // Q = M vdot + b (recursive Newton-Euler; no gravity: a satellite in free fall).
  std::vector<T> inverse_dynamics(const std::vector<T>& vdot) const;
  T kinetic_energy() const;
  // qdd = M^-1 (Q - b) by the articulated-body algorithm, with the pivots D_i of M factored from
  // the tip inward (the base's last, in its own frame) and D_i / M_ii.
  std::vector<std::vector<T>> forward_dynamics(const std::vector<T>& Q) const;
  // The joints' friction on their motor coordinates' rates (Friction), nv; f enters as
  // M qdd + b + f = Q.
  std::vector<T> friction_forces() const;
  // The flexible joints' springs and dampers, dV/dq + dD/dqd (nv) with V = sum 1/2 k (qm/p - q)^2
  // and the Rayleigh function D = sum 1/2 d (qmd/p - qd)^2; they enter as M qdd + b + f = Q.
  std::vector<T> spring_damper_forces() const;
  T potential_energy() const;
  // Springs, dampers and friction.
  std::vector<T> passive_forces() const;
  // M v: the momentum conjugate to each velocity (recursive_algorithms.hpp's P = d(M v)/dq).
  std::vector<T> generalized_momentum() const;
  // The Hamel coupling of the quasi-velocities as a matrix H(M) (nv x nv, row-major) with
  // H v = [0, omega x (M v)_omega, 0]: the base's angular velocity is in its own frame, whose
  // directions do not commute (Euler's omega x L). Zero for a fixed base.
  std::vector<T> hamel_coupling(const std::vector<T>& M) const;
  // [P (3), L (3)]: linear momentum and angular momentum about the world origin, in the world.
  std::vector<T> momentum() const;
  // The end effector's pose [x, y, z, w, qx, qy, qz]: the tip's world position and the last
  // link's orientation as a quaternion, composed joint by joint (no branches: recordable); it has
  // the norm of the base's quaternion in q (1 for a unit one; a square root is not recordable).
  std::vector<T> end_effector_pose() const;
  // The link-side joint angles and rates (N): a rigid gear's slot divided by its ratio (qm / p),
  // any other slot as it is.
  std::vector<T> joint_angles() const;
  std::vector<T> joint_rates() const;
  // The world positions of joints 1..N (each link frame's origin) and of the tip, for drawing:
  // row-major 3 x (N + 1), one column per point.
  std::vector<T> joint_positions() const;
  // Its geometric Jacobian, row-major 6 x nv: the tip's linear and the last link's angular
  // velocity in the world per unit velocity.
  std::vector<T> end_effector_jacobian() const;
  // Umetani and Yoshida's generalized Jacobian J* (6 x N): the end effector's twist per unit
  // joint (motor) rate with the base moving so that the momentum stays zero. Free base only.
  std::vector<T> generalized_jacobian() const;
  // The joint torques tau = p Q that give the link-side joint accelerations qdd_joints with no
  // force on the free base, and the base's acceleration: {tau (N), qdd_base (6)}.
  std::vector<std::vector<T>> free_base_inverse_dynamics(const std::vector<T>& qdd_joints) const;

 private:
  const ChainDescription& d_;
  Values<T> values_;
  int n_ = 0;
  std::vector<Transform<T>> X_;  // parent -> link i (X_[0] unused)
  // X_[i]'s rotation as turns, R = E^T = turns_[i][0] turns_[i][1] ... (the origin's yaw, pitch
  // and roll, then the joint's own turn, always last), for the inertias' transforms.
  std::vector<std::vector<Turn<T>>> turns_;
  // X_[i]'s shift alone, (1, r): applied after the turns.
  Transform<T> shift(int i) const {
    return {num(Mat3<double>{1, 0, 0, 0, 1, 0, 0, 0, 1}), X_[i].r};
  }
  std::vector<RigidInertia<T>> I_;  // each body's, about its origin, in its frame
  std::vector<Motion<T>> V_;        // each body's velocity, in its frame
  std::vector<Vec3<T>> parent_w_;   // the parent's angular velocity, in link i's frame
  std::vector<Vec3<T>> p_;          // world positions of the body origins
  std::vector<Mat3<T>> R_;          // world orientations
  std::vector<Vec3<T>> axis_;       // each joint's unit axis, in its link's frame
  std::vector<T> qd_;               // joint (or motor) rates (qd_[0] unused)
  // Per joint: the velocity index its torque drives (ChainDescription::motor_coordinate) and that
  // coordinate's rate, at which its rotor turns relative to the parent.
  std::vector<int> motor_;
  std::vector<T> motor_qd_;
  // Per joint: the link's motion per unit rate (a / p, 0), and an exactly coupled rotor's
  // transform from the parent (the joint's origin, not turned), inertia and velocity.
  std::vector<Motion<T>> S_;
  std::vector<Transform<T>> rotor_X_;
  std::vector<RigidInertia<T>> rotor_I_;
  std::vector<Motion<T>> rotor_V_;
  // Whether joint i has an exactly coupled rotor (a body on the parent), and whether it is
  // flexible (its rotor on a coordinate of its own, a leaf of the tree).
  bool exact_rotor(int i) const {
    return d_.links[i - 1].gear.present && d_.links[i - 1].gear.exact;
  }
  bool flexible(int i) const {
    return d_.links[i - 1].gear.present && d_.links[i - 1].gear.flexible;
  }
  // A rigid gear: its ratio scales joint i's slot (qm = p q), its rotor turns on that slot.
  const Gear* slot_gear(int i) const {
    const Gear& g = d_.links[i - 1].gear;
    return g.present && !g.flexible ? &g : nullptr;
  }
  // A number of the description: the literal, or the run-time parameter params[param].
  T value(double literal, int param) const {
    return param == kLiteral ? num(literal) : values_.input("params", param);
  }
  // 1 / value(literal, param): one number for a literal.
  T inverse(double literal, int param) const {
    return param == kLiteral ? num(1 / literal) : num(1.0) / value(literal, param);
  }
  T ratio(int i) const {  // joint i's slot's ratio (1 without a rigid gear)
    const Gear* g = slot_gear(i);
    return g ? value(g->ratio, g->ratio_param) : num(1.0);
  }
  // k / p_i^power, power 1 or 2 (a literal ratio's folded to one number), for the slot.
  T over_ratio(int i, double k, int power = 1) const {
    const Gear* g = slot_gear(i);
    if (!g) return num(k);
    if (g->ratio_param == kLiteral)
      return num(power == 1 ? k / g->ratio : k / (g->ratio * g->ratio));
    const T r = num(1.0) / ratio(i);
    return power == 1 ? r * k : r * r * k;
  }
  // The armature inertia on joint i's slot (0 without a rigid armature-coupled gear).
  T armature(int i) const {
    const Gear* g = slot_gear(i);
    return g && !g->exact ? value(g->axial, g->axial_param) : T{};
  }
  // The armature inertia on a flexible joint's motor coordinate (0 otherwise).
  T motor_armature(int i) const {
    const Gear& g = d_.links[i - 1].gear;
    return flexible(i) && !g.exact ? axial(i) : T{};
  }
  // A flexible joint's spring deflection qm / p - q, from q (of nq) or its rate from v.
  T deflection(int i, const std::string& array) const;
  T axial(int i) const {  // the rotor's axial inertia
    const Gear& g = d_.links[i - 1].gear;
    return value(g.axial, g.axial_param);
  }
  bool literal_ratio(int i) const {
    const Gear* g = slot_gear(i);
    return !g || g->ratio_param == kLiteral;
  }
  double ratio_value(int i) const {  // a literal slot ratio
    const Gear* g = slot_gear(i);
    return g ? g->ratio : 1.0;
  }
  // p_i^power (1 or 2) times the rotor's axial inertia, one number where both are literals.
  T ratio_times_axial(int i, int power) const;
  // p^2 times the armature: joint i's armature per unit link rate.
  T armature_per_link_rate(int i) const {
    const Gear* g = slot_gear(i);
    return g && !g->exact ? ratio_times_axial(i, 2) : T{};
  }
  Mat3<T> rotor_inertia(int i, const Vec3<double>& a) const;
  // A body's inertia about its frame's origin: its own inertial and its welded parts'.
  RigidInertia<T> body_inertia(const Link& l) const;
  RigidInertia<T> rigid_inertia(const Inertial& b) const;
  T num(double x) const { return values_.number(x); }
  Vec3<T> num(const std::array<double, 3>& x) const { return {num(x[0]), num(x[1]), num(x[2])}; }
  Mat3<T> num(const Mat3<double>& A) const;
  static Vec3<T> zero3() { return {T{}, T{}, T{}}; }
  static Motion<T> zero_motion() { return {zero3(), zero3()}; }
  Motion<T> base_unit(int k) const;  // the base's motion for a unit v_k (k < 6)
  std::vector<RigidInertia<T>> composite_inertias() const;
  // in_parent(X_[i], I), turn by turn: the cheaper form of the same transform.
  RigidInertia<T> in_parent_of(int i, const RigidInertia<T>& I) const;
  ArticulatedInertia<T> in_parent_of(int i, const ArticulatedInertia<T>& I) const;
  std::vector<Turn<T>> joint_turns(const Link& l, const Vec3<double>& a, const T& c,
                                   const T& s) const;
  std::vector<T> mass_matrix_diagonal() const;
  void add_rotor(int i, ArticulatedInertia<T>& Ia, Force<T>& U, T& D, Force<T>& pa) const;
  // An exact rotor's velocity-product force along what is left of it once its own coordinate is
  // eliminated, in link i's frame: (omega' x a) ((J - t) a . omega' + J qd_m).
  Vec3<T> rotor_bias(int i) const;
  // A flexible joint's exact rotor, a leaf on the parent: what it passes to the parent in link
  // i's frame once its coordinate (net force Q_m) is eliminated.
  void add_leaf_rotor(int i, const T& Q_m, ArticulatedInertia<T>& reduced, Force<T>& pa) const;
  // Column `col` of M above joint i: the force `up` (in link i - 1's frame) read along joints
  // i - 1 .. 1 and the base's directions, carried inward.
  void fill_column(std::vector<T>& M, int col, int i, Force<T> up) const;
  // Body b's contribution: the bodies that carry mass (a fixed base carries none that moves).
  int first_body() const { return d_.free_base ? 0 : 1; }
};

}  // namespace spacearm::spatial
