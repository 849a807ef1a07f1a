// The page's data for a run: per kept row, the joints' world positions from the scene's compiled
// model (joint_positions), the base pose, the joint axes and the rotors' angles, and the plots.
#include <Eigen/Geometry>
#include <sys/stat.h>

#include <filesystem>

#include <openssl/evp.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <map>
#include <sstream>
#include <memory>

#include "cli_input.hpp"
#include "compiled_model.hpp"
#include "dynamic_model.hpp"
#include "model_recipe.hpp"
#include "outputs.hpp"
#include "private_folder.hpp"
#include "provenance.hpp"
#include "run_table.hpp"
#include "spatial_scene.hpp"
#include "view_command.hpp"

namespace spacearm::cli {

using nlohmann::json;

namespace {

// A value as drawn and plotted: 9 significant digits (the page's JSON prints the shortest
// text that reads back the same double, so this keeps the page about half as large).
double shown(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.9g", v);
  return std::strtod(text, nullptr);
}

// Bytes as base64 (OpenSSL's encoder), for a mesh embedded in the page's JSON.
std::string base64(const std::string& bytes) {
  std::string text(4 * ((bytes.size() + 2) / 3) + 1, '\0');
  const int n = EVP_EncodeBlock(reinterpret_cast<unsigned char*>(text.data()),
                                reinterpret_cast<const unsigned char*>(bytes.data()),
                                static_cast<int>(bytes.size()));
  text.resize(static_cast<size_t>(n));
  return text;
}

// The scene's model at the chosen parameters. The DynamicModel refers to the CompiledModel.
struct LoadedScene {
  std::unique_ptr<ModelRecipe> recipe;
  std::unique_ptr<CompiledModel> model;
  Eigen::VectorXd params;
  DynamicModel dyn;
};

// What the page draws and plots from: joint positions, energies, momentum and, in 3D, the joint
// axes (the end-effector Jacobian's angular rows), where the scene can have them.
constexpr Output kViewOutputs[] = {Output::joint_positions, Output::kinetic_energy,
                                   Output::potential_energy, Output::momentum,
                                   Output::end_effector_jacobian};

// The scene as given if it emits all of kViewOutputs it can, else a variant that adds them.
// The variant's text (what names it in the cache) is the scene's with a comment saying so.
std::unique_ptr<ModelRecipe> view_recipe(ModelRecipe recipe) {
  const ModelFacts& facts = recipe.facts();
  std::vector<Output> missing;
  std::string note = "\n# spacearm view adds the outputs:";
  for (Output o : kViewOutputs) {
    const bool possible = missing_feature(info(o).needs, facts.features).empty() &&
                          (!facts.dims.spatial || spatial_output(o, facts.free_floating));
    if (possible &&
        std::find(facts.outputs.begin(), facts.outputs.end(), o) == facts.outputs.end()) {
      missing.push_back(o);
      note += " " + to_string(o);
    }
  }
  if (missing.empty()) return std::make_unique<ModelRecipe>(std::move(recipe));
  return std::make_unique<ModelRecipe>(recipe.with_outputs(missing, note + "\n"));
}

LoadedScene load_scene(const ViewArgs& a) {
  LoadedScene s;
  s.recipe = view_recipe(cli::load_scene(a.scene_path));
  CompileOptions options;
  options.cache_dir = a.cache_dir;
  options.engine = parse_engine(a.engine);
  options.call_first(Output::forward_dynamics);  // the integration's: compiled first
  // By value: a compile in the background says its last stage after this function returns.
  options.progress = [verbose = a.verbose](const std::string& m) {
    if (verbose || worth_saying(m)) std::fprintf(stderr, "spacearm: %s\n", m.c_str());
  };
  s.model = std::make_unique<CompiledModel>(CompiledModel::load(*s.recipe, options));
  s.params = parse_parameters(a.param_assignments, s.recipe->facts());
  s.dyn = dynamic_model(*s.model, s.params);
  return s;
}

// How a table's rows give q and qd: the model's own columns by name, else the base's and the
// link-side joint angles q1..qN (and rates q1d..qNd), motors placed at p q.
struct StateReader {
  const DynamicModel* m;
  std::vector<int> q_cols, qd_cols;  // the model's names, all found, or empty
  std::vector<int> base_q, joint_q;  // the link-side form
  std::vector<int> base_qd, joint_qd;
  bool has_velocity = false;
  int t_col = 0;
  std::string where;  // the option and file, for messages

  static std::vector<int> find(const RunTable& t, const std::vector<std::string>& names) {
    std::vector<int> cols;
    for (const auto& n : names) {
      const int c = t.column(n);
      if (c < 0) return {};
      cols.push_back(c);
    }
    return cols;
  }
  static std::vector<std::string> numbered(const std::string& suffix, int n) {
    std::vector<std::string> names;
    for (int i = 1; i <= n; ++i) names.push_back("q" + std::to_string(i) + suffix);
    return names;
  }

  StateReader(const RunTable& t, const DynamicModel& model, const std::string& what)
      : m(&model), t_col(t.column("t")), where(what + " '" + t.path + "'") {
    const auto& names = model.coordinate_names;
    const int nb = model.base_coordinates();
    q_cols = find(t, names);
    if (q_cols.empty()) {
      base_q = find(t, {names.begin(), names.begin() + nb});
      joint_q = find(t, numbered("", model.num_links));
      if ((nb > 0 && base_q.empty()) || joint_q.empty()) {
        std::string list;
        for (const auto& n : names) list += (list.empty() ? "" : ",") + n;
        throw std::invalid_argument(where + " has neither the scene's coordinates (" + list +
                                    ") nor its base's and the link-side joint angles q1..q" +
                                    std::to_string(model.num_links) + ": is it a run of scene '" +
                                    model.name + "'?");
      }
    }
    const auto vnames = model.velocity_names();
    qd_cols = find(t, vnames);
    if (qd_cols.empty()) {
      base_qd = find(t, {vnames.begin(), vnames.begin() + model.num_base()});
      joint_qd = find(t, numbered("d", model.num_links));
    }
    has_velocity =
        !qd_cols.empty() || ((model.num_base() == 0 || !base_qd.empty()) && !joint_qd.empty());
  }

  static Eigen::VectorXd pick(const std::vector<double>& row, const std::vector<int>& cols) {
    Eigen::VectorXd v(cols.size());
    for (size_t i = 0; i < cols.size(); ++i) v[i] = row[cols[i]];
    return v;
  }
  // A base quaternion is normalized; one far from unit length is not a rotation: an error.
  Eigen::VectorXd q(const std::vector<double>& row) const {
    Eigen::VectorXd q = q_cols.empty() ? m->from_joint_angles(pick(row, base_q), pick(row, joint_q))
                                       : pick(row, q_cols);
    if (m->quaternion_offset >= 0) {
      auto r = q.segment<4>(m->quaternion_offset);
      if (!(r.norm() > 0.5 && r.norm() < 2))
        throw std::invalid_argument(where + " at t = " + std::to_string(row.at(t_col)) +
                                    ": the base quaternion's norm is " + std::to_string(r.norm()) +
                                    ", not 1");
      r.normalize();
    }
    return q;
  }
  Eigen::VectorXd qd(const std::vector<double>& row) const {
    if (!qd_cols.empty()) return pick(row, qd_cols);
    return m->from_joint_rates(pick(row, base_qd), pick(row, joint_qd));
  }
};

// Whether joint j has a rotor to draw: a rigid gear's slot holds its motor angle, a flexible
// joint's motor has a coordinate of its own; either way its torque drives that coordinate.
bool has_rotor(const DynamicModel& m, int j) {
  return m.motor_angle_slots[j] || m.actuated_coordinates[j] != m.joint_v_offsets[j];
}

// The base pose [x, y, z, qw, qx, qy, qz] in q from StateReader::q (its quaternion normalized;
// a fixed base: the origin, unturned).
std::vector<double> base_pose(const DynamicModel& m, const Eigen::VectorXd& q) {
  if (m.num_base() == 0) return {0, 0, 0, 1, 0, 0, 0};
  if (m.spatial) {
    const auto r = q.segment<4>(m.quaternion_offset);
    return {q[0], q[1], q[2], r[0], r[1], r[2], r[3]};
  }
  return {q[0], q[1], 0, std::cos(q[2] / 2), 0, 0, std::sin(q[2] / 2)};
}

// Where the file has the end effector's position (ee_x, ee_y, ee_z in 3D: simulate's and a
// sweep's series), the drawn tip must be there: else the scene or its parameters are not the
// run's, and the drawing would be silently wrong.
void check_tip(const RunTable& table, const std::vector<double>& row, const Eigen::Vector3d& tip,
               bool spatial) {
  const int dims = spatial ? 3 : 2;
  double gap = 0;
  for (int k = 0; k < dims; ++k) {
    const int c = table.column(std::string("ee_") + "xyz"[k]);
    if (c < 0) return;
    gap = std::max(gap, std::abs(row[c] - tip[k]));
  }
  if (gap > 1e-6 * (1 + tip.norm()))
    throw std::invalid_argument(
        "'" + table.path + "' at t = " + std::to_string(row.at(table.column("t"))) +
        ": the scene puts the end effector " + std::to_string(gap) +
        " m from the file's ee_ columns: the run is not of this scene at these parameters (give "
        "--scene and --param as the run had them)");
}

// One run's frames: t, joint and tip positions, base pose, joint axes (3D), rotor angles.
struct Frames {
  json run;
  std::vector<Eigen::Vector3d> tips;
  std::vector<double> t;
  std::vector<Eigen::VectorXd> q;  // per kept row, as StateReader::q gave it
};

Frames frames_of(const LoadedScene& s, const RunTable& table, const StateReader& reader,
                 const std::string& label) {
  const DynamicModel& m = s.dyn;
  const int n = m.num_links, t_col = table.column("t");
  const bool axes = m.spatial && s.model->has(Output::end_effector_jacobian);
  bool rotors = false;
  for (int i = 0; i < n; ++i) rotors |= has_rotor(m, i);
  Frames f;
  json points = json::array(), base = json::array(), axis_rows = json::array(),
       rotor_rows = json::array(), body_rows = json::array();
  // The links' frames where a URDF gives a link visuals (the base's pose is `base`).
  const auto visuals = s.recipe->body_visuals();
  const bool bodies = std::any_of(visuals.begin() + (visuals.empty() ? 0 : 1), visuals.end(),
                                  [](const auto& v) { return !v.empty(); });
  const std::vector<double> params(s.params.data(), s.params.data() + s.params.size());
  for (const auto& row : table.rows) {
    const Eigen::VectorXd& q = f.q.emplace_back(reader.q(row));
    const Eigen::MatrixXd P = s.model->evaluate(Output::joint_positions, {q}, s.params).at(0);
    if (!P.allFinite())  // a zero quaternion, say: nothing to draw
      throw std::invalid_argument("'" + table.path + "' at t = " + std::to_string(row[t_col]) +
                                  ": the joint positions are not finite (are the coordinates a "
                                  "state of this scene?)");
    json p = json::array();
    for (int c = 0; c < P.cols(); ++c)
      for (int r = 0; r < 3; ++r) p.push_back(shown(r < P.rows() ? P(r, c) : 0.0));
    f.tips.push_back({P(0, n), P(1, n), P.rows() > 2 ? P(2, n) : 0.0});
    check_tip(table, row, f.tips.back(), m.spatial);
    f.t.push_back(row[t_col]);
    points.push_back(std::move(p));
    std::vector<double> pose = base_pose(m, q);
    for (double& v : pose) v = shown(v);
    base.push_back(pose);
    const Eigen::VectorXd link = m.joint_angles(q);
    if (axes) {
      const Eigen::MatrixXd J = s.model->end_effector_jacobian(q, s.params);
      json a = json::array();
      for (int i = 0; i < n; ++i) {
        const Eigen::Vector3d w = J.block<3, 1>(3, m.num_base() + i);
        const Eigen::Vector3d u =
            w.norm() > 0 ? Eigen::Vector3d(w.normalized()) : Eigen::Vector3d::UnitZ();
        a.insert(a.end(), {shown(u[0]), shown(u[1]), shown(u[2])});
      }
      axis_rows.push_back(std::move(a));
    }
    if (bodies) {
      json row = json::array();
      for (const auto& pose : s.recipe->body_poses({q.data(), q.data() + q.size()}, params))
        for (double v : pose) row.push_back(shown(v));
      body_rows.push_back(std::move(row));
    }
    if (rotors) {  // the motor's angle relative to its link: qm - q
      json r = json::array();
      for (int i = 0; i < n; ++i)
        r.push_back(shown(q[m.q_index(m.actuated_coordinates[i])] - link[i]));
      rotor_rows.push_back(std::move(r));
    }
  }
  f.run = {{"label", label},
           {"file", table.path},
           {"t", f.t},
           {"points", points},
           {"base", base},
           {"axes", axes ? axis_rows : json(nullptr)},
           {"rotor", rotors ? rotor_rows : json(nullptr)},
           {"bodies", bodies ? body_rows : json(nullptr)}};
  return f;
}

// Drawing sizes from the scene: the base as the box of its inertia (a uniform box with the same
// principal moments; the plane's square from m a^2 / 6 = I) and a URDF base's own <visual>
// shapes, joints and rods scaled to the reach.
json geometry(const LoadedScene& s, const Frames& f) {
  const DynamicModel& m = s.dyn;
  // A tree's rods (or a chain's with several end effectors): each link to its children's joints
  // and its end effectors, as pairs of points (joints 0..n-1, then the end effectors); struts
  // from the base to the joints that leave it. A chain's: each joint to the next.
  const ModelFacts& facts = s.recipe->facts();
  const int n = m.num_links;
  std::vector<std::array<int, 2>> segments;
  std::vector<int> struts;
  for (int j = 1; j <= n; ++j) {
    const int parent = facts.joint_parents.empty() ? j - 1 : facts.joint_parents[j - 1];
    if (parent == 0)
      struts.push_back(j - 1);
    else
      segments.push_back({parent - 1, j - 1});
  }
  if (facts.end_effector_bodies.empty()) segments.push_back({n - 1, n});
  for (size_t e = 0; e < facts.end_effector_bodies.size(); ++e)
    if (const int b = facts.end_effector_bodies[e]; b > 0)
      segments.push_back({b - 1, n + static_cast<int>(e)});
  double reach = 0;
  const auto& p0 = f.run["points"][0];
  for (const auto& [from, to] : segments) {
    Eigen::Vector3d a, b;
    for (int r = 0; r < 3; ++r) a[r] = p0[3 * from + r], b[r] = p0[3 * to + r];
    reach += (b - a).norm();
  }
  reach = std::max(reach, 1e-3);
  std::array<double, 3> box{0.15 * reach, 0.15 * reach, 0.05 * reach}, center{0, 0, 0};
  const ModelRecipe::BaseInertial b = s.recipe->base_inertial();
  if (m.num_base() > 0 && !m.spatial) {  // the plane's square plate: m a^2 / 6 = izz
    const double a =
        b.mass > 0 && b.inertia[5] > 0 ? std::sqrt(6 * b.inertia[5] / b.mass) : 0.15 * reach;
    box = {a, a, 0.3 * a};
  } else if (m.num_base() > 0) {  // inertia: ixx, ixy, ixz, iyy, iyz, izz
    const double I[3] = {b.inertia[0], b.inertia[3], b.inertia[5]};
    for (int k = 0; k < 3; ++k) {
      const double s2 = 6 * (I[(k + 1) % 3] + I[(k + 2) % 3] - I[k]) / std::max(b.mass, 1e-12);
      box[k] = std::sqrt(std::max(s2, 1e-4 * reach * reach));
    }
    center = b.com;
  }
  const double radius = 0.025 * reach;
  std::vector<bool> rotors;
  for (int i = 0; i < m.num_links; ++i) rotors.push_back(has_rotor(m, i));
  json out = {{"base_box", box},
              {"base_center", center},
              {"link_radius", std::vector<double>(m.num_links, radius)},
              {"joint_radius", 1.6 * radius},
              {"rotor_radius", 2.2 * radius},
              {"rotors", rotors},
              {"free_base", m.num_base() > 0}};
  if (!facts.joint_parents.empty()) {  // a chain's page stays as it was
    out["num_joints"] = n;
    out["segments"] = segments;
    out["struts"] = struts;
  }
  return out;
}

json plot(const std::string& title, const std::string& unit, const std::vector<std::string>& labels,
          std::vector<std::vector<double>> series) {
  for (auto& line : series)
    for (double& v : line) v = shown(v);
  return {{"title", title}, {"unit", unit}, {"labels", labels}, {"series", series}};
}

// The tip of run `other` at time t, interpolated between its kept rows; false outside them.
bool tip_at(const Frames& other, double t, Eigen::Vector3d& tip) {
  const auto& ts = other.t;
  if (ts.empty() || t < ts.front() || t > ts.back()) return false;
  const size_t k = std::upper_bound(ts.begin(), ts.end(), t) - ts.begin();
  if (k >= ts.size()) {
    tip = other.tips.back();
    return true;
  }
  const double w = (t - ts[k - 1]) / (ts[k] - ts[k - 1]);
  tip = other.tips[k - 1] + w * (other.tips[k] - other.tips[k - 1]);
  return true;
}

// Joint angles, link-side torques, energy, momentum drift and the end effector's distance from
// the compared run, at the main run's kept rows; notes say what is missing and why.
json plots(const LoadedScene& s, const RunTable& table, const StateReader& reader,
           const Frames& main, const Frames* compare, std::vector<std::string>& notes) {
  const DynamicModel& m = s.dyn;
  const int n = m.num_links;
  json out = json::array();
  std::vector<std::string> q_labels, tau_labels;
  std::vector<std::vector<double>> angles(n), torques;
  for (int i = 0; i < n; ++i) q_labels.push_back("q" + std::to_string(i + 1));
  for (const Eigen::VectorXd& q : main.q) {
    const Eigen::VectorXd a = m.joint_angles(q);
    for (int i = 0; i < n; ++i) angles[i].push_back(a[i]);
  }
  out.push_back(plot("joint angles (link side)", "rad", q_labels, angles));
  std::vector<int> tau_cols;
  for (int i = 1; i <= n; ++i) tau_cols.push_back(table.column("tau" + std::to_string(i)));
  if (std::find(tau_cols.begin(), tau_cols.end(), -1) == tau_cols.end()) {
    for (int i = 0; i < n; ++i) {
      tau_labels.push_back("tau" + std::to_string(i + 1));
      torques.push_back(table.values(tau_cols[i]));
    }
    out.push_back(plot("joint torques (link side)", "N m", tau_labels, torques));
  } else {
    notes.push_back("no torque plot: the file has no columns tau1..tau" + std::to_string(n));
  }
  const bool energy = reader.has_velocity && m.kinetic_energy;
  const bool momentum = reader.has_velocity && m.momentum && m.num_base() > 0;
  std::vector<std::vector<double>> T(m.potential_energy ? 3 : 1), h;
  Eigen::VectorXd h0;
  for (size_t k = 0; k < table.rows.size() && (energy || momentum); ++k) {
    const Eigen::VectorXd& q = main.q[k];
    const Eigen::VectorXd qd = reader.qd(table.rows[k]);
    if (energy) {
      T[0].push_back(m.kinetic_energy(q, qd));
      if (m.potential_energy) {
        T[1].push_back(m.potential_energy(q));
        T[2].push_back(T[0].back() + T[1].back());
      }
    }
    if (momentum) {
      const Eigen::VectorXd hk = m.momentum(q, qd);
      if (h0.size() == 0) h0 = hk, h.resize(hk.size());
      for (int c = 0; c < hk.size(); ++c) h[c].push_back(hk[c] - h0[c]);
    }
  }
  if (energy)
    out.push_back(plot("energy", "J",
                       m.potential_energy ? std::vector<std::string>{"T", "V", "T + V"}
                                          : std::vector<std::string>{"T"},
                       T));
  else
    notes.push_back(reader.has_velocity
                        ? "no energy plot: the scene does not emit kinetic_energy"
                        : "no energy or momentum plots: the file has no velocities");
  if (momentum)
    out.push_back(plot("momentum drift h(t) - h(0)", "N s, N m s",
                       m.spatial ? std::vector<std::string>{"Px", "Py", "Pz", "Lx", "Ly", "Lz"}
                                 : std::vector<std::string>{"Px", "Py", "L"},
                       h));
  else if (reader.has_velocity && m.num_base() > 0)
    notes.push_back("no momentum plot: the scene does not emit momentum");
  if (compare) {
    std::vector<json> error;
    for (size_t k = 0; k < main.t.size(); ++k) {
      Eigen::Vector3d tip;
      error.push_back(tip_at(*compare, main.t[k], tip) ? json(shown((main.tips[k] - tip).norm()))
                                                       : json(nullptr));
    }
    out.push_back({{"title", "end-effector distance from the compared run"},
                   {"unit", "m"},
                   {"labels", {"|x - x_compare|"}},
                   {"series", {error}}});
  }
  return out;
}

std::string number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

std::string thinning_note(const RunTable& t) {
  return "'" + t.path + "': " + std::to_string(t.total_rows) + " rows, " +
         (t.thinned() ? "thinned for drawing to " + std::to_string(t.rows.size()) + " (every " +
                            std::to_string(t.stride) + "th and the last)"
                      : "all drawn") +
         "; between rows the drawing is interpolated linearly";
}

// The run's provenance (provenance.hpp) fills in --scene and --param where they are not given;
// what it says goes into the page's info, a stale one into its notes.
ViewArgs with_provenance(const ViewArgs& given, json& info, std::vector<std::string>& notes) {
  ViewArgs a = given;
  bool stale = false;
  const auto made = read_provenance(a.file, &stale);
  if (stale)
    notes.push_back("'" + provenance_path(a.file) +
                    "' is stale (the run's file changed since): not used");
  if (made) {
    info.push_back({"run made by", made->command});
    info.push_back({"in the folder", made->folder});
    // The record is untrusted: its scene must be an absolute path to a regular file (a FIFO
    // would block the reader).
    struct stat st;
    if (a.scene_path.empty() && (made->scene.empty() || made->scene[0] != '/' ||
                                 ::stat(made->scene.c_str(), &st) != 0 || !S_ISREG(st.st_mode)))
      throw std::invalid_argument("'" + provenance_path(a.file) + "' names the scene " +
                                  quoted_text(made->scene) +
                                  ", not a regular file by its absolute path: give --scene");
    if (a.scene_path.empty()) a.scene_path = made->scene;
    std::error_code ec;
    if (a.param_assignments.empty() && std::filesystem::equivalent(a.scene_path, made->scene, ec))
      for (const auto& [name, value] : made->parameters) {
        char text[40];
        std::snprintf(text, sizeof text, "%.17g", value);
        a.param_assignments.push_back(name + "=" + text);
      }
  }
  if (!a.compare_file.empty())
    if (const auto other = read_provenance(a.compare_file))
      info.push_back({"compared run made by", other->command});
  if (a.scene_path.empty())
    throw std::invalid_argument("view: give --scene SCENE, the scene '" + a.file +
                                "' is a run of (it draws the arm from the scene; the run has no "
                                "provenance file that names it)");
  return a;
}

}  // namespace

// An STL file's triangles (binary: an 80-byte header, a count n, 50 bytes per triangle, 84 + 50 n
// in all; ASCII: "solid", then "vertex x y z" three per facet) as binary STL, which the page's
// STLLoader reads without its ASCII parser (a regular expression whose time grows with the
// square of a hostile file's size). Every coordinate must be finite and within 1e6 m, or the
// page's framing would be NaN or far away. Hand-written: Debian's Assimp reads STL, but as a
// dependency of the tool for nine floats per triangle it would outweigh these lines. Throws
// naming `path`.
std::string stl_as_binary(const std::string& bytes, const std::string& path) {
  auto refuse = [&path](const std::string& why) {
    throw std::invalid_argument("view: mesh '" + path + "' " + why);
  };
  std::vector<float> vertices;  // 9 per triangle
  uint32_t count = 0;
  if (bytes.size() >= 84)
    for (int k = 3; k >= 0; --k) count = (count << 8) | static_cast<unsigned char>(bytes[80 + k]);
  if (bytes.size() >= 84 && bytes.size() == 84 + 50 * static_cast<uint64_t>(count)) {
    for (uint32_t t = 0; t < count; ++t)
      for (int k = 0; k < 9; ++k) {
        float x;
        std::memcpy(&x, bytes.data() + 84 + 50 * static_cast<size_t>(t) + 12 + 4 * k, 4);
        vertices.push_back(x);
      }
  } else {
    if (bytes.compare(0, 5, "solid") != 0) refuse("is not an STL file");
    for (char c : bytes)
      if (!((c >= 0x20 && c < 0x7f) || c == '\n' || c == '\r' || c == '\t'))
        refuse("is not an STL file (a byte that is not text in an ASCII STL)");
    std::istringstream in(bytes);
    std::string word;
    while (in >> word) {
      if (word != "vertex") continue;
      for (int k = 0; k < 3; ++k) {
        std::string number;
        in >> number;
        char* end = nullptr;
        const double x = std::strtod(number.c_str(), &end);
        if (number.empty() || *end != '\0') refuse("has a vertex coordinate that is not a number");
        vertices.push_back(static_cast<float>(x));
      }
    }
    if (vertices.empty() || vertices.size() % 9 != 0)
      refuse("is not an STL file (no facets of three vertices)");
  }
  for (float x : vertices)
    if (!(std::abs(x) <= 1e6f)) refuse("has a vertex coordinate that is not finite or beyond 1e6");
  const uint32_t n = static_cast<uint32_t>(vertices.size() / 9);
  std::string out(84 + 50 * static_cast<size_t>(n), '\0');
  for (int k = 0; k < 4; ++k) out[80 + k] = static_cast<char>((n >> (8 * k)) & 0xff);
  for (uint32_t t = 0; t < n; ++t)  // normals left 0: the page computes them
    std::memcpy(out.data() + 84 + 50 * static_cast<size_t>(t) + 12, vertices.data() + 9 * t, 36);
  return out;
}

// A mesh file opened once and checked on its descriptor: a regular file whose resolved path
// (the kernel's, /proc/self/fd) lies inside `folder` (resolved), so no link and no change between
// a check and the read lets another file in.
std::string read_mesh(const std::string& folder, const std::string& path) {
  namespace fs = std::filesystem;
  const Fd fd = open_regular_file(path, "view: mesh", size_t(32) << 20);
  std::error_code ec;
  const std::string inside = fs::canonical(folder, ec).string() + "/";
  const std::string file = fs::read_symlink("/proc/self/fd/" + std::to_string(fd.get()), ec);
  if (ec || file.compare(0, inside.size(), inside) != 0)
    throw std::invalid_argument("view: mesh '" + path +
                                "' is not a file inside the URDF's folder '" + folder + "'");
  return read_all(fd.get(), path, size_t(32) << 20);
}

// A URDF's <visual> shapes per body, and its STL meshes embedded (base64) once each. A mesh must
// lie inside the URDF's folder once links are resolved, be at most 32 MB (96 MB in all) and be
// an STL file: an untrusted scene cannot carry another file into the page.
json body_visuals(const ModelRecipe& recipe, json& meshes,
                  std::vector<std::pair<std::string, std::string>>& inputs) {
  std::map<std::string, int> index;
  size_t total = 0;
  json bodies = json::array();
  for (const auto& shapes : recipe.body_visuals()) {
    json list = json::array();
    for (const spatial::Visual& v : shapes) {
      json shape = {
          {"kind", v.kind}, {"size", v.size}, {"position", v.xyz}, {"quaternion", v.quaternion}};
      if (v.kind == "mesh") {
        if (!index.count(v.mesh)) {
          const std::string path = recipe.mesh_folder() + v.mesh;
          const std::string bytes = stl_as_binary(read_mesh(recipe.mesh_folder(), path), path);
          if ((total += bytes.size()) > (size_t(96) << 20))
            throw std::invalid_argument("view: the URDF's meshes are larger than 96 MB in all");
          index[v.mesh] = static_cast<int>(meshes.size());
          meshes.push_back({{"path", v.mesh}, {"stl", base64(bytes)}});
          inputs.push_back({"mesh", path});
        }
        shape["mesh"] = index[v.mesh];
      }
      list.push_back(shape);
    }
    bodies.push_back(list);
  }
  return bodies;
}

// --camera: {fit: all | arm, eye, target} (eye and target null, or 3 numbers each).
json camera(const std::string& text, bool spatial) {
  if (text == "all" || text == "arm") return {{"fit", text}, {"eye", nullptr}, {"target", nullptr}};
  auto refuse = [&text](const std::string& why) {
    throw std::invalid_argument("view: --camera: " + why + ", got '" + text + "'");
  };
  std::vector<double> v;
  try {
    v = parse_number_list(text, "--camera");
  } catch (const std::exception&) {
    refuse("expected all, arm or x,y,z[,tx,ty,tz]");
  }
  if (v.size() != 3 && v.size() != 6) refuse("expected all, arm or x,y,z[,tx,ty,tz]");
  for (double x : v)
    if (!(std::abs(x) <= 1e6)) refuse("expected coordinates within 1e6 m");
  if (!spatial) refuse("a point to look from is for a spatial run (the plane is seen from above)");
  json target = nullptr;
  if (v.size() == 6) target = {v[3], v[4], v[5]};
  if (v.size() == 6 && v[0] == v[3] && v[1] == v[4] && v[2] == v[5])
    refuse("the point to look from is the point to look at");
  return {{"fit", "arm"}, {"eye", {v[0], v[1], v[2]}}, {"target", target}};
}

json run_view_data(const ViewArgs& given,
                   std::vector<std::pair<std::string, std::string>>& inputs) {
  json info = json::array();
  std::vector<std::string> notes;
  const ViewArgs a = with_provenance(given, info, notes);
  const LoadedScene s = load_scene(a);
  for (const auto& input : scene_inputs(a.scene_path, *s.recipe)) inputs.push_back(input);
  inputs.push_back({"the run", a.file});
  inputs.push_back({"the run's provenance", provenance_path(a.file)});
  const RunTable table = read_run_table(a.file, "view", a.max_frames);
  const StateReader reader(table, s.dyn, "view");
  notes.insert(notes.begin(), thinning_note(table));
  const Frames main = frames_of(s, table, reader, "run");
  json runs = json::array({main.run});
  std::unique_ptr<Frames> compare;
  if (!a.compare_file.empty()) {
    inputs.push_back({"the compared run", a.compare_file});
    inputs.push_back({"the compared run's provenance", provenance_path(a.compare_file)});
    const RunTable other = read_run_table(a.compare_file, "--compare", a.max_frames);
    compare = std::make_unique<Frames>(
        frames_of(s, other, StateReader(other, s.dyn, "--compare"), "compared"));
    runs.push_back(compare->run);
    notes.push_back(thinning_note(other) + " (the ghost)");
  }
  std::vector<std::string> plot_notes;
  json data = {{"kind", "run"},
               {"title", s.recipe->name()},
               {"space", s.dyn.spatial ? "spatial" : "planar"},
               {"geometry", geometry(s, main)},
               {"runs", runs}};
  data["camera"] = camera(a.camera, s.dyn.spatial);
  json meshes = json::array();
  data["geometry"]["body_visuals"] = body_visuals(*s.recipe, meshes, inputs);
  data["meshes"] = meshes;
  data["plots"] = plots(s, table, reader, main, compare.get(), plot_notes);
  data["plot_notes"] = plot_notes;
  info.push_back({"scene", s.recipe->name() + " ('" + a.scene_path + "')"});
  if (!s.recipe->facts().description.empty())
    info.push_back({"description", s.recipe->facts().description});
  const auto& names = s.recipe->facts().parameter_names;
  for (size_t i = 0; i < names.size(); ++i)
    info.push_back({"parameter " + names[i], number(s.params[static_cast<Eigen::Index>(i)])});
  data["info"] = info;
  data["notes"] = notes;
  return data;
}

}  // namespace spacearm::cli
