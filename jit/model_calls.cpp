// Calling a loaded model: each exported function behind checks of its inputs (sizes,
// finiteness, the parameters' ranges) and of its results, and the model as a source of the
// runtime's one adapter (LoadedSource). Loading it is compiled_model.cpp's.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <string>
#include <string_view>
#include <tuple>

#include "compiled_model.hpp"
#include "dynamics_checks.hpp"
#include "lane_layout.hpp"
#include "parameter_rules.hpp"
#include "outputs.hpp"

namespace spacearm {

bool CompiledModel::has(Output o) const { return (outputs_ & output_bit(o)) != 0; }

CompiledModel::Function CompiledModel::function(Output o) const {
  if (!has(o))
    throw std::invalid_argument("the scene does not emit '" + std::string(info(o).name) +
                                "' (add it to outputs)");
  return functions_.at(info(o).name);
}

CompiledModel::Function CompiledModel::lanes_function(Output o) const {
  const auto f = lanes_functions_.find(info(o).name);
  return has(o) && f != lanes_functions_.end() ? f->second : nullptr;
}

CompiledModel::Function CompiledModel::function(const std::string& name) const {
  const auto f = functions_.find(name);
  if (f == functions_.end())
    throw std::invalid_argument("the model does not export '" + name + "'");
  return f->second;
}

void CompiledModel::check(const char* what, Eigen::Ref<const Eigen::VectorXd> v, int size) const {
  if (v.size() != size)
    throw std::invalid_argument(std::string(what) + ": expected " + std::to_string(size) +
                                " values, got " + std::to_string(v.size()));
  for (int i = 0; i < size; ++i)
    if (!std::isfinite(v[i]))
      throw std::invalid_argument(std::string(what) + "[" + std::to_string(i) +
                                  "] is not finite: " + std::to_string(v[i]));
  // The base's orientation is normalized by the model: ConfigurationSpace says which norms.
  const int k = quaternion_offset_;
  if (k >= 0 && std::string_view(what) == "q") {
    const double norm = v.segment(k, 4).norm();
    if (!ConfigurationSpace::takes_quaternion_norm(norm)) {
      std::ostringstream m;
      m << "q[" << k << ".." << k + 3 << "], the base's orientation quaternion (w, x, y, z), has "
        << "norm " << norm << ": expected a unit quaternion";
      throw std::invalid_argument(m.str());
    }
  }
}

void CompiledModel::check_parameters(const Eigen::VectorXd& params) const {
  check("params", params, static_cast<int>(nominal_.size()));
  // Out of range a value would surface later as an unnamed failure (a mass matrix not
  // positive definite).
  const std::vector<double> values(params.data(), params.data() + params.size());
  if (const std::string e = parameter_range_error(parameter_names_, values); !e.empty())
    throw std::invalid_argument("parameters: " + e);
  if (const char* error = parameter_error(params.data())) {
    // The rule names the field; the values that moved from the nominal ones say why.
    const std::string moved = moved_parameters(parameter_names_, nominal_, values);
    throw std::invalid_argument(std::string("parameters: ") + error +
                                (moved.empty() ? "" : " (given " + moved + ")"));
  }
}

std::string CompiledModel::value_span(const Eigen::VectorXd& params) const {
  const bool sized = params.size() == static_cast<Eigen::Index>(nominal_.size());
  return spacearm::value_span(span_fields_, sized ? params.data() : nullptr, parameter_names_);
}

std::string CompiledModel::span_note(const Eigen::VectorXd& params) const {
  if (params.size() != static_cast<Eigen::Index>(nominal_.size())) return "";
  const double nominal = span_decades(span_fields_, nullptr),
               now = span_decades(span_fields_, params.data());
  if (now < std::log10(kNotableSpan) || now < nominal + 1) return "";
  char widened[120];
  std::snprintf(widened, sizeof widened, "from %.0f decades at the nominal values",
                std::floor(nominal));
  return ". The run-time parameters widen the model's span of values to " + value_span(params) +
         " (" + widened +
         "); double precision may not hold it: choose values that bring them "
         "closer";
}

// Calls an exported function with checked parameters; results sized by `shapes`.
std::vector<Eigen::MatrixXd> CompiledModel::call(const std::string& function,
                                                 const std::vector<std::pair<Size, Size>>& shapes,
                                                 const std::vector<const double*>& inputs,
                                                 const Eigen::VectorXd& params) const {
  check_parameters(params);
  std::vector<Eigen::MatrixXd> results;
  std::vector<double*> out;
  for (const auto& [rows, cols] : shapes) results.emplace_back(dims_(rows), dims_(cols));
  for (auto& r : results) out.push_back(r.data());
  functions_.at(function)(inputs.data(), params.data(), out.data());
  return results;
}

std::vector<Eigen::MatrixXd> CompiledModel::evaluate(Output o,
                                                     const std::vector<Eigen::VectorXd>& inputs,
                                                     const Eigen::VectorXd& params) const {
  const OutputInfo& out = info(o);
  if (!has(o))
    throw std::invalid_argument("the scene does not emit '" + std::string(out.name) +
                                "' (add it to outputs)");
  if (inputs.size() != out.inputs.size())
    throw std::invalid_argument(std::string(out.name) + " takes " +
                                std::to_string(out.inputs.size()) + " inputs, got " +
                                std::to_string(inputs.size()));
  std::vector<const double*> data;
  for (size_t i = 0; i < inputs.size(); ++i) {
    check(info(out.inputs[i]).name, inputs[i], dims_(info(out.inputs[i]).size));
    data.push_back(inputs[i].data());
  }
  std::vector<std::pair<Size, Size>> shapes;
  for (const auto& r : out.results) shapes.push_back({r.rows, r.cols});
  return call(out.name, shapes, data, params);
}

namespace {

// Runs f, naming the state of a batch in any error it throws (in the error's own type).
template <class F>
void for_state(long s, bool batch, F&& f) {
  if (!batch) return f();
  try {
    f();
  } catch (const DynamicsError& e) {
    throw DynamicsError("state " + std::to_string(s) + ": " + e.what());
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument("state " + std::to_string(s) + ": " + e.what());
  }
}

}  // namespace

// One batched evaluation's states on workspaces allocated once: the scalar path and the 4-lane
// path, both writing straight into the caller's arrays (a vector's row-major layout is its own;
// a matrix is transposed from the generated code's column-major). The checks are evaluate()'s on
// the inputs and eval's on the results, as one pass/fail test per state; a state that fails is
// checked again by the code that names what failed.
class CompiledModel::BatchCall {
 public:
  BatchCall(const CompiledModel& m, Output o, Function f, const Eigen::VectorXd& params,
            const std::vector<const double*>& inputs, const std::vector<double*>& results,
            bool batch)
      : m_(m),
        o_(o),
        out_(info(o)),
        f_(f),
        params_(params),
        inputs_(inputs),
        results_(results),
        batch_(batch),
        in_(inputs.size()),
        out_ptr_(results.size()) {
    for (Input i : out_.inputs) {
      sizes_.push_back(m.dims_(info(i).size));
      quaternion_.push_back(i == Input::q && m.quaternion_offset_ >= 0);
      has_quaternion_ = has_quaternion_ || quaternion_.back();
    }
    for (size_t r = 0; r < out_.results.size(); ++r) {
      rows_.push_back(m.dims_(out_.results[r].rows));
      cols_.push_back(m.dims_(out_.results[r].cols));
      scratch_.emplace_back(cols_.back() > 1 ? rows_.back() * cols_.back() : 0);
      // A result not kept goes to room for one group of four states, in cache.
      discard_.emplace_back(results_[r] ? 0 : 4 * rows_.back() * cols_.back());
    }
  }

  // States from .. to - 1 by the scalar function; std::invalid_argument or DynamicsError naming
  // the first that fails. The inputs are tested a run of states at a time (one sum each), and
  // state by state only in a run that fails. State s's results are checked after state s + 1 is
  // evaluated: the generated code has just stored them one by one, and the checks' paired loads
  // would wait for those stores to reach the cache. A state's results are still checked before
  // the next state's inputs, so the first failing state is the one named.
  void scalar(long from, long to) {
    constexpr long kRun = 16;
    long pending = -1;  // evaluated, its results not yet checked
    for (long run = from; run < to; run += kRun) {
      const long end = std::min(to, run + kRun);
      const bool run_ok = inputs_ok(run, end);
      for (long s = run; s < end; ++s) {
        if (!run_ok && !inputs_ok(s, s + 1)) {
          if (pending >= 0) finish(pending);
          check_inputs(s);  // throws, naming it
        }
        evaluate(s);
        if (pending >= 0) finish(pending);
        pending = s;
      }
    }
    if (pending >= 0) finish(pending);
  }

  // States s .. s + 3 by the 4-lane function; false where a check fails (the caller takes them
  // again one by one, which names the first that fails).
  bool four(Function lanes, long s) {
    if (lane_in_.empty()) {
      for (int n : sizes_) lane_in_.emplace_back(4 * n);
      for (size_t r = 0; r < rows_.size(); ++r) lane_out_.emplace_back(4 * rows_[r] * cols_[r]);
      for (double v : params_) lane_params_.insert(lane_params_.end(), 4, v);
      for (auto& v : lane_in_) lane_in_ptr_.push_back(v.data());
      for (auto& v : lane_out_) lane_out_ptr_.push_back(v.data());
    }
    for (size_t i = 0; i < in_.size(); ++i)
      if (!lanes::interleave(inputs_[i] + s * sizes_[i], sizes_[i], lane_in_[i].data()))
        return false;
    for (int l = 0; l < 4 && has_quaternion_; ++l)
      if (!quaternion_ok(s + l)) return false;
    prefetch(s + 4, 4);  // while the function computes: a batch streams through memory
    lanes(lane_in_ptr_.data(), lane_params_.data(), lane_out_ptr_.data());
    // results_ok's test: every result finite (seen as it moves) and, for forward dynamics, the
    // pivots within bounds (which no inf or NaN is). Pivots not kept are tested where they are,
    // in the lanes' layout: the test pairs entries, in any one layout.
    const bool fd = o_ == Output::forward_dynamics;
    const bool pivots_in_lanes = fd && !results_[1] && !results_[2];
    bool finite = true;
    for (size_t r = 0; r < rows_.size(); ++r) {
      if (pivots_in_lanes && r > 0) continue;
      const int rows = rows_[r], cols = cols_[r];
      const double* lane = lane_out_[r].data();
      double* to = at(r, s);  // the four states' results follow each other
      const int size = rows * cols;
      if (cols == 1) {
        finite &= lanes::deinterleave(lane, rows, to);
      } else {
        for (int l = 0; l < 4; ++l)
          for (int i = 0; i < rows; ++i)
            for (int j = 0; j < cols; ++j)
              to[l * size + i * cols + j] = lane[4 * (j * rows + i) + l];
        finite &= all_finite_array(to, 4L * size);
      }
    }
    if (!fd) return finite;
    const double* d = pivots_in_lanes ? lane_out_[1].data() : at(1, s);
    const double* scaled = pivots_in_lanes ? lane_out_[2].data() : at(2, s);
    return finite && lanes::pivots_within_bounds(d, scaled, 4L * rows_[1]);
  }

 private:
  // evaluate()'s input test on states from .. to - 1, pass or fail.
  bool inputs_ok(long from, long to) {
    bool finite = true;
    for (size_t i = 0; i < in_.size(); ++i)
      finite = finite && all_finite_array(inputs_[i] + from * sizes_[i], (to - from) * sizes_[i]);
    for (long s = from; s < to && finite && has_quaternion_; ++s) finite = quaternion_ok(s);
    return finite;
  }
  // State s by the scalar function, into at(r, s).
  void evaluate(long s) {
    for (size_t i = 0; i < in_.size(); ++i) in_[i] = inputs_[i] + s * sizes_[i];
    for (size_t r = 0; r < out_ptr_.size(); ++r)
      out_ptr_[r] = cols_[r] > 1 ? scratch_[r].data() : at(r, s);
    f_(in_.data(), params_.data(), out_ptr_.data());
    for (size_t r = 0; r < out_ptr_.size(); ++r)
      if (cols_[r] > 1)  // column-major to row-major
        for (int i = 0; i < rows_[r]; ++i)
          for (int j = 0; j < cols_[r]; ++j)
            at(r, s)[i * cols_[r] + j] = scratch_[r][j * rows_[r] + i];
  }
  void finish(long s) {
    if (!results_ok(s)) check_results(s);  // throws, naming what
  }
  // Where state s's result r goes: the caller's array, or the room of a result not kept (the
  // checks read it before the same room is written again, four states later).
  double* at(size_t r, long s) {
    return results_[r] ? results_[r] + s * rows_[r] * cols_[r]
                       : discard_[r].data() + (s & 3) * rows_[r] * cols_[r];
  }
  // The cache lines of states s .. s + count - 1, inputs to read and results to write.
  void prefetch(long s, int count) {
    for (size_t i = 0; i < in_.size(); ++i)
      for (long b = 0; b < count * sizes_[i]; b += 8)
        __builtin_prefetch(inputs_[i] + s * sizes_[i] + b);
    for (size_t r = 0; r < rows_.size(); ++r)
      if (results_[r])
        for (long b = 0; b < count * rows_[r] * cols_[r]; b += 8)
          __builtin_prefetch(at(r, s) + b, 1);
  }
  // As CompiledModel::check, in its expression (a fixed-size norm may round differently): a
  // base quaternion of a norm the model takes.
  bool quaternion_ok(long s) const {
    for (size_t i = 0; i < in_.size(); ++i) {
      if (!quaternion_[i]) continue;
      const double norm = Eigen::Map<const Eigen::VectorXd>(inputs_[i] + s * sizes_[i], sizes_[i])
                              .segment(m_.quaternion_offset_, 4)
                              .norm();
      if (!ConfigurationSpace::takes_quaternion_norm(norm)) return false;
    }
    return true;
  }
  // check_forward_dynamics' test and eval's (every result finite), on the results of state s.
  // Forward dynamics: qdd finite and each pivot within its bounds, which no inf or NaN is. (four()
  // makes the same test.)
  bool results_ok(long s) {
    if (o_ != Output::forward_dynamics) {
      bool ok = true;
      for (size_t r = 0; r < rows_.size(); ++r)
        ok = ok && all_finite_array(at(r, s), rows_[r] * cols_[r]);
      return ok;
    }
    return all_pivots_within_bounds(at(1, s), at(2, s), rows_[1]) &&
           all_finite_array(at(0, s), rows_[0]);
  }
  // The checks that name what failed (evaluate()'s and eval's); they throw.
  void check_inputs(long s) const {
    for_state(s, batch_, [&] {
      for (size_t i = 0; i < in_.size(); ++i)
        m_.check(info(out_.inputs[i]).name,
                 Eigen::Map<const Eigen::VectorXd>(inputs_[i] + s * sizes_[i], sizes_[i]),
                 sizes_[i]);
    });
  }
  void check_results(long s) {
    for_state(s, batch_, [&] {
      using Map = Eigen::Map<const Eigen::VectorXd>;
      if (o_ == Output::forward_dynamics)
        check_forward_dynamics(Map(at(1, s), rows_[1]), Map(at(2, s), rows_[2]),
                               Map(at(0, s), rows_[0]), m_.name_);
      for (size_t r = 0; r < rows_.size(); ++r)
        if (!all_finite(Map(at(r, s), rows_[r] * cols_[r])))
          throw DynamicsError(std::string(out_.results[r].name) +
                              " is not finite: the state or parameters overflow");
    });
  }

  const CompiledModel& m_;
  Output o_;
  const OutputInfo& out_;
  Function f_;
  const Eigen::VectorXd& params_;
  const std::vector<const double*>& inputs_;
  const std::vector<double*>& results_;
  bool batch_;
  std::vector<const double*> in_;
  std::vector<double*> out_ptr_;
  std::vector<int> sizes_, rows_, cols_;
  std::vector<bool> quaternion_;
  bool has_quaternion_ = false;
  std::vector<std::vector<double>> scratch_, discard_, lane_in_, lane_out_;
  std::vector<double> lane_params_;
  std::vector<const double*> lane_in_ptr_;
  std::vector<double*> lane_out_ptr_;
};

void CompiledModel::evaluate_batch(Output o, long k, const std::vector<const double*>& inputs,
                                   const Eigen::VectorXd& params,
                                   const std::vector<double*>& results, int lanes) const {
  const OutputInfo& out = info(o);
  const Function f = function(o);
  if (inputs.size() != out.inputs.size() || results.size() != out.results.size())
    throw std::invalid_argument(std::string(out.name) + ": wrong number of inputs or results");
  check_parameters(params);
  BatchCall call(*this, o, f, params, inputs, results, k > 1);
  long s = 0;
  // Four states per call where the model has the 4-lane function: each lane's bits are the
  // scalar function's, so a group that fails a check is taken again state by state, which
  // names the first failing state as the scalar path does.
  if (const Function four = lanes == 4 ? lanes_function(o) : nullptr)
    for (; s + 4 <= k; s += 4)
      if (!call.four(four, s)) call.scalar(s, s + 4);
  call.scalar(s, k);
}

Eigen::MatrixXd CompiledModel::mass_matrix(const Eigen::VectorXd& q,
                                           const Eigen::VectorXd& params) const {
  return evaluate(Output::mass_matrix, {q}, params)[0];
}
Eigen::VectorXd CompiledModel::bias_forces(const Eigen::VectorXd& q, const Eigen::VectorXd& qd,
                                           const Eigen::VectorXd& params) const {
  return evaluate(Output::bias_forces, {q, qd}, params)[0];
}
void CompiledModel::mass_matrix_and_bias(const Eigen::VectorXd& q, const Eigen::VectorXd& qd,
                                         const Eigen::VectorXd& params, Eigen::MatrixXd& M,
                                         Eigen::VectorXd& b) const {
  if (!has(Output::mass_matrix) || !has(Output::bias_forces))
    throw std::invalid_argument(
        "the scene does not emit mass_matrix and bias_forces (add them to outputs)");
  check("q", q, dims_.nq);
  check("qd", qd, dims_.nv);
  auto r = call(kMassMatrixAndBias, {{Size::nv, Size::nv}, {Size::nv, Size::one}},
                {q.data(), qd.data()}, params);
  M = std::move(r[0]);
  b = std::move(r[1]);
}
double CompiledModel::kinetic_energy(const Eigen::VectorXd& q, const Eigen::VectorXd& qd,
                                     const Eigen::VectorXd& params) const {
  return evaluate(Output::kinetic_energy, {q, qd}, params)[0](0, 0);
}
Eigen::VectorXd CompiledModel::momentum(const Eigen::VectorXd& q, const Eigen::VectorXd& qd,
                                        const Eigen::VectorXd& params) const {
  return evaluate(Output::momentum, {q, qd}, params)[0];
}
Eigen::VectorXd CompiledModel::end_effector_pose(const Eigen::VectorXd& q,
                                                 const Eigen::VectorXd& params) const {
  return evaluate(Output::end_effector_pose, {q}, params)[0];
}
Eigen::MatrixXd CompiledModel::end_effector_jacobian(const Eigen::VectorXd& q,
                                                     const Eigen::VectorXd& params) const {
  return evaluate(Output::end_effector_jacobian, {q}, params)[0];
}
double CompiledModel::potential_energy(const Eigen::VectorXd& q,
                                       const Eigen::VectorXd& params) const {
  return evaluate(Output::potential_energy, {q}, params)[0](0, 0);
}
Eigen::VectorXd CompiledModel::friction_forces(const Eigen::VectorXd& qd,
                                               const Eigen::VectorXd& params) const {
  return evaluate(Output::friction_forces, {qd}, params)[0];
}
bool CompiledModel::has_forward_dynamics() const {
  return spacearm::has_forward_dynamics([this](Output o) { return has(o); }, passive_forces_);
}
Eigen::VectorXd CompiledModel::forward_dynamics_derivatives(
    const Eigen::VectorXd& q, const Eigen::VectorXd& qd, const Eigen::VectorXd& Q,
    const Eigen::VectorXd& params, Eigen::MatrixXd& dqdd_dq, Eigen::MatrixXd& dqdd_dqd,
    Eigen::MatrixXd* dqdd_dtau) const {
  auto r = evaluate(Output::forward_dynamics_derivatives, {q, qd, Q}, params);
  for (const auto& part : r)
    if (!part.allFinite())
      throw DynamicsError("model " + name_ +
                          ": the state Jacobian is not finite (mass matrix singular?)");
  dqdd_dq = std::move(r[0]);
  dqdd_dqd = std::move(r[1]);
  if (dqdd_dtau) *dqdd_dtau = std::move(r[3]);
  return r[2];
}
Eigen::VectorXd CompiledModel::forward_dynamics(const Eigen::VectorXd& q, const Eigen::VectorXd& qd,
                                                const Eigen::VectorXd& Q,
                                                const Eigen::VectorXd& params) const {
  // Wrong sizes are the caller's error; non-finite values one of the dynamics (as Model<G>'s).
  for (const auto& [what, v, size] :
       {std::tuple{"q", &q, dims_.nq}, std::tuple{"qd", &qd, dims_.nv},
        std::tuple{"Q", &Q, dims_.nv}})
    if (v->size() != size)
      throw std::invalid_argument(std::string(what) + ": expected " + std::to_string(size) +
                                  " values, got " + std::to_string(v->size()));
  check_finite_inputs(q, qd, Q, name_, coordinate_names_);
  Eigen::VectorXd qdd, pivots, scaled_pivots;
  if (has(Output::forward_dynamics)) {
    const auto r = evaluate(Output::forward_dynamics, {q, qd, Q}, params);
    qdd = r[0];
    pivots = r[1];
    scaled_pivots = r[2];
  } else {
    if (passive_forces_)
      throw std::invalid_argument("model " + name_ +
                                  ": a scene with springs, dampers or friction needs the "
                                  "forward_dynamics output for its forward dynamics");
    Eigen::MatrixXd M;
    Eigen::VectorXd b;
    mass_matrix_and_bias(q, qd, params, M, b);
    qdd = cholesky_forward_dynamics(M, Eigen::VectorXd(Q - b), name_, pivots, scaled_pivots);
  }
  check_forward_dynamics(pivots, scaled_pivots, qdd, name_);
  return qdd;
}

CompiledModel::ForwardDynamicsCall::ForwardDynamicsCall(const CompiledModel& m,
                                                        Eigen::VectorXd params)
    : m_(&m), params_(std::move(params)), pivots_(m.nv()), scaled_pivots_(m.nv()) {
  m.check_parameters(params_);
  if (m.has(Output::forward_dynamics)) emitted_ = m.function(Output::forward_dynamics);
}

void CompiledModel::ForwardDynamicsCall::operator()(const double* q, const double* qd,
                                                    const double* Q, double* qdd) {
  const int nq = m_->nq(), nv = m_->nv(), k = m_->quaternion_offset_;
  using Map = Eigen::Map<const Eigen::VectorXd>;
  if (emitted_) {
    const double* in[3] = {q, qd, Q};
    double* out[3] = {qdd, pivots_.data(), scaled_pivots_.data()};
    emitted_(in, params_.data(), out);
    // forward_dynamics()'s checks, in one test: finite inputs, a quaternion of a norm the
    // model takes (the same expression as check()'s), finite accelerations, pivots in bounds.
    bool ok = all_finite_array(q, nq) & all_finite_array(qd, nv) & all_finite_array(Q, nv) &
              all_finite_array(qdd, nv);
    ok &= all_pivots_within_bounds(pivots_.data(), scaled_pivots_.data(), nv);
    if (k >= 0)
      ok = ok && ConfigurationSpace::takes_quaternion_norm(Map(q, nq).segment(k, 4).norm());
    if (ok) return;
  }
  // The checked call: it throws the error that names what failed.
  Eigen::Map<Eigen::VectorXd> out(qdd, nv);
  out = m_->forward_dynamics(Map(q, nq), Map(qd, nv), Map(Q, nv), params_);
}

Eigen::VectorXd CompiledModel::gear_ratios(const Eigen::VectorXd& params) const {
  return call("gear_ratios", {{Size::num_links, Size::one}}, {}, params)[0];
}

void check_forward_dynamics(const std::vector<Eigen::MatrixXd>& results,
                            std::string_view model_name) {
  check_forward_dynamics(Eigen::VectorXd(results[1]), Eigen::VectorXd(results[2]),
                         Eigen::VectorXd(results[0]), model_name);
}

bool LoadedSource::has(F f) const {
  switch (f) {
    case F::end_effector_pose:
      return m_->has(Output::end_effector_pose);
    case F::end_effector_jacobian:
      return m_->has(Output::end_effector_jacobian);
    case F::mass_matrix_and_bias:
      return m_->has(Output::mass_matrix) && m_->has(Output::bias_forces);
    case F::forward_dynamics:
      return m_->has_forward_dynamics();
    case F::forward_dynamics_derivatives:
      return m_->has(Output::forward_dynamics_derivatives);
    case F::kinetic_energy:
      return m_->has(Output::kinetic_energy);
    case F::potential_energy:
      return m_->has(Output::potential_energy);
    case F::friction_forces:
      return m_->has(Output::friction_forces);
    case F::momentum:
      return m_->has(Output::momentum);
  }
  return false;
}

DynamicModelFacts LoadedSource::facts() const {
  DynamicModelFacts f;
  f.name = m_->name();
  f.nq = m_->nq();
  f.nv = m_->nv();
  f.num_links = m_->num_links();
  f.free_floating = m_->free_floating();
  f.coordinate_names = m_->coordinate_names();
  f.gear_ratios = m_->gear_ratios(params_);  // checks params (sizes, finite, ranges) once
  f.actuated_coordinates = m_->actuated_coordinates();
  f.motor_angle_slots = m_->motor_angle_slots();
  f.passive_forces = m_->passive_forces();
  f.base_velocities = m_->num_base();
  f.quaternion_offset = m_->quaternion_offset();
  f.spatial = m_->dimensions().spatial;
  if (m_->dimensions().num_end_effectors > 1) f.end_effector_names = m_->end_effector_names();
  return f;
}

}  // namespace spacearm
