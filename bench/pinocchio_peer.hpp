// Pinocchio (Carpentier et al.) as a peer of bench_spatial, where a build of it is given
// (PINOCCHIO_DIR; bench/peers/pinocchio.sh builds one from its public repository): its model of
// the same MJCF that MuJoCo reads (spacearm export --mjcf, through Pinocchio's own MJCF parser),
// its articulated-body algorithm and its analytical ABA derivatives (computeABADerivatives:
// d qdd/dq, d qdd/dv and M^-1). Compiled apart (pinocchio_peer.cpp), so that bench_spatial's
// other sources never see Pinocchio's headers.
#pragma once

#include <Eigen/Core>

#include <memory>
#include <string>
#include <vector>

namespace spacearm::bench {

class PinocchioPeer {
 public:
  // Pinocchio's model of `mjcf`; `ratios` the joints' gear ratios (1: none): spacearm's geared
  // slots hold the motor angle qm = p q, Pinocchio's (as MuJoCo's) the link angle.
  PinocchioPeer(const std::string& mjcf, const Eigen::VectorXd& ratios);
  ~PinocchioPeer();
  // Converts spacearm's states (q = [origin, w x y z, slots], v = [world linear velocity, body
  // angular velocity, slot rates], Q likewise) into Pinocchio's once, before anything is timed.
  void set_states(const std::vector<Eigen::VectorXd>& q, const std::vector<Eigen::VectorXd>& v,
                  const std::vector<Eigen::VectorXd>& Q);
  // The timed calls at state k.
  void aba(int k);
  void aba_derivatives(int k);
  // Pinocchio's generated ABA derivatives (CppADCodeGen), where this peer was built with them
  // (PINOCCHIO_CPPADCG_DIR; bench/peers/cppadcg.sh): false where not. Generated and compiled
  // here, once (tens of seconds).
  bool build_codegen();
  void aba_derivatives_codegen(int k);
  // At state k, the largest difference (relative) of the generated derivatives from
  // computeABADerivatives' (d qdd/dq, d qdd/dv and M^-1).
  double codegen_difference(int k);
  // At state k, in spacearm's convention: the forward dynamics (nv), and the joint rows and
  // columns (N x N) of d qdd/dq, d qdd/dv and d qdd/dtau (the blocks both conventions share).
  Eigen::VectorXd forward_dynamics(int k);
  void joint_blocks(int k, Eigen::MatrixXd& dqdd_dq, Eigen::MatrixXd& dqdd_dv,
                    Eigen::MatrixXd& dqdd_dtau);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace spacearm::bench
