// Helpers shared by the tests: random scenes as YAML text, scene -> numeric oracle
// parameters, random states and comparison with the worst entry reported.
#pragma once

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <random>
#include <sstream>
#include <string>

#include "numeric_lagrangian.hpp"
#include "planar_scene.hpp"

// Expects `statement` to throw `type` with a message containing `text`.
#define EXPECT_THROW_MESSAGE(statement, type, text)                                                \
  do {                                                                                             \
    try {                                                                                          \
      statement;                                                                                   \
      ADD_FAILURE() << #statement " did not throw";                                                \
    } catch (const type& e_) {                                                                     \
      EXPECT_NE(std::string(e_.what()).find(text), std::string::npos) << "message: " << e_.what(); \
    }                                                                                              \
  } while (0)

namespace spacearm::test {

struct ChainSpec {
  int links = 3;
  bool free_floating = true;
  bool geared = false;
  bool gear_parameters = false;  // p and Im as run-time parameters
  double ratio = 10, motor_inertia = 1e-5;
  std::string outputs = "[mass_matrix, bias_forces, kinetic_energy, momentum]";
  unsigned seed = 1;
};

// A random but physically plausible chain, written as a scene file.
inline std::string random_scene_yaml(const ChainSpec& spec) {
  std::mt19937 rng(spec.seed);
  auto u = [&](double a, double b) { return std::uniform_real_distribution<double>(a, b)(rng); };
  std::ostringstream y;
  y.precision(17);
  y << "name: chain" << spec.links << (spec.free_floating ? "_free" : "_fixed")
    << (spec.geared ? "_geared" : "") << "\n";
  y << "base: {type: " << (spec.free_floating ? "free_floating" : "fixed")
    << ", mass: " << u(20, 100) << ", inertia: " << u(1, 5) << ", mount: [" << u(0.2, 0.5) << ", "
    << u(-0.05, 0.05) << "]}\n";
  y << "links:\n";
  for (int i = 0; i < spec.links; ++i)
    y << "  - {mass: " << u(0.5, 4) << ", inertia: " << u(0.01, 0.1) << ", length: " << u(0.2, 0.6)
      << ", com: [" << u(0.05, 0.3) << ", " << u(-0.02, 0.02) << "]}\n";
  if (spec.geared) {
    if (spec.gear_parameters) {
      y << "gears: {ratio: p, motor_inertia: Im, compensate_link_inertia: true}\n";
      y << "parameters: {p: " << spec.ratio << ", Im: " << spec.motor_inertia << "}\n";
    } else {
      y << "gears:\n";
      for (int i = 0; i < spec.links; ++i)
        y << "  - {ratio: " << u(1, 50) << ", motor_inertia: " << u(0, 5e-3)
          << ", compensate_link_inertia: " << (i % 2 ? "false" : "true")
          << (i % 3 == 2 ? ", rotor_coupling: armature" : "") << "}\n";
    }
  }
  y << "outputs: " << spec.outputs << "\n";
  return y.str();
}

// Numeric parameters of a scene for the oracle, parameters at the given values (nominal
// where the map has none).
inline ChainParameters chain_parameters(const Scene& s,
                                        const std::map<std::string, double>& values = {}) {
  auto v = [&](const Quantity& q) {
    if (!q.is_parameter()) return q.value;
    auto it = values.find(q.parameter);
    if (it != values.end()) return it->second;
    for (const auto& p : s.parameters)
      if (p.name == q.parameter) return p.nominal.value;
    throw std::logic_error("unknown parameter " + q.parameter);
  };
  ChainParameters c;
  c.free_floating = s.free_floating();
  if (c.free_floating) {
    c.base_mass = v(s.base.mass);
    c.base_inertia = v(s.base.inertia);
  }
  c.mount = {v(s.base.mount[0]), v(s.base.mount[1])};
  for (const auto& l : s.links)
    c.links.push_back({v(l.mass), v(l.inertia), v(l.length), {v(l.com[0]), v(l.com[1])}});
  for (const auto& g : s.gears) {
    if (!g) {
      c.gears.emplace_back();
      continue;
    }
    c.gears.push_back(ChainParameters::Gear{
        v(g->ratio), v(g->motor_inertia), g->compensate_link_inertia, g->armature,
        g->stiffness ? v(*g->stiffness) : 0.0, g->damping ? v(*g->damping) : 0.0});
  }
  for (const auto& f : s.friction) {
    if (!f) {
      c.friction.emplace_back();
      continue;
    }
    c.friction.push_back(ChainParameters::Friction{
        v(f->viscous), v(f->coulomb), f->has_coulomb ? v(f->velocity_scale) : 1.0,
        v(f->stribeck_static), f->has_stribeck ? v(f->stribeck_velocity) : 1.0});
  }
  return c;
}

inline Eigen::VectorXd random_vector(std::mt19937& rng, int n, double scale) {
  Eigen::VectorXd x(n);
  for (int i = 0; i < n; ++i) x[i] = std::uniform_real_distribution<double>(-scale, scale)(rng);
  return x;
}

// Largest |a - b| relative to max(|b|_max, floor), with the worst entry, for messages.
struct Difference {
  double relative = 0;
  Eigen::Index row = 0, col = 0;
};
inline Difference relative_difference(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b,
                                      double floor = 1e-300) {
  Difference d;
  const double scale = std::max(b.cwiseAbs().maxCoeff(), floor);
  for (Eigen::Index i = 0; i < a.rows(); ++i)
    for (Eigen::Index j = 0; j < a.cols(); ++j) {
      const double r = std::abs(a(i, j) - b(i, j)) / scale;
      if (r > d.relative) d = {r, i, j};
    }
  return d;
}

#define EXPECT_MATRIX_NEAR(a, b, tol)                                                              \
  do {                                                                                             \
    const Eigen::MatrixXd a_ = (a), b_ = (b);                                                      \
    ASSERT_EQ(a_.rows(), b_.rows());                                                               \
    ASSERT_EQ(a_.cols(), b_.cols());                                                               \
    ASSERT_GT(b_.cwiseAbs().maxCoeff(), 0.0)                                                       \
        << "reference " #b " is all zero: comparison would be vacuous";                            \
    const auto d_ = ::spacearm::test::relative_difference(a_, b_);                                 \
    EXPECT_LE(d_.relative, (tol)) << "worst entry (" << d_.row << ", " << d_.col << "): " #a " = " \
                                  << a_(d_.row, d_.col) << ", " #b " = " << b_(d_.row, d_.col);    \
  } while (0)

// A whole file as text (empty if it cannot be read).
inline std::string read_text_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

// Runs a shell command; returns its standard output and sets *status to pclose's status.
inline std::string run_command(const std::string& command, int* status = nullptr) {
  std::string out;
  if (FILE* p = popen(command.c_str(), "r")) {
    char buf[4096];
    size_t n;
    while ((n = fread(buf, 1, sizeof buf, p)) > 0) out.append(buf, n);
    const int st = pclose(p);
    if (status) *status = st;
  }
  return out;
}

}  // namespace spacearm::test
