#include "model_recipe.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <mutex>
#include <sstream>
#include <stdexcept>

#include "body_printer.hpp"
#include "cpp_emitter.hpp"
#include "lowering.hpp"
#include "numeric_outputs.hpp"
#include "planar_model.hpp"
#include "program_expression.hpp"
#include "spatial_chain.hpp"
#include "spatial_model.hpp"

namespace spacearm {

// A planar scene's derivations, each made once (GiNaC's, slow beyond a few links): of the scene's
// outputs (eval --symbolic) and of every output (inspect).
struct ClosedFormCache {
  std::shared_ptr<const SymbolicModel> of_outputs, of_all;
};

namespace {

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

// GiNaC is not thread-safe (its reference counts and shared constants are plain integers): every
// use of its expressions here, not only the derivation, holds this lock, whichever recipe it is.
std::mutex& ginac_mutex() {
  static std::mutex m;
  return m;
}

// The scene's derivation, made on the first call and kept (the caller holds ginac_mutex()).
const SymbolicModel& derivation(const Scene& scene, ClosedFormCache& cache, bool all_outputs,
                                double* derive_ms) {
  std::shared_ptr<const SymbolicModel>& kept = all_outputs ? cache.of_all : cache.of_outputs;
  const auto t0 = std::chrono::steady_clock::now();
  if (!kept) {
    DeriveOptions options;
    options.all_outputs = all_outputs;
    kept = std::make_shared<const SymbolicModel>(derive(scene, options));
  }
  if (derive_ms) *derive_ms = ms_since(t0);
  return *kept;
}

}  // namespace

ModelRecipe::ModelRecipe(Scene scene)
    : planar_(std::make_shared<const Scene>(std::move(scene))),
      facts_(planar_facts(*planar_)),
      closed_forms_(std::make_shared<ClosedFormCache>()) {}

ModelRecipe::ModelRecipe(SpatialScene scene)
    : spatial_(std::make_shared<const SpatialScene>(std::move(scene))),
      facts_(spatial_facts(*spatial_)) {}

ModelRecipe ModelRecipe::parse(const std::string& text, const std::string& source_path) {
  if (is_spatial_scene(text)) return ModelRecipe(parse_spatial_scene(text, source_path));
  return ModelRecipe(parse_scene(text, source_path));
}

const std::string& ModelRecipe::content() const {
  return planar_ ? planar_->content : spatial_->content;
}

const std::string& ModelRecipe::source_path() const {
  return planar_ ? planar_->source_path : spatial_->source_path;
}

ModelRecipe ModelRecipe::with_outputs(const std::vector<Output>& extra,
                                      const std::string& note) const {
  if (planar_) {
    Scene scene = *planar_;
    scene.outputs.insert(extra.begin(), extra.end());
    scene.content += note;
    return ModelRecipe(std::move(scene));
  }
  SpatialScene scene = *spatial_;
  scene.outputs = facts_.outputs;  // the defaults, where the scene lists none
  for (Output o : extra)
    if (std::find(scene.outputs.begin(), scene.outputs.end(), o) == scene.outputs.end())
      scene.outputs.push_back(o);
  scene.content += note;
  return ModelRecipe(std::move(scene));
}

std::vector<Quantity> ModelRecipe::gear_ratios() const {
  std::vector<Quantity> ratios;
  if (planar_)
    for (int j = 0; j < planar_->num_links(); ++j)
      ratios.push_back(planar_->has_gear(j) ? planar_->gears[j]->ratio : Quantity(1.0));
  else
    for (const spatial::Link& l : spatial_->chain.links)
      ratios.push_back(l.gear.present ? l.gear.ratio : Quantity(1.0));
  return ratios;
}

ModelRecipe::BaseInertial ModelRecipe::base_inertial() const {
  BaseInertial b;
  if (planar_) {
    b.mass = planar_->base.mass.value;
    b.inertia[5] = planar_->base.inertia.value;
  } else {
    const spatial::Link& base = spatial_->chain.base;
    b.mass = base.mass.value;
    b.com = base.com_values();
    b.inertia = base.inertia_values();
  }
  return b;
}

std::array<double, 3> ModelRecipe::base_com(const std::vector<double>& params) const {
  std::array<double, 3> c{};
  if (!spatial_) return c;
  for (int k = 0; k < 3; ++k) {
    const Quantity& q = spatial_->chain.base.com[k];
    c[k] = q.is_parameter() ? params.at(static_cast<size_t>(q.index)) : q.value;
  }
  return c;
}

std::string ModelRecipe::mesh_folder() const {
  if (!spatial_ || spatial_->read_files.empty()) return "";
  const std::string& urdf = spatial_->read_files.front();
  const size_t slash = urdf.rfind('/');
  return slash == std::string::npos ? "./" : urdf.substr(0, slash + 1);
}

std::vector<std::array<double, 7>> ModelRecipe::body_poses(
    const std::vector<double>& q, const std::vector<double>& params) const {
  if (!spatial_) throw std::invalid_argument("body_poses: a spatial scene's");
  const spatial::ChainDescription& d = spatial_->chain;
  if (static_cast<int>(q.size()) != d.nq() || params.size() != facts_.parameter_names.size())
    throw std::invalid_argument("body_poses: expected " + std::to_string(d.nq()) +
                                " coordinates and " +
                                std::to_string(facts_.parameter_names.size()) + " parameters");
  auto input = [&](const std::string& array, int i) {
    return array == "q" ? q.at(i) : array == "params" ? params.at(i) : 0.0;
  };
  const spatial::Chain<double> chain(d, Values<double>{input, [](double x) { return x; }});
  const std::vector<double> frames = chain.body_frames();
  std::vector<std::array<double, 7>> poses;
  for (size_t at = 0; at + 12 <= frames.size(); at += 12) {
    Eigen::Matrix3d R;
    for (int k = 0; k < 9; ++k) R(k / 3, k % 3) = frames[at + 3 + k];
    const Eigen::Quaterniond r(R);
    poses.push_back({frames[at], frames[at + 1], frames[at + 2], r.w(), r.x(), r.y(), r.z()});
  }
  return poses;
}

std::string ModelRecipe::parameter_error(const std::vector<double>& params) const {
  const std::vector<std::string>& names = facts_.parameter_names;
  if (params.size() != names.size())
    throw std::invalid_argument("parameter_error: " + std::to_string(params.size()) +
                                " values for " + std::to_string(names.size()) + " parameters");
  for (size_t i = 0; i < params.size(); ++i)
    if (!std::isfinite(params[i])) return "parameter '" + names[i] + "' is not finite";
  if (const std::string e = parameter_range_error(names, params); !e.empty())
    return "parameter " + e;
  auto input = [&params](const std::string&, int i) { return params.at(i); };
  for (const ParameterCheck& c : facts_.checks) {
    const double v = facts_.checks_program.evaluate({c.value}, input)[0];
    if (!(c.strict ? v > 0 : v >= 0)) {  // the rule, and the values that moved
      const std::string moved = moved_parameters(names, facts_.nominal_parameters, params);
      return c.message + (moved.empty() ? "" : " (given " + moved + ")");
    }
  }
  return "";
}

std::vector<std::string> ModelRecipe::joint_names() const {
  if (spatial_ && !spatial_->joint_names.empty()) return spatial_->joint_names;
  std::vector<std::string> names;
  for (int j = 0; j < facts_.dims.num_links; ++j) names.push_back("joint" + std::to_string(j + 1));
  return names;
}

std::vector<spatial::JointLimits> ModelRecipe::joint_limits() const {
  if (spatial_ && !spatial_->joint_limits.empty()) return spatial_->joint_limits;
  return std::vector<spatial::JointLimits>(facts_.dims.num_links);
}

std::vector<std::string> ModelRecipe::warnings() const {
  return spatial_ ? spatial_->warnings : std::vector<std::string>{};
}

std::vector<std::string> ModelRecipe::read_files() const {
  return spatial_ ? spatial_->read_files : std::vector<std::string>{};
}

std::vector<Eigen::MatrixXd> ModelRecipe::evaluate_symbolic(
    Output o, const std::vector<Eigen::VectorXd>& inputs, const Eigen::VectorXd& params,
    double* derive_ms) const {
  if (!planar_)
    throw std::invalid_argument("model '" + facts_.name +
                                "' is a spatial arm, which has no symbolic derivation");
  const std::lock_guard lock(ginac_mutex());
  return evaluate_output(derivation(*planar_, *closed_forms_, false, derive_ms), o, inputs, params);
}

EmittedModel ModelRecipe::emit(const EmitOptions& options, double* derive_ms) const {
  const auto t0 = std::chrono::steady_clock::now();
  auto derived = [&] {
    if (derive_ms) *derive_ms = ms_since(t0);
  };
  // A planar scene through its Lagrangian derivation, a spatial one through the spatial chain
  // (recorded when lowered): both then share lowering and the printer.
  if (planar_) {
    // GiNaC from the derivation to lowering's last evaluation (and the model's destruction).
    const std::lock_guard<std::mutex> lock(ginac_mutex());
    const SymbolicModel model = derive(*planar_);
    derived();
    return emit_cpp(model, options);
  }
  const DerivedModel model = spatial_derived_model(*spatial_);
  derived();
  return emit_cpp(model, options);
}

namespace {

// The inputs of a spatial entry's program as GiNaC symbols named as the model names them: q by
// its coordinates, qd by its velocities (vx0 .. wz0 for a free base, a coordinate's rate with d),
// params by name, qdd with dd, Q and qdd_joints by index.
class EntrySymbols {
 public:
  explicit EntrySymbols(const ModelFacts& f) : f_(f) {}
  GiNaC::ex operator()(const std::string& array, int i) {
    std::string name = array + std::to_string(i);
    const int base = f_.quaternion_offset >= 0 ? 6 : 0, shift = f_.quaternion_offset >= 0 ? 1 : 0;
    static const char* kBase[] = {"vx0", "vy0", "vz0", "wx0", "wy0", "wz0"};
    auto velocity = [&](const std::string& suffix) {
      return i < base ? kBase[i] + suffix.substr(1) : f_.coordinate_names.at(i + shift) + suffix;
    };
    if (array == "q") name = f_.coordinate_names.at(i);
    if (array == "qd") name = velocity("d");
    if (array == "qdd") name = velocity("dd");
    if (array == "params") name = f_.parameter_names.at(i);
    auto [at, added] = symbols_.try_emplace(name, GiNaC::symbol(name));
    if (added && array != "q") velocities_.append(at->second);  // collected by
    return at->second;
  }
  const GiNaC::lst& collected_by() const { return velocities_; }

 private:
  const ModelFacts& f_;
  std::map<std::string, GiNaC::symbol> symbols_;
  GiNaC::lst velocities_;
};

}  // namespace

std::string ModelRecipe::inspect_entry(const std::string& entry, bool latex, bool decimal) const {
  const std::lock_guard lock(ginac_mutex());
  if (spatial_) return spatial_entry(entry, latex, decimal);
  return entry_text(derivation(*planar_, *closed_forms_, true, nullptr), entry, latex, decimal) +
         "\n";
}

std::string ModelRecipe::spatial_entry(const std::string& entry, bool latex, bool decimal) const {
  const EntryText e = parse_entry(entry);
  const std::string shown =
      "entry '" + (entry.size() > 40 ? entry.substr(0, 40) + "..." : entry) + "'";
  // The output by its symbol, among those a spatial model of this base gives.
  const OutputInfo* output = nullptr;
  std::string known;
  for (const OutputInfo& o : output_registry()) {
    if (!spatial_output(o.id, spatial_->chain.free_base)) continue;
    known += (known.empty() ? "" : ", ") + std::string(o.symbol);
    if (e.name == o.symbol) output = &o;
  }
  if (!output)
    throw std::invalid_argument(shown + ": unknown quantity '" + e.name + "' for a spatial arm" +
                                " (known: " + known + ")");
  const ResultInfo& shape = output->results[0];
  const int cols = facts_.dims(shape.cols);
  const auto [row, col] = entry_position(e, *output, facts_.dims(shape.rows), cols, shown);
  const int index = row * cols + col;
  // The output alone, lowered (CSE'd) as generate would; the entry's statements printed.
  SpatialScene alone = *spatial_;
  alone.outputs = {output->id};
  const LoweredModel lowered = lower(spatial_derived_model(alone));
  for (const FunctionSpec& f : lowered.functions) {
    if (f.name != output->name) continue;
    std::string target = shape.name;
    for (int i : e.indices) target += "[" + std::to_string(i) + "]";
    const SRef root = f.entries[0].at(index);
    // The closed form where it stays small, collected by the velocities and parameters.
    EntrySymbols symbols(facts_);
    if (const std::optional<GiNaC::ex> x =
            expanded_expression(f.program, root, std::ref(symbols), kSpatialClosedFormTerms)) {
      const GiNaC::ex form =
          GiNaC::collect(decimal ? GiNaC::evalf(*x) : *x, symbols.collected_by(), true);
      std::ostringstream out;
      if (latex) out << GiNaC::latex;
      out << form << "\n";
      return out.str();
    }
    if (latex || decimal)
      throw std::invalid_argument(
          shown + ": LaTeX and decimals need a closed form, and this entry's expands past " +
          std::to_string(kSpatialClosedFormTerms) +
          " terms; without them inspect prints the statements that compute it");
    const BodyPrinter body(f.program, {{target, root, ""}}, false);
    std::string text = "// " + target + " of " + f.name + " (" + f.formulation + ") in model " +
                       facts_.name +
                       ": the statements it depends on (its closed form expands past " +
                       std::to_string(kSpatialClosedFormTerms) + " terms)\n";
    for (int k = 0; k < body.num_parts(); ++k) text += body.part(k);
    return text;
  }
  throw std::logic_error("inspect_entry: no function " + std::string(output->name));
}

}  // namespace spacearm
