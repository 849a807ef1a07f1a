#include "mujoco_compare.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Geometry>

#include <cstdio>
#include <random>
#include <stdexcept>

#include "compiled_model.hpp"
#include "text_numbers.hpp"

#ifdef SPACEARM_WITH_MUJOCO
#include <mujoco/mujoco.h>

#include <memory>
#endif

namespace spacearm::cli {

#ifndef SPACEARM_WITH_MUJOCO

bool mujoco_built() { return false; }

std::string compare_in_mujoco(const ModelRecipe&, const MjcfNames&, const Eigen::VectorXd&,
                              const std::string&, const std::string&, int) {
  throw std::invalid_argument(
      "--compare: this spacearm was built without MuJoCo (libmujoco-dev; scripts/setup.sh "
      "installs it)");
}

#else

bool mujoco_built() { return true; }

namespace {

// MuJoCo's message, control characters as '?' and at most 300 characters.
std::string shown(const std::string& text) {
  std::string s;
  for (char c : text.substr(0, 300))
    s += (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) ? '?' : c;
  return s + (text.size() > 300 ? "..." : "");
}

// The worst of three kinds of difference over the states, relative.
struct Worst {
  double mass_matrix = 0, bias = 0, forward = 0;
};

// MuJoCo's model of the file and its data, freed together.
struct Mujoco {
  std::unique_ptr<mjModel, void (*)(mjModel*)> m{nullptr, mj_deleteModel};
  std::unique_ptr<mjData, void (*)(mjData*)> d{nullptr, mj_deleteData};
  int joint(const std::string& name) const {
    const int id = mj_name2id(m.get(), mjOBJ_JOINT, name.c_str());
    if (id < 0)
      throw std::invalid_argument("--compare: MuJoCo's model has no joint " + quoted_text(name));
    return id;
  }
};

// Where each of spacearm's velocities sits in MuJoCo's (the base's six, then each joint), and
// each joint's rotor (-1: none).
struct Layout {
  std::vector<int> dof, joint_qpos, rotor;
  int base = -1;  // the free joint's id
};

Layout layout(const Mujoco& mj, const MjcfNames& names) {
  Layout l;
  if (!names.base_joint.empty()) {
    l.base = mj.joint(names.base_joint);
    for (int i = 0; i < 6; ++i) l.dof.push_back(mj.m->jnt_dofadr[l.base] + i);
  }
  for (size_t j = 0; j < names.joints.size(); ++j) {
    const int id = mj.joint(names.joints[j]);
    l.dof.push_back(mj.m->jnt_dofadr[id]);
    l.joint_qpos.push_back(mj.m->jnt_qposadr[id]);
    l.rotor.push_back(names.rotors[j].empty() ? -1 : mj.joint(names.rotors[j]));
  }
  return l;
}

}  // namespace

std::string compare_in_mujoco(const ModelRecipe& recipe, const MjcfNames& names,
                              const Eigen::VectorXd& params, const std::string& mjcf_path,
                              const std::string& cache_dir, int states) {
  Mujoco mj;
  char error[1000] = "";
  mj.m.reset(mj_loadXML(mjcf_path.c_str(), nullptr, error, sizeof error));
  if (!mj.m)  // MuJoCo's message quotes the file's names: shown through quoted_text's filter
    throw std::invalid_argument("--compare: MuJoCo refuses " + quoted_text(mjcf_path) + ": " +
                                shown(error));
  mj.d.reset(mj_makeData(mj.m.get()));
  CompileOptions options;
  options.cache_dir = cache_dir;
  const CompiledModel model = CompiledModel::load(recipe, options);
  const Layout at = layout(mj, names);
  const int nq = model.nq(), nv = model.nv(), N = model.num_links(), nb = model.num_base();
  // v = D v_mj: a geared slot holds the motor angle qm = p q.
  const Eigen::VectorXd p = model.gear_ratios(params);
  Eigen::VectorXd D = Eigen::VectorXd::Ones(nv);
  for (int j = 0; j < N; ++j)
    if (model.motor_angle_slots()[j]) D[nb + j] = p[j];
  bool rotors = false;
  for (int r : at.rotor) rotors = rotors || r >= 0;
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(-1, 1);
  Worst worst;
  for (int k = 0; k < states; ++k) {
    // A random state in spacearm's coordinates, and MuJoCo's.
    Eigen::VectorXd q(nq), v(nv), tau(N);
    for (int i = 0; i < nq; ++i) q[i] = u(rng);
    if (const int o = model.quaternion_offset(); o >= 0) {
      const Eigen::Quaterniond r = Eigen::Quaterniond::UnitRandom();
      q.segment<4>(o) << r.w(), r.x(), r.y(), r.z();
    }
    for (int i = 0; i < nv; ++i) v[i] = u(rng) * D[i];  // link rates of order 1
    for (int i = nb; i < nv; ++i) q[i + (nq - nv)] *= D[i];
    for (int j = 0; j < N; ++j) tau[j] = 10 * u(rng);
    mj_resetData(mj.m.get(), mj.d.get());
    if (at.base >= 0)
      for (int i = 0; i < 7; ++i) mj.d->qpos[mj.m->jnt_qposadr[at.base] + i] = q[i];
    for (int i = 0; i < nv; ++i) mj.d->qvel[at.dof[i]] = v[i] / D[i];
    for (int j = 0; j < N; ++j) {
      const int slot = nb + j, qslot = slot + (nq - nv);
      mj.d->qpos[at.joint_qpos[j]] = q[qslot] / D[slot];
      mj.d->qfrc_applied[at.dof[slot]] = tau[j];
      if (const int r = at.rotor[j]; r >= 0) {
        mj.d->qpos[mj.m->jnt_qposadr[r]] = q[qslot] / D[slot] * p[j];
        mj.d->qvel[mj.m->jnt_dofadr[r]] = v[slot] / D[slot] * p[j];
      }
    }
    mj_forward(mj.m.get(), mj.d.get());
    // spacearm's M and b, and its forward dynamics under the same torques and MuJoCo's passive
    // forces (its damping), all in spacearm's coordinates (a force f on q is f / p on qm).
    Eigen::MatrixXd M;
    Eigen::VectorXd b;
    model.mass_matrix_and_bias(q, v, params, M, b);
    Eigen::VectorXd Q(nv), qacc_mj(nv), b_mj(nv);
    for (int i = 0; i < nv; ++i) {
      Q[i] = ((i >= nb ? tau[i - nb] : 0) + mj.d->qfrc_passive[at.dof[i]]) / D[i];
      qacc_mj[i] = mj.d->qacc[at.dof[i]];
      b_mj[i] = mj.d->qfrc_bias[at.dof[i]];
    }
    const Eigen::VectorXd qacc = M.ldlt().solve(Q - b).cwiseQuotient(D);
    worst.forward = std::max(worst.forward, (qacc - qacc_mj).norm() / (1 + qacc_mj.norm()));
    if (rotors) continue;  // MuJoCo's M and bias then include the rotors' own dofs
    Eigen::MatrixXd M_mj(mj.m->nv, mj.m->nv);
    mj_fullM(mj.m.get(), M_mj.data(), mj.d->qM);
    Eigen::MatrixXd M_chain(nv, nv);
    for (int r = 0; r < nv; ++r)
      for (int c = 0; c < nv; ++c) M_chain(r, c) = M_mj(at.dof[r], at.dof[c]);
    worst.mass_matrix = std::max(
        worst.mass_matrix, (D.asDiagonal() * M * D.asDiagonal() - M_chain).norm() / M_chain.norm());
    worst.bias = std::max(worst.bias, (D.asDiagonal() * b - b_mj).norm() / (1 + b_mj.norm()));
  }
  char report[400];
  if (rotors)
    std::snprintf(report, sizeof report,
                  "compared with MuJoCo %s at %d random states: forward dynamics within %.1e "
                  "relative (exact rotors: MuJoCo holds them by soft joint equalities)",
                  mj_versionString(), states, worst.forward);
  else
    std::snprintf(report, sizeof report,
                  "compared with MuJoCo %s at %d random states: M within %.1e, the bias within "
                  "%.1e, forward dynamics within %.1e (relative)",
                  mj_versionString(), states, worst.mass_matrix, worst.bias, worst.forward);
  return report;
}

#endif

}  // namespace spacearm::cli
