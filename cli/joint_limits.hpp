// A run or a plan measured against a URDF's joint limits (<limit effort velocity lower upper>):
// per joint, the peak |tau| / effort and the peak |q'| / velocity on the link side (q' = qm' / p
// where the coordinate is the motor angle), and the peak |q - centre| / half the range, printed
// by plan and simulate --plan, a warning above 1.
#pragma once

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "model_recipe.hpp"
#include "text_numbers.hpp"

namespace spacearm::cli {

struct LimitUse {
  std::string joint;
  // Peak over the limit (the angle's: |q - centre| over half the range); NaN where the URDF
  // gives none.
  double effort = NAN, velocity = NAN, angle = NAN;
};

// tau[k], rates[k], angles[k]: the link-side joint torques, rates q' and angles q at sample k.
inline std::vector<LimitUse> limit_use(const ModelRecipe& recipe,
                                       const std::vector<Eigen::VectorXd>& tau,
                                       const std::vector<Eigen::VectorXd>& rates,
                                       const std::vector<Eigen::VectorXd>& angles) {
  const std::vector<spatial::JointLimits> limits = recipe.joint_limits();
  std::vector<LimitUse> use;
  for (size_t j = 0; j < limits.size(); ++j) {
    const spatial::JointLimits& l = limits[j];
    if (!l.has_effort() && !l.has_velocity() && !l.has_range()) continue;
    const auto row = static_cast<Eigen::Index>(j);
    const double centre = (l.lower + l.upper) / 2, half = (l.upper - l.lower) / 2;
    double tau_peak = 0, rate_peak = 0, angle_peak = 0;
    for (const auto& t : tau) tau_peak = std::max(tau_peak, std::abs(t[row]));
    for (const auto& v : rates) rate_peak = std::max(rate_peak, std::abs(v[row]));
    for (const auto& q : angles) angle_peak = std::max(angle_peak, std::abs(q[row] - centre));
    use.push_back({recipe.joint_names().at(j), l.has_effort() ? tau_peak / l.effort : NAN,
                   l.has_velocity() ? rate_peak / l.velocity : NAN,
                   l.has_range() ? angle_peak / half : NAN});
  }
  return use;
}

// One line of the joints' use of their limits (a second of their ranges where the URDF gives
// any), and a warning naming each joint above 1.
inline void report_limit_use(const std::vector<LimitUse>& use) {
  if (use.empty()) return;
  std::string line, ranges, over;
  char text[64];
  for (const LimitUse& u : use) {
    // "-" where the URDF gives no limit (effort, velocity or range 0 or absent).
    auto ratio = [&text](double r) {
      if (std::isnan(r)) return std::string("-");
      std::snprintf(text, sizeof text, "%.2g", r);
      return std::string(text);
    };
    line += (line.empty() ? "" : ", ") + quoted_text(u.joint) + " " + ratio(u.effort) + " / " +
            ratio(u.velocity);
    ranges += (ranges.empty() ? "" : ", ") + quoted_text(u.joint) + " " + ratio(u.angle);
    if (u.effort > 1 || u.velocity > 1 || u.angle > 1) {
      over += (over.empty() ? "" : ", ") + quoted_text(u.joint) + " (effort " + ratio(u.effort) +
              ", velocity " + ratio(u.velocity) + ", angle " + ratio(u.angle) + ")";
    }
  }
  std::fprintf(stderr,
               "spacearm: URDF limits, peak |tau| / effort and |q'| / velocity per joint: %s\n",
               line.c_str());
  if (std::any_of(use.begin(), use.end(), [](const LimitUse& u) { return !std::isnan(u.angle); }))
    std::fprintf(stderr,
                 "spacearm: URDF ranges, peak |q - centre| / half the range per joint: %s\n",
                 ranges.c_str());
  if (!over.empty())
    std::fprintf(stderr, "spacearm: warning: beyond the URDF's limits (times the limit): %s\n",
                 over.c_str());
}

}  // namespace spacearm::cli
