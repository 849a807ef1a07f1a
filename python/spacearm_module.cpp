// The Python binding (module spacearm._spacearm, imported by the package `spacearm`):
// load() compiles and loads a scene through the compile-and-load cache (jit/), and a Model has
// every output of the registry (outputs.hpp) as a method over numpy arrays. A 1-D input is one
// state; a 2-D input of shape (k, n) is k states, evaluated in C++ without the GIL.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <map>
#include <mutex>
#include <optional>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include "compiled_model.hpp"
#include "span_note.hpp"
#include "dynamics_checks.hpp"
#include "planar_scene.hpp"
#include "consistent_start.hpp"
#include "private_folder.hpp"
#include "integrator_choice.hpp"
#include "joint_control.hpp"
#include "plan_replay.hpp"
#include "simulation.hpp"
#include "simulation_table.hpp"
#include "torque_csv.hpp"
#include "step_jacobian.hpp"
#include "optimal_plan.hpp"
#include "plan_limits.hpp"
#include "trajectory_planning.hpp"

namespace py = pybind11;

namespace spacearm {
namespace {

using Array = py::array_t<double, py::array::c_style | py::array::forcecast>;

// numpy's conversion of `value` (named `what` in errors) to an array, then to contiguous
// float64. Not Array::ensure: it returns null and drops numpy's MemoryError, whose null array
// was then dereferenced. A MemoryError stays one; any other failure is a TypeError.
template <class A>
A converted(const py::handle& value, const std::string& what) {
  try {
    return A(py::reinterpret_borrow<py::object>(value));
  } catch (py::error_already_set& e) {
    if (e.matches(PyExc_MemoryError)) throw;
    throw py::type_error(what + ": not an array of numbers (" + std::string(py::str(e.value())) +
                         ")");
  }
}

// A number argument (knots, effort_weight), named in the error where it is none (a bool is
// none) or where an integer is out of T's range.
template <class T>
T number_argument(const py::object& value, const std::string& what) {
  const std::string type = py::str(py::type::of(value).attr("__name__"));
  if (py::isinstance<py::bool_>(value))
    throw py::type_error(what + ": expected a number, got bool");
  if (std::is_integral_v<T> && py::isinstance<py::int_>(value)) {
    const long long v = PyLong_AsLongLong(value.ptr());
    if (PyErr_Occurred())
      PyErr_Clear();
    else if (v >= std::numeric_limits<T>::min() && v <= std::numeric_limits<T>::max())
      return static_cast<T>(v);
    throw py::value_error(what + ": " + std::string(py::str(value)).substr(0, 40) +
                          " is out of range");
  }
  try {
    return value.cast<T>();
  } catch (const py::cast_error&) {
    throw py::type_error(what + ": expected " +
                         (std::is_integral_v<T> ? "an integer" : "a number") + ", got " + type);
  }
}

// A vector argument (q0, qd0): a 1-D array of numbers, named in the error otherwise (pybind11's
// own message, "Unable to cast Python instance...", names nothing).
Eigen::VectorXd vector_argument(const py::handle& value, const std::string& what) {
  const py::array raw = converted<py::array>(value, what);
  const char kind = raw.dtype().kind();
  if (kind != 'i' && kind != 'u' && kind != 'f')
    throw py::type_error(what + ": a 1-D array of numbers, not " +
                         std::string(py::str(py::type::of(value).attr("__name__"))));
  const Array a = converted<Array>(raw, what);
  if (a.ndim() != 1)
    throw py::value_error(what + ": a 1-D array, not " + std::to_string(a.ndim()) + " dimensions");
  return Eigen::Map<const Eigen::VectorXd>(a.data(), a.shape(0));
}

// simulate()'s options, named and with the defaults of `spacearm simulate`.
struct SimulateOptions {
  std::string integrator = "auto", interpolation = "linear", extrapolate = "error";
  double dt = 0.01, dt_out = 0;
  py::object rtol = py::none(), atol = py::none();  // None: IntegratorOptions' defaults
  bool consistent_start = false;
  py::object plan = py::none();  // a plan file's path, or the dict model.plan() returns
  std::string feedforward = "none";
  bool other_arm = false;  // replay a plan made for other kinematics (a warning, not an error)
};

// A loaded model and the parameter values its methods use unless given others.
class PyModel {
 public:
  PyModel(CompiledModel model, Eigen::VectorXd params, ModelRecipe recipe, CompileOptions options)
      : model_(std::move(model)),
        params_(std::move(params)),
        recipe_(std::move(recipe)),
        options_(std::move(options)) {}

  const CompiledModel& model() const { return model_; }
  const Eigen::VectorXd& params() const { return params_; }
  // States per call of the generated code in a batch: 4 (its 4-lane functions, where the
  // output has one; the same bits) or 1.
  int lanes() const { return lanes_; }
  void set_lanes(int lanes) {
    if (lanes != 1 && lanes != 4)
      throw py::value_error("lanes: 1 or 4, got " + std::to_string(lanes));
    lanes_ = lanes;
  }

  // Output o at the inputs (arrays, in the registry's order), one state or a batch.
  // all_results: every result array (forward_dynamics: also its LDL^T pivots), as a dict.
  py::object call(Output o, const py::args& args, const py::object& params,
                  bool all_results = false) const;

  // The names of the outputs the scene emits, in the registry's order.
  std::vector<std::string> outputs() const {
    std::vector<std::string> names;
    for (const auto& o : output_registry())
      if (model_.has(o.id)) names.push_back(o.name);
    return names;
  }

  // The zero-momentum straight line (runtime/trajectory_planning.hpp) at the model's
  // parameters (or `params`): arrays and the table's named columns, as `spacearm plan` writes.
  // A tree's end_effector (by name; "" the first) follows the line while the others hold
  // (`hold`: "joints" or "pose"); a list of names moves each along its own line (start and
  // goal then one row per name, time_law one or one per name).
  py::dict plan(const py::object& start, const py::object& goal, double duration, double dt,
                const py::object& time_law, int elbow, const py::object& q0,
                const py::object& params, const py::object& end_effector, const std::string& hold,
                const std::string& objective, const py::object& knots,
                const py::object& effort_weight) const;
  // The lines of plan()'s arguments, into task (its start, goal, law, end effector, more_lines).
  void plan_lines(const py::object& start, const py::object& goal, const py::object& time_law,
                  const py::object& end_effector, StraightLineTask& task) const;

  // The motion under sampled joint torques (or none), as `spacearm simulate` computes it.
  // t_end: nullopt for a plan's end.
  py::dict simulate(std::optional<double> t_end, const py::object& torques, const py::object& q0,
                    const py::object& qd0, const SimulateOptions& o,
                    const py::object& params) const;

  // A plan tracked in closed loop by a sampled joint controller (runtime/joint_control.hpp).
  py::dict closed_loop(const py::object& plan, const std::string& controller, double omega,
                       double period, const PyModel* control_model, const std::string& feedforward,
                       double dt_out, const py::object& params) const;

  // One symbolic entry ("M[3][4]", "T", ...) as `spacearm inspect` prints it (a planar scene is
  // derived on the first call, without the GIL, and kept).
  std::string inspect(const std::string& entry, bool latex, bool decimal) {
    py::gil_scoped_release release;
    return recipe_.inspect_entry(entry, latex, decimal);
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
  int lanes_ = 4;
  ModelRecipe recipe_;
  CompileOptions options_;  // the load's (cache, engine): a sibling model is loaded alike
  // A point-to-point plan's model (planning_recipe): the scene with its state Jacobian, loaded
  // at the first such plan where the scene lacks it.
  // Guarded by planning_mutex_ (taken with the GIL released), so that threads planning at once
  // compile it once.
  mutable std::shared_ptr<const CompiledModel> planning_model_;
  std::shared_ptr<std::mutex> planning_mutex_ = std::make_shared<std::mutex>();
  const CompiledModel& planning_model(const StraightLineTask& task) const;
};

const CompiledModel& PyModel::planning_model(const StraightLineTask& task) const {
  const std::optional<ModelRecipe> sibling = planning_recipe(recipe_, task);
  if (!sibling) return model_;
  py::gil_scoped_release release;  // a compile can take seconds; other threads wait here
  const std::lock_guard<std::mutex> lock(*planning_mutex_);
  if (!planning_model_)
    planning_model_ =
        std::make_shared<const CompiledModel>(CompiledModel::load(*sibling, options_));
  return *planning_model_;
}

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
    const double v = PyFloat_AsDouble(value.ptr());  // an int beyond double raises
    if (PyErr_Occurred()) {
      PyErr_Clear();
      throw py::value_error("params['" + name + "']: " + std::string(py::str(value)).substr(0, 40) +
                            " is out of the range of double precision");
    }
    values[it - names.begin()] = v;
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

py::object PyModel::call(Output o, const py::args& args, const py::object& params_given,
                         bool all_results) const {
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
    const std::string name = info(out.inputs[i]).name;
    const py::array raw = converted<py::array>(args[i], name);
    const char kind = raw.dtype().kind();
    if (kind != 'i' && kind != 'u' && kind != 'f')
      throw py::type_error(name + ": not an array of numbers");
    arrays.push_back(converted<Array>(raw, name));
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
  // forward_dynamics returns qdd alone unless asked for its pivots, which otherwise only serve
  // the checks and are not kept (null results).
  const bool qdd_alone = o == Output::forward_dynamics && !all_results;
  for (size_t r = 0; r < out.results.size(); ++r) {
    if (qdd_alone && r > 0) {
      out_ptrs.push_back(nullptr);
      continue;
    }
    results.push_back(result_array(out.results[r], dims, k, batch));
    out_ptrs.push_back(results.back().mutable_data());
  }
  {
    py::gil_scoped_release release;
    with_span_note([&] { return model_.span_note(params); },
                   [&] { model_.evaluate_batch(o, k, in_ptrs, params, out_ptrs, lanes_); });
  }
  if (results.size() == 1) {
    if (!batch && results[0].ndim() == 0) return py::float_(*results[0].data());
    return std::move(results[0]);
  }
  py::dict d;
  for (size_t r = 0; r < results.size(); ++r) d[out.results[r].name] = results[r];
  return std::move(d);
}

// Columns first..first+count of a table as a (rows, count) array, or (rows,) for one column.
py::array_t<double> table_columns(const PlanTable& table, size_t first, size_t count, bool matrix) {
  const py::ssize_t rows = static_cast<py::ssize_t>(table.rows.size());
  py::array_t<double> a = matrix ? py::array_t<double>({rows, static_cast<py::ssize_t>(count)})
                                 : py::array_t<double>(rows);
  double* out = a.mutable_data();
  for (const auto& row : table.rows)
    for (size_t c = 0; c < count; ++c) *out++ = row[first + c];
  return a;
}

// A str, or a list or tuple of them (not a str's characters), as names; nullopt for one str.
std::optional<std::vector<std::string>> name_list(const py::object& value,
                                                  const std::string& what) {
  if (py::isinstance<py::str>(value)) return std::nullopt;
  if (!py::isinstance<py::list>(value) && !py::isinstance<py::tuple>(value))
    throw py::type_error(what + ": a name or a list of names, not " +
                         std::string(py::str(py::type::of(value).attr("__name__"))));
  std::vector<std::string> names;
  for (const py::handle& item : value) {
    if (!py::isinstance<py::str>(item))
      throw py::type_error(what + "[" + std::to_string(names.size()) + "]: a name, not " +
                           std::string(py::str(py::type::of(item).attr("__name__"))));
    names.push_back(item.cast<std::string>());
  }
  return names;
}

void PyModel::plan_lines(const py::object& start, const py::object& goal,
                         const py::object& time_law, const py::object& end_effector,
                         StraightLineTask& task) const {
  auto index_of = [&](const std::string& name, const std::string& what) {
    try {
      return end_effector_index(model_.end_effector_names(), name, model_.name());
    } catch (const std::invalid_argument& e) {
      throw py::value_error(what + ": " + e.what());
    }
  };
  auto law = [](const std::string& text, const std::string& what) {
    try {
      return time_law_from_string(text);
    } catch (const std::invalid_argument& e) {
      throw py::value_error(what + ": " + e.what());
    }
  };
  const auto names = name_list(end_effector, "end_effector");
  const auto laws = name_list(time_law, "time_law");
  if (!names) {  // one line
    if (laws) throw py::type_error("time_law: one name for one end_effector");
    const std::string name = end_effector.cast<std::string>();
    if (!name.empty()) task.end_effector = index_of(name, "end_effector");
    task.start = vector_argument(start, "start");
    task.goal = vector_argument(goal, "goal");
    task.law = law(time_law.cast<std::string>(), "time_law");
    return;
  }
  // One line per name: start and goal one row each (a list of arrays, or a 2-D array).
  const size_t lines = names->size();
  if (lines == 0) throw py::value_error("end_effector: an empty list (give one name or more)");
  if (laws && laws->size() != lines)
    throw py::value_error("time_law: " + std::to_string(laws->size()) + " names for " +
                          std::to_string(lines) + " end effectors (one for all, or one each)");
  std::vector<Eigen::VectorXd> rows[2];
  for (int g = 0; g < 2; ++g) {
    const py::object& given = g ? goal : start;
    const std::string what = g ? "goal" : "start";
    if (py::isinstance<py::str>(given) || !py::isinstance<py::sequence>(given))
      throw py::type_error(what + ": one row per end effector (a list of arrays or a 2-D array)");
    const py::sequence rows_given = given;
    if (rows_given.size() != lines)
      throw py::value_error(what + ": " + std::to_string(rows_given.size()) + " rows for " +
                            std::to_string(lines) + " end effectors (one row each)");
    for (size_t k = 0; k < lines; ++k)
      rows[g].push_back(vector_argument(rows_given[k], what + "[" + std::to_string(k) + "]"));
  }
  for (size_t k = 0; k < lines; ++k) {
    const std::string at = "[" + std::to_string(k) + "]";
    const TimeLaw l =
        laws ? law((*laws)[k], "time_law" + at) : law(time_law.cast<std::string>(), "time_law");
    const int e = index_of((*names)[k], "end_effector" + at);
    if (k == 0) {
      task.end_effector = e, task.start = rows[0][0], task.goal = rows[1][0], task.law = l;
      continue;
    }
    task.more_lines.push_back({e, rows[0][k], rows[1][k], l});
  }
}

py::dict PyModel::plan(const py::object& start, const py::object& goal, double duration, double dt,
                       const py::object& time_law, int elbow, const py::object& q0,
                       const py::object& params_given, const py::object& end_effector,
                       const std::string& hold, const std::string& objective,
                       const py::object& knots, const py::object& effort_weight) const {
  StraightLineTask task;
  try {
    task.hold = hold_from_string(hold);
  } catch (const std::invalid_argument& e) {
    throw py::value_error(std::string("hold: ") + e.what());
  }
  try {
    task.objective = objective_from_string(objective);
  } catch (const std::invalid_argument& e) {
    throw py::value_error(std::string("objective: ") + e.what());
  }
  // An argument the objective does not use is an error, as plan's options are (uses_knots, ...).
  auto refuse = [&objective](bool given, bool used, const std::string& arg,
                             const std::string& why) {
    if (given && !used)
      throw py::value_error(arg + ": not used by objective '" + objective + "' (" + why + ")");
  };
  refuse(!knots.is_none(), uses_knots(task.objective), "knots",
         "it is min_base_rotation's and min_effort's");
  refuse(!effort_weight.is_none(), uses_effort_weight(task.objective), "effort_weight",
         "it is min_base_rotation's");
  refuse(!time_law.is_none(), uses_time_law(task.objective), "time_law",
         "a point-to-point plan goes by any path; the time law is the straight line's");
  plan_lines(start, goal, time_law.is_none() ? py::str("quintic") : time_law, end_effector, task);
  task.duration = duration;
  task.dt = dt;
  task.elbow = elbow;
  if (!q0.is_none()) task.q0 = vector_argument(q0, "q0");
  if (task.q0.size() && task.q0.size() != model_.nq())
    throw py::value_error("q0: expected " + std::to_string(model_.nq()) + " values, got " +
                          std::to_string(task.q0.size()));
  const Eigen::VectorXd params = named_parameters(model_, params_, params_given);
  TaskNames names;
  names.lines_indexed = !py::isinstance<py::str>(end_effector);  // a list of end effectors
  if (point_to_point(task.objective)) {
    // As plan --objective: within the URDF's effort, velocity and angle limits.
    const StraightLineTask defaults;
    task.knots = knots.is_none() ? defaults.knots : number_argument<int>(knots, "knots");
    task.effort_weight = effort_weight.is_none()
                             ? defaults.effort_weight
                             : number_argument<double>(effort_weight, "effort_weight");
    set_plan_limits(recipe_, task);
  }
  // The task checked on the scene's own model (the sibling's sizes, names and limits are its)
  // before a sibling is compiled for it.
  {
    const DynamicModel own = dynamic_model(model_, params);
    check_task(own, task, names);
    if (point_to_point(task.objective)) check_point_to_point(own, task, names);
  }
  // Point to point: the step Jacobians from the exact state Jacobian, as plan --objective takes
  // them (the scene compiled with it where it lacks it; the same parameters).
  const DynamicModel m = dynamic_model(planning_model(task), params);
  Plan plan;
  PlanTable table;
  bool interrupted = false;  // Ctrl-C during a solve: Python's KeyboardInterrupt
  try {
    py::gil_scoped_release release;
    plan = plan_task(m, task, [&interrupted] {
      py::gil_scoped_acquire acquire;
      return interrupted = PyErr_CheckSignals() != 0;
    });
    table = plan_table(plan, m, recipe_.facts().geared);
  } catch (const std::runtime_error&) {
    if (interrupted) throw py::error_already_set();
    throw;
  }
  // The table's columns by name, and its groups as arrays: t, q, qd, qdd, tau, ...
  py::dict out, named;
  for (size_t c = 0; c < table.names.size(); ++c)
    named[table.names[c].c_str()] = table_columns(table, c, 1, false);
  const size_t nq = static_cast<size_t>(model_.nq()), nv = static_cast<size_t>(model_.nv()),
               n = static_cast<size_t>(model_.num_links());
  out["t"] = table_columns(table, 0, 1, false);
  size_t at = 1;
  for (const auto& [group, size] : {std::pair{"q", nq}, std::pair{"qd", nv}, std::pair{"qdd", nv}})
    out[group] = table_columns(table, at, size, true), at += size;
  while (table.names[at] != "tau1") ++at;  // past a motor slot's link-side q_j, q_jd
  out["tau"] = table_columns(table, at, n, true), at += n;
  if (recipe_.facts().geared) out["tau_motor"] = table_columns(table, at, n, true), at += n;
  if (at < table.names.size()) out["base_residual"] = table_columns(table, at, 1, false);
  out["columns"] = named;
  // The plan's own checks (plan_checks_text): how near a singularity, how far the base turned.
  out["min_jacobian_rcond"] = plan.min_jacobian_rcond;
  out["min_jacobian_rcond_t"] = plan.min_jacobian_rcond_t;
  out["max_base_rotation"] = plan.max_base_rotation;
  out["final_base_rotation"] = plan.final_base_rotation;
  if (plan.knots > 0) {  // a point-to-point plan's
    out["goal_error"] = plan.goal_error;
    out["max_knot_error"] = plan.max_knot_error;
    out["iterations"] = plan.iterations;
    out["solve_seconds"] = plan.solve_seconds;
    out["cost"] = plan.cost;
  }
  return out;
}

// Torque samples (k, 1 + N) with t first, on a uniform grid as a torque file's.
TorqueTable torque_table(const py::object& torques, int N) {
  const Array a = converted<Array>(torques, "torques");
  if (a.ndim() != 2 || a.shape(1) != N + 1 || a.shape(0) < 2)
    throw py::value_error("torques: an array of shape (k, " + std::to_string(N + 1) +
                          "), k >= 2, with the times t in the first column and tau1.." +
                          std::to_string(N) + " after it");
  TorqueTable table;
  std::vector<double> times;
  for (py::ssize_t k = 0; k < a.shape(0); ++k) {
    for (int c = 0; c <= N; ++c)
      if (!std::isfinite(a.at(k, c)))
        throw py::value_error("torques[" + std::to_string(k) + ", " + std::to_string(c) +
                              "] is not finite");
    times.push_back(a.at(k, 0));
    table.samples.push_back(Eigen::Map<const Eigen::VectorXd>(a.data(k, 1), N));
  }
  detail::set_uniform_grid(
      table, times, [](size_t k) { return static_cast<long>(k) + 1; },
      detail::CsvErrors{"torques (row numbers from 1)"});
  return table;
}

// spacearm.IntegrationError (a RuntimeError): the integrator's message, the time reached as
// `.t` and every row computed up to it as `.partial` (the dict simulate returns), so that a
// failed run loses nothing that was computed, as the CLI's CSV keeps it.
py::object& integration_error_type() {
  static auto* type = new py::object();  // never destroyed: not after the interpreter ends
  return *type;
}

[[noreturn]] void raise_integration_error(const IntegrationError& e, const py::dict& partial) {
  const py::object error = integration_error_type()(std::string(e.what()));
  error.attr("t") = e.t();
  error.attr("partial") = partial;
  PyErr_SetObject(integration_error_type().ptr(), error.ptr());
  throw py::error_already_set();
}

// What simulate and closed_loop return: t, q, qd, the table's columns by name, and what the
// integrator was and why.
py::dict run_result(const SimulationTable& columns, std::vector<std::vector<double>> rows,
                    const DynamicModel& m, const std::string& why) {
  PlanTable named{columns.names(), std::move(rows)};
  py::dict out, by_name;
  for (size_t c = 0; c < named.names.size(); ++c)
    by_name[named.names[c].c_str()] = table_columns(named, c, 1, false);
  out["t"] = table_columns(named, 0, 1, false);
  out["q"] = table_columns(named, 1, m.nq, true);
  out["qd"] = table_columns(named, 1 + m.nq, m.nv, true);
  out["columns"] = by_name;
  out["integrator"] = why;
  return out;
}

// A plan as `spacearm plan` writes it: a file's text, or the CSV of model.plan()'s columns.
std::string plan_text(const py::object& plan) {
  if (py::isinstance<py::str>(plan)) {
    const std::string path = plan.cast<std::string>();
    try {
      return read_regular_file(path, "plan", size_t(1) << 30);
    } catch (const FolderError& e) {
      throw py::value_error(e.what());
    }
  }
  if (!py::isinstance<py::dict>(plan) || !plan.cast<py::dict>().contains("columns"))
    throw py::type_error("plan: a plan file's path, or the dict that model.plan() returns");
  const py::dict columns = plan.cast<py::dict>()["columns"].cast<py::dict>();
  std::vector<std::string> names;
  std::vector<py::array_t<double, py::array::c_style | py::array::forcecast>> arrays;
  for (const auto& [name, values] : columns) {
    names.push_back(name.cast<std::string>());
    arrays.push_back(values.cast<py::array_t<double, py::array::c_style | py::array::forcecast>>());
    if (arrays.back().ndim() != 1 || arrays.back().shape(0) != arrays.front().shape(0))
      throw py::value_error("plan: column '" + names.back() + "' is not one value per sample");
  }
  std::string text;
  for (const auto& n : names) text += (text.empty() ? "" : ",") + n;
  text += "\n";
  char buf[32];
  for (py::ssize_t r = 0; !arrays.empty() && r < arrays.front().shape(0); ++r) {
    for (size_t c = 0; c < arrays.size(); ++c) {
      std::snprintf(buf, sizeof buf, c ? ",%.17g" : "%.17g", arrays[c].at(r));
      text += buf;
    }
    text += "\n";
  }
  return text;
}

namespace {

// simulate's integrator, step and tolerances. As the CLI's: options that would do nothing are
// errors, not silently ignored.
IntegratorOptions integrator_options(const SimulateOptions& o) {
  IntegratorOptions opt;
  const bool automatic = o.integrator == "auto";
  if (!automatic) opt.method = method_from_string(o.integrator);
  opt.dt = o.dt;
  // As the CLI's: options that would do nothing are errors, not silently ignored.
  for (const auto& [name, given, value] :
       {std::tuple{"rtol", &o.rtol, &opt.rtol}, std::tuple{"atol", &o.atol, &opt.atol}})
    if (!given->is_none()) {
      if (automatic || !adaptive(opt.method))
        throw py::value_error(std::string(name) +
                              ": applies only to the adaptive integrators (dopri5, rkf78, "
                              "rosenbrock4), not to " +
                              o.integrator);
      *value = PyFloat_AsDouble(given->ptr());
      if (PyErr_Occurred()) {
        PyErr_Clear();
        throw py::type_error(std::string(name) + ": a number");
      }
    }
  if (!(o.dt_out >= 0 && std::isfinite(o.dt_out)))
    throw py::value_error("dt_out: " + std::to_string(o.dt_out) +
                          " must be 0 (every step) or a positive multiple of dt");
  return opt;
}

// The plan simulate replays (none without plan=), checked against the model's kinematics, with
// this model's friction fed forward where asked; `replaced`: torques, q0, qd0 or
// consistent_start were given too.
std::optional<PlanSamples> replayed_plan(const DynamicModel& m, const SimulateOptions& o,
                                         bool replaced) {
  const int N = m.num_links;
  std::optional<PlanSamples> plan;
  if (!o.plan.is_none()) {
    if (replaced)
      throw py::value_error(
          "plan: replaces torques, q0, qd0 and consistent_start (its start is mapped to this "
          "model's coordinates)");
    plan = read_plan_csv(plan_text(o.plan), N, m.free_floating,
                         py::isinstance<py::str>(o.plan) ? o.plan.cast<std::string>() : "plan",
                         m.spatial);
    bool compared = false;
    if (const std::string mismatch = plan_kinematics_mismatch(m, *plan, &compared);
        !mismatch.empty()) {
      if (!o.other_arm)
        throw py::value_error(
            "plan: made for another arm (its kinematics differ from this "
            "model's): " +
            mismatch +
            "; replan on this model, or pass "
            "other_arm=True");
      PyErr_WarnEx(PyExc_UserWarning, ("plan: made for another arm: " + mismatch).c_str(), 1);
    }
    if (o.feedforward == "friction") {
      feed_friction_forward(m, *plan);
    } else if (o.feedforward != "none") {
      throw py::value_error("feedforward: 'none' or 'friction', got '" + o.feedforward + "'");
    }
  } else if (o.feedforward != "none") {
    throw py::value_error("feedforward: needs a plan");
  }
  return plan;
}

// simulate's start (q0, qd0), the neutral configuration and rest by default, checked.
void start_state(const DynamicModel& m, const py::object& q0, const py::object& qd0,
                 Eigen::VectorXd& x0, Eigen::VectorXd& v0) {
  x0 = q0.is_none() ? m.neutral_configuration() : vector_argument(q0, "q0");
  v0 = qd0.is_none() ? Eigen::VectorXd::Zero(m.nv) : vector_argument(qd0, "qd0");
  if (x0.size() != m.nq)
    throw py::value_error("q0: expected " + std::to_string(m.nq) + " values, got " +
                          std::to_string(x0.size()));
  if (v0.size() != m.nv)
    throw py::value_error("qd0: expected " + std::to_string(m.nv) + " values, got " +
                          std::to_string(v0.size()));
  if (const std::string e = ConfigurationSpace::angle_error(
          x0, ConfigurationSpace::first_angle(m.free_floating, m.spatial), "q0",
          m.coordinate_names);
      !e.empty())
    throw py::value_error(e);
}

}  // namespace

py::dict PyModel::simulate(std::optional<double> t_end_given, const py::object& torques,
                           const py::object& q0, const py::object& qd0, const SimulateOptions& o,
                           const py::object& params_given) const {
  const Eigen::VectorXd params = named_parameters(model_, params_, params_given);
  const DynamicModel m = dynamic_model(model_, params);
  m.require_forward_dynamics("simulate");
  if (o.consistent_start && !(recipe_.facts().features & needs::springs))
    throw py::value_error("consistent_start: the scene has no flexible joint (gears[i].stiffness)");
  IntegratorOptions opt = integrator_options(o);
  const bool automatic = o.integrator == "auto";
  // The torque signal: from the samples or a plan (covering [0, t_end] unless extrapolated),
  // or zero.
  const int N = m.num_links;
  std::optional<PlanSamples> plan = replayed_plan(
      m, o, !torques.is_none() || !q0.is_none() || !qd0.is_none() || o.consistent_start);
  if (!t_end_given && !plan)
    throw py::value_error("t_end: give it (only a plan has an end of its own)");
  const double t_end = t_end_given ? *t_end_given : plan->torques.t_last();
  if (!(t_end > 0 && std::isfinite(t_end)))
    throw py::value_error("t_end must be positive and finite");
  const TorqueTable table =
      plan ? plan->torques
      : torques.is_none()
          ? TorqueTable{0, t_end, {Eigen::VectorXd::Zero(N), Eigen::VectorXd::Zero(N)}}
          : torque_table(torques, N);
  const Extrapolation outside = extrapolation_from_string(o.extrapolate);
  const std::string gap = coverage_gap(table.t0, table.t_last(), t_end);
  if (outside == Extrapolation::error && !gap.empty())
    throw py::value_error("torques cover " + gap +
                          ": give samples that cover it, or extrapolate='hold' or 'zero'");
  const TorqueSignal<Eigen::Dynamic> tau(table.t0, table.dt, table.samples,
                                         interpolation_from_string(o.interpolation), outside);
  Eigen::VectorXd x0, v0;
  start_state(m, q0, qd0, x0, v0);
  if (plan) replay_start(m, *plan, plan->torques.samples.front(), x0, v0);
  if (o.consistent_start) consistent_start(m, x0, v0, tau(0.0));
  // auto: rk4 at a step that resolves the stiffest mode at the start, or rosenbrock4.
  std::string why = "as asked";
  if (automatic) {
    const IntegratorChoice c =
        choose_integrator(stiffest_mode(m, x0, v0, m.generalized_forces(tau(0.0))), o.dt,
                          o.dt_out > 0 ? o.dt_out : o.dt, m.has_state_jacobian());
    c.apply(opt);
    why = c.why;
  }
  const TorqueReplay<Eigen::Dynamic> replay(tau, opt, "dt");
  // The run without the GIL, one row per sample of the table.
  const SimulationTable columns(m, recipe_.facts().geared);
  std::vector<std::vector<double>> rows;
  std::optional<IntegrationError> failed;
  {
    py::gil_scoped_release release;
    try {
      integrate_motion(m, x0, v0, replay, t_end, o.dt_out > 0 ? o.dt_out : o.dt, opt,
                       [&](double t, const Eigen::VectorXd& q, const Eigen::VectorXd& qd) {
                         rows.emplace_back();
                         columns.row(t, q, qd, tau(t), rows.back());
                       });
    } catch (const IntegrationError& e) {  // with the span at these parameters, if wider
      failed.emplace(e.what() + model_.span_note(params), e.t(), e.state());
    }
  }
  py::dict run = run_result(columns, std::move(rows), m, why);
  if (failed) raise_integration_error(*failed, run);
  return run;
}

py::dict PyModel::closed_loop(const py::object& plan_given, const std::string& controller,
                              double omega, double period, const PyModel* control_model,
                              const std::string& feedforward, double dt_out,
                              const py::object& params_given) const {
  const Eigen::VectorXd params = named_parameters(model_, params_, params_given);
  const DynamicModel plant = dynamic_model(model_, params);
  plant.require_forward_dynamics("closed_loop");
  const int N = plant.num_links, nb = plant.num_base();
  if (controller != "pd" && controller != "computed_torque")
    throw py::value_error("controller: 'pd' or 'computed_torque', got '" + controller + "'");
  if (feedforward != "none" && feedforward != "plan" && feedforward != "friction")
    throw py::value_error("feedforward: 'none', 'plan' or 'friction' (plan + friction), got '" +
                          feedforward + "'");
  if (!(omega > 0 && std::isfinite(omega)) || !(period > 0 && std::isfinite(period)))
    throw py::value_error("omega and period must be positive and finite");
  const long every = std::lround(dt_out / period);
  if (every < 1 || std::abs(every * period - dt_out) > 1e-9 * dt_out)
    throw py::value_error("dt_out must be a positive multiple of period");
  PlanSamples plan =
      read_plan_csv(plan_text(plan_given), N, plant.free_floating, "plan", plant.spatial);
  const SampledJointTrajectory target = joint_target(plan);
  // PD: the plan's torques (and friction) fed forward, feedback from the motor encoders.
  if (feedforward == "friction") feed_friction_forward(plant, plan);
  std::vector<Eigen::VectorXd> ff = plan.torques.samples;
  if (feedforward == "none")
    for (auto& t : ff) t.setZero();
  const TorqueSignal<Eigen::Dynamic> tau_ff(plan.torques.t0, plan.torques.dt, ff,
                                            Interpolation::linear, Extrapolation::hold);
  const JointGains gains = JointGains::critically_damped(N, omega);
  const PdController pd(gains);
  std::optional<DynamicModel> control;
  std::optional<ComputedTorqueController> ct;
  if (controller == "computed_torque") {
    const PyModel& c = control_model ? *control_model : *this;
    control = dynamic_model(c.model_, c.params_);
    ct.emplace(*control, gains);
  }
  auto decide = [&](double t, const Eigen::VectorXd& q, const Eigen::VectorXd& qd) {
    const JointTarget x = target(t);
    if (ct)
      return ct->torque(x, q.head(plant.base_coordinates()), qd.head(nb), plant.joint_angles(q),
                        plant.joint_rates(qd));
    return Eigen::VectorXd(tau_ff(t) +
                           pd.torque(x, plant.motor_side(q), plant.motor_side_rates(qd)));
  };
  Eigen::VectorXd x0, v0;
  replay_start(plant, plan, ff.front(), x0, v0);
  IntegratorOptions opt;
  const IntegratorChoice choice =
      choose_integrator(stiffest_mode(plant, x0, v0, plant.generalized_forces(ff.front())), period,
                        period, plant.has_state_jacobian());
  choice.apply(opt);
  const SimulationTable columns(plant, recipe_.facts().geared);
  std::vector<std::vector<double>> rows;
  long sample = 0;
  {
    py::gil_scoped_release release;
    try {
      integrate_closed_loop(plant, x0, v0, decide, period, plan.torques.t_last(), opt,
                            [&](double t, const Eigen::VectorXd& q, const Eigen::VectorXd& qd,
                                const Eigen::VectorXd& tau) {
                              if (sample++ % every) return;
                              rows.emplace_back();
                              columns.row(t, q, qd, tau, rows.back());
                            });
    } catch (const IntegrationError& e) {  // a loop gone unstable: say so, not the state
      const std::string why = e.what();
      char at[64];
      std::snprintf(at, sizeof at, "%.6g", e.t());
      throw std::runtime_error(
          "closed_loop: diverged after t = " + std::string(at) + " s (" +
          why.substr(0, why.find("; last accepted state")) + "): " +
          (ct ? "lower omega (computed torque on a model without the plant's springs excites "
                "them at high gains)"
              : "lower omega or the period (a sampled PD loop needs kd period / (p^2 I_m) "
                "below about 2, kd = 2 omega)") +
          model_.span_note(params));  // the run-time parameters' span, where they widen it
    }
  }
  return run_result(columns, std::move(rows), plant, choice.why);
}

// The YAML text of a scene (it has line breaks), else the path of a scene file; either kind.
// Its warnings (bodies inertia_check: positive_definite takes) become Python's UserWarnings.
ModelRecipe scene_from(const std::string& path_or_text) {
  ModelRecipe recipe = path_or_text.find('\n') != std::string::npos
                           ? ModelRecipe::parse(path_or_text, "<yaml text>")
                           : ModelRecipe::load(path_or_text);
  for (const std::string& w : recipe.warnings())
    if (PyErr_WarnEx(PyExc_UserWarning, w.c_str(), 1) != 0) throw py::error_already_set();
  return recipe;
}

PyModel load(const std::string& scene_text, const py::object& params, const std::string& cache_dir,
             const std::string& engine) {
  const ModelRecipe scene = scene_from(scene_text);
  CompileOptions options;
  options.cache_dir = cache_dir;
  options.engine = parse_engine(engine, "engine");
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
  return PyModel(std::move(m), values, scene, options);
}

// Model's read-only facts: name, sizes, names, parameter values, outputs, lanes.
void bind_model_facts(py::class_<PyModel>& model) {
  model.def_property_readonly("name", [](const PyModel& m) { return m.model().name(); })
      .def_property_readonly("nq", [](const PyModel& m) { return m.model().nq(); })
      .def_property_readonly(
          "engine", [](const PyModel& m) { return std::string(m.model().engine()); },
          "'compiled' or 'interpreter': which serves the calls now (load's engine)")
      .def_property_readonly("nv", [](const PyModel& m) { return m.model().nv(); })
      .def_property_readonly("num_links", [](const PyModel& m) { return m.model().num_links(); })
      .def_property_readonly("coordinate_names",
                             [](const PyModel& m) { return m.model().coordinate_names(); })
      .def_property_readonly(
          "end_effector_names", [](const PyModel& m) { return m.model().end_effector_names(); },
          "A tree's end effectors in the order of the pose's blocks of 7 and the Jacobians' of 6 "
          "rows (empty: one end effector)")
      .def_property_readonly("parameter_names",
                             [](const PyModel& m) { return m.model().parameter_names(); })
      .def_property_readonly("params",
                             [](const PyModel& m) {
                               py::dict d;  // name -> value, in the scene's order
                               const auto& names = m.model().parameter_names();
                               for (size_t i = 0; i < names.size(); ++i)
                                 d[names[i].c_str()] = m.params()[static_cast<Eigen::Index>(i)];
                               return d;
                             })
      .def_property_readonly("outputs", &PyModel::outputs)
      .def_property("lanes", &PyModel::lanes, &PyModel::set_lanes,
                    "States per call of the generated code in a batch: 4 (the 4-lane "
                    "functions of forward_dynamics, end_effector_pose, momentum, "
                    "kinetic_energy and those the scene lists under lanes:; the same bits) "
                    "or 1");
}

// Model.integrate and difference: q ⊕ delta and q1 ⊖ q0 on the tangent space that the
// derivatives take (configuration_space.hpp), sizes checked by name.
void bind_model_tangent(py::class_<PyModel>& model) {
  auto sized = [](const py::object& value, const char* what, int size) {
    const Eigen::VectorXd v = vector_argument(value, what);
    if (v.size() != size)
      throw py::value_error(std::string(what) + ": expected " + std::to_string(size) +
                            " values, got " + std::to_string(v.size()));
    if (!v.allFinite()) throw py::value_error(std::string(what) + ": not finite");
    return v;
  };
  auto space = [](const PyModel& m) {
    return dynamic_model(m.model(), m.params()).configuration_space();
  };
  // A configuration: nq finite values, a base quaternion of a norm the model takes.
  auto configuration = [sized, space](const PyModel& m, const py::object& value, const char* what) {
    const Eigen::VectorXd q = sized(value, what, m.model().nq());
    const int k = space(m).quaternion_offset;
    if (k >= 0 && !ConfigurationSpace::takes_quaternion_norm(q.segment<4>(k).norm()))
      throw py::value_error(std::string(what) + "[" + std::to_string(k) + ".." +
                            std::to_string(k + 3) +
                            "], the base's quaternion, must have a norm in [1e-6, 1e6], got " +
                            std::to_string(q.segment<4>(k).norm()));
    return q;
  };
  model.def(
      "integrate",
      [sized, space, configuration](const PyModel& m, const py::object& q,
                                    const py::object& delta) {
        return space(m).integrate(configuration(m, q, "q"), sized(delta, "delta", m.model().nv()));
      },
      py::arg("q"), py::arg("delta"),
      "q ⊕ delta: q moved by delta (nv values) on its tangent space, the base's quaternion "
      "turned by delta's omega in the base's own frame (MuJoCo's mj_integratePos, Pinocchio's "
      "integrate); forward_dynamics_derivatives' dqdd_dq is taken along it.");
  model.def(
      "difference",
      [space, configuration](const PyModel& m, const py::object& q0, const py::object& q1) {
        return space(m).difference(configuration(m, q0, "q0"), configuration(m, q1, "q1"));
      },
      py::arg("q0"), py::arg("q1"),
      "q1 ⊖ q0: the tangent delta (nv values) with integrate(q0, delta) == q1, the shorter turn "
      "(Pinocchio's difference).");
  model.def(
      "step_jacobians",
      [sized, configuration](const PyModel& m, const py::object& q, const py::object& v,
                             const py::object& tau, double dt) {
        const Eigen::VectorXd qs = configuration(m, q, "q"), vs = sized(v, "v", m.model().nv()),
                              taus = sized(tau, "tau", m.model().num_links());
        const DynamicModel dm = dynamic_model(m.model(), m.params());
        StepJacobians J;
        try {
          py::gil_scoped_release release;
          J = rk4_step_jacobians(dm, qs, vs, taus, dt);
        } catch (const std::invalid_argument& e) {
          throw py::value_error(e.what());
        }
        py::dict d;
        d["A"] = J.A, d["B"] = J.B, d["q"] = J.q, d["v"] = J.v;
        return d;
      },
      py::arg("q"), py::arg("v"), py::arg("tau"), py::arg("dt"),
      "One rk4 step of dt from (q, v) under the link-side joint torques tau, held through it "
      "(runtime/step_jacobian.hpp): a dict of the state after it (q, v) and its Jacobians on the "
      "tangent spaces, A = dx+/dx (2 nv x 2 nv, x = (q ⊕ delta, v)) and B = dx+/dtau (2 nv x "
      "N), the form iLQR, DDP and MPC take; exact from the state Jacobian where the scene "
      "emits forward_dynamics_derivatives, else from its central differences.");
}

// Model.plan, simulate and closed_loop: what `spacearm plan` and `simulate` do.
void bind_model_runs(py::class_<PyModel>& model) {
  model.def("plan", &PyModel::plan, py::arg("start"), py::arg("goal"), py::arg("duration"),
            py::arg("dt") = 0.01, py::arg("time_law") = py::none(), py::arg("elbow") = 1,
            py::arg("q0") = py::none(), py::arg("params") = py::none(),
            py::arg("end_effector") = "", py::arg("hold") = "joints", py::arg("objective") = "line",
            py::arg("knots") = py::none(), py::arg("effort_weight") = py::none(),
            "The zero-momentum straight line of the end-effector from start to goal (x, y or x, y, "
            "phi; in 3D x, y, z or a pose x, y, z, qw, qx, qy, qz) in `duration` s, as `spacearm "
            "plan` (a tree: `end_effector` by name follows it, the others `hold` their 'joints' "
            "or their 'pose'; a list of names moves each along its own line at once, start and "
            "goal one row per name, time_law one or one per name): a dict of t, q, qd, qdd, "
            "tau (link side), "
            "tau_motor (geared), base_residual (free base) and 'columns', the CSV's columns by "
            "name, and its checks: min_jacobian_rcond (and _t), max_base_rotation and "
            "final_base_rotation (rad). objective='reactionless' holds a free base's angular "
            "velocity at zero (the reaction null space); 'min_base_rotation' and 'min_effort' "
            "go from rest to rest at the goal position by any path (IPOPT, `knots` intervals, "
            "default 50; min_base_rotation's `effort_weight`, default 1e-2), as plan --objective "
            "(on the scene compiled with "
            "its state Jacobian where it lacks it), and add goal_error, max_knot_error, "
            "iterations, solve_seconds and cost. An argument the objective does not use (knots, "
            "effort_weight, time_law) is a ValueError.");
  model.def(
      "simulate",
      [](const PyModel& m, const py::object& t_end, const py::object& torques, const py::object& q0,
         const py::object& qd0, const std::string& integrator, double dt, double dt_out,
         const std::string& interpolation, const std::string& extrapolate, const py::object& rtol,
         const py::object& atol, bool consistent_start, const py::object& plan,
         const std::string& feedforward, bool other_arm, const py::object& params) {
        const SimulateOptions o{integrator, interpolation, extrapolate, dt,
                                dt_out,     rtol,          atol,        consistent_start,
                                plan,       feedforward,   other_arm};
        // Without t_end, a plan's end.
        std::optional<double> end;
        if (!t_end.is_none()) {
          end = PyFloat_AsDouble(t_end.ptr());
          if (PyErr_Occurred()) {
            PyErr_Clear();
            throw py::type_error("t_end: a number");
          }
        }
        return m.simulate(end, torques, q0, qd0, o, params);
      },
      py::arg("t_end") = py::none(), py::arg("torques") = py::none(), py::arg("q0") = py::none(),
      py::arg("qd0") = py::none(), py::arg("integrator") = "auto", py::arg("dt") = 0.01,
      py::arg("dt_out") = 0.0, py::arg("interpolation") = "linear",
      py::arg("extrapolate") = "error", py::arg("rtol") = py::none(), py::arg("atol") = py::none(),
      py::arg("consistent_start") = false, py::arg("plan") = py::none(),
      py::arg("feedforward") = "none", py::arg("other_arm") = false, py::arg("params") = py::none(),
      "Integrate the dynamics from (q0, qd0) (zero by default) to t_end under joint torques "
      "sampled on a uniform grid (an array (k, 1 + N): t, tau1..N, link side; None: no "
      "torque), as `spacearm simulate`: a dict of t, q, qd, 'columns' (the CSV's columns "
      "by name) and 'integrator' (what auto chose, and why). plan= (a plan file or the dict "
      "of model.plan(), made on this model or its rigid twin) replays it: its start mapped "
      "to this model's coordinates, its torques, t_end its end by default; "
      "feedforward='friction' adds this model's friction along the planned rates. A plan whose "
      "end effector this model puts elsewhere (another arm) raises ValueError unless "
      "other_arm=True (then a warning). A run that fails raises IntegrationError: its .t is "
      "the time reached, its .partial the dict of every row computed up to it.");
  model.def("closed_loop", &PyModel::closed_loop, py::arg("plan"), py::arg("controller") = "pd",
            py::arg("omega") = 20.0, py::arg("period") = 1e-3,
            py::arg("control_model") = static_cast<const PyModel*>(nullptr),
            py::arg("feedforward") = "plan", py::arg("dt_out") = 0.01,
            py::arg("params") = py::none(),
            "Track a plan (model.plan()'s dict or a plan file, made on this model or its rigid "
            "twin) in closed loop, sampled every `period` s with zero-order hold "
            "(runtime/joint_control.hpp). controller='pd': the plan's torques fed forward "
            "(feedforward='plan', 'friction' adds this model's friction, 'none') plus kp e + kd "
            "e' on the motor encoders' angles (qm / p), kp = omega^2, kd = 2 omega; "
            "'computed_torque': the inverse dynamics of control_model (this model by default) "
            "with the base free, for qdd_d + kd e' + kp e. Returns the dict simulate returns, "
            "every dt_out s (tau: the controller's torque).");
}

// Model.inspect and one method per output of the registry: model.mass_matrix(q), ...
void bind_model_outputs(py::class_<PyModel>& model) {
  model
      .def("inspect", &PyModel::inspect, py::arg("entry"), py::arg("latex") = false,
           py::arg("decimal") = false,
           "One symbolic entry as text (or LaTeX), e.g. model.inspect(\"M[3][4]\", latex=True): "
           "the closed form that `spacearm inspect` prints, grouped by velocities and parameters; "
           "for a spatial arm the statements that compute it.")
      .def("__repr__", &PyModel::repr);
  // Every output of the registry: model.mass_matrix(q), model.forward_dynamics(q, qd, Q), ...
  for (const OutputInfo& o : output_registry()) {
    std::string inputs;
    for (Input i : o.inputs) inputs += std::string(info(i).name) + ", ";
    const Output id = o.id;
    if (id == Output::forward_dynamics) {
      model.def(
          o.name,
          [id](const PyModel& m, const py::args& args, const py::object& params, bool pivots) {
            return m.call(id, args, params, pivots);
          },
          py::arg("params") = py::none(), py::arg("pivots") = false,
          (std::string(o.name) + "(" + inputs + "params=None, pivots=False): " + o.doc +
           " Returns qdd; with pivots=True a dict of qdd and the LDL^T pivots (pivots, "
           "scaled_pivots). Each input (n,) for one state or (k, n) for k states.")
              .c_str());
      continue;
    }
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

}  // namespace

void bind_study(py::module& module);  // study_binding.cpp

}  // namespace spacearm

PYBIND11_MODULE(_spacearm, module) {
  using namespace spacearm;
  module.doc() = "spacearm: exact dynamics of free-floating space manipulators, planar and spatial";
  py::register_exception<DynamicsError>(module, "DynamicsError", PyExc_ArithmeticError);
  py::register_exception<CompileError>(module, "CompileError", PyExc_RuntimeError);
  integration_error_type() =
      py::register_exception<IntegrationError>(module, "IntegrationError", PyExc_RuntimeError);
  bind_study(module);
  py::class_<PyModel> model(module, "Model");
  bind_model_facts(model);
  bind_model_tangent(model);
  bind_model_runs(model);
  bind_model_outputs(model);
  module.def("load", &load, py::arg("scene"), py::arg("params") = py::none(),
             py::arg("cache_dir") = "", py::arg("engine") = "auto",
             "Compile (or take from the cache) and load the model of a scene: a path to a scene "
             "file or its YAML text. params: a dict of parameter values (default: the scene's). "
             "engine: 'auto' (the interpreter at once while the library compiles in the "
             "background, then the compiled code: the same numbers), 'interpreter' or "
             "'compiled' (wait for the compiler).");
}
