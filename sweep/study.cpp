#include "study.hpp"

#include <fcntl.h>
#include <sys/stat.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <set>
#include <sstream>

#include "configuration_space.hpp"
#include "private_folder.hpp"
#include "version.hpp"
#include "yaml_reader.hpp"

namespace spacearm {

namespace {

constexpr std::uintmax_t kMaxStudyBytes = 1 << 20, kMaxTorqueBytes = 256u << 20;

// A number as text, shortest first ("0.01", "3e-07").
std::string text_of(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

// A regular file of at most max_bytes, read on its checked descriptor (read_regular_file).
std::string read_file(const std::string& path, const std::string& what, std::uintmax_t max_bytes) {
  return folder_errors_as<StudyError>(
      "", [&] { return read_regular_file(path, what, static_cast<size_t>(max_bytes)); });
}

// Why the quaternion at entries k .. k + 3 of v is not usable ("" if it is): a norm from 1e-6 to
// 1e6, as everywhere a quaternion is read. what: how the message names it.
std::string quaternion_problem(const Eigen::VectorXd& v, int k, const std::string& what) {
  const double norm = v.segment(k, 4).norm();
  if (ConfigurationSpace::takes_quaternion_norm(norm)) return "";
  return what + " (entries " + std::to_string(k) + " to " + std::to_string(k + 3) +
         ") needs a norm from 1e-6 to 1e6, got " + text_of(norm);
}

// Reads a study's fields; every error names the field (YamlReader::fail).
class StudyReader {
 public:
  StudyReader(const YamlReader& r, std::string dir) : r_(r), dir_(std::move(dir)) {}

  double number(const YAML::Node& n, const std::string& field) const {
    const Quantity q = r_.quantity(n, field);
    if (q.is_parameter()) r_.fail(field, "expected a number, got '" + q.parameter + "'", n);
    return q.value;
  }
  double positive(const YAML::Node& n, const std::string& field) const {
    const double v = number(n, field);
    if (!(v > 0)) r_.fail(field, "must be positive, got " + n.Scalar(), n);
    return v;
  }
  long count(const YAML::Node& n, const std::string& field, long max) const {
    const double v = number(n, field);
    if (!(v >= 1 && v <= static_cast<double>(max) && v == std::floor(v)))
      r_.fail(field,
              "expected a whole number from 1 to " + std::to_string(max) + ", got " + n.Scalar(),
              n);
    return static_cast<long>(v);
  }
  std::string text(const YAML::Node& n, const std::string& field) const {
    if (!n.IsScalar()) r_.fail(field, std::string("expected text, got ") + r_.kind(n), n);
    return r_.bounded(n, field).Scalar();
  }
  Eigen::VectorXd numbers(const YAML::Node& n, const std::string& field, int min, int max) const {
    if (!n.IsSequence() || static_cast<int>(n.size()) < min || static_cast<int>(n.size()) > max)
      r_.fail(field,
              "expected a list of " +
                  (min == max ? std::to_string(min)
                              : std::to_string(min) + " to " + std::to_string(max)) +
                  " numbers",
              n);
    Eigen::VectorXd v(static_cast<int>(n.size()));
    for (int i = 0; i < v.size(); ++i) v[i] = number(n[i], field + "[" + std::to_string(i) + "]");
    return v;
  }
  // An end-effector position, or where pose_allowed a pose: in the plane [x, y] or [x, y, phi],
  // in 3D [x, y, z] or [x, y, z, qw, qx, qy, qz] with a usable quaternion.
  Eigen::VectorXd position_or_pose(const YAML::Node& n, const std::string& field, bool spatial,
                                   bool pose_allowed) const {
    const int position = spatial ? 3 : 2, pose = spatial ? 7 : 3;
    const Eigen::VectorXd v = numbers(n, field, position, pose_allowed ? pose : position);
    if (v.size() != position && v.size() != pose)
      r_.fail(field, "expected a position (3 numbers) or a pose (7: x, y, z, qw, qx, qy, qz)", n);
    if (spatial && v.size() == pose)
      if (const std::string why = quaternion_problem(v, 3, "the quaternion"); !why.empty())
        r_.fail(field, why, n);
    return v;
  }
  // A file named relative to the study's folder.
  std::string path(const YAML::Node& n, const std::string& field) const {
    const std::filesystem::path p(text(n, field));
    return (p.is_absolute() ? p : std::filesystem::path(dir_) / p).string();
  }
  // Files a study names must be what they are for (.yaml or .yml scenes, .csv torques): a study
  // from anyone must not make spacearm read /etc/shadow and quote it back.
  std::string named_file(const YAML::Node& n, const std::string& field,
                         std::initializer_list<const char*> extensions) const {
    const std::string p = path(n, field);
    const std::string ext = std::filesystem::path(p).extension().string();
    std::string list;
    for (const char* e : extensions) {
      if (ext == e) return p;
      list += (list.empty() ? "" : " or ") + std::string(e);
    }
    r_.fail(field, "'" + p + "' is not a " + list + " file", n);
    return p;
  }
  StudyScene scene(const YAML::Node& n, const std::string& field) const {
    const std::string p = named_file(n, field, {".yaml", ".yml"});
    if (!std::filesystem::is_regular_file(p)) r_.fail(field, "no scene file '" + p + "'", n);
    return load_study_scene(p);
  }
  int parameter(const Study& s, const YAML::Node& key, const std::string& field) const {
    const std::string name = r_.key_text(key, field);
    const std::vector<std::string>& names = s.scene.parameter_names;
    for (size_t i = 0; i < names.size(); ++i)
      if (names[i] == name) return static_cast<int>(i);
    std::string known;
    for (const auto& p : names) known += (known.empty() ? "" : ", ") + p;
    r_.fail(field + "." + name,
            "not a run-time parameter of scene '" + s.scene.name +
                "' (known: " + (known.empty() ? "none" : known) + ")",
            key);
  }

  void manoeuvre(Study& s, const YAML::Node& n) const;
  void torque_manoeuvre(Study& s, const YAML::Node& n) const;
  void plan(Study& s, const YAML::Node& p, const YAML::Node& end_effector_given) const;
  int end_effector(const StudyScene& scene, const YAML::Node& n, const std::string& field) const;
  void integrator(Study& s, const YAML::Node& n) const;
  void grid(Study& s, const YAML::Node& n) const;
  void random(Study& s, const YAML::Node& n) const;
  void time_series(Study& s, const YAML::Node& n) const;

 private:
  const YamlReader& r_;
  std::string dir_;
};

void StudyReader::manoeuvre(Study& s, const YAML::Node& n) const {
  r_.check_keys(
      n, "manoeuvre",
      {"plan", "torques", "q0", "target", "command_ratio", "feedforward", "end_effector"});
  if (n["end_effector"].IsDefined())
    s.end_effector = end_effector(s.scene, n["end_effector"], "manoeuvre.end_effector");
  if (n["feedforward"].IsDefined()) {
    const std::string f = text(n["feedforward"], "manoeuvre.feedforward");
    if (f != "none" && f != "friction")
      r_.fail("manoeuvre.feedforward", "expected none or friction, got '" + f + "'",
              n["feedforward"]);
    if (f == "friction" && !n["plan"].IsDefined())
      r_.fail("manoeuvre.feedforward", "friction is fed forward along a plan's rates; give plan",
              n["feedforward"]);
    if (f == "friction" && !s.scene.wants(Output::friction_forces))
      r_.fail("manoeuvre.feedforward",
              "the scene does not emit friction_forces (add it to its field 'outputs')",
              n["feedforward"]);
    s.feedforward_friction = f == "friction";
  }
  if (n["command_ratio"].IsDefined()) {
    const std::string c = text(n["command_ratio"], "manoeuvre.command_ratio");
    if (c != "run" && c != "nominal")
      r_.fail("manoeuvre.command_ratio",
              "expected run (each run's motor gets tau / its own p) or nominal (tau / the "
              "scene's nominal p), got '" +
                  c + "'",
              n["command_ratio"]);
    s.command_ratio = c == "run" ? Study::CommandRatio::run : Study::CommandRatio::nominal;
  }
  if (n["plan"].IsDefined() == n["torques"].IsDefined())
    r_.fail("manoeuvre", "give either plan (a straight line) or torques (a CSV file)", n);
  // A target: a position (in 3D also a pose).
  const bool spatial = s.scene.is_spatial();
  if (n["target"].IsDefined())
    s.target = position_or_pose(n["target"], "manoeuvre.target", spatial, spatial);
  if (n["torques"].IsDefined()) return torque_manoeuvre(s, n);
  for (const char* f : {"q0", "target"})
    if (n[f].IsDefined())
      r_.fail(std::string("manoeuvre.") + f,
              "belongs to a torque manoeuvre; a plan starts at "
              "its line's start and aims at its end",
              n[f]);
  plan(s, n["plan"], n["end_effector"]);
}

// Torques from a file, from q0 (the base pose and link-side angles; 3D: origin, quaternion).
void StudyReader::torque_manoeuvre(Study& s, const YAML::Node& n) const {
  const StudyScene& f = s.scene;
  const int nq = f.base_coordinates + f.num_links, k = f.quaternion_offset;
  s.torque_path = named_file(n["torques"], "manoeuvre.torques", {".csv"});
  s.torques = read_torque_csv(read_file(s.torque_path, "manoeuvre.torques", kMaxTorqueBytes),
                              f.num_links, s.torque_path);
  s.q0 = Eigen::VectorXd::Zero(nq);
  if (k >= 0) s.q0[k] = 1;  // the base unturned
  if (n["q0"].IsDefined()) s.q0 = numbers(n["q0"], "manoeuvre.q0", nq, nq);
  if (k < 0) return;
  if (const std::string why = quaternion_problem(s.q0, k, "the base's quaternion"); !why.empty())
    r_.fail("manoeuvre.q0", why, n["q0"]);
  s.q0.segment(k, 4).normalize();
}

// A tree's end effector by name (manoeuvre.end_effector): its index in the scene's.
int StudyReader::end_effector(const StudyScene& scene, const YAML::Node& n,
                              const std::string& field) const {
  try {
    return end_effector_index(scene.end_effector_names, text(n, field), scene.name);
  } catch (const std::invalid_argument& e) {
    r_.fail(field, e.what(), n);
  }
}

// A straight line of the end effector, a position or a pose (3D: with the orientation slerped).
void StudyReader::plan(Study& s, const YAML::Node& p, const YAML::Node& end_effector_given) const {
  const bool spatial = s.scene.is_spatial();
  r_.check_keys(p, "manoeuvre.plan",
                {"from", "to", "duration", "time_law", "elbow", "scene", "q0", "hold", "objective",
                 "knots", "effort_weight"});
  StraightLineTask task;
  task.start = position_or_pose(r_.require(p, "from", "manoeuvre.plan"), "manoeuvre.plan.from",
                                spatial, true);
  task.goal =
      position_or_pose(r_.require(p, "to", "manoeuvre.plan"), "manoeuvre.plan.to", spatial, true);
  if (task.start.size() != task.goal.size())
    r_.fail("manoeuvre.plan.to", "must have as many numbers as manoeuvre.plan.from", p["to"]);
  task.duration = positive(r_.require(p, "duration", "manoeuvre.plan"), "manoeuvre.plan.duration");
  if (p["time_law"].IsDefined()) {
    const std::string law = text(p["time_law"], "manoeuvre.plan.time_law");
    if (law != "quintic" && law != "cubic")
      r_.fail("manoeuvre.plan.time_law", "expected quintic or cubic, got '" + law + "'",
              p["time_law"]);
    task.law = time_law_from_string(law);
  }
  if (p["elbow"].IsDefined()) {
    const double e = number(p["elbow"], "manoeuvre.plan.elbow");
    if (e != 1 && e != -1) r_.fail("manoeuvre.plan.elbow", "expected 1 or -1", p["elbow"]);
    task.elbow = static_cast<int>(e);
  }
  if (p["scene"].IsDefined()) s.plan_scene = scene(p["scene"], "manoeuvre.plan.scene");
  // The measured end effector is the planned one, found by name in the plan's scene.
  task.end_effector = end_effector_given.IsDefined() && s.plan_scene
                          ? end_effector(*s.plan_scene, end_effector_given,
                                         "manoeuvre.end_effector (in manoeuvre.plan.scene)")
                          : s.end_effector;
  if (p["hold"].IsDefined()) {
    const std::string hold = text(p["hold"], "manoeuvre.plan.hold");
    if (hold != "joints" && hold != "pose")
      r_.fail("manoeuvre.plan.hold",
              "expected joints (the other arms keep their joint angles) or pose (their end "
              "effectors keep their poses), got '" +
                  hold + "'",
              p["hold"]);
    task.hold = hold_from_string(hold);
  }
  if (p["objective"].IsDefined()) {
    const std::string objective = text(p["objective"], "manoeuvre.plan.objective");
    if (objective != "line" && objective != "reactionless" && objective != "min_base_rotation" &&
        objective != "min_effort")
      r_.fail("manoeuvre.plan.objective",
              "expected line (the base turns freely), reactionless (its angular velocity held "
              "at zero), min_base_rotation or min_effort (from rest to rest at the goal, "
              "IPOPT), got '" +
                  objective + "'",
              p["objective"]);
    task.objective = objective_from_string(objective);
  }
  if (p["knots"].IsDefined()) {
    const double k = number(p["knots"], "manoeuvre.plan.knots");
    if (!(k >= 1 && k <= 1000 && k == std::floor(k)))
      r_.fail("manoeuvre.plan.knots", "expected a whole number from 1 to 1000", p["knots"]);
    task.knots = static_cast<int>(k);
  }
  if (p["effort_weight"].IsDefined()) {
    const double w = number(p["effort_weight"], "manoeuvre.plan.effort_weight");
    if (!(w >= 0 && w <= 1e6))
      r_.fail("manoeuvre.plan.effort_weight", "expected a number from 0 to 1e6",
              p["effort_weight"]);
    task.effort_weight = w;
  }
  // A field the objective does not use is an error, as the same option is for `plan`.
  for (const auto& [field, used] : {std::pair{"knots", uses_knots(task.objective)},
                                    {"effort_weight", uses_effort_weight(task.objective)},
                                    {"time_law", uses_time_law(task.objective)}})
    if (p[field].IsDefined() && !used)
      r_.fail(std::string("manoeuvre.plan.") + field,
              std::string("not used by objective ") +
                  (p["objective"].IsDefined() ? text(p["objective"], "manoeuvre.plan.objective")
                                              : std::string("line")),
              p[field]);
  // The planner's start guess, as plan --q0: the plan scene's coordinates (the base pose, then
  // each joint's slot: a geared joint's motor angle qm = p q), which picks the IK branch.
  if (p["q0"].IsDefined()) {
    const StudyScene& pf = s.plan_scene ? *s.plan_scene : s.scene;
    const int nq = pf.base_coordinates + pf.num_links, k = pf.quaternion_offset;
    task.q0 = numbers(p["q0"], "manoeuvre.plan.q0", nq, nq);
    if (k >= 0) {
      if (const std::string why = quaternion_problem(task.q0, k, "the base's quaternion");
          !why.empty())
        r_.fail("manoeuvre.plan.q0", why, p["q0"]);
      task.q0.segment(k, 4).normalize();
    }
  }
  s.target = task.goal;
  s.plan = task;
}

void StudyReader::integrator(Study& s, const YAML::Node& n) const {
  if (n.IsDefined())
    r_.check_keys(n, "integrator", {"method", "dt", "t_end", "interpolation", "rtol", "atol"});
  IntegratorOptions& opt = s.integrator;
  // An absent integrator field reads as an empty mapping: every key undefined.
  const YAML::Node fields = n.IsDefined() ? n : YAML::Node(YAML::NodeType::Map);
  auto field = [&](const char* key) { return static_cast<const YAML::Node&>(fields)[key]; };
  if (field("method").IsDefined()) {
    const std::string m = text(field("method"), "integrator.method");
    try {
      opt.method = method_from_string(m);
    } catch (const std::invalid_argument& e) {
      r_.fail("integrator.method", e.what(), field("method"));
    }
  }
  if (field("dt").IsDefined()) opt.dt = positive(field("dt"), "integrator.dt");
  if (field("rtol").IsDefined()) opt.rtol = positive(field("rtol"), "integrator.rtol");
  if (field("atol").IsDefined()) opt.atol = positive(field("atol"), "integrator.atol");
  if (field("interpolation").IsDefined()) {
    const std::string i = text(field("interpolation"), "integrator.interpolation");
    if (i != "linear" && i != "hold")
      r_.fail("integrator.interpolation", "expected linear or hold, got '" + i + "'",
              field("interpolation"));
    s.interpolation = interpolation_from_string(i);
  }
  // The run ends with the manoeuvre unless told otherwise.
  s.t_end = field("t_end").IsDefined() ? positive(field("t_end"), "integrator.t_end")
            : s.plan                   ? s.plan->duration
                                       : s.torques->t_last();
  if (s.plan) s.plan->dt = opt.dt;  // the torque samples fall on the steps
  const double steps = s.t_end / opt.dt;
  if (!(steps >= 1 && steps <= 1e8) ||
      std::abs(steps - std::round(steps)) > 1e-9 * std::max(1.0, steps))
    r_.fail("integrator.t_end",
            "(" + text_of(s.t_end) + " s) must be a whole multiple of " + "integrator.dt (" +
                text_of(opt.dt) + " s), 1 to 1e8 steps",
            n);
  // The plan is sampled at the integrator's step; a few samples cannot carry the motion.
  if (s.plan && s.plan->duration / opt.dt < 10)
    r_.fail("integrator.dt",
            "(" + text_of(opt.dt) + " s) gives the plan of " + text_of(s.plan->duration) +
                " s fewer than 10 samples; a smaller integrator.dt",
            n);
}

void StudyReader::grid(Study& s, const YAML::Node& n) const {
  if (!n.IsMap() || n.size() == 0) r_.fail("grid", "expected a mapping of parameter: values", n);
  std::set<int> seen;
  for (const auto& kv : n) {
    const int index = parameter(s, kv.first, "grid");
    const std::string field = "grid." + s.scene.parameter_names[index];
    if (!seen.insert(index).second) r_.fail(field, "given more than once", kv.first);
    const YAML::Node& v = kv.second;
    std::vector<double> values;
    if (v.IsSequence()) {
      const Eigen::VectorXd list = numbers(v, field, 1, 1'000'000);
      values.assign(list.data(), list.data() + list.size());
    } else {
      r_.check_keys(v, field, {"from", "to", "num", "spacing"});
      const double a = number(r_.require(v, "from", field), field + ".from");
      const double b = number(r_.require(v, "to", field), field + ".to");
      const long num = count(r_.require(v, "num", field), field + ".num", 1'000'000);
      const std::string spacing =
          v["spacing"].IsDefined() ? text(v["spacing"], field + ".spacing") : "linear";
      if (spacing != "linear" && spacing != "log")
        r_.fail(field + ".spacing", "expected linear or log, got '" + spacing + "'", v);
      if (spacing == "log" && !(a > 0 && b > 0))
        r_.fail(field, "log spacing needs from and to above zero", v);
      for (long k = 0; k < num; ++k) {
        const double w = num == 1 ? 0.0 : static_cast<double>(k) / static_cast<double>(num - 1);
        values.push_back(spacing == "log" ? a * std::pow(b / a, w) : a + (b - a) * w);
      }
    }
    s.grid.emplace_back(index, std::move(values));
  }
}

void StudyReader::random(Study& s, const YAML::Node& n) const {
  r_.check_keys(n, "random", {"runs", "seed", "draws"});
  s.draws_per_point = count(r_.require(n, "runs", "random"), "random.runs", kMaxRuns);
  const double seed = number(r_.require(n, "seed", "random"), "random.seed");
  if (!(seed >= 0 && seed <= 9e15 && seed == std::floor(seed)))
    r_.fail("random.seed", "expected a whole number from 0 to 9e15", n["seed"]);
  s.seed = static_cast<std::uint64_t>(seed);
  const YAML::Node d = r_.require(n, "draws", "random");
  if (!d.IsMap() || d.size() == 0)
    r_.fail("random.draws", "expected a mapping of parameter: distribution", d);
  for (const auto& kv : d) {
    const int index = parameter(s, kv.first, "random.draws");
    const std::string field = "random.draws." + s.scene.parameter_names[index];
    for (const auto& [i, values] : s.grid)
      if (i == index) r_.fail(field, "is already on the grid; give it in one place", kv.first);
    for (const auto& [i, dist] : s.draws)
      if (i == index) r_.fail(field, "given more than once", kv.first);
    r_.check_keys(kv.second, field, {"uniform", "normal", "log_uniform"});
    if (kv.second.size() != 1)
      r_.fail(field, "give one distribution: uniform, normal or log_uniform", kv.second);
    const std::string kind = r_.key_text(kv.second.begin()->first, field);
    const Eigen::VectorXd ab = numbers(kv.second.begin()->second, field + "." + kind, 2, 2);
    Distribution dist{kind == "uniform"  ? Distribution::Kind::uniform
                      : kind == "normal" ? Distribution::Kind::normal
                                         : Distribution::Kind::log_uniform,
                      ab[0], ab[1]};
    const bool ordered = kind == "normal" ? ab[1] > 0 : ab[0] < ab[1];
    if (!ordered || (kind == "log_uniform" && !(ab[0] > 0)))
      r_.fail(field + "." + kind,
              (kind == "normal" ? "expected [mean, standard deviation] with a positive deviation"
                                : "expected [low, high] with low < high" +
                                      std::string(kind == "log_uniform" ? " and low > 0" : "")) +
                  ", got [" + text_of(ab[0]) + ", " + text_of(ab[1]) + "]",
              kv.second);
    s.draws.emplace_back(index, dist);
  }
}

void StudyReader::time_series(Study& s, const YAML::Node& n) const {
  r_.check_keys(n, "time_series", {"dt"});
  const double dt = positive(r_.require(n, "dt", "time_series"), "time_series.dt");
  const double every = dt / s.integrator.dt;
  if (std::abs(every - std::round(every)) > 1e-9 * every || std::round(every) < 1 || dt > s.t_end)
    r_.fail("time_series.dt",
            "(" + text_of(dt) + " s) must be a whole multiple of " + "integrator.dt (" +
                text_of(s.integrator.dt) + " s), at most t_end",
            n["dt"]);
  s.series_every = std::lround(every);
}

}  // namespace

bool StudyScene::wants(Output o) const {
  return std::find(outputs.begin(), outputs.end(), o) != outputs.end();
}

namespace {

// What a scene of either kind names alike: its name, file, bytes and run-time parameters.
template <class SceneKind>
void read_common(StudyScene& s, const SceneKind& sc) {
  s.name = sc.name, s.source_path = sc.source_path, s.content = sc.content;
  s.parameter_names = parameter_names(sc.parameters);
  s.nominal_parameters = nominal_values(sc.parameters);
}

}  // namespace

StudyScene load_study_scene(const std::string& path) {
  const std::string text = read_scene_file(path);
  StudyScene s;
  if (is_spatial_scene(text)) {
    s.spatial = std::make_shared<const SpatialScene>(parse_spatial_scene(text, path));
    const SpatialScene& sc = *s.spatial;
    read_common(s, sc);
    s.free_floating = sc.chain.free_base;
    for (const auto& l : sc.chain.links) s.geared = s.geared || l.gear.present;
    s.num_links = static_cast<int>(sc.chain.links.size());
    s.base_coordinates = s.free_floating ? 7 : 0;
    s.quaternion_offset = s.free_floating ? 3 : -1;
    s.features = spatial_features(sc);
    s.outputs = spatial_outputs(sc);
    for (int e = 0; e < sc.chain.num_end_effectors(); ++e)
      s.end_effector_names.push_back(sc.chain.end_effector_name(e));
    return s;
  }
  s.planar = std::make_shared<const Scene>(parse_scene(text, path));
  const Scene& sc = *s.planar;
  read_common(s, sc);
  s.free_floating = sc.free_floating();
  s.geared = sc.geared();
  s.num_links = sc.num_links();
  s.base_coordinates = sc.num_base();
  s.features = sc.features();
  for (const OutputInfo& o : output_registry())
    if (sc.wants(o.id)) s.outputs.push_back(o.id);
  return s;
}

long Study::num_runs() const {
  long runs = draws_per_point;
  for (const auto& g : grid) runs *= static_cast<long>(g.second.size());
  return runs;
}

std::vector<std::string> Study::parameter_names() const { return scene.parameter_names; }

Eigen::VectorXd Study::parameters(long run) const {
  if (run < 0 || run >= num_runs())
    throw std::out_of_range("study: run " + std::to_string(run) + " of " +
                            std::to_string(num_runs()));
  const std::vector<double>& nominal = scene.nominal_parameters;
  Eigen::VectorXd p =
      Eigen::Map<const Eigen::VectorXd>(nominal.data(), static_cast<Eigen::Index>(nominal.size()));
  // The grid point, in mixed radix with the last grid parameter fastest.
  long point = run / draws_per_point;
  for (auto g = grid.rbegin(); g != grid.rend(); ++g) {
    const long size = static_cast<long>(g->second.size());
    p[g->first] = g->second[point % size];
    point /= size;
  }
  if (draws.empty()) return p;
  // The run's own generator: std::seed_seq and mt19937_64 are specified exactly by the
  // standard; the distributions are not (their algorithms are the library's), so the draws are
  // written out here to be identical on every standard library.
  std::seed_seq seq{static_cast<std::uint32_t>(seed), static_cast<std::uint32_t>(seed >> 32),
                    static_cast<std::uint32_t>(run), static_cast<std::uint32_t>(run >> 32)};
  std::mt19937_64 gen(seq);
  auto unit = [&] { return static_cast<double>(gen() >> 11) * 0x1p-53; };  // [0, 1)
  for (const auto& [index, d] : draws) {
    const double u1 = unit(), u2 = unit();
    switch (d.kind) {
      case Distribution::Kind::uniform:
        p[index] = d.a + (d.b - d.a) * u1;
        break;
      case Distribution::Kind::log_uniform:
        p[index] = d.a * std::pow(d.b / d.a, u1);
        break;
      case Distribution::Kind::normal:  // Box-Muller
        p[index] = d.a + d.b * std::sqrt(-2 * std::log1p(-u1)) * std::cos(2 * M_PI * u2);
        break;
    }
  }
  return p;
}

Study parse_study(const std::string& yaml_text, const std::string& source_path) {
  const YamlReader r("study", source_path, [](const std::string& m) { throw StudyError(m); });
  const YAML::Node root = r.load(yaml_text);
  try {
    r.check_keys(root, "", {"scene", "manoeuvre", "integrator", "grid", "random", "time_series"});
    const StudyReader read(r, std::filesystem::path(source_path).parent_path().string());
    Study s;
    s.source_path = source_path;
    s.content = yaml_text;
    s.scene = read.scene(r.require(root, "scene", ""), "scene");
    read.manoeuvre(s, r.require(root, "manoeuvre", ""));
    read.integrator(s, root["integrator"]);
    if (root["grid"].IsDefined()) read.grid(s, root["grid"]);
    if (root["random"].IsDefined()) read.random(s, root["random"]);
    if (root["time_series"].IsDefined()) read.time_series(s, root["time_series"]);
    double runs = static_cast<double>(s.draws_per_point);
    for (const auto& g : s.grid) runs *= static_cast<double>(g.second.size());
    if (runs > static_cast<double>(kMaxRuns))
      r.fail("grid", "the grid points times random.runs give " + text_of(runs) + " runs, at most " +
                         std::to_string(kMaxRuns));
    // What the rows depend on: the files, and the generator that derives the model.
    std::string identity =
        std::string(kGeneratorVersion) + '\0' + yaml_text + '\0' + s.scene.content;
    if (s.plan_scene) identity += '\0' + s.plan_scene->content;
    if (s.torques)
      identity += '\0' + read_file(s.torque_path, "manoeuvre.torques", kMaxTorqueBytes);
    s.identity = content_hash(identity);
    return s;
  } catch (const YAML::Exception& e) {
    r.fail("", std::string("unexpected YAML structure: ") + e.what());
  }
}

Study load_study(const std::string& path) {
  return parse_study(read_file(path, "study", kMaxStudyBytes), path);
}

}  // namespace spacearm
