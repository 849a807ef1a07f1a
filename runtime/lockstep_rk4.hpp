// Fixed-step classical Runge-Kutta for L systems in lockstep ("lanes"): entry i of lane l's
// state at x[i * L + l], so that one call of the right-hand side evaluates every lane at once
// (a generated 4-lane function: four states per instruction) and each lane's arithmetic is
// exactly that of one system alone. The stages are combined as Boost.Odeint's runge_kutta4
// (explicit_generic_rk on the vector-space algebra) combines them: its coefficients, term by
// term in its order, zeros included (0 * k can turn x = -0 into +0, as odeint does), so every
// lane's states are odeint's to the bit (test_lockstep_rk4) and integrate()'s rk4 path and this
// one write the same rows. Written here because odeint's steppers call the system once per
// state, not once per group of lanes. The workspaces are allocated once, at construction.
#pragma once

#include <Eigen/Core>

#include <vector>

namespace spacearm {

template <int L>
class LockstepRk4 {
 public:
  static constexpr int kLanes = L;
  // n: a lane's state entries.
  explicit LockstepRk4(Eigen::Index n)
      : size_(n * L), k1_(size_), k2_(size_), k3_(size_), k4_(size_), x_tmp_(size_) {}

  // Advances x (size n * L, lanes interleaved) from t by h. rhs(const double* x, double* dxdt,
  // double t) evaluates every lane; it may throw (the step is then not taken).
  template <class Rhs>
  void step(Rhs&& rhs, double* x, double t, double h) {
    // odeint's Butcher tableau: a = {1/2}, {0, 1/2}, {0, 0, 1}; b = {1/6, 1/3, 1/3, 1/6};
    // c = {0, 1/2, 1/2, 1}; each term scaled as a_ij * dt.
    constexpr double half = 1.0 / 2, sixth = 1.0 / 6, third = 1.0 / 3;
    const double zero = 0.0 * h, a_half = half * h, a_one = 1.0 * h;
    const Eigen::Index n = size_;
    double *k1 = k1_.data(), *k2 = k2_.data(), *k3 = k3_.data(), *k4 = k4_.data();
    double* x_tmp = x_tmp_.data();
    rhs(static_cast<const double*>(x), k1, t);
    for (Eigen::Index i = 0; i < n; ++i) x_tmp[i] = 1.0 * x[i] + a_half * k1[i];
    rhs(static_cast<const double*>(x_tmp), k2, t + half * h);
    for (Eigen::Index i = 0; i < n; ++i) x_tmp[i] = 1.0 * x[i] + zero * k1[i] + a_half * k2[i];
    rhs(static_cast<const double*>(x_tmp), k3, t + half * h);
    for (Eigen::Index i = 0; i < n; ++i)
      x_tmp[i] = 1.0 * x[i] + zero * k1[i] + zero * k2[i] + a_one * k3[i];
    rhs(static_cast<const double*>(x_tmp), k4, t + 1.0 * h);
    const double b_sixth = sixth * h, b_third = third * h;
    for (Eigen::Index i = 0; i < n; ++i)
      x[i] = 1.0 * x[i] + b_sixth * k1[i] + b_third * k2[i] + b_third * k3[i] + b_sixth * k4[i];
  }

 private:
  Eigen::Index size_;
  std::vector<double> k1_, k2_, k3_, k4_, x_tmp_;
};

}  // namespace spacearm
