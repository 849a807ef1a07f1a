// The Python binding (module spacearm._spacearm, imported by the package `spacearm`):
// load() compiles and loads a scene through the compile-and-load cache (jit/), and a Model has
// every output of the registry (outputs.hpp) as a method over numpy arrays. A 1-D input is one
// state; a 2-D input of shape (k, n) is k states, evaluated in C++ without the GIL.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "compiled_model.hpp"
#include "dynamics_checks.hpp"
#include "scene.hpp"
#include "symbolic_model.hpp"
#include "trajectory_planning.hpp"

namespace py = pybind11;

namespace spacearm {
namespace {

using Array = py::array_t<double, py::array::c_style | py::array::forcecast>;

// A loaded model and the parameter values its methods use unless given others.
class PyModel {
 public:
  PyModel(CompiledModel model, Eigen::VectorXd params, Scene scene)
      : model_(std::move(model)), params_(std::move(params)), scene_(std::move(scene)) {}

  const CompiledModel& model() const { return model_; }
  const Eigen::VectorXd& params() const { return params_; }

  // Output o at the inputs (arrays, in the registry's order), one state or a batch.
  py::object call(Output o, const py::args& args, const py::object& params) const;

  // The names of the outputs the scene emits, in the registry's order.
  std::vector<std::string> outputs() const {
    std::vector<std::string> names;
    for (const auto& o : output_registry())
      if (model_.has(o.id)) names.push_back(o.name);
    return names;
  }

  // The zero-momentum straight line (runtime/trajectory_planning.hpp) at the model's
  // parameters (or `params`): arrays and the table's named columns, as `spacearm plan` writes.
  py::dict plan(const Eigen::VectorXd& start, const Eigen::VectorXd& goal, double duration,
                double dt, const std::string& time_law, int elbow, const py::object& q0,
                const py::object& params) const;

  // One symbolic entry ("M[3][4]", "T", ...) as `spacearm inspect` prints it; the scene is
  // derived on the first call (without the GIL) and kept.
  std::string inspect(const std::string& entry, bool latex, bool decimal) {
    if (!symbolic_) {
      py::gil_scoped_release release;
      DeriveOptions options;
      options.all_outputs = true;
      symbolic_ = std::make_shared<const SymbolicModel>(derive(scene_, options));
    }
    return entry_text(*symbolic_, entry, latex, decimal);
  }

  std::string repr() const {
    std::string outputs;
    for (const auto& name : this->outputs()) outputs += (outputs.empty() ? "" : ", ") + name;
    return "<spacearm.Model '" + model_.name() + "': nq = " + std::to_string(model_.nq()) +
           ", nv = " + std::to_string(model_.nv()) + ", " + std::to_string(model_.num_links()) +
           " links; outputs " + outputs + ">";
  }

 private:
  CompiledModel model_;
  Eigen::VectorXd params_;
  Scene scene_;
  std::shared_ptr<const SymbolicModel> symbolic_;
};

// The values of named parameters: `values`, with those of `given` (None or a dict) replaced.
// An unknown name is a ValueError naming it and the known ones.
Eigen::VectorXd named_parameters(const CompiledModel& m, Eigen::VectorXd values,
                                 const py::object& given) {
  if (given.is_none()) return values;
  if (!py::isinstance<py::dict>(given))
    throw py::type_error("params: a dict of parameter names and values");
  const auto& names = m.parameter_names();
  for (const auto& [key, value] : given.cast<py::dict>()) {
    if (!py::isinstance<py::str>(key))
      throw py::type_error("params: parameter names are strings, not " +
                           std::string(py::str(py::type::of(key).attr("__name__"))));
    const std::string name = py::str(key);
    const auto it = std::find(names.begin(), names.end(), name);
    if (it == names.end()) {
      std::string known;
      for (const auto& n : names) known += (known.empty() ? "" : ", ") + n;
      throw py::value_error("params: model '" + m.name() + "' has no parameter '" + name +
                            "' (it has: " + (known.empty() ? "none" : known) + ")");
    }
    if (!py::isinstance<py::float_>(value) && !py::isinstance<py::int_>(value))
      throw py::type_error("params['" + name + "']: a number, not " +
                           std::string(py::str(py::type::of(value).attr("__name__"))));
    values[it - names.begin()] = value.cast<double>();
  }
  return values;
}

// An array for k states of result `spec`: per state a number (1 x 1), a vector (a column) or a
// matrix, rows x cols; with a batch, the state index first.
py::array_t<double> result_array(const ResultInfo& spec, const Dimensions& dims, py::ssize_t k,
                                 bool batch) {
  std::vector<py::ssize_t> shape;
  if (batch) shape.push_back(k);
  if (spec.rows != Size::one || spec.cols != Size::one) shape.push_back(dims(spec.rows));
  if (spec.cols != Size::one) shape.push_back(dims(spec.cols));
  return py::array_t<double>(shape);
}

py::object PyModel::call(Output o, const py::args& args, const py::object& params_given) const {
  const OutputInfo& out = info(o);
  if (args.size() != out.inputs.size()) {
    std::string names;
    for (Input i : out.inputs) names += (names.empty() ? "" : ", ") + std::string(info(i).name);
    throw py::type_error(std::string(out.name) + "() takes " + names + " (" +
                         std::to_string(out.inputs.size()) + " arrays), got " +
                         std::to_string(args.size()));
  }
  // Inputs: all one state (1-D) or all batches (2-D) of one length k.
  std::vector<Array> arrays;
  for (size_t i = 0; i < args.size(); ++i) {
    const py::array raw = py::array::ensure(args[i]);
    const char kind = raw ? raw.dtype().kind() : 'O';
    if (kind != 'i' && kind != 'u' && kind != 'f')
      throw py::type_error(std::string(info(out.inputs[i]).name) + ": not an array of numbers");
    arrays.push_back(Array::ensure(raw));
  }
  const bool batch = !arrays.empty() && arrays[0].ndim() == 2;
  const py::ssize_t k = batch ? arrays[0].shape(0) : 1;
  for (size_t i = 0; i < arrays.size(); ++i) {
    const std::string name = info(out.inputs[i]).name, first = info(out.inputs[0]).name;
    if (arrays[i].ndim() != 1 && arrays[i].ndim() != 2)
      throw py::value_error(name + ": shape (n,) for one state or (k, n) for k states, not " +
                            std::to_string(arrays[i].ndim()) + " dimensions");
    if (arrays[i].ndim() != arrays[0].ndim())
      throw py::value_error(name + (batch ? ": one state where " + first + " has k states"
                                          : ": k states where " + first + " is one state"));
    if (batch && arrays[i].shape(0) != k)
      throw py::value_error(name + ": " + std::to_string(arrays[i].shape(0)) + " states where " +
                            first + " has " + std::to_string(k));
    const int n = model_.dimensions()(info(out.inputs[i]).size);
    if (arrays[i].shape(arrays[i].ndim() - 1) != n)
      throw py::value_error(name + ": expected " + std::to_string(n) + " values, got " +
                            std::to_string(arrays[i].shape(arrays[i].ndim() - 1)));
  }
  const Eigen::VectorXd params = named_parameters(model_, params_, params_given);
  // The results written in place by one batched evaluation, without the GIL.
  const Dimensions& dims = model_.dimensions();
  std::vector<py::array_t<double>> results;
  std::vector<const double*> in_ptrs;
  std::vector<double*> out_ptrs;
  for (const Array& a : arrays) in_ptrs.push_back(a.data());
  for (const auto& spec : out.results) {
    results.push_back(result_array(spec, dims, k, batch));
    out_ptrs.push_back(results.back().mutable_data());
  }
  {
    py::gil_scoped_release release;
    model_.evaluate_batch(o, k, in_ptrs, params, out_ptrs);
  }
  // forward_dynamics returns qdd alone: the pivots served the checks.
  if (o == Output::forward_dynamics) results.resize(1);
  if (results.size() == 1) {
    if (!batch && results[0].ndim() == 0) return py::float_(*results[0].data());
    return std::move(results[0]);
  }
  py::dict d;
  for (size_t r = 0; r < results.size(); ++r) d[out.results[r].name] = results[r];
  return std::move(d);
}

// Columns first..first+count of a table as a (rows, count) array, or (rows,) for one column.
py::array_t<double> columns(const PlanTable& table, size_t first, size_t count, bool matrix) {
  const py::ssize_t rows = static_cast<py::ssize_t>(table.rows.size());
  py::array_t<double> a = matrix ? py::array_t<double>({rows, static_cast<py::ssize_t>(count)})
                                 : py::array_t<double>(rows);
  double* out = a.mutable_data();
  for (const auto& row : table.rows)
    for (size_t c = 0; c < count; ++c) *out++ = row[first + c];
  return a;
}

py::dict PyModel::plan(const Eigen::VectorXd& start, const Eigen::VectorXd& goal, double duration,
                       double dt, const std::string& time_law, int elbow, const py::object& q0,
                       const py::object& params_given) const {
  StraightLineTask task;
  task.start = start;
  task.goal = goal;
  task.duration = duration;
  task.dt = dt;
  task.law = time_law_from_string(time_law);
  task.elbow = elbow;
  if (!q0.is_none()) task.q0 = q0.cast<Eigen::VectorXd>();
  if (task.q0.size() && task.q0.size() != model_.nq())
    throw py::value_error("q0: expected " + std::to_string(model_.nq()) + " values, got " +
                          std::to_string(task.q0.size()));
  const Eigen::VectorXd params = named_parameters(model_, params_, params_given);
  const DynamicModel m = dynamic_model(model_, params);
  const PlanTable table = [&] {
    py::gil_scoped_release release;
    return plan_table(plan_straight_line(m, task), m, scene_.geared());
  }();
  // The table's columns by name, and its groups as arrays: t, q, qd, qdd, tau, ...
  py::dict out, named;
  for (size_t c = 0; c < table.names.size(); ++c)
    named[table.names[c].c_str()] = columns(table, c, 1, false);
  const size_t nq = static_cast<size_t>(model_.nq()), n = static_cast<size_t>(model_.num_links());
  out["t"] = columns(table, 0, 1, false);
  size_t at = 1;
  for (const char* group : {"q", "qd", "qdd"}) out[group] = columns(table, at, nq, true), at += nq;
  out["tau"] = columns(table, at, n, true), at += n;
  if (scene_.geared()) out["tau_motor"] = columns(table, at, n, true), at += n;
  if (at < table.names.size()) out["base_residual"] = columns(table, at, 1, false);
  out["columns"] = named;
  return out;
}

// The YAML text of a scene (it has line breaks), else the path of a scene file.
Scene scene_from(const std::string& path_or_text) {
  if (path_or_text.find('\n') != std::string::npos) return parse_scene(path_or_text, "<yaml text>");
  return load_scene(path_or_text);
}

PyModel load(const std::string& scene_text, const py::object& params,
             const std::string& cache_dir) {
  const Scene scene = scene_from(scene_text);
  CompileOptions options;
  options.cache_dir = cache_dir;
  CompiledModel m = [&] {
    py::gil_scoped_release release;  // a compile can take seconds
    return CompiledModel::load(scene, options);
  }();
  const Eigen::VectorXd values = named_parameters(
      m,
      Eigen::Map<const Eigen::VectorXd>(m.nominal_parameters().data(),
                                        static_cast<Eigen::Index>(m.nominal_parameters().size())),
      params);
  // The parameters' ranges, checked now: an error at load, not at the first call.
  dynamic_model(m, values);
  return PyModel(std::move(m), values, scene);
}

}  // namespace

void bind_study(py::module& module);  // study_binding.cpp

}  // namespace spacearm

PYBIND11_MODULE(_spacearm, module) {
  using namespace spacearm;
  module.doc() = "spacearm: exact dynamics of planar free-floating space manipulators";
  py::register_exception<DynamicsError>(module, "DynamicsError", PyExc_ArithmeticError);
  py::register_exception<CompileError>(module, "CompileError", PyExc_RuntimeError);
  bind_study(module);
  py::class_<PyModel> model(module, "Model");
  model.def_property_readonly("name", [](const PyModel& m) { return m.model().name(); })
      .def_property_readonly("nq", [](const PyModel& m) { return m.model().nq(); })
      .def_property_readonly("nv", [](const PyModel& m) { return m.model().nv(); })
      .def_property_readonly("num_links", [](const PyModel& m) { return m.model().num_links(); })
      .def_property_readonly("coordinate_names",
                             [](const PyModel& m) { return m.model().coordinate_names(); })
      .def_property_readonly("parameter_names",
                             [](const PyModel& m) { return m.model().parameter_names(); })
      .def_property_readonly("params", [](const PyModel& m) { return m.params(); })
      .def_property_readonly("outputs", &PyModel::outputs)
      .def("plan", &PyModel::plan, py::arg("start"), py::arg("goal"), py::arg("duration"),
           py::arg("dt") = 0.01, py::arg("time_law") = "quintic", py::arg("elbow") = 1,
           py::arg("q0") = py::none(), py::arg("params") = py::none(),
           "The zero-momentum straight line of the end-effector from start to goal (x, y or x, y, "
           "phi) in `duration` s, as `spacearm plan`: a dict of t, q, qd, qdd, tau (link side), "
           "tau_motor (geared), base_residual (free base) and 'columns', the CSV's columns by "
           "name.")
      .def("inspect", &PyModel::inspect, py::arg("entry"), py::arg("latex") = false,
           py::arg("decimal") = false,
           "One symbolic entry as text (or LaTeX), e.g. model.inspect(\"M[3][4]\", latex=True): "
           "the closed form that `spacearm inspect` prints, grouped by velocities and parameters.")
      .def("__repr__", &PyModel::repr);
  module.def("load", &load, py::arg("scene"), py::arg("params") = py::none(),
             py::arg("cache_dir") = "",
             "Compile (or take from the cache) and load the model of a scene: a path to a scene "
             "file or its YAML text. params: a dict of parameter values (default: the scene's).");
  // Every output of the registry: model.mass_matrix(q), model.forward_dynamics(q, qd, Q), ...
  for (const OutputInfo& o : output_registry()) {
    std::string inputs;
    for (Input i : o.inputs) inputs += std::string(info(i).name) + ", ";
    const Output id = o.id;
    model.def(
        o.name,
        [id](const PyModel& m, const py::args& args, const py::object& params) {
          return m.call(id, args, params);
        },
        py::arg("params") = py::none(),
        (std::string(o.name) + "(" + inputs + "params=None): " + o.doc +
         " Each input (n,) for one state or (k, n) for k states.")
            .c_str());
  }
}
