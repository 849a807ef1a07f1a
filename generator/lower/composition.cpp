#include "composition.hpp"

#include <stdexcept>

#include "program_algebra.hpp"
#include "closed_forms.hpp"

namespace spacearm {

namespace {

// The ingredients (M, b, passive forces, J, the gear ratios) in a builder's program, from their
// closed forms or, where only those were derived, their recorded forms; and the block and row
// views the compositions below take of them (row-major vectors of node references).
struct Composer {
  const DerivedModel& derived;
  const ClosedForms& model;
  ExpressionBuilder& fb;
  Program& p = fb.program();
  const int n = derived.facts.dims.nv, N = derived.facts.dims.num_links, nb = n - N;
  std::vector<SRef> M;

  Composer(const DerivedModel& d, ExpressionBuilder& builder)
      : derived(d), model(*d.closed_forms), fb(builder), M(n * n) {
    if (!derived.has_closed_form(Output::mass_matrix)) {  // derived only recursively
      M = derived.recorded.at(Output::mass_matrix).record(p)[0];
      return;
    }
    const GiNaC::matrix& Me = model.expression(Output::mass_matrix);
    for (int i = 0; i < n; ++i)
      for (int j = i; j < n; ++j) M[i * n + j] = M[j * n + i] = fb.build(Me(i, j));
  }
  std::vector<SRef> block(int r0, int c0, int rows, int cols) const {
    std::vector<SRef> m;
    for (int i = 0; i < rows; ++i)
      for (int j = 0; j < cols; ++j) m.push_back(M[(r0 + i) * n + c0 + j]);
    return m;
  }
  static std::vector<SRef> row(const std::vector<SRef>& m, int cols, int i) {
    return std::vector<SRef>(m.begin() + i * cols, m.begin() + (i + 1) * cols);
  }
  std::vector<SRef> inputs(const char* name, int size) {
    std::vector<SRef> v;
    for (int i = 0; i < size; ++i) v.push_back(p.input(name, i));
    return v;
  }
  std::vector<SRef> bias() {
    if (!derived.has_closed_form(Output::bias_forces))
      return derived.recorded.at(Output::bias_forces).record(p)[0];
    std::vector<SRef> b;
    for (int i = 0; i < n; ++i) b.push_back(fb.build(model.expression(Output::bias_forces)(i, 0)));
    return b;
  }
  // Everything on the left of M qdd + ... = Q besides M qdd: the bias, and the spring, damper
  // and friction forces where the scene has them.
  std::vector<SRef> forces() {
    std::vector<SRef> h = bias();
    if (model.has_passive_forces())
      for (int i = 0; i < n; ++i) h[i] = p.add({h[i], fb.build(model.passive_forces(i, 0))});
    return h;
  }
  SRef gear_ratio(int j) { return fb.build((1 / model.gear_map(nb + j, nb + j)).normal()); }

  // J* = J_m - J_b X with M_bb X = M_bm, column by column.
  std::vector<std::vector<SRef>> generalized_jacobian() {
    const GiNaC::matrix& Je = model.expression(Output::end_effector_jacobian);
    const LdltProgram f = ldlt(p, block(0, 0, nb, nb), nb);
    const std::vector<SRef> Mbm = block(0, nb, nb, N);
    std::vector<std::vector<SRef>> X;  // columns
    for (int c = 0; c < N; ++c) {
      std::vector<SRef> col;
      for (int k = 0; k < nb; ++k) col.push_back(Mbm[k * N + c]);
      X.push_back(ldlt_solve(p, f, col));
    }
    std::vector<SRef> Jg;
    for (int r = 0; r < derived.facts.dims(Size::twist); ++r) {
      std::vector<SRef> Jb;
      for (int k = 0; k < nb; ++k) Jb.push_back(fb.build(Je(r, k)));
      for (int c = 0; c < N; ++c) Jg.push_back(p.add({fb.build(Je(r, nb + c)), -dot(p, Jb, X[c])}));
    }
    return {Jg};
  }

  // Q = M qdd + b (+ spring, damper and friction forces).
  std::vector<std::vector<SRef>> inverse_dynamics() {
    const std::vector<SRef> qdd = inputs("qdd", n), b = forces();
    std::vector<SRef> Q;
    for (int i = 0; i < n; ++i) Q.push_back(p.add({dot(p, row(M, n, i), qdd), b[i]}));
    return {Q};
  }

  // The right-hand side Q - b (- spring, damper, friction) of M qdd = ..., and M = L D L^T.
  LdltProgram factored(std::vector<SRef>& rhs) {
    const std::vector<SRef> Q = inputs("Q", n), b = forces();
    for (int i = 0; i < n; ++i) rhs.push_back(p.add({Q[i], -b[i]}));
    return ldlt(p, M, n);
  }

  // qdd = M^-1 (Q - b (- spring, damper, friction)), the pivots D and D_i / M_ii.
  std::vector<std::vector<SRef>> forward_dynamics() {
    std::vector<SRef> rhs, scaled;
    const LdltProgram f = factored(rhs);
    for (int i = 0; i < n; ++i) scaled.push_back(p.div(f.d[i], M[i * n + i]));
    return {ldlt_solve(p, f, rhs), f.d, scaled};
  }

  // qdd as forward_dynamics; then each column of dqdd/dq and dqdd/dqd by the same LDL^T
  // factors: M dqdd/dx_k = -dR/dx_k, with R's qdd symbols bound to the solved qdd.
  std::vector<std::vector<SRef>> forward_dynamics_derivatives() {
    std::vector<SRef> rhs;
    const LdltProgram f = factored(rhs);
    const std::vector<SRef> qdd = ldlt_solve(p, f, rhs);
    for (int j = 0; j < n; ++j) fb.bind(model.qdd[j], qdd[j]);
    auto jacobian = [&](const GiNaC::matrix& dR) {
      std::vector<SRef> J(n * n);
      for (int k = 0; k < n; ++k) {
        std::vector<SRef> minus_col;
        for (int i = 0; i < n; ++i) minus_col.push_back(fb.build(-dR(i, k)));
        const std::vector<SRef> col = ldlt_solve(p, f, minus_col);
        for (int i = 0; i < n; ++i) J[i * n + k] = col[i];
      }
      return J;
    };
    // dqdd/dtau: M^-1's actuated columns over p (Q = tau / p, eq. 14).
    const std::vector<int> actuated = actuated_coordinates(derived.facts);
    std::vector<SRef> by_torque(n * N);
    for (int j = 0; j < N; ++j) {
      std::vector<SRef> unit(n, SRef{});
      unit[actuated[j]] = fb.build(1 / model.ratios[j]);
      const std::vector<SRef> col = ldlt_solve(p, f, unit);
      for (int i = 0; i < n; ++i) by_torque[i * N + j] = col[i];
    }
    return {jacobian(model.residual_dq), jacobian(model.residual_dqd), qdd, by_torque};
  }

  // M_bb a_b = -(M_bm a + b_b); Q_m = M_mb a_b + M_mm a + b_m, with a the joint rows of qdd
  // (motor accelerations p qdd_joints) and tau = p Q_m.
  std::vector<std::vector<SRef>> free_base_inverse_dynamics() {
    const std::vector<SRef> b = bias();
    std::vector<SRef> ratio, a;
    for (int j = 0; j < N; ++j) ratio.push_back(gear_ratio(j));
    for (int j = 0; j < N; ++j) a.push_back(p.mul({p.input("qdd_joints", j), ratio[j]}));
    const std::vector<SRef> Mbm = block(0, nb, nb, N), Mmb = block(nb, 0, N, nb),
                            Mmm = block(nb, nb, N, N);
    std::vector<SRef> rhs;
    for (int k = 0; k < nb; ++k) rhs.push_back(-p.add({dot(p, row(Mbm, N, k), a), b[k]}));
    const std::vector<SRef> base = ldlt_solve(p, ldlt(p, block(0, 0, nb, nb), nb), rhs);
    std::vector<SRef> tau;
    for (int j = 0; j < N; ++j) {
      const SRef Qj = p.add({dot(p, row(Mmb, nb, j), base), dot(p, row(Mmm, N, j), a), b[nb + j]});
      tau.push_back(p.mul({Qj, ratio[j]}));
    }
    return {tau, base};
  }
};

}  // namespace

std::vector<std::vector<SRef>> compose(const DerivedModel& model, ExpressionBuilder& fb, Output o) {
  Composer c(model, fb);
  switch (o) {
    case Output::generalized_jacobian:
      return c.generalized_jacobian();
    case Output::inverse_dynamics:
      return c.inverse_dynamics();
    case Output::forward_dynamics:
      return c.forward_dynamics();
    case Output::free_base_inverse_dynamics:
      return c.free_base_inverse_dynamics();
    case Output::forward_dynamics_derivatives:
      return c.forward_dynamics_derivatives();
    default:
      throw std::logic_error("compose: " + to_string(o) + " is not a composed output");
  }
}

}  // namespace spacearm
