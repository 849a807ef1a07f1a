// The compiled generated code: equal to GiNaC's evaluation of the same expressions, and
// checked against invariants and the independent numeric oracle. Covers the checked-in
// paper models and test models generated at build time from tests/scenes.
#include <Eigen/Cholesky>

#include <random>

#include "dynamic_model.hpp"
#include "fixed_n1.hpp"
#include "fixed_n5_geared_params.hpp"
#include "free_n2_geared.hpp"
#include "free_n8.hpp"
#include "paper_geared.hpp"
#include "paper_reference.hpp"
#include "recursive_algorithms.hpp"
#include "simulation.hpp"
#include "spatial_arm2.hpp"
#include "spatial_chain.hpp"
#include "spatial_scene.hpp"
#include "spatial_tree3.hpp"
#include "support.hpp"
#include "symbolic_model.hpp"

namespace spacearm {
namespace {

namespace ref = models::paper_reference;
namespace geo = models::paper_geared;

template <class Model>
using Vec = typename Model::template Coordinates<double>;
template <class Model>
using Params = typename Model::template Parameters<double>;

Eigen::MatrixXd evaluate_matrix(const SymbolicModel& m, const GiNaC::matrix& mat,
                                const Eigen::VectorXd& q, const Eigen::VectorXd& qd,
                                const std::vector<double>& params = {}) {
  const auto values =
      evaluate(m, mat, {q.data(), q.data() + q.size()}, {qd.data(), qd.data() + qd.size()}, params);
  return Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
      values.data(), mat.rows(), mat.cols());
}

// Relative to the largest entry of the symbolic value; an identically zero symbolic
// value must come out exactly zero.
void expect_equal_to_symbolic(const Eigen::MatrixXd& compiled, const Eigen::MatrixXd& symbolic,
                              const char* what) {
  SCOPED_TRACE(what);
  if (symbolic.cwiseAbs().maxCoeff() == 0) {
    EXPECT_EQ(compiled.cwiseAbs().maxCoeff(), 0.0);
    return;
  }
  EXPECT_MATRIX_NEAR(compiled, symbolic, 1e-12);
}

template <class Model>
void check_against_symbolic(const std::string& scene_path,
                            const std::vector<std::vector<double>>& parameter_sets) {
  SCOPED_TRACE(scene_path);
  const SymbolicModel sym = derive(load_scene(scene_path));
  ASSERT_EQ(sym.n(), Model::kNq);
  std::mt19937 rng(42);
  int nontrivial = 0;
  for (const auto& pv : parameter_sets) {
    ASSERT_EQ(static_cast<int>(pv.size()), Model::kNumParams);
    Params<Model> params;
    for (int i = 0; i < Model::kNumParams; ++i) params[i] = pv[i];
    for (int trial = 0; trial < 3; ++trial) {
      const Vec<Model> q = test::random_vector(rng, Model::kNq, 3.0),
                       qd = test::random_vector(rng, Model::kNq, 2.0);
      if constexpr (Model::kHas_mass_matrix) {
        typename Model::template MassMatrix<double> M;
        Model::mass_matrix(q, params, M);
        expect_equal_to_symbolic(
            M, evaluate_matrix(sym, sym.expression(Output::mass_matrix), q, qd, pv), "mass_matrix");
        ++nontrivial;
      }
      if constexpr (Model::kHas_coriolis_matrix) {
        typename Model::template MassMatrix<double> C;
        Model::coriolis_matrix(q, qd, params, C);
        expect_equal_to_symbolic(
            C, evaluate_matrix(sym, sym.expression(Output::coriolis_matrix), q, qd, pv),
            "coriolis_matrix");
      }
      if constexpr (Model::kHas_bias_forces) {
        Vec<Model> b;
        Model::bias_forces(q, qd, params, b);
        expect_equal_to_symbolic(
            b, evaluate_matrix(sym, sym.expression(Output::bias_forces), q, qd, pv), "bias_forces");
      }
      if constexpr (Model::kHas_mass_matrix && Model::kHas_bias_forces) {
        typename Model::template MassMatrix<double> M, M2;
        Vec<Model> b, b2;
        Model::mass_matrix(q, params, M);
        Model::bias_forces(q, qd, params, b);
        Model::mass_matrix_and_bias(q, qd, params, M2, b2);
        // Same expressions, differently shared: equal to rounding.
        EXPECT_MATRIX_NEAR(M2, M, 1e-14);
        if (b.norm() > 0) EXPECT_MATRIX_NEAR(b2, b, 1e-13);
      }
      if constexpr (Model::kHas_kinetic_energy) {
        Eigen::Matrix<double, 1, 1> T;
        T(0) = Model::kinetic_energy(q, qd, params);
        expect_equal_to_symbolic(
            T, evaluate_matrix(sym, GiNaC::matrix{{sym.kinetic_energy}}, q, qd, pv),
            "kinetic_energy");
      }
      if constexpr (Model::kHas_momentum) {
        typename Model::template Pose<double> h;
        Model::momentum(q, qd, params, h);
        expect_equal_to_symbolic(
            h, evaluate_matrix(sym, sym.expression(Output::momentum), q, qd, pv), "momentum");
      }
      if constexpr (Model::kHas_end_effector_pose) {
        typename Model::template Pose<double> x;
        Model::end_effector_pose(q, params, x);
        expect_equal_to_symbolic(
            x, evaluate_matrix(sym, sym.expression(Output::end_effector_pose), q, qd, pv),
            "end_effector_pose");
      }
      if constexpr (Model::kHas_end_effector_jacobian) {
        typename Model::template PoseJacobian<double> J;
        Model::end_effector_jacobian(q, params, J);
        expect_equal_to_symbolic(
            J, evaluate_matrix(sym, sym.expression(Output::end_effector_jacobian), q, qd, pv),
            "end_effector_jacobian");
      }
      if constexpr (Model::kHas_joint_positions) {
        typename Model::template JointPositions<double> P;
        Model::joint_positions(q, params, P);
        expect_equal_to_symbolic(
            P, evaluate_matrix(sym, sym.expression(Output::joint_positions), q, qd, pv),
            "joint_positions");
        if constexpr (Model::kHas_end_effector_pose) {
          typename Model::template Pose<double> x;
          Model::end_effector_pose(q, params, x);
          EXPECT_NEAR((P.col(Model::kNumLinks) - x.template head<2>()).norm(), 0.0,
                      1e-14 * x.norm());
        }
      }
    }
  }
  EXPECT_GT(nontrivial, 0);
}

std::string scene(const std::string& relative) {
  return std::string(SPACEARM_SOURCE_DIR) + "/" + relative;
}

TEST(CompiledEqualsSymbolic, PaperReference) {
  check_against_symbolic<ref::Model>(scene("models/paper_reference.yaml"), {{}});
}
TEST(CompiledEqualsSymbolic, PaperGeared) {
  check_against_symbolic<geo::Model>(
      scene("models/paper_geared.yaml"),
      {{1.0, 1e-5}, {1.05, 1e-5}, {10, 1e-5}, {1000, 1e-5}, {50, 0.0}});
}
TEST(CompiledEqualsSymbolic, FixedOneLink) {
  check_against_symbolic<models::fixed_n1::Model>(scene("tests/scenes/fixed_n1.yaml"), {{}});
}
TEST(CompiledEqualsSymbolic, FreeTwoLinksPerJointGears) {
  check_against_symbolic<models::free_n2_geared::Model>(scene("tests/scenes/free_n2_geared.yaml"),
                                                        {{}});
}
TEST(CompiledEqualsSymbolic, FixedFiveGearedLinksWithParameters) {
  check_against_symbolic<models::fixed_n5_geared_params::Model>(
      scene("tests/scenes/fixed_n5_geared_params.yaml"), {{20, 1e-4, 1.5}, {2, 0, 3.0}});
}
TEST(CompiledEqualsSymbolic, FreeEightLinks) {
  check_against_symbolic<models::free_n8::Model>(scene("tests/scenes/free_n8.yaml"), {{}});
}

// ---------------------------------------------------------------------------------------
// Paper models: invariants and cross-model relations.

struct PaperFixture : testing::Test {
  std::mt19937 rng{7};
  ref::Coordinates<double> random_q() { return test::random_vector(rng, 6, 3.0); }
  ref::Coordinates<double> random_qd() { return test::random_vector(rng, 6, 2.0); }
  static geo::Parameters<double> geared_params(double p, double Im) { return {p, Im}; }
};

TEST_F(PaperFixture, GearedAtUnitRatioIsTheReferenceModel) {
  const ref::Parameters<double> none;
  for (int trial = 0; trial < 20; ++trial) {
    const auto q = random_q(), qd = random_qd();
    ref::MassMatrix<double> M_ref, M_g, C_ref, C_g;
    ref::mass_matrix(q, none, M_ref);
    geo::mass_matrix(q, geared_params(1.0, 1e-5), M_g);
    ref::coriolis_matrix(q, qd, none, C_ref);
    geo::coriolis_matrix(q, qd, geared_params(1.0, 1e-5), C_g);
    EXPECT_MATRIX_NEAR(M_g, M_ref, 1e-15);
    EXPECT_MATRIX_NEAR(C_g, C_ref, 1e-14);
  }
}

// M_g(qm) = G^T M_ref(q) G - sum_i Im (b_i G)^T (b_i G) + sum_i Im a_i^T a_i with q = G qm,
// G = diag(1, 1, 1, 1/p, ...); b_i maps qd to the rate of link i (its inertia is reduced
// by Im) and a_i maps qd_g to the rate of motor i (eq. 11).
TEST_F(PaperFixture, GearedMassMatrixIsMappedReferencePlusRotors) {
  const double Im = 1e-5;
  for (double p : {1.05, 10.0, 1000.0}) {
    SCOPED_TRACE("p = " + std::to_string(p));
    Eigen::Matrix<double, 6, 6> G = Eigen::Matrix<double, 6, 6>::Identity();
    for (int j = 3; j < 6; ++j) G(j, j) = 1 / p;
    for (int trial = 0; trial < 10; ++trial) {
      const auto qm = random_q();
      const ref::Coordinates<double> q = G * qm;
      ref::MassMatrix<double> M_ref, M_g;
      ref::mass_matrix(q, {}, M_ref);
      geo::mass_matrix(qm, geared_params(p, Im), M_g);
      Eigen::Matrix<double, 6, 6> expected = G.transpose() * M_ref * G;
      Eigen::Matrix<double, 6, 6> rotors = Eigen::Matrix<double, 6, 6>::Zero();
      for (int i = 1; i <= 3; ++i) {
        Eigen::Matrix<double, 1, 6> b = Eigen::Matrix<double, 1, 6>::Zero(), a = b;
        b(2) = 1;
        for (int j = 1; j <= i; ++j) b(2 + j) = 1;
        a(2) = 1;
        for (int j = 1; j < i; ++j) a(2 + j) = 1;
        const Eigen::Matrix<double, 1, 6> bG = b * G;
        Eigen::Matrix<double, 1, 6> aG = a * G;
        aG(2 + i) = 1;  // the motor's own rate qmd_i enters unscaled
        rotors += Im * (aG.transpose() * aG - bG.transpose() * bG);
      }
      ASSERT_GT(rotors.cwiseAbs().maxCoeff(), 0.0);
      expected += rotors;
      EXPECT_MATRIX_NEAR(M_g, expected, 1e-12);
      // In motor coordinates the link inertia is divided by p^2, so at large p the rotor
      // dominates the motor's own diagonal entry.
      if (p == 1000.0) {
        EXPECT_GT(rotors(5, 5), 0.9 * M_g(5, 5));
      }
    }
  }
}

template <class Model>
void check_dynamics_invariants(const typename Model::template Parameters<double>& params,
                               const NumericLagrangian& oracle) {
  std::mt19937 rng(3);
  for (int trial = 0; trial < 10; ++trial) {
    const Vec<Model> q = test::random_vector(rng, Model::kNq, 3.0),
                     qd = test::random_vector(rng, Model::kNq, 2.0);
    typename Model::template MassMatrix<double> M, C;
    Vec<Model> b;
    Model::mass_matrix(q, params, M);
    Model::coriolis_matrix(q, qd, params, C);
    Model::bias_forces(q, qd, params, b);
    // M symmetric positive definite.
    EXPECT_EQ(M, M.transpose());
    EXPECT_EQ(Eigen::LLT<typename Model::template MassMatrix<double>>(M).info(), Eigen::Success);
    // C qd from eq. 7 is the bias and the Euler-Lagrange terms (finite differences).
    ASSERT_GT(b.norm(), 0.0);
    EXPECT_MATRIX_NEAR(C * qd, b, 1e-12);
    // Finite differences: rounding ~eps/h of the largest terms of M (see test_symbolic_model).
    EXPECT_MATRIX_NEAR(C * qd, oracle.bias_forces(q, qd), 1e-6);
    EXPECT_MATRIX_NEAR(M, oracle.mass_matrix(q), 1e-12);
    // C is exactly eq. 7, C = (Mdot - 1/2 d(M qd)/dq)^T, with dM/dq by central differences
    // of the compiled M (this pins the factorization: the Christoffel C has the same C qd).
    {
      std::vector<typename Model::template MassMatrix<double>> dM(Model::kNq);
      for (int k = 0; k < Model::kNq; ++k) {
        Vec<Model> dq = Vec<Model>::Zero();
        dq[k] = 1e-6;
        typename Model::template MassMatrix<double> Mp, Mm;
        Model::template mass_matrix<double>(q + dq, params, Mp);
        Model::template mass_matrix<double>(q - dq, params, Mm);
        dM[k] = (Mp - Mm) / 2e-6;
      }
      typename Model::template MassMatrix<double> C7 = Model::template MassMatrix<double>::Zero(),
                                                  Mdot = C7;
      for (int k = 0; k < Model::kNq; ++k) Mdot += dM[k] * qd[k];
      for (int i = 0; i < Model::kNq; ++i)
        for (int j = 0; j < Model::kNq; ++j) C7(i, j) = Mdot(i, j) - 0.5 * dM[i].row(j).dot(qd);
      EXPECT_MATRIX_NEAR(C, C7, 1e-7);
      // Eq. 7's C is not the Christoffel form: Mdot - 2C is not skew-symmetric.
      const typename Model::template MassMatrix<double> N = Mdot - 2 * C;
      EXPECT_GT((N + N.transpose()).norm(), 1e-3 * N.norm());
    }
    // C(q, 0) = 0.
    Model::template coriolis_matrix<double>(q, Vec<Model>::Zero(), params, C);
    EXPECT_EQ(C.cwiseAbs().maxCoeff(), 0.0);
    // T = 1/2 qd^T M qd.
    const double T = Model::kinetic_energy(q, qd, params);
    ASSERT_GT(T, 0.0);
    EXPECT_NEAR(T, 0.5 * qd.dot(M * qd), 1e-13 * T);
    EXPECT_NEAR(T, oracle.kinetic_energy(q, qd), 1e-13 * T);
    // Momentum: P = dT/d(r0d), L = dT/dq0d + x0 Py - y0 Px. T is quadratic in qd, so the
    // central difference with unit step is exact.
    auto dT = [&](int i) {
      Vec<Model> e = Vec<Model>::Zero();
      e[i] = 1;
      return (Model::template kinetic_energy<double>(q, qd + e, params) -
              Model::template kinetic_energy<double>(q, qd - e, params)) /
             2;
    };
    typename Model::template Pose<double> h;
    Model::momentum(q, qd, params, h);
    const Eigen::Vector3d from_T(dT(0), dT(1), dT(2) + q[0] * dT(1) - q[1] * dT(0));
    EXPECT_MATRIX_NEAR(h, from_T, 1e-12);
    EXPECT_MATRIX_NEAR(h, oracle.momentum(q, qd), 1e-12);
    // End-effector pose and its Jacobian (central differences).
    typename Model::template Pose<double> x;
    typename Model::template PoseJacobian<double> J, J_fd;
    Model::end_effector_pose(q, params, x);
    Model::end_effector_jacobian(q, params, J);
    EXPECT_MATRIX_NEAR(x, oracle.end_effector_pose(q), 1e-13);
    for (int i = 0; i < Model::kNq; ++i) {
      Vec<Model> dq = Vec<Model>::Zero();
      dq[i] = 1e-6;
      typename Model::template Pose<double> xp, xm;
      Model::template end_effector_pose<double>(q + dq, params, xp);
      Model::template end_effector_pose<double>(q - dq, params, xm);
      J_fd.col(i) = (xp - xm) / 2e-6;
    }
    EXPECT_MATRIX_NEAR(J, J_fd, 1e-8);
  }
}

TEST(PaperModels, ReferenceInvariants) {
  const Scene s = load_scene(scene("models/paper_reference.yaml"));
  check_dynamics_invariants<ref::Model>({}, NumericLagrangian(test::chain_parameters(s)));
}

TEST(PaperModels, GearedInvariants) {
  const Scene s = load_scene(scene("models/paper_geared.yaml"));
  for (double p : {1.05, 10.0, 1000.0}) {
    SCOPED_TRACE("p = " + std::to_string(p));
    check_dynamics_invariants<geo::Model>(
        {p, 1e-5}, NumericLagrangian(test::chain_parameters(s, {{"p", p}, {"Im", 1e-5}})));
  }
}

TEST(PaperModels, ZeroMotorInertiaMakesTheGearAChangeOfCoordinates) {
  // With Im = 0 the geared model is the reference model in other coordinates for every p:
  // M_g = G^T M_ref G and b_g = G^T b_ref(q, G qd_g).
  std::mt19937 rng(11);
  for (double p : {1.5, 100.0}) {
    Eigen::Matrix<double, 6, 6> G = Eigen::Matrix<double, 6, 6>::Identity();
    for (int j = 3; j < 6; ++j) G(j, j) = 1 / p;
    const ref::Coordinates<double> qm = test::random_vector(rng, 6, 3.0),
                                   qdm = test::random_vector(rng, 6, 2.0);
    ref::MassMatrix<double> M_ref, M_g;
    ref::Coordinates<double> b_ref, b_g;
    ref::mass_matrix_and_bias<double>(G * qm, G * qdm, {}, M_ref, b_ref);
    geo::mass_matrix_and_bias(qm, qdm, geo::Parameters<double>(p, 0.0), M_g, b_g);
    EXPECT_MATRIX_NEAR(M_g, G.transpose() * M_ref * G, 1e-13);
    EXPECT_MATRIX_NEAR(b_g, G.transpose() * b_ref, 1e-12);
  }
}

TEST(PaperModels, OtherScalarTypesAgreeWithDouble) {
  std::mt19937 rng(5);
  const ref::Coordinates<double> q = test::random_vector(rng, 6, 3.0),
                                 qd = test::random_vector(rng, 6, 2.0);
  geo::MassMatrix<double> M;
  geo::Coordinates<double> b;
  geo::mass_matrix_and_bias(q, qd, geo::Parameters<double>(10, 1e-5), M, b);
  geo::MassMatrix<float> Mf;
  geo::Coordinates<float> bf;
  geo::mass_matrix_and_bias<float>(q.cast<float>(), qd.cast<float>(),
                                   geo::Parameters<float>(10, 1e-5f), Mf, bf);
  EXPECT_MATRIX_NEAR(Mf.cast<double>(), M, 1e-5);
  EXPECT_MATRIX_NEAR(bf.cast<double>(), b, 1e-4);
  geo::MassMatrix<long double> Ml;
  geo::Coordinates<long double> bl;
  geo::mass_matrix_and_bias<long double>(q.cast<long double>(), qd.cast<long double>(),
                                         geo::Parameters<long double>(10, 1e-5L), Ml, bl);
  EXPECT_MATRIX_NEAR(Ml.cast<double>(), M, 1e-14);
  EXPECT_MATRIX_NEAR(bl.cast<double>(), b, 1e-14);
}

// A spatial arm linked as a library (issue 31): Model<G> over tests/scenes/spatial_arm2's
// generated code (a free base in 3D, an exact and an armature rotor) gives the spatial chain's
// forward dynamics, pose and momentum (7 and 6 entries); simulate() flies it on the manifold,
// the quaternion unit and the momentum kept; the DynamicModel adapter says it is spatial.
TEST(LinkedSpatialModel, ModelOfTheGeneratedCodeIsTheChain) {
  using Arm = Model<models::spatial_arm2::Model>;
  static_assert(Arm::kSpatial && Arm::kNq == 9 && Arm::kNv == 8 && Arm::kQuaternionOffset == 3);
  static_assert(Arm::Pose::RowsAtCompileTime == 7 && Arm::Momentum::RowsAtCompileTime == 6);
  const std::string path = std::string(SPACEARM_SOURCE_DIR) + "/tests/scenes/spatial_arm2.yaml";
  const SpatialScene scene = parse_spatial_scene(test::read_text_file(path), path);
  const Arm arm;
  std::mt19937 rng(44);
  std::uniform_real_distribution<double> u(-1, 1);
  Arm::Vector q = Arm::Vector::NullaryExpr([&] { return u(rng); });
  q.segment<4>(3).normalize();
  const Arm::Velocity qd = Arm::Velocity::NullaryExpr([&] { return u(rng); });
  const Arm::Velocity Q = Arm::Velocity::NullaryExpr([&] { return u(rng); });
  auto input = [&](const std::string& a, int i) {
    return a == "q" ? q[i] : a == "qd" ? qd[i] : a == "Q" ? Q[i] : 0.0;
  };
  auto chain = [&](Output o) {
    const std::vector<double> v = evaluate_chain<spatial::Chain>(scene.chain, o, input)[0];
    return Eigen::Map<const Eigen::VectorXd>(v.data(), static_cast<Eigen::Index>(v.size())).eval();
  };
  const Eigen::VectorXd qdd = arm.forward_dynamics(q, qd, Q);
  EXPECT_LT((qdd - chain(Output::forward_dynamics)).norm(), 1e-10 * qdd.norm());
  EXPECT_LT((Eigen::VectorXd(arm.end_effector_pose(q)) - chain(Output::end_effector_pose)).norm(),
            1e-12);
  EXPECT_LT((Eigen::VectorXd(arm.momentum(q, qd)) - chain(Output::momentum)).norm(), 1e-11);
  // Free motion for 1 s (rkf78): the quaternion stays unit, the momentum as it was.
  IntegratorOptions options;
  options.method = Method::rkf78;
  options.rtol = 1e-11;
  options.atol = 1e-12;
  const auto traj = simulate(
      arm, q, qd, [](double) { return Arm::JointVector::Zero().eval(); }, 1.0, 0.1, options);
  ASSERT_EQ(traj.q.size(), 11u);
  for (size_t k = 0; k < traj.q.size(); ++k) {
    EXPECT_NEAR(traj.q[k].segment<4>(3).norm(), 1, 1e-12);
    EXPECT_LT((traj.momentum[k] - traj.momentum[0]).norm(), 1e-9 * traj.momentum[0].norm());
  }
  EXPECT_GT((traj.q.back() - q).norm(), 0.1);  // it moved
  EXPECT_TRUE(dynamic_model(arm).spatial);
}

// Issue 52: a tree linked as a library (tests/scenes/spatial_tree3: two arms on a free base, the
// first joints' exact rotors on the base). Model<G> knows its two end effectors (poses of 7 each,
// so it is spatial), gives the tree's forward dynamics and poses, flies it keeping the momentum,
// and the DynamicModel adapter names both end effectors' columns.
TEST(LinkedSpatialModel, ATreeIsTheChainsTreeWithTwoEndEffectors) {
  using Tree = Model<models::spatial_tree3::Model>;
  static_assert(Tree::kSpatial && Tree::kNumEndEffectors == 2 && Tree::kNv == 9);
  static_assert(Tree::Pose::RowsAtCompileTime == 14 && Tree::Momentum::RowsAtCompileTime == 6);
  static_assert(models::spatial_tree3::kEndEffectorNames.size() == 2);
  const std::string path = std::string(SPACEARM_SOURCE_DIR) + "/tests/scenes/spatial_tree3.yaml";
  const SpatialScene scene = parse_spatial_scene(test::read_text_file(path), path);
  ASSERT_FALSE(scene.chain.serial());
  const Tree tree;
  std::mt19937 rng(45);
  std::uniform_real_distribution<double> u(-1, 1);
  Tree::Vector q = Tree::Vector::NullaryExpr([&] { return u(rng); });
  q.segment<4>(3).normalize();
  const Tree::Velocity qd = Tree::Velocity::NullaryExpr([&] { return u(rng); });
  const Tree::Velocity Q = Tree::Velocity::NullaryExpr([&] { return u(rng); });
  auto input = [&](const std::string& a, int i) {
    return a == "q" ? q[i] : a == "qd" ? qd[i] : a == "Q" ? Q[i] : 0.0;
  };
  auto chain = [&](Output o) {
    const std::vector<double> v = evaluate_chain<spatial::Chain>(scene.chain, o, input)[0];
    return Eigen::Map<const Eigen::VectorXd>(v.data(), static_cast<Eigen::Index>(v.size())).eval();
  };
  const Eigen::VectorXd qdd = tree.forward_dynamics(q, qd, Q);
  EXPECT_LT((qdd - chain(Output::forward_dynamics)).norm(), 1e-10 * qdd.norm());
  EXPECT_LT((Eigen::VectorXd(tree.end_effector_pose(q)) - chain(Output::end_effector_pose)).norm(),
            1e-12);
  IntegratorOptions options;
  options.method = Method::rkf78;
  options.rtol = 1e-11;
  options.atol = 1e-12;
  const auto traj = simulate(
      tree, q, qd, [](double) { return Tree::JointVector::Zero().eval(); }, 1.0, 0.1, options);
  for (size_t k = 0; k < traj.q.size(); ++k)
    EXPECT_LT((traj.momentum[k] - traj.momentum[0]).norm(), 1e-9 * traj.momentum[0].norm());
  const DynamicModel d = dynamic_model(tree);
  EXPECT_TRUE(d.spatial);
  EXPECT_EQ(d.num_end_effectors(), 2);
  EXPECT_EQ(end_effector_columns(d).size(), 14u);
}

}  // namespace
}  // namespace spacearm