#include "numeric_outputs.hpp"

#include <Eigen/Dense>

#include <stdexcept>

#include "planar_chain.hpp"

namespace spacearm {

namespace {

std::vector<double> values(const Eigen::VectorXd& v) {
  return std::vector<double>(v.data(), v.data() + v.size());
}

struct State {
  std::vector<double> q, qd, params;
};

// Output o by the recursive algorithms run in double (extra: its input besides q and qd), each
// result shaped as the registry says (T is 1 x 1, h is 3 x 1), row by row.
std::vector<Eigen::MatrixXd> recursive_values(const SymbolicModel& model, Output o, const State& s,
                                              const Eigen::VectorXd& extra) {
  auto input = [&](const std::string& a, int i) {
    return a == "q"        ? s.q.at(i)
           : a == "qd"     ? s.qd.at(i)
           : a == "params" ? s.params.at(i)
                           : extra[i];
  };
  const std::vector<std::vector<double>> v = evaluate_recursive(model.scene, o, input);
  const Dimensions dims = model.scene.dimensions();
  std::vector<Eigen::MatrixXd> results;
  for (size_t k = 0; k < v.size(); ++k) {
    const ResultInfo& shape = info(o).results.at(k);
    results.push_back(
        Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
            v[k].data(), dims(shape.rows), dims(shape.cols)));
  }
  return results;
}

Eigen::MatrixXd closed_form(const SymbolicModel& model, Output o, const State& s) {
  if (!model.outputs.count(o) && has_recursive_form(o))  // derived only recursively
    return recursive_values(model, o, s, Eigen::VectorXd())[0];
  const GiNaC::matrix& e = model.expression(o);
  const auto v = evaluate(model, e, s.q, s.qd, s.params);
  return Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
      v.data(), e.rows(), e.cols());
}

// The composed outputs, as outputs.cpp describes them, with Eigen's solvers.
std::vector<Eigen::MatrixXd> composed(const SymbolicModel& model, Output o, const State& s,
                                      const Eigen::VectorXd& extra) {
  const int rows = static_cast<int>(model.residual_dq.rows());
  if (o == Output::forward_dynamics_derivatives && rows != model.n())  // derived only recursively
    return recursive_values(model, o, s, extra);
  const Eigen::MatrixXd M = closed_form(model, Output::mass_matrix, s);
  const int n = model.n(), N = model.scene.num_links(), nb = n - N;
  if (o == Output::generalized_jacobian) {
    const Eigen::MatrixXd J = closed_form(model, Output::end_effector_jacobian, s);
    return {J.rightCols(N) -
            J.leftCols(nb) * M.topLeftCorner(nb, nb).ldlt().solve(M.topRightCorner(nb, N))};
  }
  Eigen::VectorXd b = closed_form(model, Output::bias_forces, s);
  if (model.has_passive_forces()) {  // springs, dampers, friction: M qdd + b + these = Q
    const std::vector<double> f = evaluate(model, model.passive_forces, s.q, s.qd, s.params);
    b += Eigen::Map<const Eigen::VectorXd>(f.data(), n);
  }
  if (o == Output::inverse_dynamics) return {M * extra + b};
  if (o == Output::forward_dynamics) {
    // Unpivoted pivots D_j = L_jj^2 of M = L L^T, and D_j / M_jj (Eigen's Cholesky: the
    // generated code's own LDL^T is what this checks).
    const Eigen::LLT<Eigen::MatrixXd> llt(M);
    if (llt.info() != Eigen::Success)
      throw std::runtime_error("model " + model.scene.name +
                               ": mass matrix is not positive definite");
    const Eigen::VectorXd d = llt.matrixLLT().diagonal().array().square();
    return {llt.solve(Eigen::VectorXd(extra - b)), d, d.cwiseQuotient(M.diagonal())};
  }
  if (o == Output::forward_dynamics_derivatives) {
    // dqdd/dx = -M^-1 dR/dx, dR/dx evaluated with GiNaC at the solved qdd.
    const Eigen::LDLT<Eigen::MatrixXd> ldlt(M);
    const Eigen::VectorXd qdd = ldlt.solve(extra - b);
    GiNaC::exmap at_qdd;
    for (int j = 0; j < n; ++j) at_qdd[model.qdd[j]] = GiNaC::numeric(qdd[j]);
    auto minus_solve = [&](const GiNaC::matrix& dR) {
      const auto v =
          evaluate(model, GiNaC::ex_to<GiNaC::matrix>(dR.subs(at_qdd)), s.q, s.qd, s.params);
      const Eigen::MatrixXd d =
          Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
              v.data(), n, n);
      return Eigen::MatrixXd(-ldlt.solve(d));
    };
    // dqdd/dtau: M^-1's actuated columns over p (Q = tau / p, eq. 14).
    Eigen::MatrixXd by_torque(n, N);
    for (int j = 0; j < N; ++j) {
      Eigen::VectorXd unit = Eigen::VectorXd::Zero(n);
      unit[model.scene.motor_coordinate(j)] =
          1 / evaluate(model, model.ratios[j], s.q, s.qd, s.params);
      by_torque.col(j) = ldlt.solve(unit);
    }
    return {minus_solve(model.residual_dq), minus_solve(model.residual_dqd), qdd, by_torque};
  }
  if (o == Output::free_base_inverse_dynamics) {
    // extra: link-side joint accelerations; the motor ones are p times them, and tau = p Q.
    Eigen::VectorXd p(N);
    for (int j = 0; j < N; ++j)
      p[j] = 1 / evaluate(model, model.gear_map(nb + j, nb + j), s.q, s.qd, s.params);
    const Eigen::VectorXd a = extra.cwiseProduct(p);
    const Eigen::VectorXd base =
        -M.topLeftCorner(nb, nb).ldlt().solve(M.topRightCorner(nb, N) * a + b.head(nb));
    const Eigen::VectorXd Q =
        M.bottomLeftCorner(N, nb) * base + M.bottomRightCorner(N, N) * a + b.tail(N);
    return {Q.cwiseProduct(p), base};
  }
  throw std::logic_error("evaluate_output: no numeric composition for " + to_string(o));
}

}  // namespace

std::vector<Eigen::MatrixXd> evaluate_output(const SymbolicModel& model, Output output,
                                             const std::vector<Eigen::VectorXd>& inputs,
                                             const Eigen::VectorXd& params) {
  const OutputInfo& o = info(output);
  if (inputs.size() != o.inputs.size())
    throw std::invalid_argument("evaluate_output: wrong number of inputs");
  State s{std::vector<double>(model.n(), 0.0), std::vector<double>(model.n(), 0.0), values(params)};
  Eigen::VectorXd extra;  // qdd, Q or qdd_joints
  for (size_t i = 0; i < inputs.size(); ++i) {
    if (o.inputs[i] == Input::q)
      s.q = values(inputs[i]);
    else if (o.inputs[i] == Input::qd)
      s.qd = values(inputs[i]);
    else
      extra = inputs[i];
  }
  if (o.composed_of.empty()) return {closed_form(model, output, s)};
  return composed(model, output, s, extra);
}

}  // namespace spacearm
