// generator/derive/spatial/spatial_chain.hpp: the spatial chain's mass matrix, kinetic energy and
// momentum against an independent computation in world coordinates with Eigen's rotations (no code
// shared with the chain's body-frame spatial algebra), and its recursive Newton-Euler against
// the invariants: M vdot + b = Q, and with no force the momentum and the energy stay constant.
#include "spatial_chain.hpp"

#include <Eigen/Dense>

#include <random>

#include "configuration_space.hpp"
#include "integrators.hpp"
#include "planar_chain.hpp"
#include "recursive_algorithms.hpp"
#include "planar_scene.hpp"
#include "support.hpp"
#include "tangent_space.hpp"

namespace spacearm::spatial {
namespace {

// A random link: origin, any axis, a mass and a physical inertia (principal moments that satisfy
// the triangle inequality, turned by a random rotation).
Link random_link(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1, 1);
  Link l;
  l.origin_xyz = {0.5 + 0.5 * u(rng), 0.3 * u(rng), 0.3 * u(rng)};
  l.origin_rpy = {u(rng), u(rng), u(rng)};
  l.axis = {u(rng), u(rng), u(rng)};  // not unit: the chain normalizes it
  l.mass = 2 + u(rng);
  l.com = {0.3 + 0.2 * u(rng), 0.1 * u(rng), 0.1 * u(rng)};
  const double a = 1 + 0.5 * u(rng), b = 1 + 0.5 * u(rng), c = 0.5 * (a + b) + 0.2 * u(rng);
  const Eigen::Matrix3d Q = Eigen::Quaterniond::UnitRandom().toRotationMatrix();
  const Eigen::Matrix3d I = Q * Eigen::Vector3d(a, b, c).asDiagonal() * Q.transpose();
  l.inertia = {I(0, 0), I(0, 1), I(0, 2), I(1, 1), I(1, 2), I(2, 2)};
  return l;
}

// A joint about +-e_k, as URDFs mostly have, with its origin's rpy by i % 3: none, a turn about
// the same axis (which the joint's own turn takes in), or any (the chain's turns about frame
// axes, and a reduced articulated inertia's exact zeros without a gear).
void frame_axis_joint(std::mt19937& rng, Link& l, int i) {
  std::uniform_int_distribution<int> axis(0, 5);
  const int k = axis(rng);
  l.axis = {0, 0, 0};
  l.axis[k % 3] = k < 3 ? 1 : -1;
  if (i % 3 == 0) l.origin_rpy = {0, 0, 0};
  if (i % 3 == 1) l.origin_rpy = {0, 0, 0}, l.origin_rpy[k % 3] = 0.7;
}

// geared: every joint has a motor (ratio 5 to 100), exactly coupled on the odd joints and as
// armature on the even ones. frame_axes: every joint about a frame axis (frame_axis_joint).
// flexible: joints 1, 3, 4, 6, 7 (i % 3 != 1) have a spring (k 50 to 550 N m/rad), every other
// one of them a damper too; the others keep rigid gears.
// coupled: every gear's rotor turns with a coupling factor c in (0, 1), 1/2 (c omega' + qd_m a)^T
// I_r (c omega' + qd_m a), instead of exactly or as armature.
ChainDescription random_chain(std::mt19937& rng, int links, bool free_base, bool geared = false,
                              bool frame_axes = false, bool flexible = false,
                              bool coupled = false) {
  std::uniform_real_distribution<double> u(0, 1);
  ChainDescription d;
  d.free_base = free_base;
  d.base = random_link(rng);
  d.base.mass = 50;
  for (int i = 0; i < links; ++i) {
    d.links.push_back(random_link(rng));
    if (frame_axes) frame_axis_joint(rng, d.links.back(), i);
    if (!geared) continue;
    Gear& g = d.links.back().gear;
    g = {true, 5 + 95 * u(rng), 1e-4 * (1 + u(rng)), 0.6e-4 * (1 + u(rng)), i % 2 == 0};
    if (coupled) g.coupled = true, g.coupling = 0.1 + 0.8 * u(rng);
    if (!flexible || i % 3 == 1) continue;
    g.flexible = true;
    g.stiffness = 50 + 500 * u(rng);
    g.has_damping = i % 3 == 0;  // joints 1 and 7 exact, joint 4 armature
    g.damping = g.has_damping ? 0.5 * u(rng) : 0.0;
  }
  return d;
}

struct Case {
  int links;
  bool free, geared, frame_axes = false, flexible = false, coupled = false;
};
const Case kCases[] = {{7, true, false},
                       {6, false, false},
                       {7, true, true},
                       {6, false, true},
                       {7, true, false, true},
                       {7, true, true, true},
                       {6, false, false, true},
                       {7, true, true, false, true},
                       {6, false, true, true, true},
                       {7, true, true, false, false, true},
                       {6, false, true, true, false, true}};
std::string name(const Case& c) {
  return std::to_string(c.links) + (c.free ? " on a free base" : " on a fixed base") +
         (c.geared ? ", geared" : "") + (c.frame_axes ? ", about frame axes" : "") +
         (c.flexible ? ", flexible" : "") + (c.coupled ? ", rotors coupled by a factor" : "");
}
ChainDescription random_chain(std::mt19937& rng, const Case& c) {
  return random_chain(rng, c.links, c.free, c.geared, c.frame_axes, c.flexible, c.coupled);
}

// The velocity index of joint j's motor, counted here apart from the chain: its slot (past the
// base), or for a flexible joint the next one after all the slots.
int motor_index(const ChainDescription& d, int j) {
  const int slots = d.num_base() + static_cast<int>(d.links.size());
  auto flexible = [&d](int k) { return d.links[k].gear.present && d.links[k].gear.flexible; };
  if (!flexible(j)) return d.num_base() + j;
  int before = 0;
  for (int k = 0; k < j; ++k) before += flexible(k);
  return slots + before;
}

// The independent computation: world rotations by Eigen (URDF's rpy as Rz Ry Rx, the joint by
// AngleAxis), each body's angular velocity and centre-of-mass velocity summed in the world.
struct World {
  std::vector<Eigen::Matrix3d> R;
  std::vector<Eigen::Vector3d> com, com_velocity, omega;
  std::vector<double> mass;
  std::vector<Eigen::Matrix3d> inertia;  // about the com, in the body frame
  // What of a body's angular momentum the system's momentum holds: 1, or a rotor's coupling c
  // (T's derivative by a common rotation of the bodies, as its velocity is c omega' + qd_m a).
  std::vector<double> momentum_share;
  double armature_energy = 0;                         // 1/2 I qd_m^2 of the armature-coupled motors
  Eigen::Vector3d last_origin, last_origin_velocity;  // the last link frame's
  std::vector<Eigen::Vector3d> joint_origins;         // each link frame's, in the world
};

Eigen::Matrix3d inertia_of(const Link& l) {
  const auto i = l.inertia_values();
  Eigen::Matrix3d I;
  I << i[0], i[1], i[2], i[1], i[3], i[4], i[2], i[4], i[5];
  return I;
}

World world(const ChainDescription& d, const Eigen::VectorXd& q, const Eigen::VectorXd& v) {
  World w;
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d p = Eigen::Vector3d::Zero(), pdot = Eigen::Vector3d::Zero(),
                  omega = Eigen::Vector3d::Zero();
  int jq = 0, jv = 0;
  if (d.free_base) {
    R = Eigen::Quaterniond(q[3], q[4], q[5], q[6]).toRotationMatrix();
    p = q.head<3>();
    pdot = v.head<3>();
    omega = R * v.segment<3>(3);
    jq = 7;
    jv = 6;
  }
  auto add_body = [&](const Link& l) {
    const Eigen::Vector3d c = R * Eigen::Vector3d(l.com[0].value, l.com[1].value, l.com[2].value);
    w.R.push_back(R);
    w.com.push_back(p + c);
    w.com_velocity.push_back(pdot + omega.cross(c));
    w.omega.push_back(omega);
    w.mass.push_back(l.mass.value);
    w.inertia.push_back(inertia_of(l));
    w.momentum_share.push_back(1);
  };
  if (d.free_base) add_body(d.base);
  for (size_t i = 0; i < d.links.size(); ++i) {
    const Link& l = d.links[i];
    const Eigen::Vector3d origin(l.origin_xyz[0], l.origin_xyz[1], l.origin_xyz[2]);
    const Eigen::Matrix3d rpy = (Eigen::AngleAxisd(l.origin_rpy[2], Eigen::Vector3d::UnitZ()) *
                                 Eigen::AngleAxisd(l.origin_rpy[1], Eigen::Vector3d::UnitY()) *
                                 Eigen::AngleAxisd(l.origin_rpy[0], Eigen::Vector3d::UnitX()))
                                    .toRotationMatrix();
    const Eigen::Vector3d axis = Eigen::Vector3d(l.axis[0], l.axis[1], l.axis[2]).normalized();
    // A rigid gear's slot holds the motor (qm = p q); a flexible joint's motor has its own.
    const bool rigid_gear = l.gear.present && !l.gear.flexible;
    const double ratio = rigid_gear ? l.gear.ratio.value : 1, link_rate = v[jv + i] / ratio;
    const double qm_rate = v[motor_index(d, static_cast<int>(i))];
    pdot += omega.cross(R * origin);  // the joint's origin moves with the parent body
    p += R * origin;
    if (l.gear.present && (l.gear.exact || l.gear.coupled)) {  // a massless rotor on the parent
      const Eigen::Matrix3d Rr = R * rpy;
      const double c = l.gear.coupled ? l.gear.coupling.value : 1;
      w.R.push_back(Rr);
      w.com.push_back(p);
      w.com_velocity.push_back(pdot);
      w.omega.push_back(c * omega + Rr * axis * qm_rate);
      w.momentum_share.push_back(c);
      w.mass.push_back(0);
      w.inertia.push_back(l.gear.transverse.value * Eigen::Matrix3d::Identity() +
                          (l.gear.axial.value - l.gear.transverse.value) * axis * axis.transpose());
    } else if (l.gear.present) {
      w.armature_energy += 0.5 * l.gear.axial.value * qm_rate * qm_rate;
    }
    R = R * rpy * Eigen::AngleAxisd(q[jq + i] / ratio, axis).toRotationMatrix();
    omega += R * axis * link_rate;
    add_body(l);
    w.last_origin = p;
    w.last_origin_velocity = pdot;
    w.joint_origins.push_back(p);
  }
  return w;
}

double kinetic_energy(const ChainDescription& d, const Eigen::VectorXd& q,
                      const Eigen::VectorXd& v) {
  const World w = world(d, q, v);
  double T = w.armature_energy;
  for (size_t b = 0; b < w.R.size(); ++b)
    T += 0.5 * w.mass[b] * w.com_velocity[b].squaredNorm() +
         0.5 * w.omega[b].dot(w.R[b] * w.inertia[b] * w.R[b].transpose() * w.omega[b]);
  return T;
}

Eigen::Matrix<double, 6, 1> momentum(const ChainDescription& d, const Eigen::VectorXd& q,
                                     const Eigen::VectorXd& v) {
  const World w = world(d, q, v);
  Eigen::Matrix<double, 6, 1> h = Eigen::Matrix<double, 6, 1>::Zero();
  for (size_t b = 0; b < w.R.size(); ++b) {
    const Eigen::Vector3d P = w.mass[b] * w.com_velocity[b];
    h.head<3>() += P;
    h.tail<3>() += w.com[b].cross(P) +
                   w.momentum_share[b] * w.R[b] * w.inertia[b] * w.R[b].transpose() * w.omega[b];
  }
  return h;
}

// T is quadratic in v: M_kl = T(e_k + e_l) - T(e_k) - T(e_l), exactly.
Eigen::MatrixXd polarized_mass_matrix(const ChainDescription& d, const Eigen::VectorXd& q) {
  const int n = d.nv();
  Eigen::MatrixXd M(n, n);
  auto T = [&](const Eigen::VectorXd& v) { return kinetic_energy(d, q, v); };
  for (int k = 0; k < n; ++k)
    for (int l = 0; l < n; ++l) {
      const Eigen::VectorXd ek = Eigen::VectorXd::Unit(n, k), el = Eigen::VectorXd::Unit(n, l);
      M(k, l) = k == l ? 2 * T(ek) : T(ek + el) - T(ek) - T(el);
    }
  return M;
}

struct State {
  Eigen::VectorXd q, v;
};
State random_state(std::mt19937& rng, const ChainDescription& d) {
  std::uniform_real_distribution<double> u(-1, 1);
  State s{Eigen::VectorXd(d.nq()), Eigen::VectorXd(d.nv())};
  for (int i = 0; i < d.nq(); ++i) s.q[i] = 2 * u(rng);
  for (int i = 0; i < d.nv(); ++i) s.v[i] = u(rng);
  if (d.free_base) {
    const Eigen::Quaterniond r = Eigen::Quaterniond::UnitRandom();
    s.q.segment<4>(3) << r.w(), r.x(), r.y(), r.z();
  }
  return s;
}

std::vector<double> as_std(const Eigen::VectorXd& x) { return {x.data(), x.data() + x.size()}; }
Eigen::VectorXd as_eigen(const std::vector<double>& x) {
  return Eigen::Map<const Eigen::VectorXd>(x.data(), x.size());
}
// The inputs of a state by the registry's names.
std::function<double(const std::string&, int)> inputs_of(const State& s) {
  return [s](const std::string& a, int i) { return a == "q" ? s.q[i] : s.v[i]; };
}
Chain<double> chain_at(const ChainDescription& d, const State& s) {
  return Chain<double>(d, Values<double>{inputs_of(s), [](double x) { return x; }});
}
Eigen::VectorXd configuration_rate(const ChainDescription& d, const State& s) {
  const Values<double> values{inputs_of(s), [](double x) { return x; }};
  Eigen::VectorXd qdot(d.nq());
  for (int i = 0; i < d.nq(); ++i) qdot[i] = Chain<double>::configuration_rate(d, values, i);
  return qdot;
}
Eigen::MatrixXd mass_matrix(const ChainDescription& d, const State& s) {
  const std::vector<double> M = chain_at(d, s).mass_matrix();
  return Eigen::Map<const Eigen::Matrix<double, -1, -1, Eigen::RowMajor>>(M.data(), d.nv(), d.nv());
}

// A 7-joint arm on a free base (13 velocities) and a 6-joint arm on a fixed base, each without
// and with geared motors (exact and armature), at random states: M, T and the momentum are the
// world computation's.
TEST(SpatialChain, MassMatrixEnergyAndMomentumAreTheWorldComputations) {
  std::mt19937 rng(31);
  for (const Case& c : kCases) {
    const auto [links, free, geared, frame_axes, flexible, coupled] = c;
    const ChainDescription d = random_chain(rng, c);
    SCOPED_TRACE(name(c));
    const auto springs = std::count_if(d.links.begin(), d.links.end(),
                                       [](const Link& l) { return l.gear.stiffness.value > 0; });
    ASSERT_EQ(d.nv(), links + (free ? 6 : 0) + springs);
    ASSERT_EQ(d.nq(), d.nv() + (free ? 1 : 0));
    for (int trial = 0; trial < 3; ++trial) {
      const State s = random_state(rng, d);
      const Chain<double> chain = chain_at(d, s);
      const Eigen::MatrixXd M = mass_matrix(d, s), M_world = polarized_mass_matrix(d, s.q);
      EXPECT_LT((M - M_world).norm(), 1e-12 * M_world.norm());
      EXPECT_LT((M - M.transpose()).norm(), 1e-14 * M.norm());
      EXPECT_GT(Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(M).eigenvalues().minCoeff(), 0);
      const double T = kinetic_energy(d, s.q, s.v);
      EXPECT_NEAR(chain.kinetic_energy(), T, 1e-12 * T);
      EXPECT_NEAR(0.5 * s.v.dot(M * s.v), T, 1e-12 * T);
      EXPECT_LT((as_eigen(chain.generalized_momentum()) - M * s.v).norm(),
                1e-12 * (M * s.v).norm());
      if (free) {
        const std::vector<double> h = chain.momentum();
        const Eigen::Matrix<double, 6, 1> h_world = momentum(d, s.q, s.v);
        EXPECT_LT((Eigen::Map<const Eigen::Matrix<double, 6, 1>>(h.data()) - h_world).norm(),
                  1e-12 * h_world.norm());
      }
    }
  }
}

// Recursive Newton-Euler: Q(vdot) - Q(0) = M vdot; and with no force (vdot = -M^-1 b) the
// world computation's momentum and energy do not change: d/dt by central differences along
// qdot = f(q, v) (the quaternion's rate included) and vdot. A wrong gyroscopic or base term
// shows here.
TEST(SpatialChain, InverseDynamicsConservesMomentumAndEnergy) {
  std::mt19937 rng(32);
  for (const Case& c : kCases) {
    const auto [links, free, geared, frame_axes, flexible, coupled] = c;
    const ChainDescription d = random_chain(rng, c);
    SCOPED_TRACE(name(c));
    for (int trial = 0; trial < 3; ++trial) {
      const State s = random_state(rng, d);
      const Chain<double> chain = chain_at(d, s);
      const Eigen::MatrixXd M = mass_matrix(d, s);
      const Eigen::VectorXd b = as_eigen(chain.inverse_dynamics(std::vector<double>(d.nv(), 0.0)));
      const Eigen::VectorXd a = Eigen::VectorXd::Random(d.nv());
      const Eigen::VectorXd Ma = as_eigen(chain.inverse_dynamics(as_std(a))) - b;
      EXPECT_LT((Ma - M * a).norm(), 1e-12 * (M * a).norm());
      const Eigen::VectorXd vdot = M.ldlt().solve(-b);
      const Eigen::VectorXd qdot = configuration_rate(d, s);
      const double eps = 1e-5;
      auto at = [&](double t) { return State{s.q + t * qdot, s.v + t * vdot}; };
      const State plus = at(eps), minus = at(-eps);
      const double dT =
          (kinetic_energy(d, plus.q, plus.v) - kinetic_energy(d, minus.q, minus.v)) / (2 * eps);
      EXPECT_LT(std::abs(dT), 1e-7 * (1 + kinetic_energy(d, s.q, s.v)));
      if (free) {
        const Eigen::VectorXd dh =
            (momentum(d, plus.q, plus.v) - momentum(d, minus.q, minus.v)) / (2 * eps);
        EXPECT_LT(dh.norm(), 1e-7 * (1 + momentum(d, s.q, s.v).norm()));
      }
    }
  }
}

// A joint torque is internal to a free-floating system: it changes no momentum, and the base
// reacts to it.
TEST(SpatialChain, AJointTorqueLeavesTheMomentumOfAFreeBaseUnchanged) {
  std::mt19937 rng(33);
  const ChainDescription d = random_chain(rng, 6, true);
  const State s = random_state(rng, d);
  const Chain<double> chain = chain_at(d, s);
  const Eigen::MatrixXd M = mass_matrix(d, s);
  const Eigen::VectorXd b = as_eigen(chain.inverse_dynamics(std::vector<double>(d.nv(), 0.0)));
  Eigen::VectorXd Q = Eigen::VectorXd::Zero(d.nv());
  Q[6] = 3.0;
  const Eigen::VectorXd vdot = M.ldlt().solve(Q - b);
  const Eigen::VectorXd qdot = configuration_rate(d, s);
  const double eps = 1e-5;
  const Eigen::VectorXd dh = (momentum(d, s.q + eps * qdot, s.v + eps * vdot) -
                              momentum(d, s.q - eps * qdot, s.v - eps * vdot)) /
                             (2 * eps);
  EXPECT_LT(dh.norm(), 1e-7 * (1 + momentum(d, s.q, s.v).norm()));
  EXPECT_GT(vdot.head<6>().norm(), 1e-3);  // the base reacts
}

// Exact against armature coupling on the same arm: the rotor's axial inertia sits on its motor
// coordinate in both, and what exact coupling adds is the rotor's share of the angular momentum
// (I_axial a qd_m, with a the rotor's axis in the world) and its coupling to the parent's
// rotation. A gear of ratio 1 with no rotor is no gear at all.
TEST(SpatialChain, ExactRotorsAddTheirAngularMomentumToArmature) {
  std::mt19937 rng(36);
  ChainDescription exact = random_chain(rng, 7, true, true);
  const int joint = 3, col = 6 + joint;  // one motor, at joint 4; the rest are not geared
  for (int j = 0; j < 7; ++j) exact.links[j].gear.present = j == joint;
  exact.links[joint].gear.exact = true;
  ChainDescription armature = exact;
  armature.links[joint].gear.exact = false;
  State s = random_state(rng, exact);
  s.v.setZero();
  s.v[col] = 50.0;  // only motor 4 turns: its parent is at rest
  const Eigen::VectorXd h_exact = as_eigen(chain_at(exact, s).momentum()),
                        h_armature = as_eigen(chain_at(armature, s).momentum());
  const World w = world(exact, s.q, s.v);
  // The rotor's axis in the world: the parent's rotation and the joint's origin rpy.
  const Link& l = exact.links[joint];
  const Eigen::Vector3d axis = Eigen::Vector3d(l.axis[0], l.axis[1], l.axis[2]).normalized();
  const Eigen::Matrix3d R_parent = w.R[joint];  // the base and links 1..3, then the rotor
  const Eigen::Matrix3d rpy = (Eigen::AngleAxisd(l.origin_rpy[2], Eigen::Vector3d::UnitZ()) *
                               Eigen::AngleAxisd(l.origin_rpy[1], Eigen::Vector3d::UnitY()) *
                               Eigen::AngleAxisd(l.origin_rpy[0], Eigen::Vector3d::UnitX()))
                                  .toRotationMatrix();
  const Eigen::Vector3d expected = l.gear.axial.value * 50.0 * R_parent * rpy * axis;
  EXPECT_LT((h_exact.head<3>() - h_armature.head<3>()).norm(), 1e-12 * h_exact.norm());
  EXPECT_LT((h_exact.tail<3>() - h_armature.tail<3>() - expected).norm(), 1e-12 * expected.norm());
  const Eigen::MatrixXd M_exact = mass_matrix(exact, s), M_armature = mass_matrix(armature, s);
  EXPECT_NEAR(M_exact(col, col), M_armature(col, col), 1e-12 * M_exact(col, col));
  EXPECT_GT((M_exact - M_armature).norm(), 1e-6);
  ChainDescription unit = random_chain(rng, 5, true);
  const State u = random_state(rng, unit);
  const Eigen::MatrixXd M_plain = mass_matrix(unit, u);
  for (Link& k : unit.links) k.gear = {true, 1.0, 0.0, 0.0, true};
  EXPECT_LT((mass_matrix(unit, u) - M_plain).norm(), 1e-14 * M_plain.norm());
}

// The plane as a special case: a spatial arm whose axes are all z, its links along x, moving in
// the plane, has the planar model's M and bias (planar_chain.cpp, the planar scene's
// recursive forms) on the planar coordinates: base x0, y0, q0 (a free base turned by q0 about
// z), then the motor angles of geared joints, rotors exactly coupled; with flexible joints 1 and
// 3 (springs and dampers), their link angles in the slots and the motor angles after them.
TEST(SpatialChain, ThePlaneIsASpecialCase) {
  const std::array<double, 4> mass = {1.281, 3.917, 0.912, 2.736},
                              inertia = {0.0665, 0.0142, 0.0378, 0.0435},
                              length = {0.50, 0.45, 0.40, 0.30}, cx = {0.194, 0.122, 0.095, 0.066},
                              cy = {-0.0041, -0.0142, 0.0033, -0.0176}, ratio = {50, 3.5, 20, 1},
                              rotor = {2e-4, 1e-3, 5e-4, 0};
  for (const bool free : {false, true})
    for (const bool flexible : {false, true}) {
      SCOPED_TRACE(std::string(free ? "free base" : "fixed base") + (flexible ? ", flexible" : ""));
      std::string yaml =
          std::string("name: plane\nbase: ") +
          (free ? "{type: free_floating, mass: 30.5, inertia: 1.25, mount: [0.3, 0.02]}"
                : "{type: fixed, mount: [0.3, 0.02]}") +
          "\nlinks:\n";
      ChainDescription d;
      d.free_base = free;
      d.base.mass = 30.5;
      d.base.inertia = {0.9, 0, 0, 0.8, 0, 1.25};  // only izz acts in the plane
      std::string gears = "gears:\n";
      for (int i = 0; i < 4; ++i) {
        yaml += "  - {mass: " + std::to_string(mass[i]) +
                ", inertia: " + std::to_string(inertia[i]) +
                ", length: " + std::to_string(length[i]) + ", com: [" + std::to_string(cx[i]) +
                ", " + std::to_string(cy[i]) + "]}\n";
        const bool spring = flexible && i % 2 == 0;
        gears +=
            "  - {ratio: " + std::to_string(ratio[i]) +
            ", motor_inertia: " + std::to_string(rotor[i]) + ", compensate_link_inertia: false" +
            (spring ? ", stiffness: " + std::to_string(300.0 + 100 * i) + ", damping: 0.2" : "") +
            "}\n";
        Link l;
        l.origin_xyz = {i == 0 ? 0.3 : length[i - 1], i == 0 ? 0.02 : 0.0, 0.0};
        l.axis = {0, 0, 1};
        l.mass = mass[i];
        l.com = {cx[i], cy[i], 0};
        l.inertia = {0.5 * inertia[i], 0, 0, 0.7 * inertia[i], 0, inertia[i]};
        l.gear = {true, ratio[i], rotor[i], 0.3 * rotor[i], true};
        l.gear.flexible = l.gear.has_damping = spring;
        l.gear.stiffness = spring ? 300.0 + 100 * i : 0.0;
        l.gear.damping = spring ? 0.2 : 0.0;
        d.links.push_back(l);
      }
      // Friction on the motor rates, as the plane's (the same law, one field for all joints).
      const std::string friction =
          "friction: {viscous: 0.01, coulomb: 0.2, velocity_scale: 0.05, stribeck_static: 0.3, "
          "stribeck_velocity: 0.4}\n";
      for (Link& l : d.links) l.friction = {true, 0.01, 0.2, 0.05, 0.3, 0.4, true, true};
      const Scene scene = parse_scene(yaml + gears + friction, "plane.yaml");
      // A planar state, and the spatial one it is.
      const Eigen::VectorXd q2 = Eigen::VectorXd::Random(scene.num_coordinates()),
                            v2 = Eigen::VectorXd::Random(scene.num_velocities());
      State s3{Eigen::VectorXd::Zero(d.nq()), Eigen::VectorXd::Zero(d.nv())};
      std::vector<int> planar_rows;  // the spatial velocity index of each planar one
      if (free) {
        s3.q.head<2>() = q2.head<2>();
        s3.q.segment<4>(3) << std::cos(q2[2] / 2), 0, 0, std::sin(q2[2] / 2);
        s3.v.head<2>() = v2.head<2>();
        s3.v[5] = v2[2];
        planar_rows = {0, 1, 5};
      }
      const int jq = free ? 7 : 0, jv = free ? 6 : 0, j2 = free ? 3 : 0;
      for (int i = 0; i < scene.num_velocities() - j2; ++i) {  // the slots, then the motors
        s3.q[jq + i] = q2[j2 + i];
        s3.v[jv + i] = v2[j2 + i];
        planar_rows.push_back(jv + i);
      }
      auto planar = [&](Output o) {
        const std::vector<double> r =
            evaluate_recursive(scene, o, [&](const std::string& a, int i) {
              return a == "q" ? q2[i] : a == "qd" ? v2[i] : 0.0;
            })[0];
        return as_eigen(r);
      };
      const int n = scene.num_velocities();
      const Eigen::MatrixXd M2 = Eigen::Map<const Eigen::Matrix<double, -1, -1, Eigen::RowMajor>>(
          planar(Output::mass_matrix).data(), n, n);
      const Eigen::VectorXd b2 = planar(Output::bias_forces);
      const Eigen::MatrixXd M3 = mass_matrix(d, s3);
      const Eigen::VectorXd b3 =
          as_eigen(chain_at(d, s3).inverse_dynamics(std::vector<double>(d.nv(), 0.0)));
      const Eigen::VectorXd qdd2 = planar(Output::forward_dynamics),
                            qdd3 = as_eigen(chain_at(d, s3).forward_dynamics(
                                std::vector<double>(d.nv(), 0.0))[0]);
      for (int r = 0; r < n; ++r) {
        EXPECT_NEAR(b3[planar_rows[r]], b2[r], 1e-12 * (1 + b2.norm())) << r;
        EXPECT_NEAR(qdd3[planar_rows[r]], qdd2[r], 1e-10 * (1 + qdd2.norm())) << r;
        for (int c = 0; c < n; ++c)
          EXPECT_NEAR(M3(planar_rows[r], planar_rows[c]), M2(r, c), 1e-12 * M2.norm()) << r << c;
      }
    }
}

// A free base started in the plane (every axis along z, every mass in z = 0, no products of
// inertia with z, velocities in the plane) stays there over a long free motion: through the
// runtime's integrator with the quaternion's dq/dt and projection (configuration_space.hpp).
TEST(SpatialChain, AFreeBaseStartedInThePlaneStaysThere) {
  ChainDescription d;
  d.base.mass = 40;
  d.base.com = {0.1, -0.05, 0};
  d.base.inertia = {3, 0, 0, 4, 0, 5};
  for (int i = 0; i < 3; ++i) {
    Link l;
    l.origin_xyz = {i == 0 ? 0.5 : 0.4, 0.05, 0};
    l.axis = {0, 0, 1};
    l.mass = 3.0 - i;
    l.com = {0.2, 0.01 * i, 0};
    l.inertia = {0.02, 0.001, 0, 0.1, 0, 0.11};
    l.gear = {true, 20.0 + 10 * i, 1e-4, 6e-5, i != 1};  // exact and armature rotors
    d.links.push_back(l);
  }
  const ConfigurationSpace space{d.nq(), d.nv(), 3};
  Eigen::VectorXd x(d.nq() + d.nv());
  x << 0.1, 0.2, 0, std::cos(0.2), 0, 0, std::sin(0.2), 5, -10, 20,  // q: origin, yaw 0.4, qm
      0.3, -0.2, 0, 0, 0, 0.5, 30, -40, 25;                          // v: in the plane
  auto f = [&](const Eigen::VectorXd& s, Eigen::VectorXd& dsdt, double) {
    const State at{s.head(d.nq()), s.tail(d.nv())};
    dsdt.resize(s.size());
    dsdt.head(d.nq()) = space.rate(at.q, at.v);
    dsdt.tail(d.nv()) =
        as_eigen(chain_at(d, at).forward_dynamics(std::vector<double>(d.nv(), 0.0))[0]);
  };
  IntegratorOptions opt;
  opt.method = Method::rkf78;
  opt.rtol = opt.atol = 1e-11;
  opt.project = [&](Eigen::Ref<Eigen::VectorXd> s) {
    auto q = s.head(d.nq());
    space.project(q);
  };
  // The runtime's dq/dt is the one the generator differentiates (the state Jacobian's).
  std::mt19937 rng(12);
  const State random = random_state(rng, d);
  EXPECT_LT((space.rate(random.q, random.v) - configuration_rate(d, random)).norm(), 1e-15);
  double out_of_plane = 0;
  integrate(opt, f, x, 0.0, 3.0, 0.1, [&](const Eigen::VectorXd& s, double) {
    // z, the quaternion's x and y, vz, wx, wy
    for (int k : {2, 4, 5, d.nq() + 2, d.nq() + 3, d.nq() + 4})
      out_of_plane = std::max(out_of_plane, std::abs(s[k]));
  });
  EXPECT_LT(out_of_plane, 1e-13);
  EXPECT_GT(std::abs(x[6] - std::sin(0.2)), 1e-3);  // it did turn about z
}

// The same definition recorded (Sym): the program's values are the double run's, bit for bit
// up to the program's own order of operations.
TEST(SpatialChain, RecordedProgramsGiveTheDoubleValues) {
  std::mt19937 rng(35);
  const ChainDescription d = random_chain(rng, 7, true);
  const State s = random_state(rng, d);
  Program p;
  const Values<Sym> values{[&p](const std::string& a, int i) { return Sym(&p, p.input(a, i)); },
                           [&p](double v) { return Sym::number(&p, v); }};
  const Chain<Sym> recorded(d, values);
  std::vector<SRef> roots;
  for (const Sym& x : recorded.mass_matrix()) roots.push_back(x.ref());
  for (const Sym& x : recorded.inverse_dynamics(std::vector<Sym>(d.nv(), Sym{})))
    roots.push_back(x.ref());
  const std::vector<double> values_of = p.evaluate(roots, inputs_of(s));
  const Chain<double> chain = chain_at(d, s);
  std::vector<double> expected = chain.mass_matrix();
  for (double b : chain.inverse_dynamics(std::vector<double>(d.nv(), 0.0))) expected.push_back(b);
  ASSERT_EQ(values_of.size(), expected.size());
  for (size_t k = 0; k < expected.size(); ++k)
    EXPECT_NEAR(values_of[k], expected[k], 1e-12 * (1 + std::abs(expected[k]))) << k;
}

// The articulated-body algorithm eliminates from the tip inward (joints N to 1, each with a
// flexible joint's rotor, a leaf on the parent), then the free base in its own frame, linear
// before angular: its pivots are those of Gaussian elimination of T M T^T in that order, with T
// turning the base's world-linear rows into the base frame.
Eigen::VectorXd tip_first_pivots(const ChainDescription& d, const State& s,
                                 const Eigen::MatrixXd& M) {
  const int n = d.nv(), nb = d.num_base();
  Eigen::MatrixXd T = Eigen::MatrixXd::Identity(n, n);
  if (d.free_base)
    T.topLeftCorner<3, 3>() =
        Eigen::Quaterniond(s.q[3], s.q[4], s.q[5], s.q[6]).toRotationMatrix().transpose();
  std::vector<int> order;
  for (int j = static_cast<int>(d.links.size()) - 1; j >= 0; --j) {
    order.push_back(nb + j);
    if (motor_index(d, j) != nb + j) order.push_back(motor_index(d, j));
  }
  for (int i = 0; i < nb; ++i) order.push_back(i);
  const Eigen::MatrixXd turned = T * M * T.transpose();
  Eigen::MatrixXd A(n, n);
  for (int a = 0; a < n; ++a)
    for (int b = 0; b < n; ++b) A(a, b) = turned(order[a], order[b]);
  Eigen::VectorXd pivots(n);
  for (int k = 0; k < n; ++k) {  // without pivoting (Eigen's LDLT reorders by size)
    pivots[order[k]] = A(k, k);
    for (int i = k + 1; i < n; ++i)
      for (int j = k + 1; j < n; ++j) A(i, j) -= A(i, k) * A(k, j) / A(k, k);
  }
  return pivots;
}

// Forward dynamics by the articulated-body algorithm (exact rotors as clusters with their links,
// armature on the diagonal, a flexible joint's rotor a leaf) solves M qdd + b + f = Q (f: the
// springs and dampers), and its pivots are the tip-first ones of M.
TEST(SpatialChain, ForwardDynamicsIsTheArticulatedBodyAlgorithm) {
  std::mt19937 rng(43);
  for (const Case& c : kCases) {
    SCOPED_TRACE(name(c));
    const ChainDescription d = random_chain(rng, c);
    for (int trial = 0; trial < 3; ++trial) {
      const State s = random_state(rng, d);
      const Chain<double> chain = chain_at(d, s);
      const Eigen::VectorXd Q = Eigen::VectorXd::Random(d.nv());
      const auto fd = chain.forward_dynamics(std::vector<double>(Q.data(), Q.data() + Q.size()));
      const Eigen::MatrixXd M = mass_matrix(d, s);
      const Eigen::VectorXd b = as_eigen(chain.inverse_dynamics(std::vector<double>(d.nv(), 0)));
      const Eigen::VectorXd qdd = as_eigen(fd[0]), pivots = as_eigen(fd[1]);
      const Eigen::VectorXd f = as_eigen(chain.spring_damper_forces());
      EXPECT_EQ(f.norm() > 0, c.flexible);
      const Eigen::VectorXd expected = M.ldlt().solve(Q - b - f);
      EXPECT_LT((qdd - expected).norm(), 1e-10 * (1 + expected.norm()));
      const Eigen::VectorXd D = tip_first_pivots(d, s, M);
      EXPECT_LT((pivots - D).norm(), 1e-10 * D.norm());
      EXPECT_LT((as_eigen(fd[2]) - D.cwiseQuotient(M.diagonal())).norm(), 1e-10 * D.size());
    }
  }
}

// The registry's outputs through recursive_algorithms.hpp, written once for any chain: forward
// dynamics solves M qdd + b + f = Q (f: springs and dampers) with positive pivots, and the state
// Jacobian (dual numbers; dqdd/dq on q's tangent space, nv x nv, the base's quaternion turned in
// its own frame) is that of central differences of forward dynamics along q ⊕ delta, with rigid
// gears and with flexible joints; it is the same for the quaternion scaled by 3 (every model
// ignores its norm); dqdd/dtau is the response to each joint's torque.
TEST(SpatialChain, GivesTheRegistrysRecursiveOutputs) {
  std::mt19937 rng(38);
  for (const bool flexible : {false, true}) {
    SCOPED_TRACE(flexible ? "flexible" : "rigid gears");
    const ChainDescription d = random_chain(rng, 7, true, true, false, flexible);
    const State s = random_state(rng, d);
    const Eigen::VectorXd Q = Eigen::VectorXd::Random(d.nv());
    auto at = [&](const State& x) {
      return [x, Q](const std::string& a, int i) {
        return a == "q" ? x.q[i] : a == "Q" ? Q[i] : x.v[i];
      };
    };
    auto output = [&](Output o, const State& x) { return evaluate_chain<Chain>(d, o, at(x)); };
    ASSERT_EQ(Chain<double>::dimensions(d).nq, flexible ? 19 : 14);
    const Eigen::VectorXd qdd = as_eigen(output(Output::forward_dynamics, s)[0]);
    const Eigen::MatrixXd M = mass_matrix(d, s);
    const Eigen::VectorXd b = as_eigen(output(Output::bias_forces, s)[0]);
    const Eigen::VectorXd f = as_eigen(chain_at(d, s).spring_damper_forces());
    EXPECT_LT((M * qdd + b + f - Q).norm(), 1e-12 * (1 + Q.norm() + (M * qdd).norm()));
    EXPECT_GT(as_eigen(output(Output::forward_dynamics, s)[1]).minCoeff(), 0);
    const auto J = output(Output::forward_dynamics_derivatives, s);
    ASSERT_EQ(J[0].size(), size_t(d.nv() * d.nv()));
    const Eigen::MatrixXd dq = Eigen::Map<const Eigen::Matrix<double, -1, -1, Eigen::RowMajor>>(
                              J[0].data(), d.nv(), d.nv()),
                          dv = Eigen::Map<const Eigen::Matrix<double, -1, -1, Eigen::RowMajor>>(
                              J[1].data(), d.nv(), d.nv());
    State scaled = s;
    scaled.q.segment<4>(3) *= 3;
    const auto J3 = output(Output::forward_dynamics_derivatives, scaled);
    for (size_t k = 0; k < J[0].size(); ++k)
      EXPECT_NEAR(J3[0][k], J[0][k], 1e-9 * (1 + std::abs(J[0][k]))) << k;
    // dqdd/dtau: joint j's torque enters as tau / p on the coordinate it drives (the
    // description's motor_coordinate); qdd is affine in Q, so one difference per joint.
    const int N = static_cast<int>(d.links.size());
    ASSERT_EQ(J.size(), 4u);
    ASSERT_EQ(J[3].size(), size_t(d.nv() * N));
    auto qdd_with = [&](const Eigen::VectorXd& Qx) {
      return as_eigen(
          evaluate_chain<Chain>(d, Output::forward_dynamics, [&](const std::string& a, int i) {
            return a == "q" ? s.q[i] : a == "Q" ? Qx[i] : s.v[i];
          })[0]);
    };
    for (int j = 0; j < N; ++j) {
      const Gear& g = d.links[j].gear;
      ASSERT_FALSE(g.ratio.is_parameter());
      Eigen::VectorXd dQ = Eigen::VectorXd::Zero(d.nv());
      dQ[d.motor_coordinate(j)] = g.present ? 1 / g.ratio.value : 1;
      const Eigen::VectorXd column = (qdd_with(Q + dQ) - qdd_with(Q - dQ)) / 2;
      for (int r = 0; r < d.nv(); ++r)
        EXPECT_NEAR(J[3][r * N + j], column[r], 1e-9 * (1 + column.norm())) << "tau " << j;
    }
    const double h = 1e-6;
    // Central differences round off by about eps |qdd| / h: with flexible joints a light rotor's
    // own acceleration (Q_m / J, J = 1e-4) makes |qdd| some 1e4, so 1e-9 |qdd| is added.
    const double rounding = 1e-9 * qdd.norm();
    for (int k = 0; k < d.nv(); ++k) {
      State plus = s, minus = s;
      const Eigen::VectorXd step = h * Eigen::VectorXd::Unit(d.nv(), k);
      plus.q = test::moved_along_tangent(s.q, step);
      minus.q = test::moved_along_tangent(s.q, -step);
      const Eigen::VectorXd column = (as_eigen(output(Output::forward_dynamics, plus)[0]) -
                                      as_eigen(output(Output::forward_dynamics, minus)[0])) /
                                     (2 * h);
      EXPECT_LT((dq.col(k) - column).norm(), 1e-6 * (1 + column.norm()) + rounding) << "q " << k;
    }
    // The base origin's velocity moves no acceleration (a Galilean boost of the whole system):
    // its three columns are exact zeros, never differentiated, and the differences agree below.
    EXPECT_EQ(dv.leftCols(3).cwiseAbs().maxCoeff(), 0);
    for (int k = 0; k < d.nv(); ++k) {
      State plus = s, minus = s;
      plus.v[k] += h;
      minus.v[k] -= h;
      const Eigen::VectorXd column = (as_eigen(output(Output::forward_dynamics, plus)[0]) -
                                      as_eigen(output(Output::forward_dynamics, minus)[0])) /
                                     (2 * h);
      EXPECT_LT((dv.col(k) - column).norm(), 1e-6 * (1 + column.norm()) + rounding) << "v " << k;
    }
  }
}

// The generalized Jacobian against the world computation alone: the base velocity that keeps the
// world momentum zero is solved from the momentum's six columns, and the world tip twist it
// gives with the joint rates is J* qd; free-base inverse dynamics leaves the base unforced.
TEST(SpatialChain, GeneralizedJacobianKeepsTheWorldMomentumZero) {
  std::mt19937 rng(47);
  for (const bool geared : {false, true}) {
    SCOPED_TRACE(geared ? "geared" : "no gears");
    ChainDescription d = random_chain(rng, 7, true, geared);
    d.end_effectors[0].xyz = {0.2, -0.05, 0.1};
    const State s = random_state(rng, d);
    const int N = 7;
    const Eigen::VectorXd qd = s.v.tail(N);
    // h(v) is linear in v: h = H_b v_b + h(0, qd).
    Eigen::VectorXd v = Eigen::VectorXd::Zero(d.nv());
    v.tail(N) = qd;
    const Eigen::Matrix<double, 6, 1> h_joints = momentum(d, s.q, v);
    Eigen::Matrix<double, 6, 6> Hb;
    for (int k = 0; k < 6; ++k) Hb.col(k) = momentum(d, s.q, Eigen::VectorXd::Unit(d.nv(), k));
    v.head(6) = -Hb.lu().solve(h_joints);
    ASSERT_LT(momentum(d, s.q, v).norm(), 1e-12);
    const World w = world(d, s.q, v);
    const Eigen::Vector3d tip =
        w.R.back() * Eigen::Vector3d(d.end_effectors[0].xyz[0], d.end_effectors[0].xyz[1],
                                     d.end_effectors[0].xyz[2]);
    Eigen::Matrix<double, 6, 1> twist;
    twist << w.last_origin_velocity + w.omega.back().cross(tip), w.omega.back();
    const std::vector<double> Jg = chain_at(d, s).generalized_jacobian();
    const Eigen::VectorXd predicted =
        Eigen::Map<const Eigen::Matrix<double, -1, -1, Eigen::RowMajor>>(Jg.data(), 6, N) * qd;
    EXPECT_LT((predicted - twist).norm(), 1e-12 * (1 + twist.norm()));
    // Free-base inverse dynamics: RNEA at [qdd_base, p qdd_joints] gives tau / p on the joints
    // and nothing on the base.
    const Eigen::VectorXd joints = Eigen::VectorXd::Random(N);
    const auto out = chain_at(d, s).free_base_inverse_dynamics(as_std(joints));
    Eigen::VectorXd vdot(d.nv());
    vdot.head(6) = as_eigen(out[1]);
    for (int j = 0; j < N; ++j) {
      const double p = d.links[j].gear.present ? d.links[j].gear.ratio.value : 1;
      vdot[6 + j] = p * joints[j];
    }
    const Eigen::VectorXd Q = as_eigen(chain_at(d, s).inverse_dynamics(as_std(vdot)));
    EXPECT_LT(Q.head(6).norm(), 1e-10 * (1 + Q.norm()));
    for (int j = 0; j < N; ++j) {
      const double p = d.links[j].gear.present ? d.links[j].gear.ratio.value : 1;
      EXPECT_NEAR(out[0][j], p * Q[6 + j], 1e-10 * (1 + std::abs(out[0][j])));
    }
  }
}

// Joint friction (as in the plane, on each coordinate's rate: the motor's where geared) opposes
// every joint's motion and takes the kinetic energy out at its power: along free motion
// (Q = 0, forward dynamics with friction) dT/dt = -v^T f, T the world computation's, dT/dt by
// central differences along (qdot, qdd).
TEST(SpatialChain, FrictionOpposesEachJointAndTakesEnergyOutAtItsPower) {
  std::mt19937 rng(61);
  std::uniform_real_distribution<double> u(0, 1);
  for (const Case& c : kCases) {
    SCOPED_TRACE(name(c));
    ChainDescription d = random_chain(rng, c);
    for (size_t j = 0; j < d.links.size(); ++j) {
      Friction& f = d.links[j].friction;
      f.present = j != 1;  // one joint without
      f.viscous = 0.01 * u(rng);
      f.coulomb = j % 3 == 0 ? 0.0 : 0.1 * u(rng);
      f.stribeck_static = f.coulomb.value * (j % 2 == 0 ? 1.0 : 1.5);
      f.velocity_scale = 0.05 + u(rng);
      f.stribeck_velocity = 0.1 + u(rng);
      f.has_coulomb = f.coulomb.value != 0;
      f.has_stribeck = f.stribeck_static.value != f.coulomb.value;
    }
    const State s = random_state(rng, d);
    const int n = d.nv(), nb = d.num_base();
    const Chain<double> chain = chain_at(d, s);
    const Eigen::VectorXd f = as_eigen(chain.friction_forces());
    EXPECT_EQ(f.head(nb).norm(), 0.0);
    for (size_t j = 0; j < d.links.size(); ++j) {
      const Friction& fr = d.links[j].friction;
      const int m = motor_index(d, static_cast<int>(j));  // the motor's rate, as in the plane
      const double w = s.v[m], sign = std::tanh(w / fr.velocity_scale.value);
      const double want =
          !fr.present ? 0.0
                      : fr.viscous.value * w + fr.coulomb.value * sign +
                            (fr.stribeck_static.value - fr.coulomb.value) *
                                std::exp(-std::pow(w / fr.stribeck_velocity.value, 2)) * sign;
      EXPECT_NEAR(f[m], want, 1e-15) << "joint " << j + 1;
      if (fr.present) {
        EXPECT_GT(f[m] * w, 0) << "joint " << j + 1 << " does not oppose";
      }
      if (m != nb + static_cast<int>(j)) {
        EXPECT_EQ(f[nb + j], 0.0) << "a flexible joint's slot";
      }
    }
    // With flexible joints the springs and dampers act too (their own test checks them).
    const Eigen::VectorXd springs = as_eigen(chain.spring_damper_forces());
    const Eigen::VectorXd qdd = as_eigen(chain.forward_dynamics(std::vector<double>(n, 0.0))[0]);
    const Eigen::VectorXd b = as_eigen(chain.inverse_dynamics(std::vector<double>(n, 0.0)));
    EXPECT_LT((mass_matrix(d, s) * qdd + b + f + springs).norm(), 1e-10 * (1 + b.norm()));
    const Eigen::VectorXd qdot = configuration_rate(d, s);
    const double h = 1e-5;
    const double dT = (kinetic_energy(d, s.q + h * qdot, s.v + h * qdd) -
                       kinetic_energy(d, s.q - h * qdot, s.v - h * qdd)) /
                      (2 * h);
    EXPECT_LT(-s.v.dot(f), 0);
    const double power = -s.v.dot(f + springs);
    EXPECT_NEAR(dT, power, 1e-7 * (1 + std::abs(power))) << "friction's power " << power;
  }
}

// The flexible joints' springs and dampers, written here from their definition: V = sum 1/2 k
// (qm/p - q)^2 and the Rayleigh function D = sum 1/2 d (qmd/p - qd)^2. The chain's potential
// energy is V, its spring_damper_forces are dV/dq + dD/dqd (central differences); along free
// motion (Q = 0) the world computation's T + V falls at the dampers' power 2 D, and a free base's
// momentum stays (the springs are internal).
TEST(SpatialChain, SpringsStoreEnergyAndDampersTakeItOut) {
  std::mt19937 rng(67);
  for (const Case& c : kCases) {
    if (!c.flexible) continue;
    SCOPED_TRACE(name(c));
    const ChainDescription d = random_chain(rng, c);
    const int n = d.nv(), jq = d.free_base ? 7 : 0, jv = d.num_base();
    const int past_quaternion = d.free_base ? 1 : 0;
    auto sum_over_springs = [&](const Eigen::VectorXd& x, int jx, int shift, bool damper) {
      double sum = 0;
      for (size_t j = 0; j < d.links.size(); ++j) {
        const Gear& g = d.links[j].gear;
        if (!g.flexible) continue;
        const double e = x[motor_index(d, static_cast<int>(j)) + shift] / g.ratio.value - x[jx + j];
        sum += 0.5 * (damper ? g.damping.value : g.stiffness.value) * e * e;
      }
      return sum;
    };
    auto V = [&](const Eigen::VectorXd& q) {
      return sum_over_springs(q, jq, past_quaternion, false);
    };
    auto D = [&](const Eigen::VectorXd& v) { return sum_over_springs(v, jv, 0, true); };
    const State s = random_state(rng, d);
    const Chain<double> chain = chain_at(d, s);
    EXPECT_NEAR(chain.potential_energy(), V(s.q), 1e-12 * V(s.q));
    const Eigen::VectorXd f = as_eigen(chain.spring_damper_forces());
    const double h = 1e-6;
    for (int k = 0; k < n; ++k) {
      const int kq = k >= jv ? k + past_quaternion : k;  // the base's entries have no spring
      const Eigen::VectorXd eq = h * Eigen::VectorXd::Unit(d.nq(), kq),
                            ev = h * Eigen::VectorXd::Unit(n, k);
      const double expected =
          k < jv ? 0.0 : (V(s.q + eq) - V(s.q - eq) + D(s.v + ev) - D(s.v - ev)) / (2 * h);
      EXPECT_NEAR(f[k], expected, 1e-6 * (1 + f.norm())) << k;
    }
    const Eigen::VectorXd qdd = as_eigen(chain.forward_dynamics(std::vector<double>(n, 0.0))[0]);
    const Eigen::VectorXd qdot = configuration_rate(d, s);
    auto energy = [&](double t) {
      const Eigen::VectorXd q = s.q + t * qdot, v = s.v + t * qdd;
      return kinetic_energy(d, q, v) + V(q);
    };
    const double dE = (energy(h) - energy(-h)) / (2 * h), power = -2 * D(s.v);
    EXPECT_LT(power, 0);
    EXPECT_NEAR(dE, power, 1e-6 * (1 + std::abs(power)));
    if (!d.free_base) continue;
    const Eigen::VectorXd dh =
        (momentum(d, s.q + h * qdot, s.v + h * qdd) - momentum(d, s.q - h * qdot, s.v - h * qdd)) /
        (2 * h);
    EXPECT_LT(dh.norm(), 1e-6 * (1 + momentum(d, s.q, s.v).norm()));
  }
}

// A flexible joint held at the gear's output (qm = p q, qmd = p qd) is a rigid gear: with G the
// map from the rigid model's velocities to the flexible one's (a motor rate w to w / p on the
// slot and w on the motor), G^T M G and G^T b are the rigid model's M and bias (G is constant),
// and T and the momentum are the same. The springs' limit k -> infinity, exactly.
TEST(SpatialChain, AFlexibleJointHeldAtTheGearsOutputIsARigidGear) {
  std::mt19937 rng(71);
  for (const bool free : {true, false}) {
    SCOPED_TRACE(free ? "free base" : "fixed base");
    const ChainDescription flexible = random_chain(rng, 7, free, true, false, true);
    ChainDescription rigid = flexible;
    for (Link& l : rigid.links) l.gear.flexible = false;
    const State r = random_state(rng, rigid);
    State x{Eigen::VectorXd(flexible.nq()), Eigen::VectorXd(flexible.nv())};
    Eigen::MatrixXd G = Eigen::MatrixXd::Zero(flexible.nv(), rigid.nv());
    x.q.head(rigid.nq()) = r.q;
    x.v.head(rigid.nv()) = r.v;
    for (int k = 0; k < rigid.nv(); ++k) G(k, k) = 1;
    const int jq = free ? 7 : 0, jv = rigid.num_base();
    for (size_t j = 0; j < flexible.links.size(); ++j) {
      const Gear& g = flexible.links[j].gear;
      if (!g.flexible) continue;
      const int m = motor_index(flexible, static_cast<int>(j)), slot = jv + static_cast<int>(j);
      x.q[slot + jq - jv] = r.q[slot + jq - jv] / g.ratio.value;
      x.q[m + jq - jv] = r.q[slot + jq - jv];
      x.v[slot] = r.v[slot] / g.ratio.value;
      x.v[m] = r.v[slot];
      G(slot, slot) = 1 / g.ratio.value;
      G(m, slot) = 1;
    }
    ASSERT_LT((G * r.v - x.v).norm(), 1e-15);
    const Chain<double> cf = chain_at(flexible, x), cr = chain_at(rigid, r);
    const Eigen::MatrixXd Mr = mass_matrix(rigid, r);
    EXPECT_LT((G.transpose() * mass_matrix(flexible, x) * G - Mr).norm(), 1e-12 * Mr.norm());
    const Eigen::VectorXd bf = as_eigen(cf.inverse_dynamics(std::vector<double>(flexible.nv(), 0))),
                          br = as_eigen(cr.inverse_dynamics(std::vector<double>(rigid.nv(), 0)));
    EXPECT_LT((G.transpose() * bf - br).norm(), 1e-12 * (1 + br.norm()));
    EXPECT_NEAR(cf.kinetic_energy(), cr.kinetic_energy(), 1e-12 * cr.kinetic_energy());
    EXPECT_NEAR(cf.potential_energy(), 0.0, 1e-20);
    if (free) {
      EXPECT_LT((as_eigen(cf.momentum()) - as_eigen(cr.momentum())).norm(),
                1e-12 * as_eigen(cr.momentum()).norm());
    }
  }
}

// C in 3D is the Boltzmann-Hamel factorization: C = Mdot - (P G)^T / 2 + H with qdot = G v,
// P = d(M v)/dq and H v = [0, omega x (M v)_omega, 0]. C v is the bias (RNEA) to rounding, and
// each part is rebuilt here by central differences along qdot and along each velocity's
// direction of q (the quaternion's included).
TEST(SpatialChain, CoriolisMatrixIsTheBoltzmannHamelFactorization) {
  std::mt19937 rng(53);
  for (const Case& c : kCases) {
    SCOPED_TRACE(name(c));
    const ChainDescription d = random_chain(rng, c);
    const State s = random_state(rng, d);
    const int n = d.nv();
    auto output = [&](Output o, const State& x) {
      return evaluate_chain<Chain>(
          d, o, [&x](const std::string& a, int i) { return a == "q" ? x.q[i] : x.v[i]; });
    };
    const std::vector<double> Cv = output(Output::coriolis_matrix, s)[0];
    const Eigen::MatrixXd C =
        Eigen::Map<const Eigen::Matrix<double, -1, -1, Eigen::RowMajor>>(Cv.data(), n, n);
    const Eigen::VectorXd b = as_eigen(output(Output::bias_forces, s)[0]);
    EXPECT_LT((C * s.v - b).norm(), 1e-12 * (1 + b.norm()));
    // The parts by central differences (h = 1e-6).
    const double h = 1e-6;
    auto moved = [&](const Eigen::VectorXd& dq, double step) {
      State x = s;
      x.q += step * dq;
      return x;
    };
    const Eigen::VectorXd qdot = configuration_rate(d, s);
    const Eigen::MatrixXd Mdot =
        (mass_matrix(d, moved(qdot, h)) - mass_matrix(d, moved(qdot, -h))) / (2 * h);
    Eigen::MatrixXd PG(n, n);
    for (int k = 0; k < n; ++k) {
      State unit = s;
      unit.v = Eigen::VectorXd::Unit(n, k);
      const Eigen::VectorXd g = configuration_rate(d, unit);  // G e_k
      PG.col(k) = (mass_matrix(d, moved(g, h)) - mass_matrix(d, moved(g, -h))) * s.v / (2 * h);
    }
    const Eigen::MatrixXd M = mass_matrix(d, s);
    Eigen::MatrixXd H = Eigen::MatrixXd::Zero(n, n);
    if (c.free) {
      const Eigen::Vector3d w = s.v.segment<3>(3);
      for (int k = 0; k < n; ++k)
        H.block<3, 1>(3, k) = w.cross(Eigen::Vector3d(M.block<3, 1>(3, k)));
    }
    const Eigen::MatrixXd expected = Mdot - 0.5 * PG.transpose() + H;
    EXPECT_LT((C - expected).norm(), 1e-6 * (1 + expected.norm()));
  }
}

// The end effector: its pose (the tip's position, the last link's orientation composed as a
// quaternion) and its geometric Jacobian (J v = the tip's velocity and the link's angular
// velocity) and the joints' positions are the world computation's, on a free base with flexible
// joints and on a fixed base with rigid gears.
TEST(SpatialChain, EndEffectorPoseAndJacobianAreTheWorldComputations) {
  std::mt19937 rng(39);
  for (const bool free : {true, false}) {
    ChainDescription d =
        random_chain(rng, 7, free, true, false, free);  // flexible on the free base
    d.end_effectors[0].xyz = {0.2, -0.05, 0.1};
    SCOPED_TRACE(free ? "free base, flexible joints" : "fixed base");
    const State s = random_state(rng, d);
    const Chain<double> chain = chain_at(d, s);
    const World w = world(d, s.q, s.v);
    const std::vector<double> pose = chain.end_effector_pose();
    const Eigen::Vector3d tip = Eigen::Vector3d(
        d.end_effectors[0].xyz[0], d.end_effectors[0].xyz[1], d.end_effectors[0].xyz[2]);
    const Eigen::Matrix3d R = w.R.back();
    EXPECT_LT((as_eigen(pose).head<3>() - (w.last_origin + R * tip)).norm(), 1e-12);
    const Eigen::Quaterniond orientation(pose[3], pose[4], pose[5], pose[6]);
    EXPECT_NEAR(orientation.norm(), 1, 1e-12);
    EXPECT_LT((orientation.toRotationMatrix() - R).norm(), 1e-12);
    const std::vector<double> J = chain.end_effector_jacobian();
    const Eigen::VectorXd twist =
        Eigen::Map<const Eigen::Matrix<double, -1, -1, Eigen::RowMajor>>(J.data(), 6, d.nv()) * s.v;
    EXPECT_LT((twist.head<3>() - (w.last_origin_velocity + w.omega.back().cross(R * tip))).norm(),
              1e-12 * (1 + twist.norm()));
    EXPECT_LT((twist.tail<3>() - w.omega.back()).norm(), 1e-12 * (1 + twist.norm()));
    // The joints' world positions, then the tip's (3 x (N + 1), for drawing).
    const std::vector<double> P = chain.joint_positions();
    const int cols = static_cast<int>(d.links.size()) + 1;
    ASSERT_EQ(P.size(), 3u * cols);
    for (int i = 0; i < cols; ++i) {
      const Eigen::Vector3d want = i + 1 < cols ? w.joint_origins[i] : w.last_origin + R * tip;
      EXPECT_LT((Eigen::Vector3d(P[i], P[cols + i], P[2 * cols + i]) - want).norm(), 1e-12) << i;
    }
  }
}

TEST(SpatialChain, RefusesAWrongSizeAndAZeroAxis) {
  std::mt19937 rng(34);
  ChainDescription d = random_chain(rng, 2, true);
  State s = random_state(rng, d);
  EXPECT_THROW_MESSAGE(chain_at(d, s).inverse_dynamics(std::vector<double>(7, 0.0)),
                       std::invalid_argument, "spatial chain: vdot needs 8 values");
  d.links[1].axis = {0, 0, 0};
  EXPECT_THROW_MESSAGE(chain_at(d, s), std::invalid_argument,
                       "spatial chain: joint 2 has a zero axis");
}

}  // namespace
}  // namespace spacearm::spatial
