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
    EXPECT_NE(std::string(e.what()).find("gears[2].motor_inertia must be smaller than the inertia of link 3"),
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

TEST(Model, NumericallySingularMassMatrixIsReported) {
  // Im = 0 and a huge ratio: cond(M_g) ~ p^2 passes 1e14, the solve would return noise.
  Geared g;
  g.set_parameter("Im", 0);
  g.set_parameter("p", 1e9);
  const Geared::Vector q = (Geared::Vector() << 0, 0, 0, 3e8, 1.2e9, -5e8).finished();
  try {
    g.forward_dynamics(q, Geared::Vector::Zero(), Geared::Vector::Zero());
    FAIL() << "no error for cond(M) = " << g.condition_number(q);
  } catch (const DynamicsError& e) {
    EXPECT_NE(std::string(e.what()).find("numerically singular"), std::string::npos) << e.what();
  }
  g.set_parameter("p", 100);  // well conditioned again
  EXPECT_NO_THROW(g.forward_dynamics(q / 1e7, Geared::Vector::Zero(), Geared::Vector::Zero()));
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
