// Joint torques sampled on a time grid, replayed as a signal: held (zero-order hold, the
// value of the last sample) or interpolated linearly between samples.
#pragma once

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

namespace spacearm {

enum class Interpolation { hold, linear };

inline Interpolation interpolation_from_string(const std::string& s) {
  if (s == "hold") return Interpolation::hold;
  if (s == "linear") return Interpolation::linear;
  throw std::invalid_argument("unknown torque interpolation '" + s + "' (known: hold, linear)");
}

template <int N>
class TorqueSignal {
 public:
  using Joint = Eigen::Matrix<double, N, 1>;
  TorqueSignal(double t0, double dt, std::vector<Joint> samples, Interpolation mode)
      : t0_(t0), dt_(dt), samples_(std::move(samples)), mode_(mode) {
    if (samples_.empty() || !(dt_ > 0)) throw std::invalid_argument("TorqueSignal: needs samples and dt > 0");
  }
  // Outside the sampled interval the signal is zero.
  Joint operator()(double t) const {
    const double s = (t - t0_) / dt_;
    const double last = static_cast<double>(samples_.size() - 1);
    if (s < -1e-9 || s > last + 1e-9) return Joint::Zero(samples_.front().size());
    // Tolerate rounding of t at the sample times.
    long k = static_cast<long>(std::floor(s + 1e-9));
    k = std::clamp(k, 0L, static_cast<long>(samples_.size()) - 1);
    if (mode_ == Interpolation::hold || k + 1 >= static_cast<long>(samples_.size())) return samples_[k];
    const double w = std::clamp(s - k, 0.0, 1.0);
    return (1 - w) * samples_[k] + w * samples_[k + 1];
  }
  Interpolation mode() const { return mode_; }

 private:
  double t0_, dt_;
  std::vector<Joint> samples_;
  Interpolation mode_;
};

}  // namespace spacearm
