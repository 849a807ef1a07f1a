// export/mjcf_export.hpp, `spacearm export --mjcf`, against MuJoCo, a peer that shares no code
// with the chain: models/space_arm7 (from its URDF: welded links lumped) on a free base,
// ungeared, with armature gears and with its exact rotors, loaded in MuJoCo from the exported
// file at random states. Rigid and armature: the mass matrix, the bias forces and the forward
// dynamics under joint torques, each to 1e-12 relative. MuJoCo's joint coordinate is the link
// angle q, the chain's the motor angle qm = p q: v = D v_mj with D = diag(1 (base), p), so
// M_mj = D M D, b_mj = D b and a joint torque tau is Q = tau / p on the chain's coordinate.
// Exact rotors are rotor bodies held by MuJoCo's soft joint equalities: the forward dynamics to
// the tolerance those allow (measured: below 2e-4 relative; stated in docs/cli.md). The state
// Jacobian on the tangent space against differences of MuJoCo's qacc along its mj_integratePos.
#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <fstream>
#include <random>
#include <sstream>

#include "mjcf_export.hpp"
#include "mujoco_model.hpp"
#include "numeric_outputs.hpp"
#include "recursive_algorithms.hpp"
#include "spatial_chain.hpp"
#include "spatial_scene.hpp"
#include "support.hpp"

namespace spacearm {
namespace {

enum class Gears { none, armature, exact };

SpatialScene arm7(Gears gears) {
  const std::string path = std::string(SPACEARM_SOURCE_DIR) + "/models/space_arm7.yaml";
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  SpatialScene s = parse_spatial_scene(text.str(), path);
  for (auto& l : s.chain.links) {
    if (gears == Gears::none) l.gear = {};
    l.gear.exact = gears == Gears::exact;
  }
  return s;
}

// The chain's output o at (q, v, Q) as a vector.
Eigen::VectorXd chain_output(const spatial::ChainDescription& c, Output o, const Eigen::VectorXd& q,
                             const Eigen::VectorXd& v, const Eigen::VectorXd& Q) {
  auto input = [&](const std::string& a, int i) {
    return a == "q" ? q[i] : a == "qd" ? v[i] : a == "Q" ? Q[i] : 0.0;
  };
  const std::vector<double> x = evaluate_chain<spatial::Chain>(c, o, input)[0];
  return Eigen::Map<const Eigen::VectorXd>(x.data(), static_cast<Eigen::Index>(x.size()));
}

// A random state of the chain and joint torques.
struct State {
  Eigen::VectorXd q, v, tau;
};
State random_state(const spatial::ChainDescription& c, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1, 1);
  const int N = static_cast<int>(c.links.size());
  State s{Eigen::VectorXd(c.nq()), Eigen::VectorXd(c.nv()), Eigen::VectorXd(N)};
  for (int i = 0; i < c.nq(); ++i) s.q[i] = 2 * u(rng);
  const Eigen::Quaterniond r = Eigen::Quaterniond::UnitRandom();
  s.q.segment<4>(3) << r.w(), r.x(), r.y(), r.z();
  for (int i = 0; i < c.nv(); ++i) s.v[i] = u(rng);
  for (int j = 0; j < N; ++j) s.tau[j] = 10 * u(rng);
  return s;
}

// Puts the state into MuJoCo by joint name (the base's free joint, the URDF's joints, the rotors
// at qm = p q), with tau on the joints; returns D.
Eigen::VectorXd set_state(const SpatialScene& s, const test::MujocoModel& mj, const State& x) {
  const spatial::ChainDescription& c = s.chain;
  const int N = static_cast<int>(c.links.size());
  Eigen::VectorXd D = Eigen::VectorXd::Ones(c.nv());
  mju_zero(mj.d->qfrc_applied, mj.m->nv);
  const int base = mj_name2id(mj.m.get(), mjOBJ_JOINT, s.body_names[0].c_str());
  for (int i = 0; i < 7; ++i) mj.d->qpos[mj.m->jnt_qposadr[base] + i] = x.q[i];
  for (int i = 0; i < 6; ++i) mj.d->qvel[mj.m->jnt_dofadr[base] + i] = x.v[i];
  for (int j = 0; j < N; ++j) {
    const spatial::Gear& g = c.links[j].gear;
    D[6 + j] = g.present ? g.ratio.value : 1;
    const int joint = mj_name2id(mj.m.get(), mjOBJ_JOINT, s.joint_names[j].c_str());
    mj.d->qpos[mj.m->jnt_qposadr[joint]] = x.q[7 + j] / D[6 + j];
    mj.d->qvel[mj.m->jnt_dofadr[joint]] = x.v[6 + j] / D[6 + j];
    mj.d->qfrc_applied[mj.m->jnt_dofadr[joint]] = x.tau[j];
    const std::string rotor = "spacearm_rotor_" + std::to_string(j + 1);
    if (const int r = mj_name2id(mj.m.get(), mjOBJ_JOINT, rotor.c_str()); r >= 0) {
      mj.d->qpos[mj.m->jnt_qposadr[r]] = x.q[7 + j];
      mj.d->qvel[mj.m->jnt_dofadr[r]] = x.v[6 + j];
    }
  }
  return D;
}

// The chain's dofs of MuJoCo's vector x (by joint name).
Eigen::VectorXd chain_dofs(const SpatialScene& s, const test::MujocoModel& mj, const mjtNum* x) {
  Eigen::VectorXd out(s.chain.nv());
  const int base = mj_name2id(mj.m.get(), mjOBJ_JOINT, s.body_names[0].c_str());
  for (int i = 0; i < 6; ++i) out[i] = x[mj.m->jnt_dofadr[base] + i];
  for (size_t j = 0; j < s.joint_names.size(); ++j)
    out[6 + j] = x[mj.m->jnt_dofadr[mj_name2id(mj.m.get(), mjOBJ_JOINT, s.joint_names[j].c_str())]];
  return out;
}

// A URDF's joint ranges are exported (link side, MuJoCo's hinge angle) but not enforced: a joint
// beyond its range meets no limit constraint in MuJoCo, as it meets no force in spacearm.
TEST(MjcfExport, TheUrdfsRangesAreKeptNotEnforced) {
  const SpatialScene s = arm7(Gears::armature);
  ASSERT_EQ(s.joint_limits.size(), 7u);
  const test::MujocoModel mj(export_mjcf(s));
  for (size_t j = 0; j < 7; ++j) {
    const int id = mj_name2id(mj.m.get(), mjOBJ_JOINT, s.joint_names[j].c_str());
    ASSERT_GE(id, 0) << s.joint_names[j];
    EXPECT_EQ(mj.m->jnt_range[2 * id], s.joint_limits[j].lower) << j;
    EXPECT_EQ(mj.m->jnt_range[2 * id + 1], s.joint_limits[j].upper) << j;
    EXPECT_EQ(mj.m->jnt_limited[id], 0) << j;
  }
  const int joint1 = mj_name2id(mj.m.get(), mjOBJ_JOINT, s.joint_names[0].c_str());
  mj.d->qpos[mj.m->jnt_qposadr[joint1]] = s.joint_limits[0].upper + 0.5;
  mj_forward(mj.m.get(), mj.d.get());
  EXPECT_EQ(mj.d->nefc, 0);
}

TEST(MujocoAgreement, ExportedRigidAndArmatureArmsAgreeToRounding) {
  for (const Gears gears : {Gears::none, Gears::armature}) {
    SCOPED_TRACE(gears == Gears::armature ? "armature gears" : "no gears");
    const SpatialScene s = arm7(gears);
    const spatial::ChainDescription& c = s.chain;
    const test::MujocoModel mj(export_mjcf(s));
    ASSERT_EQ(mj.m->nq, c.nq());
    ASSERT_EQ(mj.m->nv, c.nv());
    std::mt19937 rng(5);
    for (int trial = 0; trial < 5; ++trial) {
      const State x = random_state(c, rng);
      const Eigen::VectorXd D = set_state(s, mj, x);
      mj_forward(mj.m.get(), mj.d.get());
      const int nv = c.nv();
      Eigen::MatrixXd M_mj(nv, nv);
      mj_fullM(mj.m.get(), M_mj.data(), mj.d->qM);  // symmetric: row or column major alike
      const Eigen::VectorXd b_mj = Eigen::Map<const Eigen::VectorXd>(mj.d->qfrc_bias, nv);
      const Eigen::VectorXd qacc_mj = Eigen::Map<const Eigen::VectorXd>(mj.d->qacc, nv);
      Eigen::VectorXd Q = Eigen::VectorXd::Zero(nv);
      Q.tail(x.tau.size()) = x.tau.cwiseQuotient(D.tail(x.tau.size()));
      const Eigen::VectorXd Mv = chain_output(c, Output::mass_matrix, x.q, x.v, Q);
      const Eigen::MatrixXd M = Eigen::Map<const Eigen::MatrixXd>(Mv.data(), nv, nv);
      const Eigen::MatrixXd M_ours = D.asDiagonal() * M * D.asDiagonal();
      EXPECT_LT((M_ours - M_mj).norm(), 1e-12 * M_mj.norm()) << trial;
      const Eigen::VectorXd b_ours =
          D.asDiagonal() * chain_output(c, Output::bias_forces, x.q, x.v, Q);
      EXPECT_LT((b_ours - b_mj).norm(), 1e-12 * (1 + b_mj.norm())) << trial;
      const Eigen::VectorXd qacc_ours =
          chain_output(c, Output::forward_dynamics, x.q, x.v, Q).cwiseQuotient(D);  // qdd_m / p
      EXPECT_LT((qacc_ours - qacc_mj).norm(), 1e-12 * (1 + qacc_mj.norm())) << trial;
    }
  }
}

// Issue 53: the chain's state Jacobian on the tangent space is MuJoCo's: central differences of
// mj_forward's qacc along mj_integratePos (MuJoCo's own q ⊕ delta: the free joint's angular
// velocity in the body's frame), along qvel and along qfrc_applied, for the ungeared arm.
TEST(MujocoAgreement, TheStateJacobianIsMujocosOnItsTangentSpace) {
  const SpatialScene s = arm7(Gears::none);
  const spatial::ChainDescription& c = s.chain;
  const test::MujocoModel mj(export_mjcf(s));
  const int nv = c.nv(), N = static_cast<int>(c.links.size());
  std::mt19937 rng(8);
  const State x = random_state(c, rng);
  Eigen::VectorXd Q = Eigen::VectorXd::Zero(nv);
  Q.tail(N) = x.tau;
  auto input = [&](const std::string& a, int i) {
    return a == "q" ? x.q[i] : a == "qd" ? x.v[i] : a == "Q" ? Q[i] : 0.0;
  };
  const auto J = evaluate_chain<spatial::Chain>(c, Output::forward_dynamics_derivatives, input);
  using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  const Eigen::MatrixXd dq = Eigen::Map<const RowMajor>(J[0].data(), nv, nv),
                        dqd = Eigen::Map<const RowMajor>(J[1].data(), nv, nv),
                        dtau = Eigen::Map<const RowMajor>(J[3].data(), nv, N);
  // MuJoCo's qacc in the chain's dofs with one input moved by +-h along direction k. Its qacc
  // reaches 1.8e3 here (a light wrist) and agrees with ours to about 1e-12 of that, so steps of
  // 1e-6 would difference its rounding (1e-3 of a column); 1e-4 keeps both it and the step's
  // own error near 1e-6.
  const double h = 1e-4;
  auto qacc = [&](int what, int k, double step) {
    set_state(s, mj, x);
    std::vector<mjtNum> direction(nv, 0.0);
    direction[k] = 1;
    if (what == 0) mj_integratePos(mj.m.get(), mj.d->qpos, direction.data(), step);
    if (what == 1) mj.d->qvel[k] += step;
    if (what == 2) mj.d->qfrc_applied[6 + k] += step;
    mj_forward(mj.m.get(), mj.d.get());
    return chain_dofs(s, mj, mj.d->qacc);
  };
  for (int k = 0; k < nv; ++k)
    for (int what : {0, 1}) {
      const Eigen::VectorXd column = (qacc(what, k, h) - qacc(what, k, -h)) / (2 * h);
      const Eigen::VectorXd ours = what == 0 ? dq.col(k) : dqd.col(k);
      EXPECT_LT((ours - column).norm(), 1e-5 * (1 + column.norm())) << what << " " << k;
    }
  for (int j = 0; j < N; ++j) {
    const Eigen::VectorXd column = (qacc(2, j, 1.0) - qacc(2, j, -1.0)) / 2;  // affine in tau
    EXPECT_LT((dtau.col(j) - column).norm(), 1e-9 * (1 + column.norm())) << "tau " << j;
  }
}

TEST(MujocoAgreement, ExportedExactRotorsAgreeToTheEqualitiesTolerance) {
  const SpatialScene s = arm7(Gears::exact);
  const spatial::ChainDescription& c = s.chain;
  const test::MujocoModel mj(export_mjcf(s));
  ASSERT_EQ(mj.m->nv, c.nv() + static_cast<int>(c.links.size()));  // a rotor per joint
  std::mt19937 rng(7);
  double worst = 0;
  for (int trial = 0; trial < 5; ++trial) {
    const State x = random_state(c, rng);
    const Eigen::VectorXd D = set_state(s, mj, x);
    mj_forward(mj.m.get(), mj.d.get());
    Eigen::VectorXd Q = Eigen::VectorXd::Zero(c.nv());
    Q.tail(x.tau.size()) = x.tau.cwiseQuotient(D.tail(x.tau.size()));
    const Eigen::VectorXd qacc_ours =
        chain_output(c, Output::forward_dynamics, x.q, x.v, Q).cwiseQuotient(D);
    const Eigen::VectorXd qacc_mj = chain_dofs(s, mj, mj.d->qacc);
    worst = std::max(worst, (qacc_ours - qacc_mj).norm() / (1 + qacc_mj.norm()));
  }
  std::printf("exact rotors: MuJoCo's forward dynamics within %.1e relative\n", worst);
  EXPECT_LT(worst, 2e-4);
  // Without the rotors' gyroscopic coupling (the armature model) the difference is larger: the
  // comparison sees the rotors.
  SpatialScene armature = s;
  for (auto& l : armature.chain.links) l.gear.exact = false;
  const State x = random_state(c, rng);
  const Eigen::VectorXd D = set_state(s, mj, x);
  mj_forward(mj.m.get(), mj.d.get());
  Eigen::VectorXd Q = Eigen::VectorXd::Zero(c.nv());
  Q.tail(x.tau.size()) = x.tau.cwiseQuotient(D.tail(x.tau.size()));
  const Eigen::VectorXd qacc_armature =
      chain_output(armature.chain, Output::forward_dynamics, x.q, x.v, Q).cwiseQuotient(D);
  const Eigen::VectorXd qacc_mj = chain_dofs(s, mj, mj.d->qacc);
  EXPECT_GT((qacc_armature - qacc_mj).norm() / (1 + qacc_mj.norm()), 10 * worst);
}

// A URDF of one identified link (Izz above Ixx + Iyy) and names that need escaping.
std::string identified_urdf(const std::string& izz) {
  return "<robot name=\"r\">\n"
         "<link name=\"bus\"><inertial><mass value=\"100\"/><inertia ixx=\"10\" ixy=\"0\" "
         "ixz=\"0\" iyy=\"12\" iyz=\"0\" izz=\"14\"/></inertial></link>\n"
         "<link name=\"arm &amp; &quot;hand&quot;\"><inertial><mass value=\"5\"/><inertia "
         "ixx=\"0.2\" ixy=\"0\" ixz=\"0\" iyy=\"0.2\" iyz=\"0\" izz=\"" +
         izz +
         "\"/></inertial></link>\n"
         "<joint name=\"j&lt;1&gt;\" type=\"revolute\"><parent link=\"bus\"/><child "
         "link=\"arm &amp; &quot;hand&quot;\"/><origin xyz=\"0.5 0 0\"/><axis xyz=\"0 0 "
         "1\"/></joint>\n</robot>\n";
}
SpatialScene urdf_scene(const std::string& xml, const std::string& more = "") {
  return parse_spatial_scene(
      "name: r\nspace: spatial\nbase: {type: free_floating}\nurdf: r.urdf\n" + more, "r.yaml",
      [xml](const std::string&) { return xml; });
}

TEST(MjcfExport, NamesAreEscapedAndParametersTakeTheirValues) {
  const SpatialScene s = urdf_scene(identified_urdf("0.3"));
  const test::MujocoModel mj(export_mjcf(s));
  EXPECT_GE(mj_name2id(mj.m.get(), mjOBJ_JOINT, "j<1>"), 0);
  EXPECT_GE(mj_name2id(mj.m.get(), mjOBJ_BODY, "arm & \"hand\""), 0);
  EXPECT_GE(mj_name2id(mj.m.get(), mjOBJ_SITE, "end_effector"), 0);
  const SpatialScene p = parse_spatial_scene(R"(name: p
space: spatial
base: {type: free_floating, mass: mb, inertia: [10, 0, 0, 12, 0, 14]}
links: [{origin: [0.5, 0, 0], axis: [0, 0, 1], mass: 5, inertia: [0.2, 0, 0, 0.2, 0, 0.3]}]
gears: {ratio: p, rotor_inertia: [1e-4, 0], rotor_coupling: armature}
friction: {viscous: 0.5}
parameters: {mb: 100, p: 50}
)",
                                             "p.yaml");
  MjcfOptions o;
  o.params = {250, 20};
  const test::MujocoModel given(export_mjcf(p, o));
  EXPECT_DOUBLE_EQ(given.m->body_mass[mj_name2id(given.m.get(), mjOBJ_BODY, "base")], 250);
  EXPECT_DOUBLE_EQ(given.m->dof_armature[6], 20 * 20 * 1e-4);
  EXPECT_DOUBLE_EQ(given.m->dof_damping[6], 20 * 20 * 0.5);  // p b p q' on q
  const test::MujocoModel nominal(export_mjcf(p));
  EXPECT_DOUBLE_EQ(nominal.m->body_mass[mj_name2id(nominal.m.get(), mjOBJ_BODY, "base")], 100);
  o.params = {1};
  EXPECT_THROW(export_mjcf(p, o), std::invalid_argument);
}

TEST(MjcfExport, WhatMujocoLacksIsRefusedNamed) {
  // An identified body: MuJoCo refuses its tensor; with balance_inertia MuJoCo changes it.
  const SpatialScene s = urdf_scene(identified_urdf("0.9"), "inertia_check: positive_definite\n");
  EXPECT_THROW_MESSAGE(export_mjcf(s), std::invalid_argument,
                       "these bodies' are not: 'arm & \"hand\"'. --balance-inertia lets MuJoCo "
                       "change them");
  MjcfOptions o;
  o.balance_inertia = true;
  const std::string xml = export_mjcf(s, o);
  EXPECT_NE(xml.find("balanceinertia=\"true\""), std::string::npos);
  EXPECT_NO_THROW(test::MujocoModel{xml});
  // A flexible joint's spring has no counterpart.
  SpatialScene flexible = arm7(Gears::exact);
  flexible.chain.links[2].gear.flexible = true;
  EXPECT_THROW_MESSAGE(export_mjcf(flexible), std::invalid_argument,
                       "joint 'joint3' is flexible (gears: stiffness)");
}

// A planar scene (issue 51) as the 3D model that moves in its plane: MuJoCo's M and bias at
// in-plane states, on its x, y, turn about z and hinges, are the planar model's (its GiNaC closed
// forms, sharing no code with the spatial chain), the geared slots scaled to link angles; the
// out-of-plane bias is zero. The reference model, and the armature model at p = 20.
TEST(MjcfExport, APlanarSceneMovesInItsPlane) {
  for (const char* name : {"paper_reference", "paper_geared_armature"}) {
    SCOPED_TRACE(name);
    const std::string path = std::string(SPACEARM_SOURCE_DIR) + "/models/" + name + ".yaml";
    const Scene planar = parse_scene(test::read_text_file(path), path);
    Eigen::VectorXd params = Eigen::VectorXd::Zero(planar.parameters.size());
    for (size_t k = 0; k < planar.parameters.size(); ++k)
      params[k] = planar.parameters[k].name == "p" ? 20 : planar.parameters[k].nominal.value;
    const test::MujocoModel mj(
        export_mjcf(planar_as_spatial(planar, {params.data(), params.data() + params.size()})));
    const int N = planar.num_links(), n = 3 + N;
    ASSERT_EQ(mj.m->nv, 6 + N);
    const SymbolicModel model = derive(planar);
    const Eigen::VectorXd ratio = Eigen::VectorXd::Constant(N, planar.geared() ? 20.0 : 1.0);
    std::mt19937 rng(8);
    std::uniform_real_distribution<double> u(-1, 1);
    for (int trial = 0; trial < 5; ++trial) {
      Eigen::VectorXd q(n), v(n);  // planar: x0, y0, q0, then the slots (motor angles if geared)
      for (int i = 0; i < n; ++i) q[i] = 2 * u(rng), v[i] = u(rng);
      mju_zero(mj.d->qpos, mj.m->nq);
      mju_zero(mj.d->qvel, mj.m->nv);
      const int plane[3] = {0, 1, 5};  // x, y and the turn about z among the free joint's dofs
      mj.d->qpos[0] = q[0], mj.d->qpos[1] = q[1];
      mj.d->qpos[3] = std::cos(q[2] / 2), mj.d->qpos[6] = std::sin(q[2] / 2);
      for (int k = 0; k < 3; ++k) mj.d->qvel[plane[k]] = v[k];
      for (int j = 0; j < N; ++j)
        mj.d->qpos[7 + j] = q[3 + j] / ratio[j], mj.d->qvel[6 + j] = v[3 + j] / ratio[j];
      mj_forward(mj.m.get(), mj.d.get());
      Eigen::MatrixXd M_mj(6 + N, 6 + N);
      mj_fullM(mj.m.get(), M_mj.data(), mj.d->qM);
      std::vector<int> rows = {0, 1, 5};
      for (int j = 0; j < N; ++j) rows.push_back(6 + j);
      Eigen::MatrixXd M_plane(n, n);
      Eigen::VectorXd b_plane(n);
      for (int r = 0; r < n; ++r) {
        b_plane[r] = mj.d->qfrc_bias[rows[r]];
        for (int c = 0; c < n; ++c) M_plane(r, c) = M_mj(rows[r], rows[c]);
      }
      for (int out : {2, 3, 4}) EXPECT_NEAR(mj.d->qfrc_bias[out], 0, 1e-12);  // no out-of-plane
      Eigen::VectorXd D = Eigen::VectorXd::Ones(n);  // d(planar slot) / d(MuJoCo's coordinate)
      D.tail(N) = ratio;
      const Eigen::MatrixXd M = evaluate_output(model, Output::mass_matrix, {q}, params)[0];
      const Eigen::VectorXd b = evaluate_output(model, Output::bias_forces, {q, v}, params)[0];
      EXPECT_LT((D.asDiagonal() * M * D.asDiagonal() - M_plane).norm(), 1e-12 * M_plane.norm());
      EXPECT_LT((D.asDiagonal() * b - b_plane).norm(), 1e-12 * (1 + b_plane.norm()));
    }
  }
}

// A rotor coupling factor (issue 51) exports at its ends: c = 1 as the exact scene's file, c = 0
// as the armature scene's; between them MuJoCo has no counterpart, refused naming the joint.
TEST(MjcfExport, ACouplingFactorExportsAtItsEndsOnly) {
  auto scene = [](const std::string& coupling, const std::string& parameters) {
    return parse_spatial_scene(
        "name: c\nspace: spatial\nbase: {type: free_floating, mass: 100, inertia: [10, 0, 0, 12, "
        "0, 14]}\nlinks: [{origin: [0.5, 0, 0], axis: [0, 0, 1], mass: 5, inertia: [0.2, 0, 0, "
        "0.2, 0, 0.3]}]\ngears: {ratio: 50, rotor_inertia: [1e-4, 6e-5], rotor_coupling: " +
            coupling + "}\n" + parameters,
        "c.yaml");
  };
  const SpatialScene coupled = scene("c", "parameters: {c: 0.5}\n");
  MjcfOptions o;
  o.params = {1};
  const std::string exact = export_mjcf(scene("exact", ""));
  EXPECT_EQ(export_mjcf(coupled, o), exact);
  o.params = {0};
  const std::string armature = export_mjcf(scene("armature", ""));
  EXPECT_EQ(export_mjcf(coupled, o), armature);
  EXPECT_THROW_MESSAGE(export_mjcf(coupled), std::invalid_argument,
                       "joint 'joint1' has rotor_coupling c = 0.5: MuJoCo has exact rotors (1) and "
                       "armature (0) only; export with --param c=1 or =0");
  EXPECT_THROW_MESSAGE(export_mjcf(scene("0.25", "")), std::invalid_argument,
                       "give rotor_coupling: exact or armature");
}

// Found in review: names XML cannot carry or MuJoCo would refuse are refused by name; a fixed
// base's exact rotor gets a mass MuJoCo takes; overflowing numbers and massless bodies are
// refused, never written.
TEST(MjcfExport, NamesAndNumbersMujocoWouldRefuseAreRefusedFirst) {
  auto renamed = [](const std::string& from, const std::string& to) {
    std::string xml = identified_urdf("0.3");
    for (size_t at; (at = xml.find(from)) != std::string::npos;) xml.replace(at, from.size(), to);
    return xml;
  };
  const std::vector<std::pair<std::string, std::string>> cases = {
      {renamed("j&lt;1&gt;", "j&#1;1"), "holds a character XML cannot carry as it is"},
      {renamed("j&lt;1&gt;", "j&#9;1"), "holds a character XML cannot carry as it is"},
      {renamed("j&lt;1&gt;", "j\xff"), "holds a character XML cannot carry as it is"},
      {renamed("j&lt;1&gt;", "bus"),
       "the base's free joint and a joint are both named 'bus', and MuJoCo needs each name once"},
      {renamed("\"bus\"", "\"world\""), "the base's body is named 'world', MuJoCo's own"},
  };
  for (const auto& [xml, message] : cases) {
    SCOPED_TRACE(message);
    EXPECT_THROW_MESSAGE(export_mjcf(urdf_scene(xml)), std::invalid_argument, message);
  }
  // A fixed base (massless) carrying an exact rotor: the rotor's own mass, and MuJoCo loads it.
  SpatialScene fixed = arm7(Gears::exact);
  fixed.chain.free_base = false;
  fixed.chain.base = {};
  EXPECT_NO_THROW(test::MujocoModel{export_mjcf(fixed)});
  // Parameters that overflow the model's numbers, or leave a body without mass.
  const SpatialScene p = parse_spatial_scene(R"(name: p
space: spatial
base: {type: free_floating, mass: 100, inertia: [10, 0, 0, 12, 0, 14]}
links: [{origin: [0.5, 0, 0], axis: [0, 0, 1], mass: m, inertia: [0.2, 0, 0, 0.2, 0, 0.3]}]
gears: {ratio: p, rotor_inertia: [1e-4, 0], rotor_coupling: armature}
parameters: {m: 5, p: 50}
)",
                                             "p.yaml");
  MjcfOptions o;
  o.params = {5, 1e200};
  EXPECT_THROW_MESSAGE(export_mjcf(p, o), std::invalid_argument, "is not finite");
  o.params = {0, 50};
  EXPECT_THROW_MESSAGE(export_mjcf(p, o), std::invalid_argument,
                       "need a positive mass, and these bodies' is 0 at the parameters' values: "
                       "'link1'");
}

// Issue 52: trees. MuJoCo's view of a tree by the exporter's names: the state in (rotors at
// qm = p q), and the chain's dofs out.
struct TreeInMujoco {
  const spatial::ChainDescription& c;
  MjcfNames names;
  const test::MujocoModel& mj;
  int dof(int j) const {
    return mj.m->jnt_dofadr[mj_name2id(mj.m.get(), mjOBJ_JOINT, names.joints[j].c_str())];
  }
  Eigen::VectorXd set(const State& x) const {
    const int N = static_cast<int>(c.links.size());
    Eigen::VectorXd D = Eigen::VectorXd::Ones(c.nv());
    mju_zero(mj.d->qfrc_applied, mj.m->nv);
    const int base = mj_name2id(mj.m.get(), mjOBJ_JOINT, names.base_joint.c_str());
    for (int i = 0; i < 7; ++i) mj.d->qpos[mj.m->jnt_qposadr[base] + i] = x.q[i];
    for (int i = 0; i < 6; ++i) mj.d->qvel[mj.m->jnt_dofadr[base] + i] = x.v[i];
    for (int j = 0; j < N; ++j) {
      const spatial::Gear& g = c.links[j].gear;
      D[6 + j] = g.present ? g.ratio.value : 1;
      const int joint = mj_name2id(mj.m.get(), mjOBJ_JOINT, names.joints[j].c_str());
      mj.d->qpos[mj.m->jnt_qposadr[joint]] = x.q[7 + j] / D[6 + j];
      mj.d->qvel[mj.m->jnt_dofadr[joint]] = x.v[6 + j] / D[6 + j];
      mj.d->qfrc_applied[mj.m->jnt_dofadr[joint]] = x.tau[j];
      if (names.rotors[j].empty()) continue;
      const int r = mj_name2id(mj.m.get(), mjOBJ_JOINT, names.rotors[j].c_str());
      mj.d->qpos[mj.m->jnt_qposadr[r]] = x.q[7 + j];
      mj.d->qvel[mj.m->jnt_dofadr[r]] = x.v[6 + j];
    }
    return D;
  }
  Eigen::VectorXd dofs(const mjtNum* x) const {
    Eigen::VectorXd out(c.nv());
    const int base = mj_name2id(mj.m.get(), mjOBJ_JOINT, names.base_joint.c_str());
    for (int i = 0; i < 6; ++i) out[i] = x[mj.m->jnt_dofadr[base] + i];
    for (size_t j = 0; j < c.links.size(); ++j) out[6 + j] = x[dof(static_cast<int>(j))];
    return out;
  }
};

// A random tree of 10 joints (each link's parent one of the three bodies before it, so that
// several leave the base and inner links) with physical inertias, ungeared or with armature.
SpatialScene random_tree_scene(std::mt19937& rng, bool armature) {
  std::uniform_real_distribution<double> u(-1, 1);
  SpatialScene s;
  s.name = "tree";
  s.chain.base.mass = 80;
  s.chain.base.inertia = {9, 0.3, 0, 11, -0.2, 10};
  s.chain.end_effectors.clear();
  for (int i = 1; i <= 10; ++i) {
    spatial::Link l;
    l.parent = std::uniform_int_distribution<int>(std::max(0, i - 3), i - 1)(rng);
    l.origin_xyz = {0.3 + 0.2 * u(rng), 0.2 * u(rng), 0.2 * u(rng)};
    l.origin_rpy = {u(rng), u(rng), u(rng)};
    l.axis = {u(rng), u(rng), u(rng)};
    l.mass = 2 + u(rng);
    l.com = {0.15, 0.05 * u(rng), 0.05 * u(rng)};
    const double a = 0.05 + 0.01 * u(rng), b = 0.05 + 0.01 * u(rng);
    l.inertia = {a, 0, 0, b, 0, 0.5 * (a + b)};
    if (armature) l.gear = {true, 20 + 30 * (1 + u(rng)), 1e-4, 5e-5, false};
    s.chain.links.push_back(l);
  }
  for (int i = 1; i <= 10; ++i) {
    bool leaf = true;
    for (const auto& l : s.chain.links) leaf = leaf && l.parent != i;
    if (leaf) s.chain.end_effectors.push_back({"leaf" + std::to_string(i), i, {0.1, 0, 0}, {}});
  }
  return s;
}

// Issue 52: trees exported to MuJoCo, a body per link nested in its parent's (and a rotor body
// per exact gear on the parent, a branch's first joint's on the base): models/dual_arm7 (two
// 7-joint arms) and random trees, ungeared and with armature, agree with MuJoCo on M, the bias
// and the forward dynamics to 1e-12 relative; with exact rotors to the equalities' tolerance.
TEST(MujocoAgreement, ExportedTreesAgreeToRounding) {
  const std::string path = std::string(SPACEARM_SOURCE_DIR) + "/models/dual_arm7.yaml";
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  const SpatialScene dual = parse_spatial_scene(text.str(), path);
  std::mt19937 rng(11);
  std::vector<std::pair<std::string, SpatialScene>> scenes;
  for (const bool geared : {false, true}) {
    SpatialScene d = dual;
    for (auto& l : d.chain.links) {
      if (!geared) l.gear = {};
      l.gear.exact = false;
    }
    scenes.push_back({geared ? "dual arm, armature" : "dual arm", d});
    scenes.push_back(
        {geared ? "random tree, armature" : "random tree", random_tree_scene(rng, geared)});
  }
  for (const auto& [name, s] : scenes) {
    SCOPED_TRACE(name);
    const spatial::ChainDescription& c = s.chain;
    ASSERT_FALSE(c.serial());
    const test::MujocoModel mj(export_mjcf(s));
    const TreeInMujoco tree{c, mjcf_names(s), mj};
    ASSERT_EQ(mj.m->nv, c.nv());
    for (int trial = 0; trial < 4; ++trial) {
      const State x = random_state(c, rng);
      const Eigen::VectorXd D = tree.set(x);
      mj_forward(mj.m.get(), mj.d.get());
      const int nv = c.nv();
      Eigen::MatrixXd M_full(nv, nv);
      mj_fullM(mj.m.get(), M_full.data(), mj.d->qM);
      Eigen::VectorXi order(nv);  // MuJoCo's dof of each chain velocity
      for (int i = 0; i < 6; ++i) order[i] = i;
      for (int j = 0; j < nv - 6; ++j) order[6 + j] = tree.dof(j);
      Eigen::MatrixXd M_mj(nv, nv);
      for (int a = 0; a < nv; ++a)
        for (int b = 0; b < nv; ++b) M_mj(a, b) = M_full(order[a], order[b]);
      Eigen::VectorXd Q = Eigen::VectorXd::Zero(nv);
      Q.tail(x.tau.size()) = x.tau.cwiseQuotient(D.tail(x.tau.size()));
      const Eigen::VectorXd Mv = chain_output(c, Output::mass_matrix, x.q, x.v, Q);
      const Eigen::MatrixXd M =
          D.asDiagonal() * Eigen::Map<const Eigen::MatrixXd>(Mv.data(), nv, nv) * D.asDiagonal();
      EXPECT_LT((M - M_mj).norm(), 1e-12 * M_mj.norm()) << trial;
      const Eigen::VectorXd b_mj = tree.dofs(mj.d->qfrc_bias);
      const Eigen::VectorXd b = D.asDiagonal() * chain_output(c, Output::bias_forces, x.q, x.v, Q);
      EXPECT_LT((b - b_mj).norm(), 1e-12 * (1 + b_mj.norm())) << trial;
      const Eigen::VectorXd qacc_mj = tree.dofs(mj.d->qacc);
      const Eigen::VectorXd qacc =
          chain_output(c, Output::forward_dynamics, x.q, x.v, Q).cwiseQuotient(D);
      EXPECT_LT((qacc - qacc_mj).norm(), 1e-12 * (1 + qacc_mj.norm())) << trial;
    }
  }
  // Exact rotors on both arms, the shoulders' on the satellite.
  const test::MujocoModel mj(export_mjcf(dual));
  const TreeInMujoco tree{dual.chain, mjcf_names(dual), mj};
  ASSERT_EQ(mj.m->nv, dual.chain.nv() + 14);
  double worst = 0;
  for (int trial = 0; trial < 4; ++trial) {
    const State x = random_state(dual.chain, rng);
    const Eigen::VectorXd D = tree.set(x);
    mj_forward(mj.m.get(), mj.d.get());
    Eigen::VectorXd Q = Eigen::VectorXd::Zero(dual.chain.nv());
    Q.tail(x.tau.size()) = x.tau.cwiseQuotient(D.tail(x.tau.size()));
    const Eigen::VectorXd qacc =
        chain_output(dual.chain, Output::forward_dynamics, x.q, x.v, Q).cwiseQuotient(D);
    const Eigen::VectorXd qacc_mj = tree.dofs(mj.d->qacc);
    worst = std::max(worst, (qacc - qacc_mj).norm() / (1 + qacc_mj.norm()));
  }
  std::printf("dual arm, exact rotors: MuJoCo's forward dynamics within %.1e relative\n", worst);
  EXPECT_LT(worst, 2e-4);
}

}  // namespace
}  // namespace spacearm
