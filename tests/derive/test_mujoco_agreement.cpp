// The spatial chain against MuJoCo (tests/support/mujoco_spatial.hpp), a peer that shares no code
// with it: models/space_arm7 (from its URDF: welded links lumped) on a free base, ungeared and with
// armature gears, at random states: the mass matrix, the bias forces and the forward dynamics
// under joint torques, each to 1e-12 relative. MuJoCo's joint coordinate is the link angle q,
// the chain's the motor angle qm = p q: v = D v_mj with D = diag(1 (base), p), so
// M_mj = D M D, b_mj = D b and a joint torque tau is Q = tau / p on the chain's coordinate.
#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <fstream>
#include <random>
#include <sstream>

#include "mujoco_spatial.hpp"
#include "recursive_algorithms.hpp"
#include "spatial_scene.hpp"

namespace spacearm {
namespace {

spatial::ChainDescription arm7(bool geared) {
  const std::string path = std::string(SPACEARM_SOURCE_DIR) + "/models/space_arm7.yaml";
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  spatial::ChainDescription c = parse_spatial_scene(text.str(), path).chain;
  for (auto& l : c.links) {
    if (!geared) l.gear = {};
    l.gear.exact = false;  // MuJoCo has the armature model only
  }
  return c;
}

TEST(MujocoAgreement, SpatialArmOnAFreeBaseAtRandomStates) {
  for (const bool geared : {false, true}) {
    SCOPED_TRACE(geared ? "armature gears" : "no gears");
    const spatial::ChainDescription c = arm7(geared);
    test::MujocoModel mj(test::mjcf_of(c));
    const int nq = c.nq(), nv = c.nv(), N = static_cast<int>(c.links.size());
    ASSERT_EQ(mj.m->nq, nq);
    ASSERT_EQ(mj.m->nv, nv);
    Eigen::VectorXd D = Eigen::VectorXd::Ones(nv);
    for (int j = 0; j < N; ++j)
      D[6 + j] = c.links[j].gear.present ? c.links[j].gear.ratio.value : 1;
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> u(-1, 1);
    for (int trial = 0; trial < 5; ++trial) {
      Eigen::VectorXd q(nq), v(nv), tau(N);
      for (int i = 0; i < nq; ++i) q[i] = 2 * u(rng);
      const Eigen::Quaterniond r = Eigen::Quaterniond::UnitRandom();
      q.segment<4>(3) << r.w(), r.x(), r.y(), r.z();
      for (int i = 0; i < nv; ++i) v[i] = u(rng);
      for (int j = 0; j < N; ++j) tau[j] = 10 * u(rng);
      // MuJoCo at the same state in its coordinates.
      for (int i = 0; i < nq; ++i) mj.d->qpos[i] = i < 7 ? q[i] : q[i] / D[i - 1];
      for (int i = 0; i < nv; ++i) mj.d->qvel[i] = v[i] / D[i];
      for (int i = 0; i < nv; ++i) mj.d->qfrc_applied[i] = i < 6 ? 0 : tau[i - 6];
      mj_forward(mj.m.get(), mj.d.get());
      Eigen::MatrixXd M_mj(nv, nv);
      mj_fullM(mj.m.get(), M_mj.data(), mj.d->qM);  // symmetric: row or column major alike
      const Eigen::VectorXd b_mj = Eigen::Map<const Eigen::VectorXd>(mj.d->qfrc_bias, nv);
      const Eigen::VectorXd qacc_mj = Eigen::Map<const Eigen::VectorXd>(mj.d->qacc, nv);
      // The chain.
      Eigen::VectorXd Q = Eigen::VectorXd::Zero(nv);
      for (int j = 0; j < N; ++j) Q[6 + j] = tau[j] / D[6 + j];
      auto input = [&](const std::string& a, int i) {
        return a == "q" ? q[i] : a == "qd" ? v[i] : a == "Q" ? Q[i] : 0.0;
      };
      auto output = [&](Output o) {
        const std::vector<double> x = evaluate_chain<spatial::Chain>(c, o, input)[0];
        return Eigen::VectorXd(Eigen::Map<const Eigen::VectorXd>(x.data(), x.size()));
      };
      const Eigen::VectorXd Mv = output(Output::mass_matrix);
      const Eigen::MatrixXd M = Eigen::Map<const Eigen::MatrixXd>(Mv.data(), nv, nv);
      const Eigen::MatrixXd M_ours = D.asDiagonal() * M * D.asDiagonal();
      EXPECT_LT((M_ours - M_mj).norm(), 1e-12 * M_mj.norm()) << trial;
      const Eigen::VectorXd b_ours = D.asDiagonal() * output(Output::bias_forces);
      EXPECT_LT((b_ours - b_mj).norm(), 1e-12 * (1 + b_mj.norm())) << trial;
      const Eigen::VectorXd qacc_ours =
          output(Output::forward_dynamics).cwiseQuotient(D);  // qdd_m / p
      EXPECT_LT((qacc_ours - qacc_mj).norm(), 1e-12 * (1 + qacc_mj.norm())) << trial;
    }
  }
}

}  // namespace
}  // namespace spacearm
