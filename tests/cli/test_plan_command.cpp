// `spacearm plan` end to end: the CSV it writes for a redundant free-floating arm (5 links)
// and a redundant geared fixed-base arm (4 links) is checked against the independent numeric
// Lagrangian (tests/support/numeric_lagrangian.hpp, no generator code): the end-effector follows
// the line, momentum stays zero, qd and qdd are the derivatives of q and qd, and the torques
// satisfy eq. 5 with no force on the base. The torques replayed by `spacearm simulate`
// reproduce the line; a spatial plan flies into a twin with joint friction. Cost: about 27 s,
// mostly compiling four models once.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "support.hpp"
#include "text_numbers.hpp"
#include "trajectory_planning.hpp"

namespace spacearm {
namespace {

namespace fs = std::filesystem;

struct Csv {
  std::vector<std::string> names;
  std::vector<std::vector<double>> rows;
  int column(const std::string& name) const {
    for (size_t i = 0; i < names.size(); ++i)
      if (names[i] == name) return static_cast<int>(i);
    ADD_FAILURE() << "no column " << name;
    return 0;
  }
  Eigen::VectorXd values(size_t row, const std::vector<std::string>& columns) const {
    Eigen::VectorXd v(static_cast<int>(columns.size()));
    for (size_t i = 0; i < columns.size(); ++i)
      v[static_cast<int>(i)] = rows[row][column(columns[i])];
    return v;
  }
};

Csv read_csv(const std::string& path) {
  Csv csv;
  std::istringstream in(test::read_text_file(path));
  std::string line;
  std::getline(in, line);
  std::istringstream head(line);
  for (std::string name; std::getline(head, name, ',');) csv.names.push_back(name);
  while (std::getline(in, line)) csv.rows.push_back(parse_number_list(line, path));
  return csv;
}

std::vector<std::string> suffixed(const std::vector<std::string>& names,
                                  const std::string& suffix) {
  std::vector<std::string> out;
  for (const auto& n : names) out.push_back(n + suffix);
  return out;
}

class PlanCommand : public ::testing::Test {
 protected:
  static fs::path dir() {
    static const fs::path d = [] {
      const fs::path p =
          fs::temp_directory_path() / ("spacearm_plan_test_" + std::to_string(::getpid()));
      fs::create_directories(p);
      return p;
    }();
    return d;
  }
  static std::string cli() { return std::string(SPACEARM_CLI) + " "; }
  // One cache for the test processes of a build, so that each model is compiled once.
  static std::string cache() { return " --cache-dir " SPACEARM_TEST_CACHE_DIR; }

  // Runs plan; returns its status, with stderr in *out.
  static int plan(const std::string& scene, const std::string& options, const std::string& csv,
                  std::string* out) {
    int status = 0;
    *out = test::run_command(cli() + "plan tests/scenes/" + scene + ".yaml " + options + " -o " +
                                 csv + cache() + " 2>&1",
                             &status);
    return status;
  }
};

// The CSV of a plan against the oracle. task: the line and time law the plan was asked for.
void check_plan(const Csv& csv, const Scene& scene, const std::map<std::string, double>& params,
                const StraightLineTask& task) {
  const ChainParameters chain = test::chain_parameters(scene, params);
  const NumericLagrangian oracle(chain);
  std::vector<std::string> q_names;
  for (int i = 0; i < oracle.n(); ++i) q_names.push_back(csv.names[1 + i]);
  const int N = scene.num_links(), nb = oracle.n() - N, rows = static_cast<int>(task.start.size());
  Eigen::VectorXd p = Eigen::VectorXd::Ones(N);
  for (size_t j = 0; j < chain.gears.size(); ++j) p[static_cast<int>(j)] = chain.gears[j]->ratio;
  ASSERT_EQ(csv.rows.size(), static_cast<size_t>(std::lround(task.duration / task.dt)) + 1);
  double tau_peak = 0, qd_peak = 0, qdd_peak = 0, worst_path = 0, worst_momentum = 0,
         worst_force = 0, worst_qd = 0, worst_qdd = 0, worst_ee = 0;
  for (size_t k = 0; k < csv.rows.size(); ++k) {
    const double t = csv.rows[k][0];
    const Eigen::VectorXd q = csv.values(k, q_names), qd = csv.values(k, suffixed(q_names, "d")),
                          qdd = csv.values(k, suffixed(q_names, "dd"));
    Eigen::VectorXd tau(N);
    for (int j = 0; j < N; ++j) tau[j] = csv.rows[k][csv.column("tau" + std::to_string(j + 1))];
    tau_peak = std::max(tau_peak, tau.cwiseAbs().maxCoeff());
    qd_peak = std::max(qd_peak, qd.cwiseAbs().maxCoeff());
    qdd_peak = std::max(qdd_peak, qdd.cwiseAbs().maxCoeff());
    // The line, with the time law.
    const Eigen::Vector3d s = time_law(task.law, t / task.duration);
    const Eigen::VectorXd want = task.start + s[0] * (task.goal - task.start);
    const Eigen::VectorXd pose = oracle.end_effector_pose(q);
    worst_path = std::max(worst_path, (pose.head(rows) - want).cwiseAbs().maxCoeff());
    // The plan's own end-effector columns (what a replay compares its arm with) are the oracle's.
    for (int i = 0; i < 3; ++i)
      worst_ee = std::max(
          worst_ee,
          std::abs(csv.rows[k][csv.column(std::vector<std::string>{"ee_x", "ee_y", "ee_phi"}[i])] -
                   pose[i]));
    if (nb > 0)
      worst_momentum = std::max(worst_momentum, oracle.momentum(q, qd).cwiseAbs().maxCoeff());
    // Eq. 5: M qdd + b is no force on the base and tau / p at the joints (eq. 14).
    Eigen::VectorXd Q = Eigen::VectorXd::Zero(oracle.n());
    Q.tail(N) = tau.cwiseQuotient(p);
    worst_force = std::max(
        worst_force,
        (oracle.mass_matrix(q) * qdd + oracle.bias_forces(q, qd) - Q).cwiseAbs().maxCoeff());
    if (k == 0 || k + 1 == csv.rows.size()) continue;
    // qd and qdd are the derivatives of q and qd (central differences, O(dt^2)).
    const double h = csv.rows[k + 1][0] - csv.rows[k - 1][0];
    worst_qd = std::max(
        worst_qd,
        ((csv.values(k + 1, q_names) - csv.values(k - 1, q_names)) / h - qd).cwiseAbs().maxCoeff());
    const auto qd_names = suffixed(q_names, "d");
    worst_qdd =
        std::max(worst_qdd, ((csv.values(k + 1, qd_names) - csv.values(k - 1, qd_names)) / h - qdd)
                                .cwiseAbs()
                                .maxCoeff());
  }
  EXPECT_GT(tau_peak, 0.0);
  EXPECT_LT(worst_path, 1e-10);
  EXPECT_LT(worst_ee, 1e-10);
  EXPECT_LT(worst_momentum, 1e-10);
  // The oracle's bias is a finite difference (h = 1e-6): about 1e-8 of the torques.
  EXPECT_LT(worst_force, 1e-6 * std::max(1.0, tau_peak));
  // Central differences over dt = 0.01 s: O(dt^2) times the third derivative, which scales
  // with the rates (motor rates are p times the link ones).
  EXPECT_LT(worst_qd, 1e-4 * qd_peak);
  EXPECT_LT(worst_qdd, 1e-3 * qdd_peak);
  std::printf(
      "path %.1e, momentum %.1e, eq. 5 %.1e (tau peak %.2g), qd %.1e (peak %.2g), qdd %.1e (peak "
      "%.2g)\n",
      worst_path, worst_momentum, worst_force, tau_peak, worst_qd, qd_peak, worst_qdd, qdd_peak);
}

TEST_F(PlanCommand, FreeFiveLinkArmFollowsTheLineWithZeroMomentum) {
  const std::string csv = (dir() / "free_n5.csv").string();
  std::string out;
  ASSERT_EQ(plan("free_n5", "--from 1.6,0.2,0.3 --to 1.2,-0.2,0.5 --duration 5", csv, &out), 0)
      << out;
  EXPECT_NE(out.find("max |momentum|"), std::string::npos) << out;
  StraightLineTask task;
  task.start = Eigen::Vector3d(1.6, 0.2, 0.3);
  task.goal = Eigen::Vector3d(1.2, -0.2, 0.5);
  task.duration = 5;
  const Csv c = read_csv(csv);
  // The base's residual, then the end effector's pose (checked against the oracle's below).
  EXPECT_EQ(c.column("base_residual") + 1, c.column("ee_x"));
  EXPECT_EQ(c.names.back(), "ee_phi");
  check_plan(c, load_scene("tests/scenes/free_n5.yaml"), {}, task);
}

// A geared fixed-base arm: link-side torques, motor coordinates; the torques replayed by
// simulate (from plan's --torque-file) reproduce the line.
TEST_F(PlanCommand, FixedFourLinkGearedArmReplaysThroughSimulate) {
  const std::string csv = (dir() / "fixed_n4.csv").string(),
                    sim = (dir() / "fixed_n4_sim.csv").string(),
                    tau = (dir() / "fixed_n4_tau.csv").string();
  std::string out;
  ASSERT_EQ(plan("fixed_n4_geared",
                 "--from 1.0,0.3,0.2 --to 0.7,0.6,0.8 --duration 4 --time-law cubic --elbow -1 "
                 "--torque-file " +
                     tau,
                 csv, &out),
            0)
      << out;
  StraightLineTask task;
  task.start = Eigen::Vector3d(1.0, 0.3, 0.2);
  task.goal = Eigen::Vector3d(0.7, 0.6, 0.8);
  task.duration = 4;
  task.law = TimeLaw::cubic;
  const Csv c = read_csv(csv);
  ASSERT_EQ(c.column("tau_motor4") + 1, c.column("ee_x"));  // no base_residual
  EXPECT_LT(c.rows[0][c.column("qm2")], 0.0);               // the elbow branch
  check_plan(c, load_scene("tests/scenes/fixed_n4_geared.yaml"), {{"p", 5.0}, {"Im", 1e-4}}, task);

  std::string q0;
  for (int i = 1; i <= 4; ++i) q0 += (i > 1 ? "," : "") + std::to_string(c.rows[0][i]);
  int status = 0;
  out = test::run_command(cli() + "simulate tests/scenes/fixed_n4_geared.yaml --torques " + tau +
                              " --t-end 4 --q0 " + q0 + " -o " + sim + cache() + " 2>&1",
                          &status);
  ASSERT_EQ(status, 0) << out;
  const Csv s = read_csv(sim);
  ASSERT_EQ(s.rows.size(), c.rows.size());
  const Eigen::VectorXd end = s.values(s.rows.size() - 1, {"ee_x", "ee_y", "ee_phi"});
  // RK4 at 0.01 s on torques linear between 0.01 s samples: a few micrometres off the goal
  // (std::to_string's 6 digits of q0 put the start within 1e-6 rad).
  EXPECT_LT((end - task.goal).cwiseAbs().maxCoeff(), 1e-4) << end.transpose();
}

TEST_F(PlanCommand, TwoLinkArmPlansPositionOnly) {
  const std::string csv = (dir() / "free_n2.csv").string();
  std::string out;
  ASSERT_EQ(plan("free_n2_geared", "--from 0.9,0.3 --to 0.7,0.5 --duration 4", csv, &out), 0)
      << out;
  StraightLineTask task;
  task.start = Eigen::Vector2d(0.9, 0.3);
  task.goal = Eigen::Vector2d(0.7, 0.5);
  task.duration = 4;
  check_plan(read_csv(csv), load_scene("tests/scenes/free_n2_geared.yaml"), {}, task);
}

// Issue 29: a plan made on the rigid geared scene is replayed into its flexible twin with
// friction by one command, with the integrator's defaults (auto chooses rosenbrock4 for the
// 3200 1/s motor springs and says so). Fed forward, friction leaves the end effector at the
// goal; without, the stalling joints are named. rk4 chosen by hand names the mode and the
// remedy instead of printing the state.
TEST_F(PlanCommand, RigidPlanReplaysIntoTheFlexibleTwinWithoutHandWork) {
  const std::string csv = (dir() / "rigid.csv").string(), sim = (dir() / "flex.csv").string();
  int status = 0;
  std::string out = test::run_command(cli() +
                                          "plan models/paper_geared.yaml --param p=10 --from "
                                          "0.9,0.3,0 --to 0.7,0.6,0.5 --duration 5 -o " +
                                          csv + cache() + " 2>&1",
                                      &status);
  ASSERT_EQ(status, 0) << out;
  const std::string flex = cli() +
                           "simulate models/paper_flexible.yaml --param fs=5e-3 --param "
                           "fc=5e-3 --plan " +
                           csv + " --dt-out 0.05 -o " + sim + cache();
  const Eigen::Vector3d goal(0.7, 0.6, 0.5);
  auto end_pose = [&] {
    const Csv s = read_csv(sim);
    EXPECT_EQ(s.rows.back()[0], 5.0);  // --t-end: the plan's end
    return Eigen::Vector3d(s.values(s.rows.size() - 1, {"ee_x", "ee_y", "ee_phi"}));
  };
  out = test::run_command(flex + " --feedforward friction 2>&1", &status);
  ASSERT_EQ(status, 0) << out;
  EXPECT_NE(out.find("integrator: rosenbrock4"), std::string::npos) << out;
  EXPECT_LT((end_pose() - goal).norm(), 1e-3) << end_pose().transpose();
  out = test::run_command(flex + " 2>&1", &status);
  ASSERT_EQ(status, 0) << out;
  EXPECT_NE(out.find("friction (p f(p q')) reaches the planned torque's peak at joint"),
            std::string::npos)
      << out;
  EXPECT_GT((end_pose() - goal).norm(), 2e-2);
  out = test::run_command(flex + " --integrator rk4 2>&1", &status);
  EXPECT_NE(status, 0);
  EXPECT_NE(out.find("is unstable for the stiffest mode at the start"), std::string::npos) << out;
  EXPECT_NE(out.find("run with --integrator auto or rosenbrock4"), std::string::npos) << out;
  EXPECT_EQ(out.find("last accepted state"), std::string::npos) << out;
  // A plan for another base or joint count is refused by name.
  out = test::run_command(
      cli() + "simulate tests/scenes/fixed_n4_geared.yaml --plan " + csv + cache() + " 2>&1",
      &status);
  EXPECT_NE(out.find("planned on a free-floating base"), std::string::npos) << out;
}

// Issue 53: a point-to-point plan (min_effort, IPOPT) is a plan like a line's: simulate --plan
// flies it in the model it was planned on to the goal, and into the flexible twin near it.
TEST_F(PlanCommand, ALeastEffortPlanReplaysIntoItsTwins) {
  const std::string csv = (dir() / "least.csv").string(),
                    sim = (dir() / "least_flown.csv").string();
  int status = 0;
  std::string out = test::run_command(cli() +
                                          "plan models/paper_geared.yaml --param p=10 --from "
                                          "0.9,0.3 --to 0.7,0.6 --duration 5 --objective "
                                          "min_effort -o " +
                                          csv + cache() + " 2>&1",
                                      &status);
  ASSERT_EQ(status, 0) << out;
  EXPECT_NE(out.find("(50 knots, "), std::string::npos) << out;
  const Eigen::Vector2d goal(0.7, 0.6);
  auto end_position = [&] {
    const Csv s = read_csv(sim);
    return Eigen::Vector2d(s.values(s.rows.size() - 1, {"ee_x", "ee_y"}));
  };
  out = test::run_command(cli() + "simulate models/paper_geared.yaml --param p=10 --plan " + csv +
                              " -o " + sim + cache() + " 2>&1",
                          &status);
  ASSERT_EQ(status, 0) << out;
  EXPECT_LT((end_position() - goal).norm(), 1e-5) << end_position().transpose();
  // The flexible twin with its friction fed forward: measured 1.3e-3 m from the goal.
  out = test::run_command(cli() +
                              "simulate models/paper_flexible.yaml --param fs=5e-3 --param "
                              "fc=5e-3 --feedforward friction --plan " +
                              csv + " --dt-out 0.05 -o " + sim + cache() + " 2>&1",
                          &status);
  ASSERT_EQ(status, 0) << out;
  EXPECT_LT((end_position() - goal).norm(), 3e-3) << end_position().transpose();
}

// Issue 53, an attacker's review: a point-to-point plan whose flight misses the goal (6 knots:
// steps of 0.5 s) is an error, never a table; a tree is refused (it would move every arm).
TEST_F(PlanCommand, APointToPointPlanThatMissesItsGoalIsRefused) {
  const std::string csv = (dir() / "missed.csv").string();
  int status = 0;
  std::string out = test::run_command(
      cli() +
          "plan models/paper_reference.yaml --q0 0,0,0,0.3,0.8,0.5 --from 0.99269851,0.88958051 "
          "--to 0.9,0.95 --duration 3 --objective min_effort --knots 6 -o " +
          csv + cache() + " 2>&1",
      &status);
  EXPECT_NE(status, 0);
  EXPECT_NE(out.find("the flown plan ends 0.139 m from the goal and with rates up to 0.135 (0.076 "
                     "of their peak), not at rest"),
            std::string::npos)
      << out;
  EXPECT_NE(out.find("more knots make its steps finer"), std::string::npos) << out;
  EXPECT_FALSE(fs::exists(csv));
  out = test::run_command(cli() +
                              "plan models/dual_arm7.yaml --from 0.6,0.5,2.67 --to 0.9,0.6,2.3 "
                              "--duration 10 --objective min_effort -o " +
                              csv + cache() + " 2>&1",
                          &status);
  EXPECT_NE(status, 0);
  EXPECT_NE(out.find("objective min_effort plans a chain: on a tree it would move every arm"),
            std::string::npos)
      << out;
}

// Issue 49: a named output never replaces what is not a regular file. view's page and
// generate's sources are renamed into place, so a FIFO or a link at the name (as /dev/stdout
// is) is refused by name and left as it was; nothing is written.
TEST_F(PlanCommand, OutputsNeverReplaceAFifoOrALink) {
  const std::string csv = (dir() / "special_plan.csv").string();
  std::string out;
  ASSERT_EQ(plan("free_n2_geared", "--from 0.9,0.3 --to 0.7,0.5 --duration 1", csv, &out), 0)
      << out;
  const fs::path fifo = dir() / "page_fifo.html", link = dir() / "page_link.html";
  fs::remove(fifo);
  fs::remove(link);
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  fs::create_symlink("/proc/self/fd/1", link);
  const std::string scene = " --scene tests/scenes/free_n2_geared.yaml";
  for (const auto& [target, kind] :
       {std::pair{fifo, "a FIFO"}, std::pair{link, "a symbolic link"}}) {
    int status = 0;
    out = test::run_command(
        cli() + "view " + csv + scene + " -o " + target.string() + cache() + " 2>&1", &status);
    if (out.find("built without the viewer") != std::string::npos) break;
    EXPECT_NE(status, 0) << out;
    EXPECT_NE(out.find("'" + target.string() + "' exists and is " + kind), std::string::npos)
        << out;
    EXPECT_EQ(out.find("wrote"), std::string::npos) << out;
  }
  EXPECT_TRUE(fs::is_fifo(fs::symlink_status(fifo)));
  EXPECT_TRUE(fs::is_symlink(fs::symlink_status(link)));
  // generate -o DIR with a FIFO at DIR/NAME.hpp: refused before either file is written.
  const fs::path gen = dir() / "generated_special";
  fs::remove_all(gen);
  fs::create_directories(gen);
  ASSERT_EQ(::mkfifo((gen / "free_n2_geared.hpp").c_str(), 0600), 0);
  int status = 0;
  out = test::run_command(
      cli() + "generate tests/scenes/free_n2_geared.yaml -o " + gen.string() + " 2>&1", &status);
  EXPECT_NE(status, 0) << out;
  EXPECT_NE(out.find("free_n2_geared.hpp' exists and is a FIFO"), std::string::npos) << out;
  EXPECT_TRUE(fs::is_fifo(fs::symlink_status(gen / "free_n2_geared.hpp")));
  EXPECT_FALSE(fs::exists(gen / "free_n2_geared.cpp"));
}

// Issue 49: a plan replayed into another arm with the same base and joint count (link 2 longer)
// is refused, naming the scene it was made on (its provenance) and where the end effectors part;
// --other-arm replays it with a warning; the plan's own arm and its geared twin pass.
TEST_F(PlanCommand, APlanForAnotherArmIsRefusedNamingBothScenes) {
  const std::string csv = (dir() / "two_link_plan.csv").string();
  std::string out;
  ASSERT_EQ(plan("free_n2_geared", "--from 0.9,0.3 --to 0.7,0.5 --duration 1", csv, &out), 0)
      << out;
  std::string twin = test::read_text_file("tests/scenes/free_n2_geared.yaml");
  const std::string length = "length: 0.370";
  ASSERT_NE(twin.find(length), std::string::npos);
  twin.replace(twin.find(length), length.size(), "length: 0.420");
  twin.replace(twin.find("name: free_n2_geared"), 20, "name: longer_n2");
  const std::string longer = (dir() / "longer_n2.yaml").string();
  std::ofstream(longer) << twin;
  const std::string replay =
      cli() + "simulate " + longer + " --plan " + csv + " -o /dev/null" + cache();
  int status = 0;
  out = test::run_command(replay + " 2>&1", &status);
  EXPECT_NE(status, 0) << out;
  EXPECT_NE(out.find("--plan '" + csv + "' was made on '"), std::string::npos) << out;
  EXPECT_NE(out.find("free_n2_geared.yaml', whose kinematics differ from the scene '" + longer),
            std::string::npos)
      << out;
  EXPECT_NE(out.find("at t = 0 s the plan's end effector is at (0.9, 0.3)"), std::string::npos)
      << out;
  EXPECT_NE(out.find("add --other-arm"), std::string::npos) << out;
  out = test::run_command(replay + " --other-arm 2>&1", &status);
  EXPECT_EQ(status, 0) << out;
  EXPECT_NE(out.find("warning: --plan '" + csv + "' was made on"), std::string::npos) << out;
  out = test::run_command(cli() + "simulate tests/scenes/free_n2_geared.yaml --plan " + csv +
                              " -o /dev/null" + cache() + " 2>&1",
                          &status);
  EXPECT_EQ(status, 0) << out;
  EXPECT_EQ(out.find("kinematics differ"), std::string::npos) << out;
}

// Issue 49: a line passing 2 um from the shoulder of a folded arm (two equal links: the end
// effector there folds the arm onto its shoulder, a singularity) is planned, but its joint rates
// blow up; the warning says where and why instead of only "--dt is coarse". A line across the
// workspace gets no such warning.
TEST_F(PlanCommand, ALineNearASingularityIsNamed) {
  const std::string scene = (dir() / "folding_n2.yaml").string();
  std::ofstream(scene) << "name: folding_n2\nbase: {type: fixed, mount: [0, 0]}\nlinks:\n"
                          "  - {mass: 1.0, inertia: 0.02, length: 0.5, com: [0.25, 0]}\n"
                          "  - {mass: 1.0, inertia: 0.02, length: 0.5, com: [0.25, 0]}\n";
  const std::string csv = (dir() / "folding.csv").string();
  int status = 0;
  std::string out = test::run_command(cli() + "plan " + scene +
                                          " --from 0.3,2e-6 --to -0.3,2e-6 --duration 2 -o " + csv +
                                          cache() + " 2>&1",
                                      &status);
  EXPECT_EQ(status, 0) << out;
  EXPECT_NE(out.find("warning: the line passes near a singularity of the arm at t = 1 s: the "
                     "rates reach"),
            std::string::npos)
      << out;
  EXPECT_NE(out.find("move the line away from it"), std::string::npos) << out;
  out =
      test::run_command(cli() + "plan " + scene + " --from 0.8,0.3 --to 0.3,0.6 --duration 2 -o " +
                            csv + cache() + " 2>&1",
                        &status);
  EXPECT_EQ(status, 0) << out;
  EXPECT_EQ(out.find("near a singularity"), std::string::npos) << out;
}

TEST_F(PlanCommand, BadRequestsNameTheOption) {
  const std::string csv = (dir() / "bad.csv").string();
  const std::string scene = (fs::path(SPACEARM_SOURCE_DIR) / "tests/scenes/free_n5.yaml").string();
  const std::string line = "free_n5 --from 1.6,0.2,0.3 --to 1.2,-0.2,0.5 ";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"free_n2_geared --from 0.9,0.3,0 --to 0.7,0.5,0 --duration 4",
       "a 2-link arm cannot follow a pose"},
      {"free_n5 --from 1.6,0.2 --to 1.2,-0.2,0.5 --duration 4", "--to has 3 values and --from 2"},
      {"free_n5 --from 1.6 --to 1.2 --duration 4", "--from must be x,y (position) or x,y,phi"},
      {"free_n5 --from 9,0,0 --to 1.2,0,0 --duration 4",
       "no start configuration on elbow branch 1"},
      {"free_n5 --from 1e300,0,0 --to 1.2,0,0 --duration 4", "--from value 1 must be finite"},
      {line + "--duration 4 --elbow 0", "--elbow must be +1 or -1, got 0"},
      {line + "--duration 4 --q0 1,2", "--q0"},
      {line + "--duration 4 --time-law linear", "--time-law"},
      {line + "--duration -4", "--duration"},
      {line + "--duration 1 --dt 0.3", "--duration (1 s) must be a whole multiple of --dt (0.3"},
      {line + "--duration 1e6", "= 1e+08 samples; at most 1e+06"},
      {line + "--duration 4 --torque-file " + csv, "--torque-file '" + csv + "' is also the -o"},
      {line + "--duration 4 --torque-file " + scene, "--torque-file '" + scene + "' is the scene"},
      {"free_n5 --from 1.6,x,0.3 --to 1.2,-0.2,0.5 --duration 4", "--from"},
      {"free_n5 --from 0.5,0.2,0.3 --to 3,0.2,0.3 --duration 4", "singular"},
      // A spatial arm: 3 or 7 values; the 2-joint one follows no 3D position.
      {"spatial_arm2 --from 1,0 --to 1.1,0 --duration 4",
       "--from must be x,y,z (position) or x,y,z,qw,qx,qy,qz (pose), got 2 values"},
      {"spatial_arm2 --from 1,0,0 --to 1.1,0,0 --duration 4",
       "a 2-link arm cannot follow a position (3 task coordinates)"},
      // An option the objective does not use is refused, not ignored.
      {line + "--duration 4 --knots 20",
       "--knots: not used by --objective line (it is min_base_rotation's and min_effort's)"},
      {line + "--duration 4 --objective reactionless --effort-weight 0.1",
       "--effort-weight: not used by --objective reactionless"},
      {"free_n5 --from 1.6,0.2 --to 1.2,-0.2 --duration 4 --objective min_effort "
       "--effort-weight 0.1",
       "--effort-weight: not used by --objective min_effort (min_effort minimises the effort "
       "alone"},
      {"free_n5 --from 1.6,0.2 --to 1.2,-0.2 --duration 4 --objective min_effort "
       "--time-law cubic",
       "--time-law: not used by --objective min_effort (a point-to-point plan goes by any path"},
  };
  for (const auto& [args, want] : cases) {
    SCOPED_TRACE(args);
    const auto space = args.find(' ');
    std::string out;
    EXPECT_EQ(plan(args.substr(0, space), args.substr(space + 1), csv, &out), 1 << 8) << out;
    EXPECT_NE(out.find(want), std::string::npos) << out;
  }
}

// In 3D (issue 31): the 7-joint arm of models/space_arm7 (geared, exact rotors, p = 100) plans
// a pose (a line and a turn) through the command, and `simulate --plan` flies it: the base's
// quaternion stays unit, the link-side columns are the motor angles over p, and the replay ends
// at the goal with the momentum still zero. Cost: about 6 s, compiling the arm once.
TEST_F(PlanCommand, SpatialArmPlansAPoseAndSimulateFliesIt) {
  const std::string scene = (fs::path(SPACEARM_SOURCE_DIR) / "models/space_arm7.yaml").string();
  const std::string csv = (dir() / "arm7.csv").string(),
                    flown = (dir() / "arm7_flown.csv").string();
  const std::string q0 = "0,0,0,1,0,0,0,30,50,-20,-160,40,90,10";
  const std::string from =
      "1.5199002392044572,0.20122055952054133,1.243704490684638,"
      "-0.6356536114580597,0.14067478618696588,0.6807863076312657,"
      "0.3356860052390699";
  const std::string to = "1.6,0.15,1.15,-0.5,0.2,0.7,0.4";
  int status = 0;
  const std::string out =
      test::run_command(cli() + "plan " + scene + " --from " + from + " --to " + to +
                            " --duration 4 --q0 " + q0 + " -o " + csv + cache() + " 2>&1",
                        &status);
  ASSERT_EQ(status, 0) << out;
  const Csv plan = read_csv(csv);
  ASSERT_EQ(plan.rows.size(), 401u);
  for (const char* name : {"qw0", "vx0", "wz0", "qm7dd", "q7", "tau7", "tau_motor7"})
    plan.column(name);
  for (size_t k = 0; k < plan.rows.size(); ++k) {
    EXPECT_NEAR(plan.values(k, {"qw0", "qx0", "qy0", "qz0"}).norm(), 1, 1e-12);
    EXPECT_NEAR(plan.values(k, {"qm4"})[0] / 100, plan.values(k, {"q4"})[0], 1e-12);
  }
  const std::string sim = test::run_command(
      cli() + "simulate " + scene + " --plan " + csv + " -o " + flown + cache() + " 2>&1", &status);
  ASSERT_EQ(status, 0) << sim;
  const Csv run = read_csv(flown);
  const size_t last = run.rows.size() - 1;
  EXPECT_NEAR(run.rows[last][0], 4, 1e-12);
  // RK4 at 0.01 s, torques linear between samples: measured 3e-6 m from the goal.
  EXPECT_LT((run.values(last, {"ee_x", "ee_y", "ee_z"}) - Eigen::Vector3d(1.6, 0.15, 1.15)).norm(),
            3e-5);
  EXPECT_LT(run.values(last, {"Px", "Py", "Pz", "Lx", "Ly", "Lz"}).norm(), 1e-8);

  // The scene's URDF is an input: -o and --torque-file refuse it (a copy here, so that a failure
  // cannot overwrite the repository's); a base quaternion of no usable size in --q0 is named.
  fs::copy_file(fs::path(SPACEARM_SOURCE_DIR) / "models/space_arm7.urdf", dir() / "space_arm7.urdf",
                fs::copy_options::overwrite_existing);
  fs::copy_file(scene, dir() / "space_arm7.yaml", fs::copy_options::overwrite_existing);
  const std::string urdf = (dir() / "space_arm7.urdf").string();
  const std::string copy = cli() + "plan " + (dir() / "space_arm7.yaml").string() + " --from " +
                           from + " --to " + to + " --duration 4 --q0 " + q0 + cache();
  for (const std::string& option : {std::string(" -o "), " -o " + csv + " --torque-file "}) {
    const std::string refused = test::run_command(copy + option + urdf + " 2>&1", &status);
    EXPECT_NE(status, 0) << refused;
    EXPECT_NE(refused.find("is the scene's URDF file: it would be overwritten"), std::string::npos)
        << refused;
  }
  EXPECT_NE(test::read_text_file(urdf).find("<robot"), std::string::npos);
  const std::string huge =
      test::run_command(cli() + "plan " + scene + " --from " + from + " --to " + to +
                            " --duration 4 --q0 0,0,0,1e300,0,0,0,30,50,-20,-160,40,90,10 -o " +
                            csv + cache() + " 2>&1",
                        &status);
  EXPECT_NE(status, 0);
  EXPECT_NE(huge.find("--q0 values 4 to 7, the base's quaternion, must have a norm in [1e-6, 1e6], "
                      "got 1e+300"),
            std::string::npos)
      << huge;

  // Replayed into a twin with joint friction (the same URDF and gears): the arm stalls without
  // feed-forward, and reaches the goal with the scene's own friction fed forward along the plan.
  const fs::path twin = dir() / "arm7_friction.yaml";
  {
    std::string text = test::read_text_file(scene);
    text.replace(text.find("name: space_arm7"), 16, "name: space_arm7_friction");
    std::ofstream(twin) << text
                        << "friction: {viscous: 0.02, coulomb: 0.05, velocity_scale: 0.5}\n";
  }
  const std::string fly =
      cli() + "simulate " + twin.string() + " --plan " + csv + " -o " + flown + cache();
  std::string fed = test::run_command(fly + " --feedforward friction 2>&1", &status);
  ASSERT_EQ(status, 0) << fed;
  const Eigen::Vector3d goal(1.6, 0.15, 1.15);
  auto end_point = [&] {
    const Csv r = read_csv(flown);
    return Eigen::Vector3d(r.values(r.rows.size() - 1, {"ee_x", "ee_y", "ee_z"}));
  };
  EXPECT_LT((end_point() - goal).norm(), 1e-3) << end_point().transpose();
  const std::string stalled = test::run_command(fly + " 2>&1", &status);
  ASSERT_EQ(status, 0) << stalled;
  EXPECT_NE(stalled.find("friction (p f(p q')) reaches the planned torque's peak at joint"),
            std::string::npos)
      << stalled;
  EXPECT_GT((end_point() - goal).norm(), 1e-2) << end_point().transpose();

  // Replayed into a flexible twin (a spring and a damper in every gear, the motors after the
  // joints): its start is mapped and the springs pre-deflected with no hand work, the springs
  // wind up along the way, the momentum stays zero and the arm still reaches the goal (measured
  // 4.6e-6 m with k = 5000 N m/rad; cost about 1 s).
  const fs::path flexible = dir() / "arm7_flexible.yaml";
  {
    std::string text = test::read_text_file(scene);
    text.replace(text.find("name: space_arm7"), 16, "name: space_arm7_flexible");
    text.replace(text.find("rotor_coupling: exact}"), 22,
                 "rotor_coupling: exact, stiffness: 5000, damping: 2}");
    std::ofstream(flexible) << text;
  }
  const std::string flex = test::run_command(cli() + "simulate " + flexible.string() + " --plan " +
                                                 csv + " -o " + flown + cache() + " 2>&1",
                                             &status);
  ASSERT_EQ(status, 0) << flex;
  const Csv twin_run = read_csv(flown);
  const size_t end = twin_run.rows.size() - 1;
  EXPECT_NEAR(twin_run.rows[end][0], 4, 1e-12);
  EXPECT_LT((end_point() - goal).norm(), 1e-4) << end_point().transpose();
  EXPECT_LT(twin_run.values(end, {"Px", "Py", "Pz", "Lx", "Ly", "Lz"}).norm(), 1e-8);
  // The start: the plan's link angles in the slots, the motors at p q (the plan starts at rest
  // with no torque, so no pre-deflection).
  for (int j = 1; j <= 7; ++j) {
    const std::string q = "q" + std::to_string(j), qm = "qm" + std::to_string(j);
    EXPECT_NEAR(twin_run.values(0, {q})[0], plan.values(0, {q})[0], 1e-12) << q;
    EXPECT_NEAR(twin_run.values(0, {qm})[0], 100 * plan.values(0, {q})[0], 1e-10) << qm;
  }
  // Along the way joint 4's spring carries torque of the planned size: k |qm4/p - q4| peaks
  // within a factor 3 of the planned |tau4|'s peak (measured 0.088 against 0.092 N m).
  double wound = 0, apart = 0, peak = 0;
  for (size_t k = 0; k < twin_run.rows.size(); ++k) {
    wound = std::max(wound, twin_run.values(k, {"potential_energy"})[0]);
    apart = std::max(
        apart, std::abs(twin_run.values(k, {"qm4"})[0] / 100 - twin_run.values(k, {"q4"})[0]));
    peak = std::max(peak, std::abs(twin_run.values(k, {"tau4"})[0]));
  }
  EXPECT_GT(wound, 1e-7);
  EXPECT_GT(5000 * apart, peak / 3);
  EXPECT_LT(5000 * apart, peak * 3);
}

// A published robot (issue 51): ETS-VII's URDF, byte for byte as its authors published it
// (models/published/SOURCE.md), with inertias identified in orbit that no rigid body has. It
// loads with inertia_check: positive_definite alone (three links named once), plans a line with
// zero momentum, and flies it to the goal with the momentum kept; MuJoCo cannot take it as it is.
// Cost: about 3 s (one model).
TEST_F(PlanCommand, PublishedEtsViiPlansAndFlies) {
  const fs::path folder = fs::path(SPACEARM_SOURCE_DIR) / "models/published";
  int status = 0;
  EXPECT_EQ(
      test::run_command("sha256sum " + (folder / "ETSVII.urdf").string(), &status).substr(0, 64),
      "9f8405b5bff9f0c3c013841cdf6082b648ce36a36361ed45d0ee77506f5e8948");
  const std::string scene = (folder / "ets_vii.yaml").string();
  const std::string csv = (dir() / "ets.csv").string(), flown = (dir() / "ets_flown.csv").string();
  const std::string out = test::run_command(cli() + "plan " + scene +
                                                " --from 0.9,-0.3,2.0 --to 0.9,0.1,2.0 "
                                                "--duration 10 --dt 0.05 -o " +
                                                csv + cache() + " 2>&1",
                                            &status);
  ASSERT_EQ(status, 0) << out;
  EXPECT_NE(out.find("takes 3 bodies whose inertia no rigid body has (a principal moment above "
                     "the sum of the other two, as identified parameters may be): link 'Link_1' "
                     "(principal moments 0.25, 0.25, 1.69); link 'Link_2' (principal moments "
                     "0.1, 1.31, 3.75); link 'Link_3' (principal moments 0.1, 0.71, 2.53)"),
            std::string::npos)
      << out;
  const std::string sim = test::run_command(
      cli() + "simulate " + scene + " --plan " + csv + " -o " + flown + cache() + " 2>&1", &status);
  ASSERT_EQ(status, 0) << sim;
  const Csv run = read_csv(flown);
  const size_t last = run.rows.size() - 1;
  EXPECT_LT((run.values(last, {"ee_x", "ee_y", "ee_z"}) - Eigen::Vector3d(0.9, 0.1, 2.0)).norm(),
            1e-4);
  EXPECT_LT(run.values(last, {"Px", "Py", "Pz", "Lx", "Ly", "Lz"}).norm(), 1e-8);
  const std::string mjcf = test::run_command(
      cli() + "export --mjcf " + scene + " -o " + (dir() / "ets.xml").string() + " 2>&1", &status);
  EXPECT_NE(status, 0);
  EXPECT_NE(mjcf.find("these bodies' are not: 'Link_1', 'Link_2', 'Link_3'"), std::string::npos)
      << mjcf;
}

// Issue 51: a URDF with identified link inertias (models/identified_arm3: each Izz above
// Ixx + Iyy) under inertia_check: positive_definite plans and flies like any arm (momentum
// held), says once which bodies are not physical, ends at the URDF's welded tool, and measures
// the plan against the URDF's <limit effort velocity>, warning beyond them; its <dynamics>
// become joint friction with friction: {from_urdf: true}. Cost: about 5 s (two models).
TEST_F(PlanCommand, IdentifiedUrdfPlansFliesAndReportsItsLimits) {
  const fs::path models = fs::path(SPACEARM_SOURCE_DIR) / "models";
  const std::string scene = (models / "identified_arm3.yaml").string();
  const std::string csv = (dir() / "identified.csv").string(),
                    flown = (dir() / "identified_flown.csv").string();
  const std::string line =
      " --q0 0,0,0,1,0,0,0,0.3,0.5,-0.8 --from 2.455210170466492,0.4192156315649229,"
      "0.9619002758873577 --to 2.3,0.6,1.1 -o " +
      csv + cache();
  int status = 0;
  const std::string out =
      test::run_command(cli() + "plan " + scene + line + " --duration 10 2>&1", &status);
  ASSERT_EQ(status, 0) << out;
  const std::string said =
      "inertia_check: positive_definite takes 3 bodies whose inertia no "
      "rigid body has";
  EXPECT_NE(out.find(said + " (a principal moment above the sum of the other two, as identified "
                            "parameters may be): link 'Link_1' (principal moments 0.25, 0.25, "
                            "1.69)"),
            std::string::npos)
      << out;
  EXPECT_EQ(out.find(said), out.rfind(said)) << out;  // once
  EXPECT_NE(out.find("URDF limits, peak |tau| / effort and |q'| / velocity per joint: 'Joint_1' "),
            std::string::npos)
      << out;
  EXPECT_EQ(out.find("beyond the URDF's limits"), std::string::npos) << out;
  // Each joint's range is [-3, 3] or [-2.5, 2.5]: the peak |q| over half of it, from the CSV.
  const std::string ranges = "URDF ranges, peak |q - centre| / half the range per joint: ";
  ASSERT_NE(out.find(ranges), std::string::npos) << out;
  {
    const Csv plan = read_csv(csv);
    std::string expected;
    char text[64];
    const double half[3] = {3.0, 2.5, 2.5};
    for (int j = 0; j < 3; ++j) {
      double peak = 0;
      for (size_t r = 0; r < plan.rows.size(); ++r)
        peak = std::max(peak, std::abs(plan.values(r, {"q" + std::to_string(j + 1)})[0]));
      std::snprintf(text, sizeof text, "%s'Joint_%d' %.2g", j ? ", " : "", j + 1, peak / half[j]);
      expected += text;
    }
    EXPECT_NE(out.find(ranges + expected + "\n"), std::string::npos) << expected << "\n" << out;
  }
  EXPECT_NE(out.find("<dynamics damping friction> of joints 'Joint_1', 'Joint_2', 'Joint_3' are "
                     "ignored"),
            std::string::npos)
      << out;
  const std::string sim = test::run_command(
      cli() + "simulate " + scene + " --plan " + csv + " -o " + flown + cache() + " 2>&1", &status);
  ASSERT_EQ(status, 0) << sim;
  const std::string limits = "URDF limits, peak |tau| / effort and |q'| / velocity per joint: ";
  EXPECT_EQ(sim.substr(sim.find(limits), sim.find('\n', sim.find(limits)) - sim.find(limits)),
            out.substr(out.find(limits), out.find('\n', out.find(limits)) - out.find(limits)))
      << sim;  // the replay reports the plan's use of the limits
  EXPECT_EQ(sim.substr(sim.find(ranges), sim.find('\n', sim.find(ranges)) - sim.find(ranges)),
            out.substr(out.find(ranges), out.find('\n', out.find(ranges)) - out.find(ranges)))
      << sim;
  const Csv run = read_csv(flown);
  const size_t last = run.rows.size() - 1;
  EXPECT_LT((run.values(last, {"ee_x", "ee_y", "ee_z"}) - Eigen::Vector3d(2.3, 0.6, 1.1)).norm(),
            1e-4);
  EXPECT_LT(run.values(last, {"Px", "Py", "Pz", "Lx", "Ly", "Lz"}).norm(), 1e-8);
  // The same line in 0.5 s asks 20 times the rates: beyond the joints' velocity limits.
  const std::string fast =
      test::run_command(cli() + "plan " + scene + line + " --duration 0.5 2>&1", &status);
  ASSERT_EQ(status, 0) << fast;
  EXPECT_NE(fast.find("warning: beyond the URDF's limits (times the limit): 'Joint_1' (effort"),
            std::string::npos)
      << fast;
  // The URDF's <dynamics> as friction: the replay without feed-forward lags the plan.
  const fs::path twin = dir() / "identified_friction.yaml";
  fs::copy_file(models / "identified_arm3.urdf", dir() / "identified_arm3.urdf",
                fs::copy_options::overwrite_existing);
  {
    std::string text = test::read_text_file(scene);
    text.replace(text.find("name: identified_arm3"), 21, "name: identified_friction");
    std::ofstream(twin) << text << "friction: {from_urdf: true, velocity_scale: 0.01}\n";
  }
  const std::string lag = test::run_command(
      cli() + "simulate " + twin.string() + " --plan " + csv + " -o " + flown + cache() + " 2>&1",
      &status);
  ASSERT_EQ(status, 0) << lag;
  EXPECT_EQ(lag.find("are ignored"), std::string::npos) << lag;
  const Csv lagged = read_csv(flown);
  EXPECT_GT((lagged.values(lagged.rows.size() - 1, {"ee_x", "ee_y", "ee_z"}) -
             Eigen::Vector3d(2.3, 0.6, 1.1))
                .norm(),
            1e-3);
}

// Issue 52: models/dual_arm7, two 7-joint arms on one satellite. The left tool follows a line
// while the right one holds its pose in the inertial frame (the base and the right arm's joints
// moving under it) or its joints; replayed by simulate (exact rotors, RK4 at 0.01 s, torques
// linear between samples) the left tool reaches the goal, the held one stays put, and the
// momentum stays zero. Both tools move at once, each along its own line and time law; an end
// effector the scene lacks, or a --from per line missing, is named.
TEST_F(PlanCommand, ATreePlansOneArmWhileTheOtherHoldsItsPose) {
  const std::string scene = (fs::path(SPACEARM_SOURCE_DIR) / "models/dual_arm7.yaml").string();
  const std::string line = " --from 0.6,0.5,2.67 --to 0.9,0.6,2.3 --duration 10 ";
  auto tool = [](const Csv& c, size_t row, const std::string& side) {
    return c.values(row, {"ee_" + side + "_tool_flange_x", "ee_" + side + "_tool_flange_y",
                          "ee_" + side + "_tool_flange_z"});
  };
  for (const std::string hold : {"pose", "joints"}) {
    SCOPED_TRACE(hold);
    const std::string csv = (dir() / ("dual_" + hold + ".csv")).string(),
                      flown = (dir() / ("dual_" + hold + "_flown.csv")).string();
    int status = 0;
    const std::string out =
        test::run_command(cli() + "plan " + scene + line + "--end-effector l_tool_flange --hold " +
                              hold + " -o " + csv + cache() + " 2>&1",
                          &status);
    ASSERT_EQ(status, 0) << out;
    EXPECT_NE(out.find("held end effectors or joints within"), std::string::npos) << out;
    const Csv plan = read_csv(csv);
    const size_t last = plan.rows.size() - 1;
    EXPECT_LT((tool(plan, last, "l") - Eigen::Vector3d(0.9, 0.6, 2.3)).norm(), 1e-10);
    std::vector<std::string> right_joints;
    for (int j = 8; j <= 14; ++j) right_joints.push_back("q" + std::to_string(j));
    if (hold == "pose") {
      EXPECT_LT((tool(plan, last, "r") - tool(plan, 0, "r")).norm(), 1e-10);
    } else {
      EXPECT_EQ(plan.values(last, right_joints), plan.values(0, right_joints));
      EXPECT_GT((tool(plan, last, "r") - tool(plan, 0, "r")).norm(), 1e-3);  // rides the base
    }
    const std::string sim = test::run_command(
        cli() + "simulate " + scene + " --plan " + csv + " -o " + flown + cache() + " 2>&1",
        &status);
    ASSERT_EQ(status, 0) << sim;
    const Csv run = read_csv(flown);
    const size_t end = run.rows.size() - 1;
    // Open-loop replay: the left tool measured 7e-5 m (hold pose) and 3.2e-4 m (hold joints)
    // from the goal, the held right one 3e-6 m from its start.
    EXPECT_LT((tool(run, end, "l") - Eigen::Vector3d(0.9, 0.6, 2.3)).norm(), 5e-4);
    if (hold == "pose") {
      EXPECT_LT((tool(run, end, "r") - tool(run, 0, "r")).norm(), 3e-5);
    }
    EXPECT_LT(run.values(end, {"Px", "Py", "Pz", "Lx", "Ly", "Lz"}).norm(), 1e-8);
  }
  // Both tools at once, each along its own line with its own time law.
  int status = 0;
  const std::string both = (dir() / "dual_both.csv").string();
  const std::string out = test::run_command(
      cli() + "plan " + scene +
          " --end-effector l_tool_flange --from 0.6,0.5,2.67 --to 0.9,0.6,2.3 --time-law quintic"
          " --end-effector r_tool_flange --from 0.6,-0.5,2.67 --to 0.8,-0.7,2.4 --time-law cubic"
          " --duration 4 -o " +
          both + cache() + " 2>&1",
      &status);
  ASSERT_EQ(status, 0) << out;
  const Csv plan = read_csv(both);
  const size_t last = plan.rows.size() - 1, quarter = last / 4;
  EXPECT_LT((tool(plan, last, "l") - Eigen::Vector3d(0.9, 0.6, 2.3)).norm(), 1e-10);
  EXPECT_LT((tool(plan, last, "r") - Eigen::Vector3d(0.8, -0.7, 2.4)).norm(), 1e-10);
  // At a quarter of the time: s = 0.15625 on the cubic law (3 s^2 - 2 s^3), 0.103515625 on the
  // quintic.
  EXPECT_LT((tool(plan, quarter, "r") -
             (Eigen::Vector3d(0.6, -0.5, 2.67) + 0.15625 * Eigen::Vector3d(0.2, -0.2, -0.27)))
                .norm(),
            1e-10);
  EXPECT_LT((tool(plan, quarter, "l") -
             (Eigen::Vector3d(0.6, 0.5, 2.67) + 0.103515625 * Eigen::Vector3d(0.3, 0.1, -0.37)))
                .norm(),
            1e-10);
  const std::string uneven = test::run_command(
      cli() + "plan " + scene +
          " --end-effector l_tool_flange --end-effector r_tool_flange --from 0.6,0.5,2.67 "
          "--to 0.9,0.6,2.3 --duration 4 -o " +
          both + cache() + " 2>&1",
      &status);
  EXPECT_NE(status, 0);
  EXPECT_NE(uneven.find("--from: given 1 times for 2 end effector line(s)"), std::string::npos)
      << uneven;
  // More rows than joints (a 3-joint tree: a position and the other tool's pose held) is named,
  // never solved (the minimum-norm solve read past its factors).
  const std::string small =
      test::run_command(cli() +
                            "plan tests/scenes/spatial_tree3.yaml --end-effector b2 --hold pose "
                            "--from 0.8,-0.3,0.2 --to 0.8,-0.2,0.2 --duration 1 -o " +
                            both + cache() + " 2>&1",
                        &status);
  EXPECT_NE(status, 0);
  EXPECT_NE(small.find("3 task coordinates and 6 held (the other end effectors' or joints', "
                       "--hold) are 9 rows, more than its 3 joints can follow"),
            std::string::npos)
      << small;
  const std::string bad =
      test::run_command(cli() + "plan " + scene + line + "--end-effector hand -o " +
                            (dir() / "x.csv").string() + cache() + " 2>&1",
                        &status);
  EXPECT_NE(status, 0);
  EXPECT_NE(bad.find("--end-effector: 'hand' is not an end effector of 'dual_arm7' "
                     "('l_tool_flange', 'r_tool_flange')"),
            std::string::npos)
      << bad;
}

}  // namespace
}  // namespace spacearm
