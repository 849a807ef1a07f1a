// runtime/plan_replay.hpp: a plan made on the rigid geared scene, written as `spacearm plan`
// writes it, is read back and replayed into the flexible twin with friction (springs, motor
// inertia, friction on the motor) with no hand work: the start maps to the flexible
// coordinates, and with friction fed forward the end effector reaches the planned goal; without
// it the friction-heavy joints are named and the arm falls short. Bad plan files are named
// errors. Cost: about 1 s.
#include "plan_replay.hpp"

#include <sstream>

#include "paper_flexible.hpp"
#include "paper_geared.hpp"
#include "simulation.hpp"
#include "support.hpp"
#include "torque_signal.hpp"
#include "trajectory_planning.hpp"

namespace spacearm {
namespace {

using Geared = Model<models::paper_geared::Model>;
using Flex = Model<models::paper_flexible::Model>;

// The plan as `spacearm plan` writes it: header, then rows at full precision.
std::string plan_text(const PlanTable& table) {
  std::ostringstream s;
  s.precision(17);
  for (size_t c = 0; c < table.names.size(); ++c) s << (c ? "," : "") << table.names[c];
  s << "\n";
  for (const auto& row : table.rows) {
    for (size_t c = 0; c < row.size(); ++c) s << (c ? "," : "") << row[c];
    s << "\n";
  }
  return s.str();
}

struct Replay : ::testing::Test {
  static void SetUpTestSuite() {
    static Geared rigid;
    rigid.set_parameter("p", 10);
    StraightLineTask task;
    task.start = Eigen::Vector3d(0.9, 0.3, 0.0);
    task.goal = Eigen::Vector3d(0.7, 0.6, 0.5);
    task.duration = 5;
    task.dt = 0.01;
    const DynamicModel d = dynamic_model(rigid);
    text = plan_text(plan_table(plan_straight_line(d, task), d, true));
    goal = task.goal;
  }
  // The end-effector pose after replaying the plan into the flexible model.
  static Eigen::Vector3d fly(const Flex& flex, bool feedforward) {
    const DynamicModel d = dynamic_model(flex);
    PlanSamples plan = read_plan_csv(text, 3, true, "plan.csv");
    if (feedforward) feed_friction_forward(d, plan);
    Eigen::VectorXd q0, qd0;
    replay_start(d, plan, plan.torques.samples.front(), q0, qd0);
    const TorqueSignal<Eigen::Dynamic> tau(plan.torques.t0, plan.torques.dt, plan.torques.samples,
                                           Interpolation::linear);
    IntegratorOptions opt;
    opt.method = Method::rosenbrock4;
    const TorqueReplay<Eigen::Dynamic> replay(tau, opt, "dt");
    Eigen::Vector3d pose;
    integrate_motion(
        d, q0, qd0, [&](double t) { return replay(t); }, 5.0, 5.0, opt,
        [&](double, const Eigen::VectorXd& q, const Eigen::VectorXd&) {
          pose = d.end_effector_pose(q);
        });
    return pose;
  }
  static inline std::string text;
  static inline Eigen::Vector3d goal;
};

TEST_F(Replay, StartMapsToTheFlexibleCoordinates) {
  Flex flex;
  const DynamicModel d = dynamic_model(flex);
  const PlanSamples plan = read_plan_csv(text, 3, true, "plan.csv");
  Eigen::VectorXd q0, qd0;
  const Eigen::VectorXd tau0(Eigen::Vector3d(0.3, -0.2, 0.1));  // springs must carry it
  const Eigen::VectorXd e = replay_start(d, plan, tau0, q0, qd0);
  const double p = flex.gear_ratios()[0];
  for (int i = 0; i < 3; ++i) EXPECT_EQ(q0[i], plan.base.front()[i]);
  for (int j = 0; j < 3; ++j) {
    EXPECT_DOUBLE_EQ(q0[3 + j], plan.angles.front()[j]);                 // the link angle
    EXPECT_NEAR(q0[6 + j], p * (plan.angles.front()[j] + e[j]), 1e-14);  // motor, pre-deflected
    EXPECT_GT(std::abs(e[j]), 1e-7);
  }
  // The plan's start pose is the flexible model's start pose.
  EXPECT_LT((d.end_effector_pose(q0) - Eigen::Vector3d(0.9, 0.3, 0.0)).norm(), 1e-12);
}

TEST_F(Replay, FrictionFedForwardReachesTheGoal) {
  Flex flex;
  flex.set_parameter("fs", 5e-3);  // harmonic-drive Coulomb friction: p fc = 0.05 N m link side
  flex.set_parameter("fc", 5e-3);
  const Eigen::Vector3d with = fly(flex, true), without = fly(flex, false);
  std::printf("goal error: with feed-forward %.2e, without %.2e\n", (with - goal).norm(),
              (without - goal).norm());
  EXPECT_LT((with - goal).norm(), 1e-3) << with.transpose();
  EXPECT_GT((without - goal).norm(), 2e-2) << without.transpose();
  // And the check that warns names the joints friction stalls.
  const PlanSamples plan = read_plan_csv(text, 3, true, "plan.csv");
  const auto stalled = joints_stalled_by_friction(plan, friction_along(dynamic_model(flex), plan));
  EXPECT_FALSE(stalled.empty());
  flex.set_parameter("fc", 0);
  flex.set_parameter("fs", 0);
  flex.set_parameter("fv", 0);
  EXPECT_TRUE(joints_stalled_by_friction(plan, friction_along(dynamic_model(flex), plan)).empty());
}

TEST_F(Replay, BadPlanFilesAreNamedErrors) {
  auto error_of = [](const std::string& t, int joints, bool free_base) {
    try {
      read_plan_csv(t, joints, free_base, "my_plan.csv");
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(error_of(text, 2, true).find("more than 2 joints"), std::string::npos);
  EXPECT_NE(error_of(text, 3, false).find("planned on a free-floating base"), std::string::npos);
  EXPECT_NE(error_of(text, 4, true).find("missing column 'tau4'"), std::string::npos);
  EXPECT_NE(error_of("", 3, true).find("my_plan.csv"), std::string::npos);
  // A plan from before link-side columns: its missing q1 is named, with the remedy.
  std::string old = text;
  old.replace(old.find(",q1,"), 4, ",u1,");
  EXPECT_NE(error_of(old, 3, true)
                .find("missing column 'q1' (a plan from spacearm plan has it; "
                      "replan"),
            std::string::npos);
  std::string bad = text;
  const size_t line2 = bad.find('\n') + 1;
  bad.replace(line2, 1, "nan");
  EXPECT_NE(error_of(bad, 3, true).find("line 2, column 't'"), std::string::npos)
      << error_of(bad, 3, true);
  // A plan that starts later than t = 0 would pair its start with other torques.
  std::string later;
  std::istringstream rows(text);
  for (std::string row; std::getline(rows, row);) {
    const size_t comma = row.find(',');
    if (later.empty() || row.empty()) {
      later += row + "\n";
      continue;
    }
    later += std::to_string(std::stod(row.substr(0, comma)) + 1) + row.substr(comma) + "\n";
  }
  EXPECT_NE(error_of(later, 3, true).find("line 2: column 't' starts at 1 s"), std::string::npos)
      << error_of(later, 3, true);
  // In 3D, a quaternion the model cannot take is named by its line.
  const std::string spatial =
      "t,tau1,x0,y0,z0,qw0,qx0,qy0,qz0,vx0,vy0,vz0,wx0,wy0,wz0,q1,q1d\n"
      "0,0,0,0,0,1,0,0,0,0,0,0,0,0,0,0,0\n"
      "0.1,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0\n";
  try {
    read_plan_csv(spatial, 1, true, "arm.csv", true);
    ADD_FAILURE() << "a zero quaternion was read";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("arm.csv' line 3: columns qw0..qz0"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace spacearm
