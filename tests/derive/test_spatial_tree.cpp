// generator/derive/spatial/spatial_chain.hpp on kinematic trees (several arms on one base, a
// torso with two arms, random parent arrays), with exact rotors, armature, flexible joints and
// coupled rotors on every branch, the joints that start a branch included: M, T and the momentum
// against an independent world-frame computation (Eigen's rotations, each body from its parent's
// world pose; no code shared with the chain's body-frame algebra), M's zeros between branches,
// RNEA's invariants, ABA against M^-1, the state Jacobian against differences, every end
// effector's pose and Jacobian, mirrored arms that keep their symmetry, and momentum and energy
// over a long free motion.
#include <Eigen/Dense>

#include <random>

#include "recorded_scalar.hpp"
#include "recursive_algorithms.hpp"
#include "spatial_chain.hpp"
#include "support.hpp"
#include "tangent_space.hpp"

namespace spacearm::spatial {
namespace {

// A link with a physical inertia (principal moments a, b and c within the triangle inequality,
// turned at random), an origin mostly along x and any axis (not unit: the chain normalizes it).
Link link_at_random(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1, 1);
  Link l;
  l.origin_xyz = {0.4 + 0.3 * u(rng), 0.2 * u(rng), 0.2 * u(rng)};
  l.origin_rpy = {0.8 * u(rng), 0.8 * u(rng), 0.8 * u(rng)};
  l.axis = {u(rng), u(rng), u(rng)};
  l.mass = 1.5 + u(rng);
  l.com = {0.2 + 0.1 * u(rng), 0.05 * u(rng), 0.05 * u(rng)};
  const double a = 0.8 + 0.3 * u(rng), b = 0.8 + 0.3 * u(rng), c = 0.5 * (a + b) + 0.1 * u(rng);
  const Eigen::Matrix3d Q = Eigen::Quaterniond::UnitRandom().toRotationMatrix();
  const Eigen::Matrix3d I = Q * Eigen::Vector3d(a, b, c).asDiagonal() * Q.transpose();
  l.inertia = {I(0, 0), I(0, 1), I(0, 2), I(1, 1), I(1, 2), I(2, 2)};
  return l;
}

struct TreeCase {
  const char* name;
  std::vector<int> parents;  // of links 1..N (0 the base)
  bool free_base, geared, flexible = false, coupled = false;
};

// Two 3-joint arms on the base; a torso of two joints carrying two 2-joint arms; a joint with
// three children; a random tree of 9 (each link's parent one of the three bodies before it).
std::vector<TreeCase> tree_cases() {
  std::mt19937 rng(5);
  std::vector<int> random_parents;
  for (int i = 1; i <= 9; ++i)
    random_parents.push_back(std::uniform_int_distribution<int>(std::max(0, i - 3), i - 1)(rng));
  const std::vector<int> dual = {0, 1, 2, 0, 4, 5}, torso = {0, 1, 2, 3, 2, 5},
                         fork = {0, 1, 1, 1, 2};
  return {{"two arms, free base", dual, true, false},
          {"two arms, geared", dual, true, true},
          {"two arms, fixed base, geared", dual, false, true},
          {"torso and two arms, flexible", torso, true, true, true},
          {"three children, coupled rotors", fork, true, true, false, true},
          {"random tree of 9, geared", random_parents, true, true},
          {"random tree of 9, fixed base, flexible", random_parents, false, true, true}};
}

// geared: every joint has a motor, exactly coupled on odd joints (link 1, the first of a branch
// in most cases) and as armature on even ones; flexible: joints with i % 3 != 1 have springs.
ChainDescription random_tree(std::mt19937& rng, const TreeCase& c) {
  std::uniform_real_distribution<double> u(0, 1);
  ChainDescription d;
  d.free_base = c.free_base;
  d.base = link_at_random(rng);
  d.base.mass = 40;
  d.end_effectors.clear();
  for (size_t i = 0; i < c.parents.size(); ++i) {
    Link l = link_at_random(rng);
    l.parent = c.parents[i];
    if (c.geared) {
      Gear& g = l.gear;
      g = {true, 4 + 60 * u(rng), 1e-4 * (1 + u(rng)), 0.5e-4 * (1 + u(rng)), i % 2 == 0};
      if (c.coupled) g.coupled = true, g.coupling = 0.1 + 0.8 * u(rng);
      if (c.flexible && i % 3 != 1) {
        g.flexible = true;
        g.stiffness = 80 + 400 * u(rng);
        g.has_damping = i % 2 == 0;
        g.damping = g.has_damping ? 0.4 * u(rng) : 0.0;
      }
    }
    d.links.push_back(l);
  }
  // An end effector at a point of every leaf, turned by some rpy.
  const int n = static_cast<int>(c.parents.size());
  for (int i = 1; i <= n; ++i)
    if (std::find(c.parents.begin(), c.parents.end(), i) == c.parents.end())
      d.end_effectors.push_back({"leaf" + std::to_string(i), i, {0.1, -0.05, 0.2}, {0.3, -0.2, 1}});
  return d;
}

// The velocity index of joint j's motor, counted here apart from the chain.
int motor_index(const ChainDescription& d, int j) {
  auto flexible = [&d](int k) { return d.links[k].gear.present && d.links[k].gear.flexible; };
  if (!flexible(j)) return d.num_base() + j;
  int before = 0;
  for (int k = 0; k < j; ++k) before += flexible(k);
  return d.num_base() + static_cast<int>(d.links.size()) + before;
}

Eigen::Matrix3d rpy_matrix(const std::array<double, 3>& rpy) {
  return (Eigen::AngleAxisd(rpy[2], Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(rpy[1], Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(rpy[0], Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

// A frame in the world: its rotation, origin, the origin's velocity and the angular velocity.
struct WorldFrame {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d p = Eigen::Vector3d::Zero(), pdot = Eigen::Vector3d::Zero(),
                  omega = Eigen::Vector3d::Zero();
};

// The independent computation: each link's frame from its parent's (URDF's rpy as Rz Ry Rx, the
// joint by AngleAxis), and the mass-carrying bodies (links and massless exact rotors) in the
// world, as kinetic energy and momentum sum them.
struct World {
  std::vector<WorldFrame> frames;  // 0 the base, i link i
  struct Mass {
    Eigen::Matrix3d R;
    Eigen::Vector3d com, com_velocity, omega;
    double m, share;  // share: what of its angular momentum the system holds (a coupling c)
    Eigen::Matrix3d inertia;
  };
  std::vector<Mass> masses;
  double armature_energy = 0;
};

Eigen::Matrix3d tensor(const Inertial& l) {
  const auto i = l.inertia_values();
  Eigen::Matrix3d I;
  I << i[0], i[1], i[2], i[1], i[3], i[4], i[2], i[4], i[5];
  return I;
}

World world(const ChainDescription& d, const Eigen::VectorXd& q, const Eigen::VectorXd& v) {
  World w;
  const int n = static_cast<int>(d.links.size()), jq = d.free_base ? 7 : 0, jv = d.num_base();
  w.frames.resize(n + 1);
  if (d.free_base) {
    w.frames[0].R = Eigen::Quaterniond(q[3], q[4], q[5], q[6]).toRotationMatrix();
    w.frames[0].p = q.head<3>();
    w.frames[0].pdot = v.head<3>();
    w.frames[0].omega = w.frames[0].R * v.segment<3>(3);
  }
  auto add_mass = [&w](const WorldFrame& f, const Inertial& l) {
    const Eigen::Vector3d c = f.R * Eigen::Vector3d(l.com[0].value, l.com[1].value, l.com[2].value);
    w.masses.push_back(
        {f.R, f.p + c, f.pdot + f.omega.cross(c), f.omega, l.mass.value, 1.0, tensor(l)});
  };
  if (d.free_base) add_mass(w.frames[0], d.base);
  for (int i = 1; i <= n; ++i) {
    const Link& l = d.links[i - 1];
    const WorldFrame& parent = w.frames[l.parent < 0 ? i - 1 : l.parent];
    const Eigen::Vector3d origin(l.origin_xyz[0], l.origin_xyz[1], l.origin_xyz[2]);
    const Eigen::Vector3d axis = Eigen::Vector3d(l.axis[0], l.axis[1], l.axis[2]).normalized();
    const bool rigid_gear = l.gear.present && !l.gear.flexible;
    const double ratio = rigid_gear ? l.gear.ratio.value : 1, link_rate = v[jv + i - 1] / ratio;
    const double motor_rate = v[motor_index(d, i - 1)];
    WorldFrame f;
    f.p = parent.p + parent.R * origin;
    f.pdot = parent.pdot + parent.omega.cross(parent.R * origin);
    const Eigen::Matrix3d turned = parent.R * rpy_matrix(l.origin_rpy);
    if (l.gear.present && (l.gear.exact || l.gear.coupled)) {  // a rotor riding on the parent
      const double c = l.gear.coupled ? l.gear.coupling.value : 1;
      const Eigen::Matrix3d Ir =
          l.gear.transverse.value * Eigen::Matrix3d::Identity() +
          (l.gear.axial.value - l.gear.transverse.value) * axis * axis.transpose();
      w.masses.push_back(
          {turned, f.p, f.pdot, c * parent.omega + turned * axis * motor_rate, 0.0, c, Ir});
    } else if (l.gear.present) {
      w.armature_energy += 0.5 * l.gear.axial.value * motor_rate * motor_rate;
    }
    f.R = turned * Eigen::AngleAxisd(q[jq + i - 1] / ratio, axis).toRotationMatrix();
    f.omega = parent.omega + f.R * axis * link_rate;
    w.frames[i] = f;
    add_mass(f, l);
  }
  return w;
}

double kinetic_energy(const ChainDescription& d, const Eigen::VectorXd& q,
                      const Eigen::VectorXd& v) {
  const World w = world(d, q, v);
  double T = w.armature_energy;
  for (const World::Mass& b : w.masses)
    T += 0.5 * b.m * b.com_velocity.squaredNorm() +
         0.5 * b.omega.dot(b.R * b.inertia * b.R.transpose() * b.omega);
  return T;
}

Eigen::Matrix<double, 6, 1> momentum(const ChainDescription& d, const Eigen::VectorXd& q,
                                     const Eigen::VectorXd& v) {
  Eigen::Matrix<double, 6, 1> h = Eigen::Matrix<double, 6, 1>::Zero();
  for (const World::Mass& b : world(d, q, v).masses) {
    const Eigen::Vector3d P = b.m * b.com_velocity;
    h.head<3>() += P;
    h.tail<3>() += b.com.cross(P) + b.share * b.R * b.inertia * b.R.transpose() * b.omega;
  }
  return h;
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

Chain<double> chain_at(const ChainDescription& d, const State& s) {
  return Chain<double>(
      d, Values<double>{[s](const std::string& a, int i) { return a == "q" ? s.q[i] : s.v[i]; },
                        [](double x) { return x; }});
}
Eigen::VectorXd as_eigen(const std::vector<double>& x) {
  return Eigen::Map<const Eigen::VectorXd>(x.data(), x.size());
}
std::vector<double> as_std(const Eigen::VectorXd& x) { return {x.data(), x.data() + x.size()}; }
Eigen::MatrixXd as_matrix(const std::vector<double>& x, int rows, int cols) {
  return Eigen::Map<const Eigen::Matrix<double, -1, -1, Eigen::RowMajor>>(x.data(), rows, cols);
}
Eigen::MatrixXd mass_matrix(const ChainDescription& d, const State& s) {
  return as_matrix(chain_at(d, s).mass_matrix(), d.nv(), d.nv());
}
Eigen::VectorXd bias(const ChainDescription& d, const State& s) {
  return as_eigen(chain_at(d, s).inverse_dynamics(std::vector<double>(d.nv(), 0.0)));
}
// qdot = f(q, v): the base origin's velocity, the quaternion's rate 1/2 q (0, omega), the rates.
Eigen::VectorXd configuration_rate(const ChainDescription& d, const State& s) {
  Eigen::VectorXd qdot(d.nq());
  const int jq = d.free_base ? 7 : 0;
  if (d.free_base) {
    const Eigen::Quaterniond r(s.q[3], s.q[4], s.q[5], s.q[6]);
    const Eigen::Quaterniond rate = r * Eigen::Quaterniond(0, s.v[3] / 2, s.v[4] / 2, s.v[5] / 2);
    qdot.head<3>() = s.v.head<3>();
    qdot.segment<4>(3) << rate.w(), rate.x(), rate.y(), rate.z();
  }
  qdot.tail(d.nq() - jq) = s.v.tail(d.nv() - d.num_base());
  return qdot;
}

// M by polarization of the world's T (quadratic in v).
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

// Whether body a is body b or carries it.
bool carries(const ChainDescription& d, int a, int b) {
  for (; b > 0; b = d.parent(b))
    if (a == b) return true;
  return a == 0;
}

TEST(SpatialTree, MassMatrixEnergyAndMomentumAreTheWorldComputations) {
  std::mt19937 rng(61);
  for (const TreeCase& c : tree_cases()) {
    SCOPED_TRACE(c.name);
    const ChainDescription d = random_tree(rng, c);
    ASSERT_FALSE(d.serial());
    for (int trial = 0; trial < 3; ++trial) {
      const State s = random_state(rng, d);
      const Chain<double> chain = chain_at(d, s);
      const Eigen::MatrixXd M = mass_matrix(d, s), M_world = polarized_mass_matrix(d, s.q);
      EXPECT_LT((M - M_world).norm(), 1e-12 * M_world.norm());
      EXPECT_LT((M - M.transpose()).norm(), 1e-14 * M.norm());
      EXPECT_GT(Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(M).eigenvalues().minCoeff(), 0);
      const double T = kinetic_energy(d, s.q, s.v);
      EXPECT_NEAR(chain.kinetic_energy(), T, 1e-12 * T);
      EXPECT_LT((as_eigen(chain.generalized_momentum()) - M * s.v).norm(),
                1e-12 * (M * s.v).norm());
      if (c.free_base) {
        const Eigen::Matrix<double, 6, 1> h_world = momentum(d, s.q, s.v);
        EXPECT_LT((as_eigen(chain.momentum()) - h_world).norm(), 1e-12 * h_world.norm());
      }
    }
  }
}

// Featherstone's branch-induced sparsity (RBDA 6.5): joints on different branches have exact
// zeros in M (not computed, not rounding), a joint and the joints it carries do not.
TEST(SpatialTree, JointsOnDifferentBranchesHaveZerosInTheMassMatrix) {
  std::mt19937 rng(62);
  for (const TreeCase& c : tree_cases()) {
    SCOPED_TRACE(c.name);
    const ChainDescription d = random_tree(rng, c);
    const Eigen::MatrixXd M = mass_matrix(d, random_state(rng, d));
    const int n = static_cast<int>(d.links.size()), nb = d.num_base();
    int zeros = 0;
    for (int i = 1; i <= n; ++i)
      for (int j = 1; j <= n; ++j) {
        const bool related = carries(d, i, j) || carries(d, j, i);
        const double Mij = M(motor_index(d, i - 1), nb + j - 1);
        const double slots = M(nb + i - 1, nb + j - 1);
        if (!related) {
          EXPECT_EQ(slots, 0.0) << i << ", " << j;
          EXPECT_EQ(Mij, 0.0) << "motor " << i << ", " << j;
          ++zeros;
        } else if (i != j) {
          EXPECT_NE(slots, 0.0) << i << ", " << j;
        }
      }
    EXPECT_GT(zeros, 0);
  }
}

// RNEA: Q(vdot) - Q(0) = M vdot; with no force the world's momentum and energy stay constant
// (central differences along qdot = f(q, v) and vdot = -M^-1 (b + f)); springs count their own
// energy, so the flexible cases check momentum only, and dampers stay off for the energy.
TEST(SpatialTree, InverseDynamicsConservesMomentumAndEnergy) {
  std::mt19937 rng(63);
  for (const TreeCase& c : tree_cases()) {
    SCOPED_TRACE(c.name);
    const ChainDescription d = random_tree(rng, c);
    for (int trial = 0; trial < 2; ++trial) {
      const State s = random_state(rng, d);
      const Chain<double> chain = chain_at(d, s);
      const Eigen::MatrixXd M = mass_matrix(d, s);
      const Eigen::VectorXd b = bias(d, s), a = Eigen::VectorXd::Random(d.nv());
      const Eigen::VectorXd Ma = as_eigen(chain.inverse_dynamics(as_std(a))) - b;
      EXPECT_LT((Ma - M * a).norm(), 1e-12 * (M * a).norm());
      const Eigen::VectorXd vdot = M.ldlt().solve(-b - as_eigen(chain.passive_forces()));
      const Eigen::VectorXd qdot = configuration_rate(d, s);
      const double eps = 1e-5;
      const State plus{s.q + eps * qdot, s.v + eps * vdot},
          minus{s.q - eps * qdot, s.v - eps * vdot};
      if (!c.flexible) {
        const double dT =
            (kinetic_energy(d, plus.q, plus.v) - kinetic_energy(d, minus.q, minus.v)) / (2 * eps);
        EXPECT_LT(std::abs(dT), 1e-7 * (1 + kinetic_energy(d, s.q, s.v)));
      }
      if (c.free_base) {
        const Eigen::VectorXd dh =
            (momentum(d, plus.q, plus.v) - momentum(d, minus.q, minus.v)) / (2 * eps);
        EXPECT_LT(dh.norm(), 1e-7 * (1 + momentum(d, s.q, s.v).norm()));
      }
    }
  }
}

// The articulated-body algorithm on a tree (each branch's inertia passed to the body it leaves)
// solves M qdd + b + f = Q, with positive pivots.
TEST(SpatialTree, ForwardDynamicsSolvesTheMassMatrix) {
  std::mt19937 rng(64);
  for (const TreeCase& c : tree_cases()) {
    SCOPED_TRACE(c.name);
    const ChainDescription d = random_tree(rng, c);
    for (int trial = 0; trial < 3; ++trial) {
      const State s = random_state(rng, d);
      const Chain<double> chain = chain_at(d, s);
      const Eigen::VectorXd Q = Eigen::VectorXd::Random(d.nv());
      const auto fd = chain.forward_dynamics(as_std(Q));
      const Eigen::VectorXd expected =
          mass_matrix(d, s).ldlt().solve(Q - bias(d, s) - as_eigen(chain.passive_forces()));
      EXPECT_LT((as_eigen(fd[0]) - expected).norm(), 1e-10 * (1 + expected.norm()));
      EXPECT_GT(as_eigen(fd[1]).minCoeff(), 0);
    }
  }
}

// The state Jacobian on trees is that of central differences of forward dynamics, along q ⊕ delta
// and along v, under a random Q (the base's force included): the free base's columns come from
// its symmetries (zeros along its velocity; its turns from qdd and one solve), the rest from the
// recorded algorithms differentiated forward.
TEST(SpatialTree, StateJacobianIsThatOfDifferences) {
  std::mt19937 rng(91);
  for (const TreeCase& c : tree_cases()) {
    SCOPED_TRACE(c.name);
    const ChainDescription d = random_tree(rng, c);
    const State s = random_state(rng, d);
    const Eigen::VectorXd Q = Eigen::VectorXd::Random(d.nv());
    auto qdd = [&](const State& x) {
      return as_eigen(chain_at(d, x).forward_dynamics(as_std(Q))[0]);
    };
    const auto J = evaluate_chain<Chain>(d, Output::forward_dynamics_derivatives,
                                         [&](const std::string& a, int i) {
                                           return a == "q" ? s.q[i] : a == "Q" ? Q[i] : s.v[i];
                                         });
    const int nv = d.nv();
    const Eigen::MatrixXd dq = as_matrix(J[0], nv, nv), dv = as_matrix(J[1], nv, nv);
    const double h = 1e-6, rounding = 1e-9 * qdd(s).norm();
    for (int k = 0; k < nv; ++k) {
      State plus = s, minus = s;
      if (d.free_base) {
        plus.q = test::moved_along_tangent(s.q, h * Eigen::VectorXd::Unit(nv, k));
        minus.q = test::moved_along_tangent(s.q, -h * Eigen::VectorXd::Unit(nv, k));
      } else {
        plus.q[k] += h, minus.q[k] -= h;
      }
      const Eigen::VectorXd along_q = (qdd(plus) - qdd(minus)) / (2 * h);
      EXPECT_LT((dq.col(k) - along_q).norm(), 1e-6 * (1 + along_q.norm()) + rounding) << "q " << k;
      plus = s, minus = s;
      plus.v[k] += h, minus.v[k] -= h;
      const Eigen::VectorXd along_v = (qdd(plus) - qdd(minus)) / (2 * h);
      EXPECT_LT((dv.col(k) - along_v).norm(), 1e-6 * (1 + along_v.norm()) + rounding) << "v " << k;
    }
    if (d.free_base) EXPECT_EQ(dv.leftCols(3).cwiseAbs().maxCoeff(), 0);
  }
}

// Every end effector: its pose (position, and the quaternion's rotation) and its Jacobian rows
// (J v = its world twist) are the world computation's; the joints' and end effectors' points
// are the frames' origins and the end effectors; the generalized Jacobian gives each end
// effector's twist when the base moves so that the momentum stays zero.
TEST(SpatialTree, EveryEndEffectorIsTheWorldComputation) {
  std::mt19937 rng(65);
  for (const TreeCase& c : tree_cases()) {
    SCOPED_TRACE(c.name);
    const ChainDescription d = random_tree(rng, c);
    const int E = d.num_end_effectors(), nv = d.nv(), n = static_cast<int>(d.links.size());
    ASSERT_GE(E, 2);
    State s = random_state(rng, d);
    if (c.free_base && !c.flexible) {  // base velocities that keep the world momentum zero
      Eigen::VectorXd v = s.v;
      v.head<6>().setZero();
      Eigen::Matrix<double, 6, 6> Hb;
      for (int k = 0; k < 6; ++k) Hb.col(k) = momentum(d, s.q, Eigen::VectorXd::Unit(nv, k));
      s.v.head<6>() = -Hb.lu().solve(momentum(d, s.q, v));
      ASSERT_LT(momentum(d, s.q, s.v).norm(), 1e-12);
    }
    const Chain<double> chain = chain_at(d, s);
    const World w = world(d, s.q, s.v);
    const Eigen::VectorXd pose = as_eigen(chain.end_effector_pose());
    const Eigen::MatrixXd J = as_matrix(chain.end_effector_jacobian(), 6 * E, nv);
    const Eigen::MatrixXd P = as_matrix(chain.joint_positions(), 3, n + E);
    ASSERT_EQ(pose.size(), 7 * E);
    for (int e = 0; e < E; ++e) {
      const EndEffector& ee = d.end_effectors[e];
      const WorldFrame& f = w.frames[d.end_effector_body(e)];
      const Eigen::Vector3d r = f.R * Eigen::Vector3d(ee.xyz[0], ee.xyz[1], ee.xyz[2]);
      EXPECT_LT((pose.segment<3>(7 * e) - (f.p + r)).norm(), 1e-12);
      const Eigen::Quaterniond got(pose[7 * e + 3], pose[7 * e + 4], pose[7 * e + 5],
                                   pose[7 * e + 6]);
      EXPECT_LT((got.toRotationMatrix() - f.R * rpy_matrix(ee.rpy)).norm(), 1e-12);
      Eigen::Matrix<double, 6, 1> twist;
      twist << f.pdot + f.omega.cross(r), f.omega;
      EXPECT_LT((J.middleRows<6>(6 * e) * s.v - twist).norm(), 1e-12 * (1 + twist.norm()));
      EXPECT_LT((P.col(n + e) - (f.p + r)).norm(), 1e-12);
      if (c.free_base && !c.flexible) {
        const Eigen::MatrixXd Jg = as_matrix(chain.generalized_jacobian(), 6 * E, n);
        EXPECT_LT((Jg.middleRows<6>(6 * e) * s.v.tail(n) - twist).norm(),
                  1e-11 * (1 + twist.norm()));
      }
    }
    for (int i = 1; i <= n; ++i) EXPECT_LT((P.col(i - 1) - w.frames[i].p).norm(), 1e-12);
  }
}

// Two identical arms, one the mirror image of the other in the base's x-z plane, on a base
// symmetric about it: from a mirrored state (equal joint angles and rates, the base moving in its
// plane of symmetry) the accelerations stay mirrored: the base's y, roll and yaw accelerations are
// zero and the arms' joints accelerate alike. Geared, exact rotors on the joints that leave the
// base.
TEST(SpatialTree, MirroredArmsKeepTheSymmetry) {
  std::mt19937 rng(66);
  ChainDescription d;
  d.base.mass = 120;
  d.base.inertia = {30, 0, 2, 40, 0, 35};  // ixy = iyz = 0: symmetric about the x-z plane
  d.base.com = {0.1, 0, -0.05};
  d.end_effectors.clear();
  const int per_arm = 4;
  std::vector<Link> arm;
  for (int i = 0; i < per_arm; ++i) {
    Link l = link_at_random(rng);
    l.parent = i;  // relabelled below
    l.gear = {true, 50, 2e-4, 1e-4, i % 2 == 0};
    arm.push_back(l);
  }
  arm[0].origin_xyz = {0.3, 0.8, 0.1};
  // The mirror S = diag(1, -1, 1) of a joint: origin S x, rpy (-r, p, -y), axis -S a (the same
  // angle turns the mirrored way), com S c, inertia S I S.
  auto mirrored = [](Link l) {
    l.origin_xyz[1] = -l.origin_xyz[1];
    l.origin_rpy[0] = -l.origin_rpy[0];
    l.origin_rpy[2] = -l.origin_rpy[2];
    l.axis = {-l.axis[0], l.axis[1], -l.axis[2]};
    l.com[1] = -l.com[1].value;
    l.inertia[1] = -l.inertia[1].value;
    l.inertia[4] = -l.inertia[4].value;
    return l;
  };
  for (int side = 0; side < 2; ++side)
    for (int i = 0; i < per_arm; ++i) {
      Link l = side == 0 ? arm[i] : mirrored(arm[i]);
      l.parent = i == 0 ? 0 : side * per_arm + i;
      d.links.push_back(l);
    }
  d.end_effectors = {{"left", per_arm, {0.2, 0.1, 0}, {}},
                     {"right", 2 * per_arm, {0.2, -0.1, 0}, {}}};
  State s{Eigen::VectorXd::Zero(d.nq()), Eigen::VectorXd::Zero(d.nv())};
  s.q[3] = 1;
  s.v.head<6>() << 0.3, 0, -0.2, 0, 0.4, 0;  // in the plane; omega about y only
  for (int i = 0; i < per_arm; ++i) {
    s.q[7 + i] = s.q[7 + per_arm + i] = 0.7 * (i + 1) - 1;
    s.v[6 + i] = s.v[6 + per_arm + i] = 1.5 - 0.8 * i;
  }
  Eigen::VectorXd Q = Eigen::VectorXd::Zero(d.nv());
  for (int i = 0; i < per_arm; ++i) Q[6 + i] = Q[6 + per_arm + i] = 0.2 * (i - 1.5);
  const Eigen::VectorXd qdd = as_eigen(chain_at(d, s).forward_dynamics(as_std(Q))[0]);
  const double scale = qdd.norm();
  ASSERT_GT(scale, 1e-3);
  for (int k : {1, 3, 5}) EXPECT_LT(std::abs(qdd[k]), 1e-13 * scale) << k;
  for (int i = 0; i < per_arm; ++i)
    EXPECT_NEAR(qdd[6 + i], qdd[6 + per_arm + i], 1e-13 * scale) << i;
  const Eigen::VectorXd pose = as_eigen(chain_at(d, s).end_effector_pose());
  EXPECT_NEAR(pose[1], -pose[8], 1e-14);
  EXPECT_NEAR(pose[0], pose[7], 1e-14);
}

// The recorded programs (recorded_scalar.hpp's Sym) of a tree give the double chain's values.
TEST(SpatialTree, RecordedProgramsGiveTheDoubleValues) {
  std::mt19937 rng(67);
  const ChainDescription d = random_tree(rng, tree_cases()[3]);
  const State s = random_state(rng, d);
  Program p;
  const Values<Sym> values{[&p](const std::string& a, int i) { return Sym(&p, p.input(a, i)); },
                           [&p](double v) { return Sym::number(&p, v); }};
  const Chain<Sym> recorded(d, values);
  std::vector<SRef> roots;
  std::vector<Sym> Q;
  for (int k = 0; k < d.nv(); ++k) Q.push_back(Sym::number(&p, 0.1 * k));
  for (const auto& part : {recorded.mass_matrix(), recorded.forward_dynamics(Q)[0],
                           recorded.end_effector_pose(), recorded.end_effector_jacobian()})
    for (const Sym& x : part) roots.push_back(x.ref());
  const std::vector<double> got =
      p.evaluate(roots, [&s](const std::string& a, int i) { return a == "q" ? s.q[i] : s.v[i]; });
  const Chain<double> chain = chain_at(d, s);
  std::vector<double> Qd;
  for (int k = 0; k < d.nv(); ++k) Qd.push_back(0.1 * k);
  std::vector<double> expected;
  for (const auto& part : {chain.mass_matrix(), chain.forward_dynamics(Qd)[0],
                           chain.end_effector_pose(), chain.end_effector_jacobian()})
    expected.insert(expected.end(), part.begin(), part.end());
  ASSERT_EQ(got.size(), expected.size());
  for (size_t k = 0; k < expected.size(); ++k)
    EXPECT_NEAR(got[k], expected[k], 1e-12 * (1 + std::abs(expected[k]))) << k;
}

// A long free motion of two geared arms (exact rotors, armature) on a free base: 4000 steps of
// RK4 at 1 ms with the chain's forward dynamics keep the world momentum to 1e-10 and the energy
// to 1e-9 (relative).
TEST(SpatialTree, LongFreeMotionKeepsMomentumAndEnergy) {
  std::mt19937 rng(68);
  const ChainDescription d = random_tree(rng, tree_cases()[1]);
  State s = random_state(rng, d);
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(d.nv());
  auto rate = [&](const State& x) {
    return State{configuration_rate(d, x),
                 as_eigen(chain_at(d, x).forward_dynamics(as_std(zero))[0])};
  };
  auto step = [](const State& x, const State& k, double h) {
    return State{x.q + h * k.q, x.v + h * k.v};
  };
  const Eigen::Matrix<double, 6, 1> h0 = momentum(d, s.q, s.v);
  const double T0 = kinetic_energy(d, s.q, s.v);
  const double dt = 1e-3;
  for (int k = 0; k < 4000; ++k) {
    const State k1 = rate(s), k2 = rate(step(s, k1, dt / 2)), k3 = rate(step(s, k2, dt / 2)),
                k4 = rate(step(s, k3, dt));
    s.q += dt / 6 * (k1.q + 2 * k2.q + 2 * k3.q + k4.q);
    s.v += dt / 6 * (k1.v + 2 * k2.v + 2 * k3.v + k4.v);
    s.q.segment<4>(3).normalize();
  }
  EXPECT_LT((momentum(d, s.q, s.v) - h0).norm(), 1e-10 * h0.norm());
  EXPECT_NEAR(kinetic_energy(d, s.q, s.v), T0, 1e-9 * T0);
}

// A link whose parent is not a body before it, and an end effector past the last link, are
// refused by name.
TEST(SpatialTree, RefusesAParentAfterItsLinkAndAnEndEffectorPastTheLinks) {
  std::mt19937 rng(69);
  ChainDescription d = random_tree(rng, tree_cases()[0]);
  const State s = random_state(rng, d);
  ChainDescription bad = d;
  bad.links[2].parent = 3;
  EXPECT_THROW_MESSAGE(chain_at(bad, s), std::invalid_argument, "link 3's parent 3");
  bad = d;
  bad.end_effectors[0].body = 7;
  EXPECT_THROW_MESSAGE(chain_at(bad, s), std::invalid_argument, "past the last link");
}

}  // namespace
}  // namespace spacearm::spatial
