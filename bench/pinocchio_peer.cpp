// bench/pinocchio_peer.hpp: Pinocchio's model, states and calls.
#include "pinocchio_peer.hpp"

// Pinocchio's code generation must come before its other headers (its scalar traits).
#ifdef SPACEARM_PINOCCHIO_CODEGEN
#include <pinocchio/codegen/cppadcg.hpp>
#include <pinocchio/codegen/code-generator-algo.hpp>
#endif

#include <pinocchio/algorithm/aba-derivatives.hpp>
#include <pinocchio/algorithm/aba.hpp>
#include <pinocchio/multibody/data.hpp>
#include <pinocchio/multibody/model.hpp>
#include <pinocchio/parsers/mjcf.hpp>

#include <Eigen/Geometry>

#include <stdlib.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <stdexcept>

namespace spacearm::bench {

#ifdef SPACEARM_PINOCCHIO_CODEGEN
// Its results are protected members (Pinocchio's own tests read them through a subclass too).
struct GeneratedAbaDerivatives : pinocchio::CodeGenABADerivatives<double> {
  using CodeGenABADerivatives::CodeGenABADerivatives;
  using CodeGenABADerivatives::dddq_dq;
  using CodeGenABADerivatives::dddq_dtau;
  using CodeGenABADerivatives::dddq_dv;
};
#endif

struct PinocchioPeer::Impl {
  pinocchio::Model model;
  std::unique_ptr<pinocchio::Data> data;
  Eigen::VectorXd ratios;  // per joint
  std::vector<Eigen::VectorXd> q, v, tau;
  std::vector<Eigen::Matrix3d> R;  // the base's orientation per state
#ifdef SPACEARM_PINOCCHIO_CODEGEN
  std::unique_ptr<GeneratedAbaDerivatives> codegen;
#endif
  // Per velocity: spacearm's slot over Pinocchio's (p for a geared joint's rate, else 1).
  Eigen::VectorXd D() const {
    Eigen::VectorXd d = Eigen::VectorXd::Ones(model.nv);
    d.tail(ratios.size()) = ratios;
    return d;
  }
};

PinocchioPeer::PinocchioPeer(const std::string& mjcf, const Eigen::VectorXd& ratios)
    : impl_(std::make_unique<Impl>()) {
  // From a file: Pinocchio 3.7's buildModelFromXML reads its argument as a file name too. The
  // file is made by mkstemps (created exclusively, mode 0600: no link followed, none replaced).
  std::string file =
      (std::filesystem::temp_directory_path() / "spacearm-pinocchio-XXXXXX.xml").string();
  const int fd = ::mkstemps(file.data(), 4);
  if (fd < 0) throw std::runtime_error("pinocchio peer: cannot create a temporary file");
  const bool written = ::write(fd, mjcf.data(), mjcf.size()) == static_cast<ssize_t>(mjcf.size());
  ::close(fd);
  if (written) pinocchio::mjcf::buildModel(file, impl_->model);
  std::filesystem::remove(file);
  if (!written) throw std::runtime_error("pinocchio peer: cannot write " + file);
  impl_->model.gravity.setZero();  // in space (its parser does not read <option gravity>)
  if (impl_->model.nv != 6 + ratios.size() || impl_->model.nq != 7 + ratios.size())
    throw std::runtime_error("pinocchio peer: the MJCF gave nq " + std::to_string(impl_->model.nq) +
                             ", nv " + std::to_string(impl_->model.nv) + " (a free base and " +
                             std::to_string(ratios.size()) + " joints expected)");
  impl_->data = std::make_unique<pinocchio::Data>(impl_->model);
  impl_->ratios = ratios;
}

PinocchioPeer::~PinocchioPeer() = default;

// computeABADerivatives recorded on CppADCodeGen's scalars, printed as C and compiled by gcc
// with Pinocchio's own flags (-Ofast) into a library in a fresh temporary folder, then loaded;
// the folder is removed once the library is loaded (its mapping stays).
bool PinocchioPeer::build_codegen() {
#ifdef SPACEARM_PINOCCHIO_CODEGEN
  char folder[] = "/tmp/spacearm-pinocchio-cg-XXXXXX";
  if (!::mkdtemp(folder)) throw std::runtime_error("pinocchio peer: cannot create a folder");
  const auto start = std::chrono::steady_clock::now();
  impl_->codegen = std::make_unique<GeneratedAbaDerivatives>(
      impl_->model, "partial_aba", std::string(folder) + "/cg_partial_aba_eval");
  impl_->codegen->initLib();
  impl_->codegen->loadLib(true);
  std::filesystem::remove_all(folder);
  std::printf(
      "pinocchio peer: CppADCodeGen's ABA derivatives generated, compiled and loaded in "
      "%.1f s\n",
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  return true;
#else
  return false;
#endif
}

#ifdef SPACEARM_PINOCCHIO_CODEGEN
void PinocchioPeer::aba_derivatives_codegen(int k) {
  Impl& p = *impl_;
  p.codegen->evalFunction(p.q[k], p.v[k], p.tau[k]);
}

double PinocchioPeer::codegen_difference(int k) {
  Impl& p = *impl_;
  aba_derivatives(k);
  aba_derivatives_codegen(k);
  const GeneratedAbaDerivatives& cg = *p.codegen;
  const Eigen::MatrixXd Minv = p.data->Minv.selfadjointView<Eigen::Upper>();
  auto relative = [](const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
    return (a - b).norm() / (1 + a.norm());
  };
  return std::max({relative(p.data->ddq_dq, cg.dddq_dq), relative(p.data->ddq_dv, cg.dddq_dv),
                   relative(Minv, cg.dddq_dtau)});
}
#else
void PinocchioPeer::aba_derivatives_codegen(int) {}
double PinocchioPeer::codegen_difference(int) { return NAN; }
#endif

// Pinocchio's free flyer: q = [origin, x y z w], v = [linear velocity in the base frame,
// angular velocity in the base frame], tau = [force, torque] in the base frame.
void PinocchioPeer::set_states(const std::vector<Eigen::VectorXd>& q,
                               const std::vector<Eigen::VectorXd>& v,
                               const std::vector<Eigen::VectorXd>& Q) {
  Impl& p = *impl_;
  const int N = static_cast<int>(p.ratios.size());
  for (size_t k = 0; k < q.size(); ++k) {
    const Eigen::Quaterniond r =
        Eigen::Quaterniond(q[k][3], q[k][4], q[k][5], q[k][6]).normalized();
    const Eigen::Matrix3d R = r.toRotationMatrix();
    Eigen::VectorXd qp(7 + N), vp(6 + N), tp(6 + N);
    qp << q[k].head<3>(), r.x(), r.y(), r.z(), r.w(), q[k].tail(N).cwiseQuotient(p.ratios);
    vp << R.transpose() * v[k].head<3>(), v[k].segment<3>(3), v[k].tail(N).cwiseQuotient(p.ratios);
    tp << R.transpose() * Q[k].head<3>(), Q[k].segment<3>(3), Q[k].tail(N).cwiseProduct(p.ratios);
    p.q.push_back(qp), p.v.push_back(vp), p.tau.push_back(tp), p.R.push_back(R);
  }
}

void PinocchioPeer::aba(int k) {
  Impl& p = *impl_;
  pinocchio::aba(p.model, *p.data, p.q[k], p.v[k], p.tau[k]);
}

void PinocchioPeer::aba_derivatives(int k) {
  Impl& p = *impl_;
  pinocchio::computeABADerivatives(p.model, *p.data, p.q[k], p.v[k], p.tau[k]);
}

// The base's linear acceleration in the world: v_world = R v_local, so a_world = R (a_local +
// omega x v_local).
Eigen::VectorXd PinocchioPeer::forward_dynamics(int k) {
  Impl& p = *impl_;
  const Eigen::VectorXd& a = pinocchio::aba(p.model, *p.data, p.q[k], p.v[k], p.tau[k]);
  Eigen::VectorXd qdd = a.cwiseProduct(p.D());
  qdd.head<3>() = p.R[k] * (a.head<3>() + p.v[k].segment<3>(3).cross(p.v[k].head<3>()));
  return qdd;
}

void PinocchioPeer::joint_blocks(int k, Eigen::MatrixXd& dqdd_dq, Eigen::MatrixXd& dqdd_dv,
                                 Eigen::MatrixXd& dqdd_dtau) {
  Impl& p = *impl_;
  aba_derivatives(k);
  const int N = static_cast<int>(p.ratios.size());
  const Eigen::MatrixXd Minv =
      p.data->Minv.selfadjointView<Eigen::Upper>();  // its upper triangle holds M^-1
  // Slot i holds p_i q_i: d(p_i qdd_i)/d(p_j q_j) = p_i / p_j d qdd_i / d q_j, and by the
  // link-side torque tau_j (spacearm's dqdd_dtau) p_i M^-1_ij.
  const Eigen::VectorXd r = p.ratios, inv = r.cwiseInverse();
  dqdd_dq = r.asDiagonal() * p.data->ddq_dq.bottomRightCorner(N, N) * inv.asDiagonal();
  dqdd_dv = r.asDiagonal() * p.data->ddq_dv.bottomRightCorner(N, N) * inv.asDiagonal();
  dqdd_dtau = r.asDiagonal() * Minv.bottomRightCorner(N, N);
}

}  // namespace spacearm::bench
