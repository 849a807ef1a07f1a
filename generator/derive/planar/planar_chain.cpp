#include "planar_chain.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace spacearm {

namespace {

// Planar spatial algebra (Featherstone ch. 2.16): motions (omega, vx, vy), forces (n, fx, fy).
template <class T>
struct Motion {
  T w, x, y;
};
template <class T>
struct Force {
  T n, x, y;
  Force& operator+=(const Force& o) {
    n += o.n;
    x += o.x;
    y += o.y;
    return *this;
  }
};
template <class T>
T dot(const Force<T>& f, const Motion<T>& m) {
  return f.n * m.w + f.x * m.x + f.y * m.y;
}
// v x* f.
template <class T>
Force<T> cross_force(const Motion<T>& v, const Force<T>& f) {
  return {v.x * f.y - v.y * f.x, -(v.w * f.y), v.w * f.x};
}

// A symmetric 3 x 3 inertia [[a, b, c], [b, d, e], [c, e, f]].
template <class T>
struct Inertia {
  T a, b, c, d, e, f;
  Force<T> operator*(const Motion<T>& m) const {
    return {a * m.w + b * m.x + c * m.y, b * m.w + d * m.x + e * m.y, c * m.w + e * m.x + f * m.y};
  }
  Inertia& operator+=(const Inertia& o) {
    a += o.a, b += o.b, c += o.c, d += o.d, e += o.e, f += o.f;
    return *this;
  }
};

// A rigid body's (or a composite's) inertia about a frame's origin: mass m, first moment
// h = m c, rotational inertia Io; four numbers in the plane where a general inertia has six.
template <class T>
struct RigidInertia {
  T m, hx, hy, Io;
  Inertia<T> spatial() const { return {Io, -hy, hx, m, T{}, m}; }
  RigidInertia& operator+=(const RigidInertia& o) {
    m += o.m, hx += o.hx, hy += o.hy, Io += o.Io;
    return *this;
  }
};

// A child frame at r in its parent's coordinates, turned by an angle with cosine c, sine s.
template <class T>
struct Transform {
  T c, s, rx, ry;
  // A motion from parent to child coordinates: (w, R^T (v + w J r)).
  Motion<T> apply(const Motion<T>& m) const {
    const T ux = m.x - m.w * ry, uy = m.y + m.w * rx;
    return {m.w, c * ux + s * uy, c * uy - s * ux};
  }
  // A force from child to parent coordinates: F = R f, n + r x F.
  Force<T> apply_transpose(const Force<T>& f) const {
    const T Fx = c * f.x - s * f.y, Fy = s * f.x + c * f.y;
    return {f.n + rx * Fy - ry * Fx, Fx, Fy};
  }
  // The parallel-axis theorem: h' = m r + R h, Io' = Io + 2 r . (R h) + m |r|^2.
  RigidInertia<T> to_parent(const RigidInertia<T>& I) const {
    const T Rhx = c * I.hx - s * I.hy, Rhy = s * I.hx + c * I.hy;
    return {I.m, I.m * rx + Rhx, I.m * ry + Rhy,
            I.Io + (rx * Rhx + ry * Rhy) * 2.0 + I.m * (rx * rx + ry * ry)};
  }
  // X^T I X: the rotation turns the first moment and (by double angles) the 2 x 2 block, then
  // the translation t = J r = (-ry, rx) shifts them.
  Inertia<T> to_parent(const Inertia<T>& I) const {
    const T cos2 = c * c - s * s, sin2 = c * s * 2.0;
    const T half_diff = (I.d - I.f) * 0.5, half_sum = (I.d + I.f) * 0.5;
    const T turn = half_diff * cos2 - I.e * sin2;
    const T d = half_sum + turn, f = half_sum - turn, e = half_diff * sin2 + I.e * cos2;
    const T b = c * I.b - s * I.c, cc = s * I.b + c * I.c;
    const T tx = -ry, ty = rx;
    const T Ctx = d * tx + e * ty, Cty = e * tx + f * ty;
    return {I.a + (b * tx + cc * ty) * 2.0 + tx * Ctx + ty * Cty, b + Ctx, cc + Cty, d, e, f};
  }
};

// The scene's chain with its numbers as T: bodies, joints, and the transforms at q. A chain as
// recursive_algorithms.hpp describes it; in the plane nq = nv (the angles are their own
// coordinates), so n_ sizes both.
template <class T>
class PlanarChain {
 public:
  PlanarChain(const Scene& scene, Values<T> values)
      : scene_(scene),
        val_(std::move(values)),
        n_(scene.num_coordinates()),
        N_(scene.num_links()),
        free_(scene.free_floating()) {
    for (int i = 0; i < n_; ++i) q_.push_back(val_.input("q", i));
    for (int i = 0; i < n_; ++i) qd_.push_back(val_.input("qd", i));
    joints();
    bodies();
    transforms();
  }

  // Q = M qdd + b by recursive Newton-Euler (b: qdd = 0), without springs or friction.
  std::vector<T> inverse_dynamics(const std::vector<T>& qdd) const;
  // M by the composite-rigid-body algorithm, row-major n x n.
  std::vector<T> mass_matrix() const;
  // qdd = M^-1 (Q - b - passive) by the articulated-body algorithm, with the pivots D_i of M
  // factored from the tip inward and D_i / M_ii.
  std::vector<std::vector<T>> forward_dynamics(const std::vector<T>& Q) const;
  // Springs, dampers and friction, so that M qdd + b + passive = Q.
  std::vector<T> passive_forces() const;
  // T = 1/2 sum v . I v over the bodies, plus 1/2 I_m w^2 of each rotor (eqs. 3 and 10).
  T kinetic_energy() const;
  // p = M qd = dT/dqd: the bodies' momenta gathered from the tip inward and projected on the
  // joints, as inverse dynamics gathers forces.
  std::vector<T> generalized_momentum() const;
  // [Px, Py, L]: the base rows of M qd (momenta at the base's CoM), with L moved to the world
  // origin, as symbolic_model.cpp defines it. Free base only.
  std::vector<T> momentum() const;
  T input(const std::string& array, int i) const { return val_.input(array, i); }
  // Joint j's (1-based) torque tau enters as Q = tau / p on its motor coordinate (eq. 14).
  int torque_coordinate(int j) const { return joint_[j].m; }
  T per_torque(int j) const { return joint_[j].inv_p; }
  int nq() const { return n_; }
  int nv() const { return n_; }
  static Dimensions dimensions(const Scene& scene) { return scene.dimensions(); }
  // The base's x0 and y0 rates (world frame), v's first two entries for a free base; its turn,
  // the next, and a world vector u's rate as the base turns: z x u.
  static int base_translations(const Scene& scene) { return scene.num_base() > 0 ? 2 : 0; }
  static int base_rotations(const Scene& scene) { return scene.num_base() > 0 ? 1 : 0; }
  std::vector<T> turned_about_base_axis(int, const std::vector<T>& u) const {
    return {-u[1], u[0]};
  }
  // qdot = v: every planar coordinate is its own velocity's integral.
  static T configuration_rate(const Scene&, const Values<T>& values, int i) {
    return values.input(info(Input::qd).name, i);
  }

 private:
  enum class Rotor { none, exact, armature };
  struct Joint {
    int c = 0, m = 0;  // the joint's slot and its motor coordinate (equal but for a flexible joint)
    T g, inv_p, Im;    // link rate per slot rate (1/p for a rigid gear, else 1); 1/p; I_m
    Rotor rotor = Rotor::none;
    bool flexible = false;
  };
  const Scene& scene_;
  Values<T> val_;
  const int n_, N_;
  const bool free_;
  std::vector<T> q_, qd_;
  std::vector<Joint> joint_;           // 1..N (index 0 unused)
  std::vector<RigidInertia<T>> body_;  // 0: base (free), 1..N: links, about their frames
  std::vector<Transform<T>> X_;        // 1..N: body i in body i-1

  T value(const Quantity& q) const {
    if (!q.is_parameter()) return val_.number(q.value);
    for (size_t i = 0; i < scene_.parameters.size(); ++i)
      if (scene_.parameters[i].name == q.parameter) return val_.input("params", i);
    throw std::logic_error("recursive dynamics: unknown parameter " + q.parameter);
  }
  // Whether body i's force reaches a moving parent (not a fixed base).
  bool has_moving_parent(int i) const { return i > 1 || free_; }

  void joints();
  void bodies();
  void transforms();
  std::vector<Motion<T>> velocities() const;
  std::vector<RigidInertia<T>> composite_inertias() const;
  // c_i = v_i x S u_i: the joint's velocity-product acceleration.
  Motion<T> velocity_product(const Motion<T>& v, int i) const {
    const T u = joint_[i].g * qd_[joint_[i].c];
    return {T{}, v.y * u, -(v.x * u)};
  }
  // A rotor's rate: Omega_{i-1} + qd_m in the exact model (eq. 10), qd_m as armature.
  T rotor_rate(const std::vector<Motion<T>>& v, int i) const {
    const Joint& J = joint_[i];
    return J.rotor == Rotor::exact ? v[i - 1].w + qd_[J.m] : qd_[J.m];
  }
  std::vector<T> mass_matrix_diagonal() const;
  void solve_base(const Inertia<T>& IA, const Force<T>& rhs, std::vector<T>& qdd,
                  std::vector<T>& pivots, Motion<T>& a0) const;
};

template <class T>
void PlanarChain<T>::joints() {
  joint_.resize(N_ + 1);
  for (int i = 1; i <= N_; ++i) {
    Joint& J = joint_[i];
    J.c = scene_.joint_coordinate(i - 1);
    J.m = scene_.motor_coordinate(i - 1);
    J.g = J.inv_p = val_.number(1.0);
    J.Im = T{};
    if (!scene_.has_gear(i - 1)) continue;
    const Gear& gear = *scene_.gears[i - 1];
    J.inv_p = val_.number(1.0) / value(gear.ratio);
    J.flexible = gear.flexible();
    if (!J.flexible) J.g = J.inv_p;
    J.Im = value(gear.motor_inertia);
    J.rotor = gear.armature ? Rotor::armature : Rotor::exact;
  }
}

template <class T>
void PlanarChain<T>::bodies() {
  body_.resize(N_ + 1);
  if (free_) body_[0] = {value(scene_.base.mass), T{}, T{}, value(scene_.base.inertia)};
  for (int i = 1; i <= N_; ++i) {
    const Link& l = scene_.links[i - 1];
    const T m = value(l.mass), cx = value(l.com[0]), cy = value(l.com[1]);
    T Ic = value(l.inertia);
    if (scene_.has_gear(i - 1) && scene_.gears[i - 1]->compensate_link_inertia) Ic -= joint_[i].Im;
    body_[i] = {m, m * cx, m * cy, Ic + m * (cx * cx + cy * cy)};
  }
}

// Link i's frame sits on joint i, turned by the link-side joint angle g q_c (eq. 12); the
// base's frame sits on its CoM with the world's axes, so link 1 turns by q0 + g q_c and its
// mount is turned by q0.
template <class T>
void PlanarChain<T>::transforms() {
  using std::cos;
  using std::sin;
  X_.resize(N_ + 1);
  for (int i = 1; i <= N_; ++i) {
    const Joint& J = joint_[i];
    T angle = J.g * q_[J.c], rx{}, ry{};
    if (i == 1) {
      const T mx = value(scene_.base.mount[0]), my = value(scene_.base.mount[1]);
      if (free_) {
        angle = q_[2] + angle;
        const T c0 = cos(q_[2]), s0 = sin(q_[2]);
        rx = c0 * mx - s0 * my;
        ry = s0 * mx + c0 * my;
      } else {
        rx = mx;
        ry = my;
      }
    } else {
      rx = value(scene_.links[i - 2].length);
    }
    X_[i] = {cos(angle), sin(angle), rx, ry};
  }
}

// v_0 = (q0d, x0d, y0d) for a free base (its frame keeps the world's axes); v_i = X_i v_{i-1}
// + S u_i.
template <class T>
std::vector<Motion<T>> PlanarChain<T>::velocities() const {
  std::vector<Motion<T>> v(N_ + 1, Motion<T>{T{}, T{}, T{}});
  if (free_) v[0] = {qd_[2], qd_[0], qd_[1]};
  for (int i = 1; i <= N_; ++i) {
    v[i] = X_[i].apply(v[i - 1]);
    v[i].w += joint_[i].g * qd_[joint_[i].c];
  }
  return v;
}

template <class T>
std::vector<T> PlanarChain<T>::inverse_dynamics(const std::vector<T>& qdd) const {
  const std::vector<Motion<T>> v = velocities();
  std::vector<Motion<T>> a(N_ + 1, Motion<T>{T{}, T{}, T{}});
  std::vector<Force<T>> f(N_ + 1, Force<T>{T{}, T{}, T{}});
  std::vector<T> Q(n_, T{});
  // The base's spatial acceleration at its CoM (the frame translates with it): rdd - w J rd.
  if (free_) {
    a[0] = {qdd[2], qdd[0] + qd_[1] * qd_[2], qdd[1] - qd_[0] * qd_[2]};
    f[0] = {body_[0].Io * qdd[2], body_[0].m * qdd[0], body_[0].m * qdd[1]};
  }
  // Forward: accelerations and each body's force I a + v x* I v.
  for (int i = 1; i <= N_; ++i) {
    const Motion<T> c = velocity_product(v[i], i), ap = X_[i].apply(a[i - 1]);
    a[i] = {ap.w + joint_[i].g * qdd[joint_[i].c], ap.x + c.x, ap.y + c.y};
    const Inertia<T> I = body_[i].spatial();
    f[i] = I * a[i];
    f[i] += cross_force(v[i], I * v[i]);
  }
  // Backward: project on the joints, pass to the parents; a rotor's torque I_m (alpha_{i-1} +
  // qdd_m) acts on its coordinate and on the body that carries it (a couple: no force).
  for (int i = N_; i >= 1; --i) {
    const Joint& J = joint_[i];
    Q[J.c] += J.g * f[i].n;
    if (has_moving_parent(i)) f[i - 1] += X_[i].apply_transpose(f[i]);
    if (J.rotor == Rotor::armature) Q[J.m] += J.Im * qdd[J.m];
    if (J.rotor != Rotor::exact) continue;
    const T torque = J.Im * (a[i - 1].w + qdd[J.m]);
    Q[J.m] += torque;
    if (has_moving_parent(i)) f[i - 1].n += torque;
  }
  if (free_) Q[0] = f[0].x, Q[1] = f[0].y, Q[2] = f[0].n;
  return Q;
}

// Composite inertias (rotors of the exact model on the body that carries them), tip first.
template <class T>
std::vector<RigidInertia<T>> PlanarChain<T>::composite_inertias() const {
  std::vector<RigidInertia<T>> Ic = body_;
  for (int i = 1; i <= N_; ++i)
    if (joint_[i].rotor == Rotor::exact && has_moving_parent(i)) Ic[i - 1].Io += joint_[i].Im;
  for (int i = N_; i >= 1; --i)
    if (has_moving_parent(i)) Ic[i - 1] += X_[i].to_parent(Ic[i]);
  return Ic;
}

template <class T>
std::vector<T> PlanarChain<T>::mass_matrix() const {
  const std::vector<RigidInertia<T>> Ic = composite_inertias();
  std::vector<T> M(n_ * n_, T{});
  auto add = [&](int r, int c, const T& x) { M[std::min(r, c) * n_ + std::max(r, c)] += x; };
  // Column of joint i: F = Ic_i S, carried to each ancestor (Featherstone's CRBA).
  for (int i = N_; i >= 1; --i) {
    const Joint& J = joint_[i];
    Force<T> F = Ic[i].spatial() * Motion<T>{val_.number(1.0), T{}, T{}};
    add(J.c, J.c, J.g * J.g * F.n);
    for (int k = i - 1; k >= 1; --k) {
      F = X_[k + 1].apply_transpose(F);
      add(J.c, joint_[k].c, J.g * joint_[k].g * F.n);
    }
    if (free_) {
      F = X_[1].apply_transpose(F);
      add(J.c, 0, J.g * F.x), add(J.c, 1, J.g * F.y), add(J.c, 2, J.g * F.n);
    }
    // The rotor turns with every body before it: I_m couples its coordinate to theirs.
    if (J.rotor == Rotor::none) continue;
    add(J.m, J.m, J.Im);
    if (J.rotor == Rotor::armature) continue;
    for (int k = i - 1; k >= 1; --k) add(J.m, joint_[k].c, J.Im * joint_[k].g);
    if (free_) add(J.m, 2, J.Im);
  }
  // The base block: the whole system's inertia about the base CoM, in (x0, y0, q0).
  if (free_) {
    const RigidInertia<T>& B = Ic[0];
    add(0, 0, B.m), add(1, 1, B.m), add(0, 2, -B.hy), add(1, 2, B.hx), add(2, 2, B.Io);
  }
  for (int r = 0; r < n_; ++r)
    for (int c = 0; c < r; ++c) M[r * n_ + c] = M[c * n_ + r];
  return M;
}

// M_ii alone: from the composite inertias, without the off-diagonal entries.
template <class T>
std::vector<T> PlanarChain<T>::mass_matrix_diagonal() const {
  const std::vector<RigidInertia<T>> Ic = composite_inertias();
  std::vector<T> d(n_, T{});
  if (free_) d[0] = d[1] = Ic[0].m, d[2] = Ic[0].Io;
  for (int i = 1; i <= N_; ++i) {
    const Joint& J = joint_[i];
    d[J.c] += J.g * J.g * Ic[i].Io;
    d[J.m] += J.Im;
  }
  return d;
}

template <class T>
std::vector<T> PlanarChain<T>::passive_forces() const {
  using std::exp;
  using std::tanh;
  std::vector<T> F(n_, T{});
  for (int i = 1; i <= N_; ++i) {
    const Joint& J = joint_[i];
    if (J.flexible) {
      // V = 1/2 k (qm/p - q)^2 and D = 1/2 d (qmd/p - qd)^2 (symbolic_model.cpp).
      const Gear& gear = *scene_.gears[i - 1];
      T force = value(*gear.stiffness) * (q_[J.m] * J.inv_p - q_[J.c]);
      if (gear.damping) force += value(*gear.damping) * (qd_[J.m] * J.inv_p - qd_[J.c]);
      F[J.c] -= force;
      F[J.m] += force * J.inv_p;
    }
    if (!scene_.has_friction() || !scene_.friction[i - 1]) continue;
    // f(w) = b w + Fc tanh(w/vs) + (Fs - Fc) exp(-(w/vst)^2) tanh(w/vs) on the motor rate.
    const Friction& fr = *scene_.friction[i - 1];
    const T w = qd_[J.m];
    T force = value(fr.viscous) * w;
    if (fr.has_coulomb) {
      const T sign = tanh(w / value(fr.velocity_scale));
      force += value(fr.coulomb) * sign;
      if (fr.has_stribeck) {
        const T r = w / value(fr.stribeck_velocity);
        force += (value(fr.stribeck_static) - value(fr.coulomb)) * exp(-(r * r)) * sign;
      }
    }
    F[J.m] += force;
  }
  return F;
}

// I^A_0 a_0 = f - p^A_0 by LDL^T in the order (x0, y0, q0), then qdd of the base from its spatial
// acceleration: rdd = a + w J rd.
template <class T>
void PlanarChain<T>::solve_base(const Inertia<T>& IA, const Force<T>& rhs, std::vector<T>& qdd,
                                std::vector<T>& pivots, Motion<T>& a0) const {
  const T A00 = IA.d, A10 = IA.e, A11 = IA.f, A20 = IA.b, A21 = IA.c, A22 = IA.a;
  const T D0 = A00, inv0 = val_.number(1.0) / D0, L10 = A10 * inv0, L20 = A20 * inv0;
  const T D1 = A11 - L10 * A10, inv1 = val_.number(1.0) / D1;
  const T A21r = A21 - L20 * A10, L21 = A21r * inv1;
  const T D2 = A22 - L20 * A20 - L21 * A21r;
  const T z0 = rhs.x, z1 = rhs.y - L10 * z0, z2 = rhs.n - L20 * z0 - L21 * z1;
  const T x2 = z2 / D2, x1 = z1 * inv1 - L21 * x2, x0 = z0 * inv0 - L10 * x1 - L20 * x2;
  a0 = {x2, x0, x1};
  qdd[0] = x0 - qd_[1] * qd_[2];
  qdd[1] = x1 + qd_[0] * qd_[2];
  qdd[2] = x2;
  pivots[0] = D0, pivots[1] = D1, pivots[2] = D2;
}

template <class T>
std::vector<std::vector<T>> PlanarChain<T>::forward_dynamics(const std::vector<T>& Q) const {
  const std::vector<Motion<T>> v = velocities();
  const std::vector<T> passive = passive_forces();
  std::vector<T> Qe(n_), qdd(n_, T{}), pivots(n_, T{}), u(N_ + 1);
  for (int i = 0; i < n_; ++i) Qe[i] = Q[i] - passive[i];
  std::vector<Inertia<T>> IA(N_ + 1);
  std::vector<Force<T>> pA(N_ + 1), U(N_ + 1);
  std::vector<T> D(N_ + 1);
  for (int i = free_ ? 0 : 1; i <= N_; ++i) {
    IA[i] = body_[i].spatial();
    pA[i] = cross_force(v[i], IA[i] * v[i]);
  }
  // Backward: each joint's D = u^T I^A u (+ I_m) and U = I^A u (+ the rotor's I_m), with u the
  // link's S / p; the parent receives I^A - U U^T / D (+ the rotor) and its bias.
  for (int i = N_; i >= 1; --i) {
    const Joint& J = joint_[i];
    const Force<T> col = IA[i] * Motion<T>{val_.number(1.0), T{}, T{}};
    U[i] = {J.g * col.n, J.g * col.x, J.g * col.y};
    D[i] = J.g * U[i].n;
    // A rigid gear's rotor turns on the joint's own slot: its I_m joins D (and, carried by the
    // parent, U and the inertia passed on).
    const bool exact_on_slot = J.rotor == Rotor::exact && !J.flexible;
    if (J.rotor != Rotor::none && !J.flexible) D[i] += J.Im;
    if (exact_on_slot) U[i].n += J.Im;
    Force<T> pc = IA[i] * velocity_product(v[i], i);
    pc += pA[i];
    u[i] = Qe[J.c] - J.g * pc.n;
    if (!has_moving_parent(i)) continue;
    const T inv_D = val_.number(1.0) / D[i];
    const Force<T> W{U[i].n * inv_D, U[i].x * inv_D, U[i].y * inv_D};
    const Inertia<T>& I = IA[i];
    Inertia<T> Ia{I.a - U[i].n * W.n, I.b - U[i].n * W.x, I.c - U[i].n * W.y,
                  I.d - U[i].x * W.x, I.e - U[i].x * W.y, I.f - U[i].y * W.y};
    if (exact_on_slot) Ia.a += J.Im;
    pc += Force<T>{W.n * u[i], W.x * u[i], W.y * u[i]};
    // A flexible joint's rotor is a leaf of its own: it passes on only its coordinate's force.
    if (J.rotor == Rotor::exact && J.flexible) pc.n += Qe[J.m];
    IA[i - 1] += X_[i].to_parent(Ia);
    pA[i - 1] += X_[i].apply_transpose(pc);
  }
  // Forward: the base, then each joint's acceleration from its parent's.
  Motion<T> a_prev{T{}, T{}, T{}};
  if (free_) {
    const Force<T> rhs{Qe[2] - pA[0].n, Qe[0] - pA[0].x, Qe[1] - pA[0].y};
    solve_base(IA[0], rhs, qdd, pivots, a_prev);
  }
  for (int i = 1; i <= N_; ++i) {
    const Joint& J = joint_[i];
    const Motion<T> ap = X_[i].apply(a_prev), c = velocity_product(v[i], i);
    qdd[J.c] = (u[i] - dot(U[i], ap)) / D[i];
    pivots[J.c] = D[i];
    if (J.flexible) {
      // The rotor's own equation I_m (alpha_{i-1} + qdd_m) = Q_m (armature: I_m qdd_m = Q_m).
      qdd[J.m] = Qe[J.m] / J.Im - (J.rotor == Rotor::exact ? a_prev.w : T{});
      pivots[J.m] = J.Im;
    }
    a_prev = {ap.w + J.g * qdd[J.c], ap.x + c.x, ap.y + c.y};
  }
  const std::vector<T> diagonal = mass_matrix_diagonal();
  std::vector<T> scaled(n_);
  for (int i = 0; i < n_; ++i) scaled[i] = pivots[i] / diagonal[i];
  return {qdd, pivots, scaled};
}

template <class T>
T PlanarChain<T>::kinetic_energy() const {
  const std::vector<Motion<T>> v = velocities();
  T twice{};
  for (int i = free_ ? 0 : 1; i <= N_; ++i) twice += dot(body_[i].spatial() * v[i], v[i]);
  for (int i = 1; i <= N_; ++i)
    if (joint_[i].rotor != Rotor::none) {
      const T w = rotor_rate(v, i);
      twice += joint_[i].Im * w * w;
    }
  return twice * 0.5;
}

template <class T>
std::vector<T> PlanarChain<T>::generalized_momentum() const {
  const std::vector<Motion<T>> v = velocities();
  std::vector<Force<T>> h(N_ + 1);
  for (int i = free_ ? 0 : 1; i <= N_; ++i) h[i] = body_[i].spatial() * v[i];
  std::vector<T> p(n_, T{});
  // Tip first: each body's momentum to its joint and its parent; a rotor's spin I_m (Omega_{i-1}
  // + qd_m) to its coordinate and, as a pure angular momentum, to the body that carries it (an
  // armature's spin I_m qd_m only to its coordinate: it does not turn with the parent).
  for (int i = N_; i >= 1; --i) {
    const Joint& J = joint_[i];
    p[J.c] += J.g * h[i].n;
    if (has_moving_parent(i)) h[i - 1] += X_[i].apply_transpose(h[i]);
    if (J.rotor == Rotor::none) continue;
    const T spin = J.Im * rotor_rate(v, i);
    p[J.m] += spin;
    if (J.rotor == Rotor::exact && has_moving_parent(i)) h[i - 1].n += spin;
  }
  if (free_) p[0] = h[0].x, p[1] = h[0].y, p[2] = h[0].n;
  return p;
}

template <class T>
std::vector<T> PlanarChain<T>::momentum() const {
  if (!free_) throw std::logic_error("recursive dynamics: momentum of a fixed base");
  const std::vector<T> p = generalized_momentum();
  // L about the world origin: L_CoM + r0 x P.
  return {p[0], p[1], p[2] + q_[0] * p[1] - q_[1] * p[0]};
}

}  // namespace

std::vector<std::vector<SRef>> record_recursive(const Scene& scene, Output o, Program& p) {
  return record_chain<PlanarChain>(scene, o, p);
}

std::vector<std::vector<double>> evaluate_recursive(
    const Scene& scene, Output o, const std::function<double(const std::string&, int)>& input) {
  return evaluate_chain<PlanarChain>(scene, o, input);
}

}  // namespace spacearm
