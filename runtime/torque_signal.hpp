// Joint torques sampled on a uniform time grid t_k = t0 + k dt, replayed as a signal:
//   hold    zero-order hold: sample k on [t_k, t_{k+1}). Integrators must give every stage
//           of a step the one interval's value (held_over), or a step that ends on a
//           sample would see the next one in its last stage (a first-order error).
//   linear  straight lines between samples.
// Outside [t_first, t_last] the signal is an error unless asked to hold the end values or
// to be zero there.
#pragma once

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "text_numbers.hpp"

namespace spacearm {

enum class Interpolation { hold, linear };
enum class Extrapolation { error, hold, zero };

inline Interpolation interpolation_from_string(const std::string& s) {
  if (s == "hold") return Interpolation::hold;
  if (s == "linear") return Interpolation::linear;
  throw std::invalid_argument("unknown torque interpolation '" + s + "' (known: hold, linear)");
}

inline Extrapolation extrapolation_from_string(const std::string& s) {
  if (s == "error") return Extrapolation::error;
  if (s == "hold") return Extrapolation::hold;
  if (s == "zero") return Extrapolation::zero;
  throw std::invalid_argument("unknown torque extrapolation '" + s +
                              "' (known: error, hold, zero)");
}

template <int N>
class TorqueSignal {
 public:
  using Joint = Eigen::Matrix<double, N, 1>;
  TorqueSignal(double t0, double dt, std::vector<Joint> samples, Interpolation mode,
               Extrapolation outside = Extrapolation::error)
      : t0_(t0), dt_(dt), samples_(std::move(samples)), mode_(mode), outside_(outside) {
    if (samples_.empty() || !(dt_ > 0) || !std::isfinite(t0_) || !std::isfinite(dt_))
      throw std::invalid_argument("TorqueSignal: needs samples, a finite t0 and dt > 0");
    zero_ = Joint::Zero(samples_.front().size());
  }

  // The signal at t (hold: right-continuous, the sample that starts at or before t).
  Joint operator()(double t) const {
    Joint value = Joint::Zero(size());
    evaluate(t, value);
    return value;
  }
  // The same into `value` (sized as a sample): no allocation, for the integrators' hot path.
  template <class Out>
  void evaluate(double t, Out& value) const {
    const double s = (t - t0_) / dt_;
    const long last = static_cast<long>(samples_.size()) - 1;
    if (const Joint* outside = beyond(s, t)) {
      value = *outside;
      return;
    }
    // Tolerate rounding of t at the sample times.
    const long k = std::clamp(static_cast<long>(std::floor(s + 1e-9)), 0L, last);
    if (mode_ == Interpolation::hold || k == last) {
      value = samples_[k];
      return;
    }
    const double w = std::clamp(s - k, 0.0, 1.0);
    value = (1 - w) * samples_[k] + w * samples_[k + 1];
  }
  int size() const { return static_cast<int>(samples_.front().size()); }

  // The held value for a whole step [t_a, t_b] that lies in one sample interval: that
  // interval's sample, for every stage of the step, including one at t_b = t_{k+1}.
  Joint held_over(double t_a, double t_b) const { return (*this)(0.5 * (t_a + t_b)); }

  Interpolation mode() const { return mode_; }
  double t_first() const { return t0_; }
  double t_last() const { return t0_ + dt_ * static_cast<double>(samples_.size() - 1); }
  double dt() const { return dt_; }

 private:
  double t0_, dt_;
  std::vector<Joint> samples_;
  Interpolation mode_;
  Extrapolation outside_;
  Joint zero_;

  const Joint* beyond(double s, double t) const {
    const double last = static_cast<double>(samples_.size() - 1);
    if (s >= -1e-9 && s <= last + 1e-9) return nullptr;
    if (outside_ == Extrapolation::zero) return &zero_;
    if (outside_ == Extrapolation::hold) return s < 0 ? &samples_.front() : &samples_.back();
    // A runtime_error, so that an integrator reports it with the last accepted state.
    throw std::runtime_error("torque requested at t = " + number_text(t) +
                             " s, outside the samples [" + number_text(t_first()) + ", " +
                             number_text(t_last()) +
                             "] s (extrapolate with hold or zero to allow it)");
  }
};

}  // namespace spacearm
