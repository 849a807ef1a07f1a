// Spatial algebra in body coordinates as Featherstone writes it (Rigid Body Dynamics Algorithms,
// 2008, ch. 2), over any scalar T (double, and recorded_scalar.hpp's Sym and duals): 3-vectors and
// row-major 3 x 3 matrices, a motion (omega, v), a force (n, f), a transform from a parent frame to
// a child frame (E, r), rigid and articulated inertias, rotations by turns, axes, quaternions and
// URDF's roll-pitch-yaw. Header-only; knows nothing of chains or scenes.
#pragma once

#include <array>
#include <cmath>

namespace spacearm::spatial {

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

// A scene's snap_right_angles: an angle within 1e-5 rad of a multiple k pi/2 becomes k pi/2
// (URDFs round pi/2 to 1.5708), and the cosine and sine of such a multiple are exactly 0 and +-1,
// so a right angle leaves no 1e-6 or 1e-17 residue in the model's terms.
inline double snapped_right_angle(double a) {
  const double k = std::round(a / (M_PI / 2));
  return std::abs(a - k * (M_PI / 2)) <= 1e-5 ? k * (M_PI / 2) : a;
}
inline void cos_sin(double a, bool exact_right_angles, double& c, double& s) {
  const double k = std::round(a / (M_PI / 2));
  if (exact_right_angles && a == k * (M_PI / 2) && std::abs(k) < 1e6) {
    const int quarter = static_cast<int>(((static_cast<long>(k) % 4) + 4) % 4);
    const double cosines[] = {1, 0, -1, 0}, sines[] = {0, 1, 0, -1};
    c = cosines[quarter], s = sines[quarter];
    return;
  }
  c = std::cos(a), s = std::sin(a);
}

// URDF's roll-pitch-yaw as a rotation matrix (R = Rz Ry Rx), from the quaternion the pose
// composes: one convention for the frames and for the pose. With exact_right_angles (a scene's
// snap_right_angles), the product of the three turns, each right angle's exactly. Inline: the
// scene readers use it without the chain's algorithms.
inline Mat3<double> rpy_rotation(const std::array<double, 3>& rpy,
                                 bool exact_right_angles = false) {
  if (!exact_right_angles) {
    const Quaternion<double> q = rpy_quaternion(rpy);
    return quaternion_rotation(q[0], q[1], q[2], q[3], 1.0, 2.0);
  }
  double cr, sr, cp, sp, cy, sy;
  cos_sin(rpy[0], true, cr, sr);
  cos_sin(rpy[1], true, cp, sp);
  cos_sin(rpy[2], true, cy, sy);
  return {cy * cp,
          cy * sp * sr - sy * cr,
          cy * sp * cr + sy * sr,
          sy * cp,
          sy * sp * sr + cy * cr,
          sy * sp * cr - cy * sr,
          -sp,
          cp * sr,
          cp * cr};
}

}  // namespace spacearm::spatial
