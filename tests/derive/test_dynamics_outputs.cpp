// The outputs composed or derived beyond M and b (forward and inverse dynamics, Mdot, the
// Christoffel-form C, the generalized Jacobian, free-base inverse dynamics, link-side joint
// state), each checked against an independent numeric computation on the compiled M, b,
// pose and momentum: Eigen's solves, finite differences, zero-momentum motions.
#include <Eigen/Dense>

#include "fixed_n1.hpp"
#include "fixed_n5_geared_params.hpp"
#include "free_n2_geared.hpp"
#include "free_n3_base_params.hpp"
#include "free_n4_mixed.hpp"
#include "model.hpp"
#include "paper_flexible.hpp"
#include "paper_geared.hpp"
#include "paper_geared_armature.hpp"
#include "paper_reference.hpp"
#include "support.hpp"

namespace spacearm {
namespace {

// d/dt f(q + t v) at t = 0 by the fourth-order central difference, with the step scaled so
// that |t v| = 1e-3 (truncation about 1e-12, rounding about 1e-13 of f's size).
template <class F, class V>
auto derivative_along(const F& f, const V& q, const V& v) {
  const double h = 1e-3 / v.cwiseAbs().maxCoeff();
  auto at = [&](double t) { return f((q + t * v).eval()); };
  return ((at(-2 * h) - 8 * at(-h) + 8 * at(h) - at(2 * h)) / (12 * h)).eval();
}

template <class G>
struct Dyn {
  static constexpr int n = G::kNv, N = G::kNumLinks, nb = n - N;
  using Vec = Eigen::Matrix<double, n, 1>;
  using Mat = Eigen::Matrix<double, n, n>;
  typename G::template Parameters<double> params;
  Eigen::Matrix<double, N, 1> ratios;
  std::mt19937 rng{7};

  explicit Dyn(const typename G::template Parameters<double>& p) : params(p) {
    typename G::template JointVector<double> r;
    G::gear_ratios(params, r);
    ratios = r;
  }
  Vec random(double scale) { return test::random_vector(rng, n, scale); }
  template <class V>
  Mat M(const V& q_expr) {
    const Vec q = q_expr;
    Mat m;
    G::mass_matrix(q, params, m);
    return m;
  }
  Vec b(const Vec& q, const Vec& qd) {
    Vec v;
    G::bias_forces(q, qd, params, v);
    return v;
  }
};

// Forward dynamics solves M qdd + b = Q; its pivots are those of the scaled M; inverse
// dynamics is M qdd + b.
template <class G>
void check_forward_and_inverse(Dyn<G>& d) {
  for (int trial = 0; trial < 5; ++trial) {
    const auto q = d.random(3.0), qd = d.random(2.0), Q = d.random(10.0), a = d.random(4.0);
    const auto M = d.M(q);
    const auto b = d.b(q, qd);
    if constexpr (G::kHas_forward_dynamics) {
      typename Dyn<G>::Vec qdd, pivots, scaled;
      G::forward_dynamics(q, qd, Q, d.params, qdd, pivots, scaled);
      EXPECT_MATRIX_NEAR(qdd, M.ldlt().solve(Q - b), 1e-10);
      const Eigen::LLT<Eigen::MatrixXd> llt{Eigen::MatrixXd(M)};
      const Eigen::VectorXd D = llt.matrixL().toDenseMatrix().diagonal().array().square();
      EXPECT_MATRIX_NEAR(pivots, D, 1e-10);
      EXPECT_MATRIX_NEAR(scaled, D.cwiseQuotient(M.diagonal()), 1e-10);
      EXPECT_GT(pivots.minCoeff(), 0.0);
    }
    if constexpr (G::kHas_inverse_dynamics) {
      typename Dyn<G>::Vec Qid;
      G::inverse_dynamics(q, qd, a, d.params, Qid);
      EXPECT_MATRIX_NEAR(Qid, M * a + b, 1e-12);
    }
  }
}

// Mdot against central differences of M along qd; the Christoffel form reproduces the bias
// and makes Mdot - 2 Cc skew-symmetric.
template <class G>
void check_mass_matrix_derivative(Dyn<G>& d) {
  for (int trial = 0; trial < 5; ++trial) {
    const auto q = d.random(3.0), qd = d.random(2.0);
    const auto fd = derivative_along([&](const auto& x) { return d.M(x); }, q, qd);
    typename Dyn<G>::Mat Mdot, Cc;
    G::mass_matrix_derivative(q, qd, d.params, Mdot);
    EXPECT_MATRIX_NEAR(Mdot, fd, 1e-9);
    G::christoffel_coriolis_matrix(q, qd, d.params, Cc);
    EXPECT_MATRIX_NEAR(Cc * qd, d.b(q, qd), 1e-12);
    const auto S = (Mdot - 2 * Cc).eval();
    EXPECT_LE((S + S.transpose()).cwiseAbs().maxCoeff(), 1e-12 * S.cwiseAbs().maxCoeff());
  }
}

// The generalized Jacobian: against the base eliminated numerically from M and J, and
// physically: the joint rates with the base rates that keep the momentum zero move the tip
// at Jg qd_m (finite differences of the pose, which share nothing with the Jacobians).
template <class G>
void check_generalized_jacobian(Dyn<G>& d) {
  constexpr int n = Dyn<G>::n, N = Dyn<G>::N, nb = Dyn<G>::nb;
  for (int trial = 0; trial < 5; ++trial) {
    const auto q = d.random(3.0);
    const auto M = d.M(q);
    Eigen::Matrix<double, 3, N> Jg;
    G::generalized_jacobian(q, d.params, Jg);
    Eigen::Matrix<double, 3, n> J;
    G::end_effector_jacobian(q, d.params, J);
    const Eigen::MatrixXd X = M.topLeftCorner(nb, nb).ldlt().solve(M.topRightCorner(nb, N));
    EXPECT_MATRIX_NEAR(Jg, J.rightCols(N) - J.leftCols(nb) * X, 1e-11);

    typename Dyn<G>::Vec qd;
    qd.template tail<N>() = test::random_vector(d.rng, N, 1.0);
    qd.template head<nb>() = -X * qd.template tail<N>();
    Eigen::Vector3d h_momentum;
    G::momentum(q, qd, d.params, h_momentum);
    EXPECT_LE(h_momentum.norm(), 1e-12 * M.norm() * qd.norm());
    const auto pose = [&](const typename Dyn<G>::Vec& x) {
      Eigen::Vector3d p;
      G::end_effector_pose(x, d.params, p);
      return p;
    };
    EXPECT_MATRIX_NEAR(Jg * qd.template tail<N>(), derivative_along(pose, q, qd), 1e-9);
  }
}

// Free-base inverse dynamics: the torques it returns (tau / p on the joints, no force on
// the base) make forward dynamics give back the joint accelerations (link side: the motor
// coordinates' accelerations are p times them) and its base acceleration.
template <class G>
void check_free_base_inverse_dynamics(Dyn<G>& d) {
  constexpr int N = Dyn<G>::N, nb = Dyn<G>::nb;
  for (int trial = 0; trial < 5; ++trial) {
    const auto q = d.random(3.0), qd = d.random(2.0);
    const Eigen::Matrix<double, N, 1> a = test::random_vector(d.rng, N, 4.0);
    Eigen::Matrix<double, N, 1> tau;
    Eigen::Matrix<double, nb, 1> base;
    G::free_base_inverse_dynamics(q, qd, a, d.params, tau, base);
    typename Dyn<G>::Vec Q = Dyn<G>::Vec::Zero();
    Q.template tail<N>() = tau.cwiseQuotient(d.ratios);
    const auto qdd = d.M(q).ldlt().solve(Q - d.b(q, qd)).eval();
    EXPECT_MATRIX_NEAR(qdd.template tail<N>(), a.cwiseProduct(d.ratios), 1e-9);
    EXPECT_MATRIX_NEAR(qdd.template head<nb>(), base, 1e-9);
  }
}

// Link-side joint angles and rates are the motor ones divided by the gear ratio.
template <class G>
void check_joint_state(Dyn<G>& d) {
  constexpr int N = Dyn<G>::N;
  const auto q = d.random(3.0), qd = d.random(2.0);
  Eigen::Matrix<double, N, 1> angles, rates;
  G::joint_angles(q, d.params, angles);
  G::joint_rates(qd, d.params, rates);
  EXPECT_MATRIX_NEAR(angles, q.template tail<N>().cwiseQuotient(d.ratios), 1e-15);
  EXPECT_MATRIX_NEAR(rates, qd.template tail<N>().cwiseQuotient(d.ratios), 1e-15);
}

// The state Jacobian against fourth-order central differences of forward_dynamics, column by
// column, compared row by row (a flexible joint's motor row is k / I_m times larger than a
// link row); qdd is forward dynamics' own; dqdd/dtau against differences in the joint torques.
// Rates of size `rate` (small: inside the steep part of tanh friction). Nominal parameters.
template <class G>
void check_state_jacobian(double rate) {
  const typename G::template Parameters<double> params =
      Eigen::Map<const typename G::template Parameters<double>>(G::nominal_parameters().data());
  SCOPED_TRACE(G::kName);
  static_assert(G::kHas_forward_dynamics_derivatives);
  constexpr int n = G::kNv;
  using Vec = Eigen::Matrix<double, n, 1>;
  std::mt19937 rng(11);
  const Model<G> model;  // forward dynamics: the emitted solve, or Cholesky of M and b
  const auto qdd_at = [&](const Vec& q, const Vec& qd, const Vec& Q) {
    return Vec(model.forward_dynamics(q, qd, Q));
  };
  for (int trial = 0; trial < 4; ++trial) {
    const Vec q = test::random_vector(rng, n, 1.0), qd = test::random_vector(rng, n, rate),
              Q = test::random_vector(rng, n, 5.0);
    Eigen::Matrix<double, n, n> dq, dqd, fd_q, fd_qd;
    Eigen::Matrix<double, n, G::kNumLinks> dtau;
    Vec qdd;
    G::forward_dynamics_derivatives(q, qd, Q, params, dq, dqd, qdd, dtau);
    EXPECT_MATRIX_NEAR(qdd, qdd_at(q, qd, Q), 1e-12);
    // dqdd/dtau through the runtime's own map of joint torques (Q = tau / p on each actuated
    // coordinate): qdd is affine in tau, so one central difference per joint is exact but for
    // rounding.
    for (int j = 0; j < G::kNumLinks; ++j) {
      const typename Model<G>::JointVector step = Model<G>::JointVector::Unit(j);
      const Vec column = (qdd_at(q, qd, Q + model.generalized_forces(step)) -
                          qdd_at(q, qd, Q - model.generalized_forces(step))) /
                         2;
      SCOPED_TRACE("tau " + std::to_string(j));
      EXPECT_MATRIX_NEAR(dtau.col(j), column, 1e-9 * (1 + column.norm()));
    }
    for (int k = 0; k < n; ++k) {
      const Vec e = Vec::Unit(k);  // steps of 1e-3 (derivative_along)
      fd_q.col(k) = derivative_along([&](const Vec& x) { return qdd_at(x, qd, Q); }, q, e);
      fd_qd.col(k) = derivative_along([&](const Vec& x) { return qdd_at(q, x, Q); }, qd, e);
    }
    for (int i = 0; i < n; ++i) {
      SCOPED_TRACE("row " + std::to_string(i));
      EXPECT_MATRIX_NEAR(dq.row(i), fd_q.row(i), 1e-7);
      EXPECT_MATRIX_NEAR(dqd.row(i), fd_qd.row(i), 1e-7);
    }
  }
}

template <class G>
void check_all(const typename G::template Parameters<double>& params) {
  SCOPED_TRACE(G::kName);
  Dyn<G> d(params);
  int checked = 0;
  check_forward_and_inverse(d);
  checked += G::kHas_forward_dynamics + G::kHas_inverse_dynamics;
  if constexpr (G::kHas_mass_matrix_derivative && G::kHas_christoffel_coriolis_matrix) {
    check_mass_matrix_derivative(d);
    ++checked;
  }
  if constexpr (G::kHas_generalized_jacobian) {
    check_generalized_jacobian(d);
    ++checked;
  }
  if constexpr (G::kHas_free_base_inverse_dynamics) {
    check_free_base_inverse_dynamics(d);
    ++checked;
  }
  if constexpr (G::kHas_joint_angles && G::kHas_joint_rates) {
    check_joint_state(d);
    ++checked;
  }
  EXPECT_GT(checked, 0) << "the model emits none of the outputs checked here";
}

TEST(DynamicsOutputs, PaperReference) { check_all<models::paper_reference::Model>({}); }
TEST(DynamicsOutputs, PaperGearedAtHighRatio) {
  check_all<models::paper_geared::Model>((Eigen::Vector2d() << 100, 2e-5).finished());
}
TEST(DynamicsOutputs, PaperGearedArmature) {
  check_all<models::paper_geared_armature::Model>((Eigen::Vector2d() << 10, 2e-5).finished());
}
TEST(DynamicsOutputs, FixedOneLink) { check_all<models::fixed_n1::Model>({}); }
TEST(DynamicsOutputs, FreeTwoLinksPerJointGears) { check_all<models::free_n2_geared::Model>({}); }
TEST(DynamicsOutputs, FixedFiveGearedLinksWithParameters) {
  check_all<models::fixed_n5_geared_params::Model>((Eigen::Vector3d() << 20, 1e-4, 1.5).finished());
}
TEST(DynamicsOutputs, FreeThreeLinksLightBase) {
  check_all<models::free_n3_base_params::Model>(
      (Eigen::Vector4d() << 2.0, 0.05, 50, 1e-5).finished());
}

TEST(DynamicsOutputs, StateJacobianRigidGearedFreeBase) {
  check_state_jacobian<models::free_n3_base_params::Model>(2.0);
}
TEST(DynamicsOutputs, StateJacobianFlexibleWithFriction) {
  // Motor rates well above and inside the friction's velocity scale vs = 0.1 rad/s.
  for (double rate : {2.0, 0.05}) check_state_jacobian<models::paper_flexible::Model>(rate);
}
TEST(DynamicsOutputs, StateJacobianMixedJoints) {
  for (double rate : {2.0, 0.05}) check_state_jacobian<models::free_n4_mixed::Model>(rate);
}

}  // namespace
}  // namespace spacearm
