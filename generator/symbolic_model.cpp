#include "symbolic_model.hpp"

#include <cctype>
#include <cmath>
#include <regex>
#include <set>
#include <stdexcept>

namespace spacearm {

using GiNaC::ex;
using GiNaC::lst;
using GiNaC::matrix;
using GiNaC::numeric;
using GiNaC::symbol;

numeric exact_decimal(const std::string& literal) {
  static const std::regex re(R"(([+-]?)(\d*)(?:\.(\d*))?(?:[eE]([+-]?\d+))?)");
  std::smatch m;
  if (!std::regex_match(literal, m, re)) throw std::invalid_argument("not a decimal: " + literal);
  std::string digits = m[2].str() + m[3].str();
  if (digits.empty()) digits = "0";
  const long exponent = (m[4].matched ? std::stol(m[4].str()) : 0) - static_cast<long>(m[3].length());
  numeric value(digits.c_str());
  value = value * GiNaC::pow(numeric(10), numeric(exponent));
  return m[1].str() == "-" ? -value : value;
}

namespace {

// Everything the derivation needs about one scene, as GiNaC expressions.
struct Builder {
  const Scene& scene;
  SymbolicModel& model;
  std::map<std::string, ex> parameter_symbols;

  ex value(const Quantity& q) const {
    if (q.is_parameter()) return parameter_symbols.at(q.parameter);
    return exact_decimal(q.literal);
  }

  // d/dt of an expression of q along qd (qdd = 0 is all we ever need it for).
  ex time_derivative(const ex& e) const {
    ex result = 0;
    for (int i = 0; i < model.n(); ++i) result += e.diff(model.q[i]) * model.qd[i];
    return result;
  }
};

struct Vec2 {
  ex x, y;
};

// R(theta) J u with J the rotation by +90 degrees: d/dtheta of R(theta) u.
Vec2 rotated_perp(const ex& theta, const Vec2& u) {
  return {-GiNaC::cos(theta) * u.y - GiNaC::sin(theta) * u.x,
          GiNaC::cos(theta) * u.x - GiNaC::sin(theta) * u.y};
}

Vec2 rotated(const ex& theta, const Vec2& u) {
  return {GiNaC::cos(theta) * u.x - GiNaC::sin(theta) * u.y,
          GiNaC::sin(theta) * u.x + GiNaC::cos(theta) * u.y};
}

}  // namespace

const GiNaC::matrix& SymbolicModel::expression(Output output) const {
  auto it = outputs.find(output);
  if (it == outputs.end()) throw std::invalid_argument("the model has no " + to_string(output) + " (not derived)");
  return it->second;
}

SymbolicModel derive(const Scene& scene, const DeriveOptions& options) {
  SymbolicModel model;
  model.scene = scene;
  Builder b{scene, model, {}};
  const int N = scene.num_links();
  const bool free = scene.free_floating();
  const bool geared = scene.geared();

  // Symbols in a fixed order: coordinates, velocities, parameters.
  for (const auto& name : scene.coordinate_names()) model.q.emplace_back(name);
  for (const auto& name : scene.coordinate_names()) model.qd.emplace_back(name + "d");
  for (const auto& p : scene.parameters) {
    model.parameters.emplace_back(p.name);
    b.parameter_symbols[p.name] = model.parameters.back();
  }
  const int n = model.n();
  const int first_joint = free ? 3 : 0;

  // Base pose and absolute angles theta_k = q0 + sum_{j<=k} q_j (eq. 4); in motor
  // coordinates q_j = q_m_j / p_j (eq. 9 integrated with q_m(0) = p q(0)).
  Vec2 r0{0, 0}, r0d{0, 0};
  ex theta0 = 0;
  if (free) {
    r0 = {model.q[0], model.q[1]};
    r0d = {model.qd[0], model.qd[1]};
    theta0 = model.q[2];
  }
  model.gear_map = matrix(n, n);
  for (int i = 0; i < n; ++i) model.gear_map(i, i) = 1;
  std::vector<ex> p(N + 1, 1), Im(N + 1, 0);
  for (int j = 1; j <= N; ++j) {
    if (geared) {
      p[j] = b.value(scene.gears[j - 1].ratio);
      Im[j] = b.value(scene.gears[j - 1].motor_inertia);
      model.gear_map(first_joint + j - 1, first_joint + j - 1) = 1 / p[j];
    }
  }
  model.theta.push_back(theta0);
  for (int j = 1; j <= N; ++j)
    model.theta.push_back(model.theta.back() + model.q[first_joint + j - 1] / p[j]);
  for (const ex& th : model.theta) model.omega.push_back(b.time_derivative(th).expand());
  for (int k = 0; k <= N; ++k) {
    model.angle_table[model.theta[k].expand()] = {-1, k};
    for (int l = k + 1; l <= N; ++l) model.angle_table[(model.theta[l] - model.theta[k]).expand()] = {k, l};
  }
  const auto& theta = model.theta;
  const auto& Omega = model.omega;

  // Kinetic energy, eq. 3. With d_i = CoM_i - r0 = sum_k R(theta_k) u_ki, the CoM velocity
  // is v_i = r0d + sum_k Omega_k R(theta_k) J u_ki and
  // |v_i|^2 = |r0d|^2 + 2 sum_k Omega_k r0d.(R_k J u_k) + sum_kl Omega_k Omega_l u_k^T R(theta_l - theta_k) u_l,
  // written with the relative angles so the closed form stays compact (no trig identities
  // are needed afterwards).
  ex T = 0;
  const ex m0 = free ? b.value(scene.base.mass) : ex(0);
  const ex I0 = free ? b.value(scene.base.inertia) : ex(0);
  T += m0 * (r0d.x * r0d.x + r0d.y * r0d.y) / 2 + I0 * Omega[0] * Omega[0] / 2;
  const Vec2 mount{b.value(scene.base.mount[0]), b.value(scene.base.mount[1])};
  for (int i = 1; i <= N; ++i) {
    const Link& link = scene.links[i - 1];
    std::vector<Vec2> u;  // u_ki, k = 0..i
    u.push_back(mount);
    for (int k = 1; k < i; ++k) u.push_back({b.value(scene.links[k - 1].length), 0});
    u.push_back({b.value(link.com[0]), b.value(link.com[1])});
    ex v2 = r0d.x * r0d.x + r0d.y * r0d.y;
    for (int k = 0; k <= i; ++k) {
      const Vec2 w = rotated_perp(theta[k], u[k]);
      v2 += 2 * Omega[k] * (r0d.x * w.x + r0d.y * w.y);
      v2 += Omega[k] * Omega[k] * (u[k].x * u[k].x + u[k].y * u[k].y);
      for (int l = k + 1; l <= i; ++l) {
        const ex delta = theta[l] - theta[k];
        // u_k^T R(delta) u_l = (u_k . u_l) cos(delta) + (u_ky u_lx - u_kx u_ly) sin(delta)
        const ex dot = u[k].x * u[l].x + u[k].y * u[l].y;
        const ex cross = u[k].y * u[l].x - u[k].x * u[l].y;
        v2 += 2 * Omega[k] * Omega[l] * (dot * GiNaC::cos(delta) + cross * GiNaC::sin(delta));
      }
    }
    ex I_link = b.value(link.inertia);
    if (geared && scene.gears[i - 1].compensate_link_inertia) I_link -= Im[i];
    T += b.value(link.mass) * v2 / 2 + I_link * Omega[i] * Omega[i] / 2;
    if (geared) {
      // Motor i turns with the previous body plus its own rate (eq. 11), 1/2 I_m w^2 (eq. 10);
      // the armature approximation keeps only the motor's own rate.
      const ex& qd_m = model.qd[first_joint + i - 1];
      const ex omega_m = scene.gears[i - 1].armature ? qd_m : Omega[i - 1] + qd_m;
      T += Im[i] * omega_m * omega_m / 2;
    }
  }
  model.kinetic_energy = T.expand();

  const bool want_all = options.all_outputs;
  // What the scene asks for, and what its composed outputs are composed of.
  std::set<Output> wanted = scene.outputs;
  for (Output o : scene.outputs) wanted.insert(info(o).composed_of.begin(), info(o).composed_of.end());
  auto wants = [&](Output o) {
    return (want_all && (free || !info(o).free_floating_only) && info(o).composed_of.empty()) || wanted.count(o);
  };
  auto& out = model.outputs;
  if (wants(Output::kinetic_energy)) out[Output::kinetic_energy] = matrix{{model.kinetic_energy}};

  // Mass matrix, eq. 6: M_ij = d^2 T / dqd_i dqd_j.
  std::vector<ex> dT_dqd(n);
  for (int i = 0; i < n; ++i) dT_dqd[i] = model.kinetic_energy.diff(model.qd[i]);
  matrix M(n, n);
  if (wants(Output::mass_matrix) || wants(Output::coriolis_matrix) || wants(Output::mass_matrix_derivative) ||
      wants(Output::christoffel_coriolis_matrix)) {
    for (int i = 0; i < n; ++i)
      for (int j = i; j < n; ++j) M(i, j) = M(j, i) = dT_dqd[i].diff(model.qd[j]).expand();
    if (wants(Output::mass_matrix)) out[Output::mass_matrix] = M;
  }

  // Coriolis matrix exactly as eq. 7: C = (Mdot - 1/2 d(M qd)/dq)^T, i.e.
  // C_ij = sum_k dM_ij/dq_k qd_k - 1/2 sum_k dM_jk/dq_i qd_k.
  if (wants(Output::coriolis_matrix)) {
    matrix C(n, n);
    std::vector<ex> M_qd(n);  // (M qd)_j
    for (int j = 0; j < n; ++j) {
      ex s = 0;
      for (int k = 0; k < n; ++k) s += M(j, k) * model.qd[k];
      M_qd[j] = s.expand();
    }
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) C(i, j) = (b.time_derivative(M(i, j)) - M_qd[j].diff(model.q[i]) / 2).expand();
    out[Output::coriolis_matrix] = C;
  }

  // Mdot = sum_k dM/dq_k qd_k, and the Christoffel form Cc_ij = sum_k Gamma_ijk qd_k with
  // Gamma_ijk = 1/2 (dM_ij/dq_k + dM_ik/dq_j - dM_jk/dq_i).
  if (wants(Output::mass_matrix_derivative)) {
    matrix Mdot(n, n);
    for (int i = 0; i < n; ++i)
      for (int j = i; j < n; ++j) Mdot(i, j) = Mdot(j, i) = b.time_derivative(M(i, j)).expand();
    out[Output::mass_matrix_derivative] = Mdot;
  }
  if (wants(Output::christoffel_coriolis_matrix)) {
    matrix Cc(n, n);
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) {
        ex s = 0;
        for (int k = 0; k < n; ++k)
          s += (M(i, j).diff(model.q[k]) + M(i, k).diff(model.q[j]) - M(j, k).diff(model.q[i])) * model.qd[k] / 2;
        Cc(i, j) = s.expand();
      }
    out[Output::christoffel_coriolis_matrix] = Cc;
  }

  // Link-side joint angles and rates: q_link = gear_map q (eq. 12), qd_link = gear_map qd.
  if (wants(Output::joint_angles) || wants(Output::joint_rates)) {
    matrix angles(N, 1), rates(N, 1);
    for (int j = 0; j < N; ++j) {
      angles(j, 0) = model.gear_map(first_joint + j, first_joint + j) * model.q[first_joint + j];
      rates(j, 0) = model.gear_map(first_joint + j, first_joint + j) * model.qd[first_joint + j];
    }
    if (wants(Output::joint_angles)) out[Output::joint_angles] = angles;
    if (wants(Output::joint_rates)) out[Output::joint_rates] = rates;
  }

  // Bias C qd, emitted directly from the Euler-Lagrange terms at qdd = 0 (cheaper than C).
  if (wants(Output::bias_forces)) {
    matrix bias(n, 1);
    for (int i = 0; i < n; ++i)
      bias(i, 0) = (b.time_derivative(dT_dqd[i]) - model.kinetic_energy.diff(model.q[i])).expand();
    out[Output::bias_forces] = bias;
  }

  // Momentum: P = dT/d(r0d); angular momentum about the world origin
  // L = dT/dq0d + r0 x P (dT/dq0d is the angular momentum about the base CoM).
  if (wants(Output::momentum) && free)
    out[Output::momentum] = matrix{{dT_dqd[0].expand()},
                                   {dT_dqd[1].expand()},
                                   {(dT_dqd[2] + r0.x * dT_dqd[1] - r0.y * dT_dqd[0]).expand()}};

  // End-effector: tip of the last link, orientation of the last link.
  if (wants(Output::end_effector_pose) || wants(Output::end_effector_jacobian) || wants(Output::joint_positions)) {
    Vec2 tip = r0;
    const Vec2 m0vec = rotated(theta[0], mount);
    tip = {tip.x + m0vec.x, tip.y + m0vec.y};
    matrix P(2, N + 1);
    for (int k = 1; k <= N; ++k) {
      P(0, k - 1) = tip.x.expand();
      P(1, k - 1) = tip.y.expand();
      const Vec2 seg = rotated(theta[k], {b.value(scene.links[k - 1].length), 0});
      tip = {tip.x + seg.x, tip.y + seg.y};
    }
    P(0, N) = tip.x.expand();
    P(1, N) = tip.y.expand();
    const matrix pose{{tip.x.expand()}, {tip.y.expand()}, {theta[N].expand()}};
    matrix J(3, n);
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < n; ++c) J(r, c) = pose(r, 0).diff(model.q[c]).expand();
    if (wants(Output::joint_positions)) out[Output::joint_positions] = P;
    if (wants(Output::end_effector_pose)) out[Output::end_effector_pose] = pose;
    if (wants(Output::end_effector_jacobian)) out[Output::end_effector_jacobian] = J;
  }
  return model;
}

namespace {

// An entry "NAME", "NAME[i]" or "NAME[i][j]" (spaces allowed around the parts), parsed by
// hand in one pass: a regular expression recursed once per character on long input.
struct EntryText {
  std::string name;
  std::vector<int> indices;
};

EntryText parse_entry(const std::string& entry) {
  const std::string shown = "entry '" + (entry.size() > 40 ? entry.substr(0, 40) + "..." : entry) + "'";
  const std::string usage = ": expected e.g. T, M[3][4], C[0][3], b[2], h[0], x[1], J[0][3]";
  if (entry.size() > 100) throw std::invalid_argument(shown + " is too long" + usage);
  EntryText e;
  size_t i = 0;
  auto skip = [&] {
    while (i < entry.size() && entry[i] == ' ') ++i;
  };
  skip();
  while (i < entry.size() && std::isalpha(static_cast<unsigned char>(entry[i]))) e.name += entry[i++];
  if (e.name.empty()) throw std::invalid_argument(shown + usage);
  for (skip(); i < entry.size() && entry[i] == '['; skip()) {
    ++i;
    skip();
    std::string digits;
    while (i < entry.size() && std::isdigit(static_cast<unsigned char>(entry[i]))) digits += entry[i++];
    skip();
    if (digits.empty() || digits.size() > 6 || i >= entry.size() || entry[i] != ']')
      throw std::invalid_argument(shown + usage);
    ++i;
    e.indices.push_back(std::stoi(digits));
  }
  if (i != entry.size() || e.indices.size() > 2) throw std::invalid_argument(shown + usage);
  return e;
}

}  // namespace

GiNaC::ex symbolic_entry(const SymbolicModel& model, const std::string& entry) {
  const EntryText e = parse_entry(entry);
  std::string known;
  for (const auto& o : output_registry()) {
    known += (known.empty() ? "" : ", ") + std::string(o.symbol);
    if (e.name != o.symbol) continue;
    if (!o.composed_of.empty()) {
      std::string parts;
      for (Output c : o.composed_of) parts += (parts.empty() ? "" : ", ") + std::string(info(c).symbol) + " (" + to_string(c) + ")";
      throw std::invalid_argument("entry '" + entry + "': " + o.name +
                                  " is composed in the emitted program (a solve or a product), not a closed form; "
                                  "inspect what it is made of: " + parts);
    }
    if (o.free_floating_only && !model.scene.free_floating())
      throw std::invalid_argument("entry '" + entry + "': " + o.name + " is only defined for a free-floating base");
    const matrix& m = model.expression(o.id);
    // A scalar takes no index, a vector one, a matrix two (by the registry's shape, so that
    // a one-coordinate model's M still takes two); each in range.
    const ResultInfo& shape = o.results[0];
    const size_t count = shape.cols != Size::one ? 2 : shape.rows != Size::one ? 1 : 0;
    if (e.indices.size() != count)
      throw std::invalid_argument("entry '" + entry + "': " + e.name + " takes " + std::to_string(count) +
                                  (count == 1 ? " index" : " indices") + ", got " + std::to_string(e.indices.size()));
    const unsigned limits[2] = {m.rows(), m.cols()};
    for (size_t k = 0; k < count; ++k)
      if (static_cast<unsigned>(e.indices[k]) >= limits[k])
        throw std::invalid_argument("entry '" + entry + "': index " + std::to_string(e.indices[k]) +
                                    " out of range 0.." + std::to_string(limits[k] - 1));
    return m(count ? e.indices[0] : 0, count == 2 ? e.indices[1] : 0);
  }
  throw std::invalid_argument("entry '" + entry + "': unknown quantity '" + e.name + "' (known: " + known + ")");
}

double evaluate(const SymbolicModel& model, const GiNaC::ex& e, const std::vector<double>& q,
                const std::vector<double>& qd, const std::vector<double>& params) {
  lst subs;
  // Doubles are converted exactly to rationals so the evaluation itself adds no rounding.
  auto exact = [](double v) {
    int exponent = 0;
    const double mantissa = std::frexp(v, &exponent);  // v = mantissa 2^exponent
    const long integer = static_cast<long>(std::ldexp(mantissa, 53));
    return GiNaC::numeric(integer) * GiNaC::pow(GiNaC::numeric(2), exponent - 53);
  };
  const int saved_digits = GiNaC::Digits;
  GiNaC::Digits = 40;
  for (int i = 0; i < model.n(); ++i) {
    subs.append(model.q[i] == exact(q.at(i)));
    subs.append(model.qd[i] == exact(qd.at(i)));
  }
  for (size_t i = 0; i < model.parameters.size(); ++i)
    subs.append(model.parameters[i] ==
                exact(params.empty() ? model.scene.parameters[i].nominal.value : params.at(i)));
  const ex value = GiNaC::evalf(e.subs(subs));
  GiNaC::Digits = saved_digits;
  if (!GiNaC::is_a<numeric>(value)) throw std::runtime_error("expression did not evaluate to a number");
  return GiNaC::ex_to<numeric>(value).to_double();
}

std::vector<double> evaluate(const SymbolicModel& model, const GiNaC::matrix& m, const std::vector<double>& q,
                             const std::vector<double>& qd, const std::vector<double>& params) {
  std::vector<double> values;
  for (unsigned i = 0; i < m.rows(); ++i)
    for (unsigned j = 0; j < m.cols(); ++j) values.push_back(evaluate(model, m(i, j), q, qd, params));
  return values;
}

}  // namespace spacearm
