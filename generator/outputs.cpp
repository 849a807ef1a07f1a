#include "outputs.hpp"

#include <cctype>
#include <stdexcept>

#include "text_numbers.hpp"

namespace spacearm {

int Dimensions::operator()(Size s) const {
  switch (s) {
    case Size::one:
      return 1;
    case Size::pose:
      return spatial ? 7 : 3;
    case Size::twist:
      return spatial ? 6 : 3;
    case Size::point:
      return spatial ? 3 : 2;
    case Size::poses:
      return (*this)(Size::pose)*num_end_effectors;
    case Size::twists:
      return (*this)(Size::twist)*num_end_effectors;
    case Size::num_points:
      return num_links + num_end_effectors;
    case Size::nq:
      return nq;
    case Size::nv:
      return nv;
    case Size::num_links:
      return num_links;
    case Size::num_links_plus_one:
      return num_links + 1;
    case Size::num_base:
      return nv - num_links;
  }
  throw std::logic_error("unknown size");
}

std::string size_constant(Size s, const Dimensions& dims) {
  switch (s) {
    case Size::one:
      return "1";
    case Size::pose:
    case Size::twist:
    case Size::point:
    case Size::poses:
    case Size::twists:
      return std::to_string(dims(s));
    case Size::num_points:
      return "kNumLinks + " + std::to_string(dims.num_end_effectors);
    case Size::nq:
      return "kNq";
    case Size::nv:
      return "kNv";
    case Size::num_links:
      return "kNumLinks";
    case Size::num_links_plus_one:
      return "kNumLinks + 1";
    case Size::num_base:
      return "kNv - kNumLinks";
  }
  throw std::logic_error("unknown size");
}

const InputInfo& info(Input input) {
  static const InputInfo inputs[] = {
      {Input::q, "q", Size::nq},
      {Input::qd, "qd", Size::nv},
      {Input::qdd, "qdd", Size::nv},
      {Input::generalized_forces, "Q", Size::nv},
      {Input::joint_accelerations, "qdd_joints", Size::num_links},
  };
  for (const auto& i : inputs)
    if (i.id == input) return i;
  throw std::logic_error("unknown input");
}

// The registry, one entry per output: id, name, symbol; inputs; results (name, rows, cols,
// symmetric); base; by default; composed of; the paper's equation; doc. Kept as a table, one
// entry per block, so that adding an output reads as one entry.
const std::vector<OutputInfo>& output_registry() {
  using I = Input;
  using S = Size;
  using O = Output;
  constexpr unsigned kAnyBase = needs::nothing, kFreeBaseOnly = needs::free_base,
                     kRigidFreeBase = needs::free_base | needs::rigid_joints;
  constexpr bool kByDefault = true, kOnRequest = false;
  // clang-format off
  static const std::vector<OutputInfo> registry = {
      {O::mass_matrix, "mass_matrix", "M", {I::q}, {{"M", S::nv, S::nv, true}},
       kAnyBase, kByDefault, {}, "6", "Mass matrix M(q) (symmetric positive definite)."},
      {O::coriolis_matrix, "coriolis_matrix", "C", {I::q, I::qd}, {{"C", S::nv, S::nv, false}},
       kAnyBase, kByDefault, {}, "7",
       "Coriolis/centrifugal matrix C(q, qd), exactly as the paper defines it; C qd is the bias. "
       "Not the Christoffel form: Mdot - 2C is not skew-symmetric."},
      {O::bias_forces, "bias_forces", "b", {I::q, I::qd}, {{"b", S::nv, S::one, false}},
       kAnyBase, kByDefault, {}, "5", "Bias b = C(q, qd) qd, so that M qdd + b = Q."},
      {O::kinetic_energy, "kinetic_energy", "T", {I::q, I::qd}, {{"T", S::one, S::one, false}},
       kAnyBase, kByDefault, {}, "3 and 10", "Kinetic energy T = 1/2 qd^T M qd."},
      {O::momentum, "momentum", "h", {I::q, I::qd}, {{"h", S::twist, S::one, false}},
       kFreeBaseOnly, kByDefault, {}, "",
       "Momentum h = [Px, Py, L]: linear momentum and angular momentum about the world origin."},
      {O::end_effector_pose, "end_effector_pose", "x", {I::q}, {{"x", S::poses, S::one, false}},
       kAnyBase, kByDefault, {}, "",
       "End-effector pose [x, y, phi]: tip of the last link, absolute angle of the last link."},
      {O::end_effector_jacobian, "end_effector_jacobian", "J", {I::q},
       {{"J", S::twists, S::nv, false}}, kAnyBase, kByDefault, {}, "",
       "Jacobian of the end-effector pose, d[x, y, phi]/dq."},
      {O::joint_positions, "joint_positions", "P", {I::q},
       {{"P", S::point, S::num_points, false}}, kAnyBase, kByDefault, {}, "",
       "World positions of joints 1..N (columns) and of the tip (last column)."},
      {O::joint_angles, "joint_angles", "qj", {I::q}, {{"q_joints", S::num_links, S::one, false}},
       kAnyBase, kByDefault, {}, "12",
       "Link-side joint angles q_i (motor angles divided by the gear ratio in a geared scene)."},
      {O::joint_rates, "joint_rates", "qjd", {I::qd}, {{"qd_joints", S::num_links, S::one, false}},
       kAnyBase, kByDefault, {}, "9",
       "Link-side joint rates qd_i (motor rates divided by the gear ratio in a geared scene)."},
      {O::mass_matrix_derivative, "mass_matrix_derivative", "Mdot", {I::q, I::qd},
       {{"Mdot", S::nv, S::nv, true}}, kAnyBase, kOnRequest, {}, "",
       "Time derivative of the mass matrix, Mdot = sum_k dM/dq_k qd_k."},
      {O::christoffel_coriolis_matrix, "christoffel_coriolis_matrix", "Cc", {I::q, I::qd},
       {{"Cc", S::nv, S::nv, false}}, kAnyBase, kOnRequest, {}, "",
       "Coriolis matrix in the Christoffel form: Cc qd = C qd, and Mdot - 2 Cc is skew-symmetric."},
      {O::inverse_dynamics, "inverse_dynamics", "Q", {I::q, I::qd, I::qdd},
       {{"Q", S::nv, S::one, false}}, kAnyBase, kByDefault, {O::mass_matrix, O::bias_forces}, "5",
       "Generalized forces Q = M qdd + b that give the acceleration qdd."},
      {O::forward_dynamics, "forward_dynamics", "qdd", {I::q, I::qd, I::generalized_forces},
       {{"qdd", S::nv, S::one, false}, {"pivots", S::nv, S::one, false},
        {"scaled_pivots", S::nv, S::one, false}},
       kAnyBase, kByDefault, {O::mass_matrix, O::bias_forces}, "8",
       "Acceleration qdd = M^-1 (Q - b) by an unrolled LDL^T solve, with the pivots D_i (all "
       "positive for a positive definite M) and D_i / M_ii, the pivots of "
       "diag(M)^-1/2 M diag(M)^-1/2 (max/min bounds its condition number)."},
      {O::generalized_jacobian, "generalized_jacobian", "Jg", {I::q},
       {{"Jg", S::twists, S::num_links, false}}, kRigidFreeBase, kByDefault,
       {O::mass_matrix, O::end_effector_jacobian}, "",
       "Generalized Jacobian J* (Umetani-Yoshida): end-effector velocity per rate of the joint "
       "coordinates (motor rates in a geared scene) with the base moving so that the momentum "
       "stays zero, J* = J_m - J_b M_bb^-1 M_bm."},
      {O::free_base_inverse_dynamics, "free_base_inverse_dynamics", "tau",
       {I::q, I::qd, I::joint_accelerations},
       {{"tau", S::num_links, S::one, false}, {"qdd_base", S::num_base, S::one, false}},
       kRigidFreeBase, kByDefault, {O::mass_matrix, O::bias_forces}, "14",
       "Joint torques tau that give the link-side joint accelerations qdd_joints with no force on "
       "the free base, and the base acceleration that follows; both tau and qdd_joints on the "
       "link side of the gears (tau = p Q, motor acceleration = p qdd_joints)."},
      {O::potential_energy, "potential_energy", "V", {I::q}, {{"V", S::one, S::one, false}},
       needs::springs, kByDefault, {}, "",
       "Potential energy of the joint springs, V = sum 1/2 k_i (qm_i / p_i - q_i)^2."},
      {O::spring_damper_forces, "spring_damper_forces", "fk", {I::q, I::qd},
       {{"fk", S::nv, S::one, false}}, needs::springs, kByDefault, {}, "",
       "Generalized forces of the joint springs and dampers, dV/dq + dD/dqd with the Rayleigh "
       "function D = sum 1/2 d_i (qmd_i / p_i - qd_i)^2; they enter as M qdd + b + fk = Q."},
      {O::friction_forces, "friction_forces", "ff", {I::qd}, {{"ff", S::nv, S::one, false}},
       needs::friction, kByDefault, {}, "",
       "Joint friction on the motor rate w (qd of an ungeared joint): f(w) = b w + Fc tanh(w/vs) "
       "+ (Fs - Fc) exp(-(w/vst)^2) tanh(w/vs); it enters as M qdd + b + ff = Q."},
      {O::forward_dynamics_derivatives, "forward_dynamics_derivatives", "dqdd",
       {I::q, I::qd, I::generalized_forces},
       {{"dqdd_dq", S::nv, S::nv, false}, {"dqdd_dqd", S::nv, S::nv, false},
        {"qdd", S::nv, S::one, false}, {"dqdd_dtau", S::nv, S::num_links, false}},
       kAnyBase, kOnRequest, {O::mass_matrix, O::bias_forces}, "8",
       "State Jacobian of forward dynamics at constant Q, d qdd/dq = -M^-1 (dM/dq qdd + dh/dq) and "
       "d qdd/dqd = -M^-1 dh/dqd (h: bias, springs, dampers, friction), from the exact symbolic "
       "derivatives and the same LDL^T solve as forward_dynamics; qdd at the same point. d qdd/dq "
       "is on the tangent space (nv columns): q moves as q + dq, a 3D base's quaternion turned by "
       "d omega in its own frame (MuJoCo's mj_integratePos, Pinocchio's integrate). d qdd/dtau "
       "(nv x N) by the link-side joint torques, Q = tau / p on each actuated coordinate: those "
       "columns of M^-1 over p."},
  };
  // clang-format on
  return registry;
}

std::string missing_feature(unsigned required, unsigned features) {
  const unsigned missing = required & ~features;
  if (missing & needs::free_base) return "is only defined for a free_floating base";
  if (missing & needs::rigid_joints)
    return "is not defined for a scene with flexible joints (the link and motor sides move apart)";
  if (missing & needs::springs) return "needs a flexible joint (gears: stiffness)";
  if (missing & needs::friction) return "needs joint friction (friction:)";
  return "";
}

const OutputInfo& info(Output output) {
  for (const auto& o : output_registry())
    if (o.id == output) return o;
  throw std::logic_error("output missing from the registry");
}

bool emitted_by_default(const OutputInfo& o, bool closed_form_affordable) {
  return o.by_default && (closed_form_affordable || o.id != Output::coriolis_matrix);
}

std::string to_string(Output output) { return info(output).name; }

bool has_lanes_version(Output output) {
  return output == Output::forward_dynamics || output == Output::end_effector_pose ||
         output == Output::momentum || output == Output::kinetic_energy;
}

std::string lanes_error(const std::string& name, bool known) {
  return known ? "'" + name + "' is not an output this scene emits (list it in 'outputs')"
               : "unknown output " + quoted_text(name) + " (known: " + output_names() + ")";
}

std::optional<Output> output_from_string(const std::string& name) {
  for (const auto& o : output_registry())
    if (name == o.name) return o.id;
  return std::nullopt;
}

std::string output_names() {
  std::string list;
  for (const auto& o : output_registry()) list += (list.empty() ? "" : ", ") + std::string(o.name);
  return list;
}

// Parsed by hand in one pass: a regular expression recursed once per character on long input.
EntryText parse_entry(const std::string& entry) {
  const std::string shown =
      "entry '" + (entry.size() > 40 ? entry.substr(0, 40) + "..." : entry) + "'";
  const std::string usage = ": expected e.g. T, M[3][4], C[0][3], b[2], h[0], x[1], J[0][3]";
  if (entry.size() > 100) throw std::invalid_argument(shown + " is too long" + usage);
  EntryText e;
  size_t i = 0;
  auto skip = [&] {
    while (i < entry.size() && entry[i] == ' ') ++i;
  };
  skip();
  while (i < entry.size() && std::isalpha(static_cast<unsigned char>(entry[i])))
    e.name += entry[i++];
  if (e.name.empty()) throw std::invalid_argument(shown + usage);
  for (skip(); i < entry.size() && entry[i] == '['; skip()) {
    ++i;
    skip();
    std::string digits;
    while (i < entry.size() && std::isdigit(static_cast<unsigned char>(entry[i])))
      digits += entry[i++];
    skip();
    if (digits.empty() || digits.size() > 6 || i >= entry.size() || entry[i] != ']')
      throw std::invalid_argument(shown + usage);
    ++i;
    e.indices.push_back(std::stoi(digits));
  }
  if (i != entry.size() || e.indices.size() > 2) throw std::invalid_argument(shown + usage);
  return e;
}

std::pair<int, int> entry_position(const EntryText& e, const OutputInfo& o, int rows, int cols,
                                   const std::string& shown) {
  const ResultInfo& shape = o.results[0];
  const size_t count = shape.cols != Size::one ? 2 : shape.rows != Size::one ? 1 : 0;
  if (e.indices.size() != count)
    throw std::invalid_argument(shown + ": " + e.name + " takes " + std::to_string(count) +
                                (count == 1 ? " index" : " indices") + ", got " +
                                std::to_string(e.indices.size()));
  const int limits[2] = {rows, cols};
  for (size_t k = 0; k < count; ++k)
    if (e.indices[k] >= limits[k])
      throw std::invalid_argument(shown + ": index " + std::to_string(e.indices[k]) +
                                  " out of range 0.." + std::to_string(limits[k] - 1));
  return {count ? e.indices[0] : 0, count == 2 ? e.indices[1] : 0};
}

}  // namespace spacearm
