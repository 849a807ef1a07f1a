// runtime/simulation_table.hpp: the columns of a simulation for a geared and a reference model,
// and a row's values against the model's own functions (link side q = qm / p, tau_motor = tau/p).
#include <gtest/gtest.h>

#include "paper_geared.hpp"
#include "paper_reference.hpp"
#include "simulation_table.hpp"

namespace spacearm {
namespace {

TEST(SimulationTable, ColumnsFollowWhatTheModelHas) {
  const Model<models::paper_reference::Model> ref;
  const SimulationTable table(dynamic_model(ref), false);
  const std::vector<std::string> head(table.names().begin(), table.names().begin() + 8);
  EXPECT_EQ(head, (std::vector<std::string>{"t", "x0", "y0", "q0", "q1", "q2", "q3", "x0d"}));
  EXPECT_EQ(table.names()[13], "tau1");
  EXPECT_EQ(std::count(table.names().begin(), table.names().end(), "tau_motor1"), 0);
  EXPECT_EQ(table.names().back(), "L");
}

TEST(SimulationTable, GearedRowsHoldLinkSideAnglesAndMotorTorques) {
  Model<models::paper_geared::Model> g;
  g.set_parameter("p", 4);
  const DynamicModel m = dynamic_model(g);
  const SimulationTable table(m, true);
  const auto& names = table.names();
  auto at = [&](const std::string& n) {
    const auto it = std::find(names.begin(), names.end(), n);
    EXPECT_NE(it, names.end()) << n;
    return static_cast<size_t>(it - names.begin());
  };
  Eigen::VectorXd q(6), qd(6), tau(3);
  q << 0.1, 0.2, 0.3, 0.4, 0.8, -1.2;
  qd << 0.01, -0.02, 0.03, 0.4, -0.4, 0.8;
  tau << 1, -2, 3;
  std::vector<double> row;
  table.row(0.5, q, qd, tau, row);
  ASSERT_EQ(row.size(), names.size());
  EXPECT_EQ(row[at("t")], 0.5);
  EXPECT_EQ(row[at("qm2")], 0.8);
  EXPECT_DOUBLE_EQ(row[at("q2")], 0.2);   // qm2 / p
  EXPECT_DOUBLE_EQ(row[at("q3d")], 0.2);  // qm3d / p
  EXPECT_EQ(row[at("tau3")], 3);
  EXPECT_DOUBLE_EQ(row[at("tau_motor3")], 0.75);
  EXPECT_EQ(row[at("ee_y")], g.end_effector_pose(q)[1]);
  EXPECT_EQ(row[at("kinetic_energy")], g.kinetic_energy(q, qd));
  EXPECT_EQ(row[at("L")], g.momentum(q, qd)[2]);
}

}  // namespace
}  // namespace spacearm
