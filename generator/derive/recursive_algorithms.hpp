// The recursive outputs of any chain: which outputs the algorithms give, and the derivatives made
// by running them on dual numbers (Mdot, C of eq. 7, the Christoffel form, the state Jacobian),
// written once over a chain type. A chain (planar_chain.cpp; a spatial one alike) is a class
// template Chain<T> over the scalars of recorded_scalar.hpp with
//   Chain(const Description&, Values<T>)           its numbers from the inputs and literals
//   static Dimensions dimensions(const Description&)       nq, nv, num_links
//   static T configuration_rate(const Description&, const Values<T>&, int i)
//                                                  entry i of qdot = f(q, v) (v itself where nq =
//                                                  nv)
//   static int base_translations(const Description&)   a free base's translational velocities,
//                                                  the first in v (0 for a fixed base)
//   static int base_rotations(const Description&)  its turns, the next in v
//   turned_about_base_axis(k, u)   a world vector u's rate as the base turns about its axis k
//   nq(), nv(), input(array, i)
//   mass_matrix()                  row-major nv x nv      (CRBA)
//   inverse_dynamics(qdd)          M qdd + b, nv          (RNEA; no passive forces)
//   forward_dynamics(Q)            {qdd, pivots, pivots / M_ii}   (ABA; passive forces included)
//   passive_forces()               springs, dampers, friction, nv
//   kinetic_energy(), generalized_momentum() (M v), momentum()    (the base's momenta)
#pragma once

#include <functional>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "outputs.hpp"
#include "recorded_scalar.hpp"

namespace spacearm {

// The algorithm that gives output o, e.g. "CRBA", "RNEA", "ABA" or "ABA, forward-mode" (a
// derivative by forward-mode differentiation of the recorded algorithm); nullptr if it has none.
inline const char* recursive_algorithm(Output o) {
  switch (o) {
    case Output::mass_matrix:
      return "CRBA";
    case Output::bias_forces:
    case Output::inverse_dynamics:
      return "RNEA";
    case Output::forward_dynamics:
      return "ABA";
    case Output::kinetic_energy:
      return "body velocities";
    case Output::momentum:
      return "body momenta";
    case Output::mass_matrix_derivative:
      return "CRBA, forward-mode";
    case Output::coriolis_matrix:
    case Output::christoffel_coriolis_matrix:
      return "CRBA and momenta, forward-mode";
    case Output::forward_dynamics_derivatives:
      return "RNEA and ABA, forward-mode";
    default:
      return nullptr;
  }
}

// Whether output o has a recursive form: every output derived from the kinetic energy (M, b, T,
// the momentum, C, Mdot, Cc) and the dynamics (inverse, forward, forward's state Jacobian).
inline bool has_recursive_form(Output o) { return recursive_algorithm(o) != nullptr; }

namespace chain_algorithms {

// The derivatives of y = f(chain) along n directions, row-major (one column per direction), one
// forward pass each: direction(k) gives input entry (array, i)'s tangent along direction k.
// f: const Chain<Dual<T>>& -> std::vector<Dual<T>>.
template <template <class> class Chain, class T, class Description, class F, class Direction>
std::vector<T> along_directions(const Description& d, const Values<T>& values, int n,
                                const Direction& direction, const F& f) {
  std::vector<T> J;
  for (int k = 0; k < n; ++k) {
    const Values<Dual<T>> along = seeded<T>(
        values, [&direction, k](const std::string& a, int i) { return direction(k, a, i); });
    const std::vector<T> column = tangents(f(Chain<Dual<T>>(d, along)));
    if (J.empty()) J.resize(column.size() * n);
    for (size_t r = 0; r < column.size(); ++r) J[r * n + k] = column[r];
  }
  return J;
}

// dy/dx, row-major, of y = f(chain) with x the input array `x` (q: nq columns; qd: nv), one
// forward pass per entry: each costs what the entry's dependents cost, so O(N) here. Entries in
// [skip_from, skip_to) are not taken: their columns are zeros.
template <template <class> class Chain, class T, class Description, class F>
std::vector<T> jacobian(const Description& d, const Values<T>& values, Input x, const F& f,
                        int skip_from = 0, int skip_to = 0) {
  const char* name = info(x).name;
  return along_directions<Chain>(
      d, values, Chain<T>::dimensions(d)(info(x).size),
      [&values, name, skip_from, skip_to](int k, const std::string& a, int i) {
        const bool taken = k < skip_from || k >= skip_to;
        return a == name && i == k && taken ? values.number(1.0) : T{};
      },
      f);
}

// The chain's input array x (sized by the registry: q has nq entries, qdd_joints num_links).
template <template <class> class Chain, class T, class Description>
std::vector<T> inputs(const Description& d, const Chain<T>& chain, Input x) {
  const int n = Chain<T>::dimensions(d)(info(x).size);
  std::vector<T> v;
  for (int i = 0; i < n; ++i) v.push_back(chain.input(info(x).name, i));
  return v;
}

// The chain along the configuration rate: q's tangent is qdot = f(q, v), the others none.
template <template <class> class Chain, class T, class Description>
Chain<Dual<T>> along_configuration_rate(const Description& d, const Values<T>& values) {
  return Chain<Dual<T>>(
      d, seeded<T>(values, [&d, &values](const std::string& a, int i) {
        return a == info(Input::q).name ? Chain<T>::configuration_rate(d, values, i) : T{};
      }));
}

// G = d(qdot)/dv (nq x nv, row-major): qdot = f(q, v) is linear in v, so one forward pass per
// velocity gives it exactly.
template <template <class> class Chain, class T, class Description>
std::vector<T> configuration_rate_matrix(const Description& d, const Values<T>& values) {
  const Dimensions dims = Chain<T>::dimensions(d);
  std::vector<T> G(dims.nq * dims.nv);
  for (int k = 0; k < dims.nv; ++k) {
    const Values<Dual<T>> unit = seeded<T>(values, [&values, k](const std::string& a, int i) {
      return a == info(Input::qd).name && i == k ? values.number(1.0) : T{};
    });
    for (int i = 0; i < dims.nq; ++i)
      G[i * dims.nv + k] = Chain<Dual<T>>::configuration_rate(d, unit, i).d;
  }
  return G;
}

// dy/dδ (row-major, nv columns) of y = f(chain) on the configuration's tangent space: q moves as
// q ⊕ δ, its tangent G δ (G = d(qdot)/dv), so a base's quaternion turns by δω in the base's own
// frame (MuJoCo's mj_integratePos, Pinocchio's integrate). One forward pass per velocity; where
// nq = nv, G = 1 and this is jacobian(Input::q). Directions in [skip_from, skip_to) are not
// taken: their columns are zeros.
template <template <class> class Chain, class T, class Description, class F>
std::vector<T> tangent_jacobian(const Description& d, const Values<T>& values, const F& f,
                                int skip_from = 0, int skip_to = 0) {
  const Dimensions dims = Chain<T>::dimensions(d);
  if (dims.nq == dims.nv) return jacobian<Chain>(d, values, Input::q, f, skip_from, skip_to);
  const std::vector<T> G = configuration_rate_matrix<Chain>(d, values);
  const char* name = info(Input::q).name;
  const int nv = dims.nv;
  return along_directions<Chain>(
      d, values, nv,
      [&G, name, nv, skip_from, skip_to](int k, const std::string& a, int i) {
        const bool taken = k < skip_from || k >= skip_to;
        return a == name && taken ? G[i * nv + k] : T{};
      },
      f);
}

// dy/dtau (row-major, N columns) of y = f(chain) by the link-side joint torques: joint j's
// enters as Q = tau_j / p_j on the coordinate it drives (chain.torque_coordinate(j),
// chain.per_torque(j) = 1 / p_j; 1-based j), one forward pass per joint.
template <template <class> class Chain, class T, class Description, class F>
std::vector<T> torque_jacobian(const Description& d, const Values<T>& values, const Chain<T>& chain,
                               const F& f) {
  const char* name = info(Input::generalized_forces).name;
  return along_directions<Chain>(
      d, values, Chain<T>::dimensions(d).num_links,
      [&chain, name](int j, const std::string& a, int i) {
        return a == name && i == chain.torque_coordinate(j + 1) ? chain.per_torque(j + 1) : T{};
      },
      f);
}

// Whether a chain has quasi-velocities whose directions do not commute (the spatial chain's
// base angular velocity in its own frame): it then gives their Hamel coupling as a matrix.
template <class C, class = void>
struct has_quasi_velocities : std::false_type {};
template <class C>
struct has_quasi_velocities<C, std::void_t<decltype(&C::hamel_coupling)>> : std::true_type {};

// The state Jacobian of forward dynamics at constant Q: {dqdd/dq (tangent), dqdd/dqd, qdd,
// dqdd/dtau}. Along q, Carpentier and Mansard's split (RSS 2018): with R(q, qd) = M qdd + b +
// passive forces at the solved qdd held, dqdd/dq = -M^-1 dR/dq, R's partials by RNEA forward
// (cheaper than ABA's, whose articulated inertias depend on q) and M^-1 by ABA's force pass
// alone (a tangent along Q: the articulated inertias do not depend on it, so they fold away).
// Along qd, ABA forward directly: its inertias do not depend on qd either, and RNEA's partials
// and the solve together cost more there (measured by `spacearm generate --stats`). Along a free
// base's translational velocity (world frame) dqdd/dqd is zero: a Galilean boost of the whole
// system changes no acceleration, as no force depends on the base's own velocity (the passive
// forces act on the joints). Those columns are seeded with nothing: exact zeros, which the
// recorded programs fold away.
template <template <class> class Chain, class T, class Description>
std::vector<std::vector<T>> state_jacobian(const Description& d, const Values<T>& values) {
  auto qdd_of = [&d](const Chain<Dual<T>>& c) {
    return c.forward_dynamics(inputs(d, c, Input::generalized_forces))[0];
  };
  const Chain<T> chain(d, values);
  const std::vector<T> qdd = chain.forward_dynamics(inputs(d, chain, Input::generalized_forces))[0];
  auto residual = [&qdd](const Chain<Dual<T>>& c) {
    std::vector<Dual<T>> held;
    for (const T& x : qdd) held.push_back({x, T{}});
    std::vector<Dual<T>> R = c.inverse_dynamics(held);
    const std::vector<Dual<T>> passive = c.passive_forces();
    for (size_t k = 0; k < R.size(); ++k) R[k] += passive[k];
    return R;
  };
  // A free base's turns (tangent directions [boosts, boosts + turns)) by the same symmetry:
  // turning the whole system turns the world vectors (v's, Q's and qdd's base-linear rows, the
  // first `boosts`) and leaves the rest. With dqdd/dv_lin = 0, dqdd along turn k is then
  // (a_k x qdd_lin, 0) - dqdd/dQ_lin (a_k x Q_lin), a_k the base's axis k in the world: one
  // force-pass solve, no RNEA partials.
  const int boosts = Chain<T>::base_translations(d), turns = Chain<T>::base_rotations(d);
  const std::vector<T> dR_dq = tangent_jacobian<Chain>(d, values, residual, boosts, boosts + turns);
  const int nv = Chain<T>::dimensions(d).nv;
  const std::vector<T> Qs = inputs(d, chain, Input::generalized_forces);
  const std::vector<T> Q_lin(Qs.begin(), Qs.begin() + boosts),
      qdd_lin(qdd.begin(), qdd.begin() + boosts);
  std::vector<std::vector<T>> turned_Q, turned_qdd;
  for (int t = 0; t < turns; ++t) {
    turned_Q.push_back(chain.turned_about_base_axis(t, Q_lin));
    turned_qdd.push_back(chain.turned_about_base_axis(t, qdd_lin));
  }
  const char* Q = info(Input::generalized_forces).name;
  std::vector<T> dqdd_dq = along_directions<Chain>(
      d, values, nv,
      [&dR_dq, &turned_Q, Q, nv, boosts, turns](int k, const std::string& a, int i) {
        if (a != Q) return T{};
        if (k >= boosts && k < boosts + turns) return i < boosts ? -turned_Q[k - boosts][i] : T{};
        return -dR_dq[i * nv + k];
      },
      qdd_of);
  for (int t = 0; t < turns; ++t)
    for (int i = 0; i < boosts; ++i)
      dqdd_dq[i * nv + boosts + t] = dqdd_dq[i * nv + boosts + t] + turned_qdd[t][i];
  return {dqdd_dq, jacobian<Chain>(d, values, Input::qd, qdd_of, 0, boosts), qdd,
          torque_jacobian<Chain>(d, values, chain, qdd_of)};
}

// The outputs made by differentiating the algorithms forward: Mdot = dM/dq qdot; with P =
// d(M v)/dq (v held), C of eq. 7 = Mdot - P^T / 2 and the Christoffel form (Mdot + P - P^T) / 2
// (where nq = nv); the state Jacobian of forward dynamics at constant Q. With quasi-velocities
// (qdot = G v, nq > nv) C is the Boltzmann-Hamel factorization: C = Mdot - (P G)^T / 2 + H, so
// that C v = Mdot v - G^T dT/dq + H v with H v the Hamel terms (omega x (M v)_omega for a base
// turning at omega in its own frame, Euler's).
template <template <class> class Chain, class T, class Description>
std::vector<std::vector<T>> differentiated(const Description& d, const Values<T>& values,
                                           Output o) {
  const int n = Chain<T>::dimensions(d).nv;
  if (o == Output::forward_dynamics_derivatives) return state_jacobian<Chain>(d, values);
  const std::vector<T> Mdot = tangents(along_configuration_rate<Chain>(d, values).mass_matrix());
  if (o == Output::mass_matrix_derivative) return {Mdot};
  std::vector<T> P = jacobian<Chain>(
      d, values, Input::q, [](const Chain<Dual<T>>& c) { return c.generalized_momentum(); });
  const int nq = Chain<T>::dimensions(d).nq;
  if (nq != n) {
    if (o == Output::christoffel_coriolis_matrix)
      throw std::logic_error("recursive dynamics: no Christoffel form with quasi-velocities");
    const std::vector<T> G = configuration_rate_matrix<Chain>(d, values);
    std::vector<T> PG(n * n, T{});  // d(M v)/dq along each velocity's direction
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j)
        for (int k = 0; k < nq; ++k) PG[i * n + j] += P[i * nq + k] * G[k * n + j];
    P = PG;
  }
  std::vector<T> C(n * n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      C[i * n + j] = o == Output::coriolis_matrix
                         ? Mdot[i * n + j] - P[j * n + i] * 0.5
                         : (Mdot[i * n + j] + P[i * n + j] - P[j * n + i]) * 0.5;
  if constexpr (has_quasi_velocities<Chain<T>>::value) {
    const Chain<T> chain(d, values);
    const std::vector<T> H = chain.hamel_coupling(chain.mass_matrix());
    for (int k = 0; k < n * n; ++k) C[k] += H[k];
  }
  return {C};
}

// Whether a chain gives its end effector's kinematics and what composes from them with M (the
// generalized Jacobian, free-base inverse dynamics): the spatial chain does; the planar chain's
// come from its closed forms.
template <class C, class = void>
struct has_kinematics : std::false_type {};
template <class C>
struct has_kinematics<C, std::void_t<decltype(std::declval<const C&>().end_effector_pose())>>
    : std::true_type {};

// Whether a chain gives its passive forces' parts alone (the spatial chain: friction, springs and
// dampers, the springs' potential energy); the planar chain's come from its closed forms.
template <class C, class = void>
struct has_passive_parts : std::false_type {};
template <class C>
struct has_passive_parts<C, std::void_t<decltype(std::declval<const C&>().friction_forces())>>
    : std::true_type {};

// The results of output o (the registry's, each row by row; a symmetric one in full).
template <template <class> class Chain, class T, class Description>
std::vector<std::vector<T>> compute(const Description& d, const Values<T>& values, Output o) {
  if (o == Output::mass_matrix_derivative || o == Output::coriolis_matrix ||
      o == Output::christoffel_coriolis_matrix || o == Output::forward_dynamics_derivatives)
    return differentiated<Chain>(d, values, o);
  const Chain<T> chain(d, values);
  switch (o) {
    case Output::mass_matrix:
      return {chain.mass_matrix()};
    case Output::bias_forces:
      return {chain.inverse_dynamics(std::vector<T>(chain.nv(), T{}))};
    case Output::inverse_dynamics: {
      std::vector<T> Q = chain.inverse_dynamics(inputs(d, chain, Input::qdd));
      const std::vector<T> passive = chain.passive_forces();
      for (int i = 0; i < chain.nv(); ++i) Q[i] += passive[i];
      return {Q};
    }
    case Output::forward_dynamics:
      return chain.forward_dynamics(inputs(d, chain, Input::generalized_forces));
    case Output::kinetic_energy:
      return {{chain.kinetic_energy()}};
    case Output::momentum:
      return {chain.momentum()};
    case Output::friction_forces:
    case Output::spring_damper_forces:
    case Output::potential_energy:
      if constexpr (has_passive_parts<Chain<T>>::value) {
        if (o == Output::friction_forces) return {chain.friction_forces()};
        if (o == Output::spring_damper_forces) return {chain.spring_damper_forces()};
        return {{chain.potential_energy()}};
      }
      throw std::logic_error("recursive dynamics: no recursive form of " + to_string(o));
    case Output::end_effector_pose:
    case Output::end_effector_jacobian:
    case Output::joint_positions:
    case Output::joint_angles:
    case Output::joint_rates:
    case Output::generalized_jacobian:
    case Output::free_base_inverse_dynamics:
      if constexpr (has_kinematics<Chain<T>>::value) {
        if (o == Output::end_effector_pose) return {chain.end_effector_pose()};
        if (o == Output::end_effector_jacobian) return {chain.end_effector_jacobian()};
        if (o == Output::joint_positions) return {chain.joint_positions()};
        if (o == Output::joint_angles) return {chain.joint_angles()};
        if (o == Output::joint_rates) return {chain.joint_rates()};
        if (o == Output::generalized_jacobian) return {chain.generalized_jacobian()};
        return chain.free_base_inverse_dynamics(inputs(d, chain, Input::joint_accelerations));
      }
      [[fallthrough]];
    default:
      throw std::logic_error("recursive dynamics: no recursive form of " + to_string(o));
  }
}

}  // namespace chain_algorithms

// Output o of the chain described by d, recorded in p from its inputs p.input(name, i) under the
// registry's names and p.input("params", i).
template <template <class> class Chain, class Description>
std::vector<std::vector<SRef>> record_chain(const Description& d, Output o, Program& p) {
  Values<Sym> values{[&p](const std::string& a, int i) { return Sym(&p, p.input(a, i)); },
                     [&p](double v) { return Sym::number(&p, v); }};
  std::vector<std::vector<SRef>> refs;
  for (const auto& result : chain_algorithms::compute<Chain>(d, values, o)) {
    auto& r = refs.emplace_back();
    for (const Sym& x : result) r.push_back(x.ref());
  }
  return refs;
}

// The same algorithms run in double on the given inputs ("q", "qd", "qdd", "Q", "params"): the
// reference a recorded program is checked against, independent of the program's CSE.
template <template <class> class Chain, class Description>
std::vector<std::vector<double>> evaluate_chain(
    const Description& d, Output o, const std::function<double(const std::string&, int)>& input) {
  Values<double> values{input, [](double v) { return v; }};
  return chain_algorithms::compute<Chain>(d, values, o);
}

}  // namespace spacearm
