// A MuJoCo model loaded from MJCF text, the peer of the agreement tests and the benchmarks
// (bench/mujoco_chain.hpp writes the planar chains' MJCF, export/mjcf_export.hpp the
// spatial ones), and MuJoCo's stages that give M and the bias without the rest of mj_forward.
#pragma once

#include <mujoco/mujoco.h>
#include <unistd.h>

#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>

namespace spacearm::test {

struct MujocoModel {
  std::unique_ptr<mjModel, void (*)(mjModel*)> m{nullptr, mj_deleteModel};
  std::unique_ptr<mjData, void (*)(mjData*)> d{nullptr, mj_deleteData};

  explicit MujocoModel(const std::string& mjcf) {
    // mj_loadXML reads files only (2.2): a private temporary file, created exclusively with its
    // suffix and written through its descriptor.
    char path[] = "/tmp/spacearm-mjcf-XXXXXX.xml";
    const int fd = mkstemps(path, 4);
    if (fd < 0) throw std::runtime_error("mujoco: cannot create a temporary file");
    const bool written = ::write(fd, mjcf.data(), mjcf.size()) == static_cast<ssize_t>(mjcf.size());
    ::close(fd);
    char error[1000] = "";
    if (written) m.reset(mj_loadXML(path, nullptr, error, sizeof error));
    std::remove(path);
    if (!written) throw std::runtime_error("mujoco: cannot write a temporary file");
    if (!m) throw std::runtime_error(std::string("mujoco: cannot load the model: ") + error);
    d.reset(mj_makeData(m.get()));
  }

  // M (full, nv x nv, into `full`) and the bias forces (d->qfrc_bias) at d's qpos and qvel:
  // the stages of mj_forward that compute them.
  void mass_matrix_and_bias(mjtNum* full) const {
    mj_kinematics(m.get(), d.get());
    mj_comPos(m.get(), d.get());
    mj_crb(m.get(), d.get());
    mj_comVel(m.get(), d.get());
    mj_rne(m.get(), d.get(), 0, d->qfrc_bias);
    mj_fullM(m.get(), full, d->qM);
  }
};

}  // namespace spacearm::test
