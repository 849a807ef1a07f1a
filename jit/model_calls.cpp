// Calling a loaded model: each exported function behind checks of its inputs (sizes,
// finiteness, the parameters' ranges) and of its results, and the model as a source of the
// runtime's one adapter (LoadedSource). Loading it is compiled_model.cpp's.
#include <cmath>
#include <sstream>
#include <string>
#include <string_view>
#include <tuple>

#include "compiled_model.hpp"
#include "dynamics_checks.hpp"
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
  // The base's orientation is normalized by the model (spatial_chain.hpp): any quaternion of a
  // norm that squares without under- or overflow is a rotation.
  const int k = quaternion_offset_;
  if (k >= 0 && std::string_view(what) == "q") {
    const double norm = v.segment(k, 4).norm();
    if (!(norm >= 1e-6 && norm <= 1e6)) {
      std::ostringstream m;
      m << "q[" << k << ".." << k + 3 << "], the base's orientation quaternion (w, x, y, z), has "
        << "norm " << norm << ": expected a unit quaternion";
      throw std::invalid_argument(m.str());
    }
  }
}

// Calls an exported function with checked parameters; results sized by `shapes`.
std::vector<Eigen::MatrixXd> CompiledModel::call(const std::string& function,
                                                 const std::vector<std::pair<Size, Size>>& shapes,
                                                 const std::vector<const double*>& inputs,
                                                 const Eigen::VectorXd& params) const {
  check("params", params, static_cast<int>(nominal_.size()));
  if (const char* error = parameter_error_(params.data()))
    throw std::invalid_argument(std::string("parameters: ") + error);
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

void CompiledModel::evaluate_batch(Output o, long k, const std::vector<const double*>& inputs,
                                   const Eigen::VectorXd& params,
                                   const std::vector<double*>& results) const {
  const OutputInfo& out = info(o);
  const Function f = function(o);
  if (inputs.size() != out.inputs.size() || results.size() != out.results.size())
    throw std::invalid_argument(std::string(out.name) + ": wrong number of inputs or results");
  check("params", params, static_cast<int>(nominal_.size()));
  if (const char* error = parameter_error_(params.data()))
    throw std::invalid_argument(std::string("parameters: ") + error);
  // One state's results in the generated code's layout (column-major), then row-major.
  std::vector<Eigen::MatrixXd> state;
  std::vector<double*> state_out;
  for (const auto& r : out.results) state.emplace_back(dims_(r.rows), dims_(r.cols));
  for (auto& r : state) state_out.push_back(r.data());
  std::vector<const double*> in(inputs.size());
  for (long s = 0; s < k; ++s)
    for_state(s, k > 1, [&] {
      for (size_t i = 0; i < in.size(); ++i) {
        const int n = dims_(info(out.inputs[i]).size);
        in[i] = inputs[i] + s * n;
        check(info(out.inputs[i]).name, Eigen::Map<const Eigen::VectorXd>(in[i], n), n);
      }
      f(in.data(), params.data(), state_out.data());
      if (o == Output::forward_dynamics) check_forward_dynamics(state, name_);
      for (size_t r = 0; r < state.size(); ++r) {
        if (!all_finite(state[r]))  // as eval's: no overflow passes as a number
          throw DynamicsError(std::string(out.results[r].name) +
                              " is not finite: the state or parameters overflow");
        const Eigen::Index size = state[r].size();
        Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
            results[r] + s * size, state[r].rows(), state[r].cols()) = state[r];
      }
    });
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
    const Eigen::VectorXd& params, Eigen::MatrixXd& dqdd_dq, Eigen::MatrixXd& dqdd_dqd) const {
  auto r = evaluate(Output::forward_dynamics_derivatives, {q, qd, Q}, params);
  for (const auto& part : r)
    if (!part.allFinite())
      throw DynamicsError("model " + name_ +
                          ": the state Jacobian is not finite (mass matrix singular?)");
  dqdd_dq = std::move(r[0]);
  dqdd_dqd = std::move(r[1]);
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
  return f;
}

}  // namespace spacearm
