#include "outputs.hpp"

#include <stdexcept>

namespace spacearm {

int Dimensions::operator()(Size s) const {
  switch (s) {
    case Size::one: return 1;
    case Size::two: return 2;
    case Size::three: return 3;
    case Size::nq: return nq;
    case Size::nv: return nv;
    case Size::num_links: return num_links;
    case Size::num_links_plus_one: return num_links + 1;
  }
  throw std::logic_error("unknown size");
}

std::string size_constant(Size s) {
  switch (s) {
    case Size::one: return "1";
    case Size::two: return "2";
    case Size::three: return "3";
    case Size::nq: return "kNq";
    case Size::nv: return "kNv";
    case Size::num_links: return "kNumLinks";
    case Size::num_links_plus_one: return "kNumLinks + 1";
  }
  throw std::logic_error("unknown size");
}

const InputInfo& info(Input input) {
  static const InputInfo inputs[] = {
      {Input::q, "q", Size::nq},
      {Input::qd, "qd", Size::nv},
  };
  for (const auto& i : inputs)
    if (i.id == input) return i;
  throw std::logic_error("unknown input");
}

const std::vector<OutputInfo>& output_registry() {
  using I = Input;
  using S = Size;
  static const std::vector<OutputInfo> registry = {
      {Output::mass_matrix, "mass_matrix", "M", {I::q}, {{"M", S::nv, S::nv, true}}, false, true, "6",
       "Mass matrix M(q) (symmetric positive definite)."},
      {Output::coriolis_matrix, "coriolis_matrix", "C", {I::q, I::qd}, {{"C", S::nv, S::nv, false}}, false, true, "7",
       "Coriolis/centrifugal matrix C(q, qd), exactly as the paper defines it; C qd is the bias. "
       "Not the Christoffel form: Mdot - 2C is not skew-symmetric."},
      {Output::bias_forces, "bias_forces", "b", {I::q, I::qd}, {{"b", S::nv, S::one, false}}, false, true, "5",
       "Bias b = C(q, qd) qd, so that M qdd + b = Q."},
      {Output::kinetic_energy, "kinetic_energy", "T", {I::q, I::qd}, {{"T", S::one, S::one, false}}, false, true,
       "3 and 10", "Kinetic energy T = 1/2 qd^T M qd."},
      {Output::momentum, "momentum", "h", {I::q, I::qd}, {{"h", S::three, S::one, false}}, true, true, "",
       "Momentum h = [Px, Py, L]: linear momentum and angular momentum about the world origin."},
      {Output::end_effector_pose, "end_effector_pose", "x", {I::q}, {{"x", S::three, S::one, false}}, false, true,
       "", "End-effector pose [x, y, phi]: tip of the last link, absolute angle of the last link."},
      {Output::end_effector_jacobian, "end_effector_jacobian", "J", {I::q}, {{"J", S::three, S::nv, false}}, false,
       true, "", "Jacobian of the end-effector pose, d[x, y, phi]/dq."},
      {Output::joint_positions, "joint_positions", "P", {I::q},
       {{"P", S::two, S::num_links_plus_one, false}}, false, true, "",
       "World positions of joints 1..N (columns) and of the tip (last column)."},
  };
  return registry;
}

const OutputInfo& info(Output output) {
  for (const auto& o : output_registry())
    if (o.id == output) return o;
  throw std::logic_error("output missing from the registry");
}

std::string to_string(Output output) { return info(output).name; }

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

}  // namespace spacearm
