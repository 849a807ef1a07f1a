// runtime/model.hpp: forward dynamics, generalized forces, parameters and errors.
#include "model.hpp"

#include "paper_geared.hpp"
#include "paper_reference.hpp"
#include "support.hpp"

namespace spacearm {
namespace {

using Ref = Model<models::paper_reference::Model>;
using Geared = Model<models::paper_geared::Model>;

TEST(Model, ForwardDynamicsSolvesEquation5) {
  Geared g;
  g.set_parameter("p", 10);
  std::mt19937 rng(1);
  for (int trial = 0; trial < 10; ++trial) {
    const Geared::Vector q = test::random_vector(rng, 6, 3), qd = test::random_vector(rng, 6, 2),
                         Q = test::random_vector(rng, 6, 1);
    const Geared::Vector qdd = g.forward_dynamics(q, qd, Q);
    ASSERT_GT(qdd.norm(), 0.0);
    EXPECT_MATRIX_NEAR(g.mass_matrix(q) * qdd + g.bias_forces(q, qd), Q, 1e-12);
  }
}

TEST(Model, GeneralizedForcesAreTorquesOverRatio) {
  Geared g;
  g.set_parameter("p", 4);
  const Geared::Vector Q = g.generalized_forces(Geared::JointVector(1, -2, 8));
  EXPECT_EQ(Q, (Geared::Vector() << 0, 0, 0, 0.25, -0.5, 2).finished());
  Ref r;
  EXPECT_EQ(r.generalized_forces(Ref::JointVector(1, 2, 3)).tail<3>(), Ref::JointVector(1, 2, 3));
}

TEST(Model, BadInputGetsAClearError) {
  Geared g;
  EXPECT_THROW(g.set_parameter("q", 1), std::invalid_argument);
  try {
    g.set_parameter("p", -1);
    FAIL() << "p = -1 accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("gears[0].ratio must be positive"), std::string::npos)
        << e.what();
  }
  // The scene's range checks hold for run-time values too: I_m must stay below the link
  // inertia it compensates (link 3: 0.022 kg m^2), and a failed set leaves the model valid.
  try {
    g.set_parameter("Im", 0.03);
    FAIL() << "Im = 0.03 accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(
                  "gears[2].motor_inertia must be smaller than the inertia of link 3"),
              std::string::npos)
        << e.what();
  }
  EXPECT_EQ(g.parameters()[1], 1e-5);
  Geared::Vector q = Geared::Vector::Zero();
  q[4] = std::nan("");
  try {
    g.forward_dynamics(q, Geared::Vector::Zero(), Geared::Vector::Zero());
    FAIL() << "NaN accepted";
  } catch (const DynamicsError& e) {
    EXPECT_NE(std::string(e.what()).find("q[4] (qm2) = nan"), std::string::npos) << e.what();
  }
}

// A stand-in for a generated model with one coordinate pair whose mass matrix
// [[1, 1], [1, 1 + delta]] is as singular as delta says (no physical chain gets there
// without a degenerate scene: M of positive masses and inertias stays regular).
struct NearlySingular {
  static constexpr int kNq = 2, kNv = 2, kNumLinks = 2, kNumParams = 1;
  static constexpr bool kFreeFloating = false, kHas_forward_dynamics = false;
  static constexpr bool kHas_mass_matrix = true, kHas_bias_forces = true;
  static constexpr bool kHas_potential_energy = false, kHas_friction_forces = false;
  static constexpr bool kHas_forward_dynamics_derivatives = false, kPassiveForces = false;
  static constexpr int kNumBase = 0, kQuaternionOffset = -1;
  static constexpr const char* kName = "nearly_singular";
  static const std::array<int, 2>& actuated_coordinates() {
    static const std::array<int, 2> c = {0, 1};
    return c;
  }
  static const std::array<bool, 2>& motor_angle_slots() {
    static const std::array<bool, 2> s = {false, false};
    return s;
  }
  template <typename T>
  using Pose = Eigen::Matrix<T, 3, 1>;  // as a generated header's (the planar pose)
  template <typename T>
  using PoseJacobian = Eigen::Matrix<T, 3, kNv>;
  static const std::array<double, 1>& nominal_parameters() {
    static const std::array<double, 1> p = {1.0};
    return p;
  }
  static const std::array<const char*, 1>& parameter_names() {
    static const std::array<const char*, 1> n = {"delta"};
    return n;
  }
  static const std::array<const char*, 2>& coordinate_names() {
    static const std::array<const char*, 2> n = {"q1", "q2"};
    return n;
  }
  static const char* parameter_error(const Eigen::Matrix<double, 1, 1>& p) {
    return p[0] > 0 ? nullptr : "delta must be positive";
  }
  static void gear_ratios(const Eigen::Matrix<double, 1, 1>&, Eigen::Vector2d& r) { r.setOnes(); }
  static void mass_matrix(const Eigen::Vector2d&, const Eigen::Matrix<double, 1, 1>& p,
                          Eigen::Matrix2d& M) {
    M << 1, 1, 1, 1 + p[0];
  }
  static void mass_matrix_and_bias(const Eigen::Vector2d& q, const Eigen::Vector2d&,
                                   const Eigen::Matrix<double, 1, 1>& p, Eigen::Matrix2d& M,
                                   Eigen::Vector2d& b) {
    mass_matrix(q, p, M);
    b.setZero();
  }
};

// The same with an emitted forward_dynamics (the LDL^T pivots of M by hand: 1 and delta).
struct NearlySingularEmitted : NearlySingular {
  static constexpr bool kHas_forward_dynamics = true;
  static void forward_dynamics(const Eigen::Vector2d&, const Eigen::Vector2d&,
                               const Eigen::Vector2d& Q, const Eigen::Matrix<double, 1, 1>& p,
                               Eigen::Vector2d& qdd, Eigen::Vector2d& pivots,
                               Eigen::Vector2d& scaled) {
    const double delta = (1 + p[0]) - 1;
    qdd << Q[0] - (Q[1] - Q[0]) / delta, (Q[1] - Q[0]) / delta;
    pivots << 1, delta;
    scaled << 1, delta / (1 + p[0]);
  }
};

template <class G>
void expect_singular_mass_matrix_reported() {
  Model<G> m;
  const Eigen::Vector2d zero = Eigen::Vector2d::Zero(), Q(1, 2);
  m.set_parameter("delta", 1e-6);  // cond ~ 4e6: solved, and right
  EXPECT_MATRIX_NEAR(m.forward_dynamics(zero, zero, Q), Eigen::Vector2d(1 - 1e6, 1e6), 1e-9);
  m.set_parameter("delta", 1e-16);  // rounds to 1 + 2.2e-16 or 1: no digit of the answer is left
  EXPECT_THROW_MESSAGE(m.forward_dynamics(zero, zero, Q), DynamicsError,
                       "nearly_singular: mass matrix");
}

TEST(Model, NumericallySingularMassMatrixIsReported) {
  expect_singular_mass_matrix_reported<NearlySingular>();
}
TEST(Model, NumericallySingularMassMatrixIsReportedWithEmittedSolve) {
  expect_singular_mass_matrix_reported<NearlySingularEmitted>();
}

// Without motor inertia cond(M_g) grows as p^2, but only as a scaling of the motor
// coordinates: the solve stays accurate (test_extremes checks the accelerations up to p = 1e10).
TEST(Model, LargeRatiosWithoutMotorInertiaAreSolved) {
  Geared g;
  g.set_parameter("Im", 0);
  g.set_parameter("p", 1e9);
  const Geared::Vector q = (Geared::Vector() << 0, 0, 0, 3e8, 1.2e9, -5e8).finished();
  EXPECT_GT(g.condition_number(q), 1e18);
  EXPECT_LT(g.scaled_condition_number(q), 1e4);
  EXPECT_TRUE(g.forward_dynamics(q, Geared::Vector::Zero(),
                                 g.generalized_forces(Geared::JointVector(1, 0, 0)))
                  .allFinite());
}

TEST(Model, ConditionNumberGrowsAsPSquaredWithoutMotorInertia) {
  // MODEL-NOTES: cond(M_g) grows as p^2 when I_m = 0; with I_m the rotor bounds it.
  Geared g;
  g.set_parameter("Im", 0);
  const Geared::Vector q = (Geared::Vector() << 0, 0, 0, 0.3, 1.2, -0.5).finished();
  g.set_parameter("p", 100);
  const double c100 = g.condition_number(q * 1.0);
  g.set_parameter("p", 1000);
  const double c1000 = g.condition_number(q * 1.0);
  EXPECT_NEAR(c1000 / c100, 100.0, 5.0);
  g.set_parameter("Im", 1e-5);
  g.set_parameter("p", 1e4);
  EXPECT_LT(g.condition_number(q), 1e8);
}

}  // namespace
}  // namespace spacearm
