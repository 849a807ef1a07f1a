// runtime/torque_signal.hpp: held and linearly interpolated torque samples.
#include "torque_signal.hpp"

#include <gtest/gtest.h>

namespace spacearm {
namespace {

TEST(TorqueSignal, HoldAndLinear) {
  using J = Eigen::Matrix<double, 2, 1>;
  const std::vector<J> samples{J(0, 10), J(1, 20), J(3, 20)};
  const TorqueSignal<2> hold(0.0, 0.5, samples, Interpolation::hold);
  const TorqueSignal<2> linear(0.0, 0.5, samples, Interpolation::linear);
  EXPECT_EQ(hold(0.25), J(0, 10));
  EXPECT_EQ(linear(0.25), J(0.5, 15));
  EXPECT_EQ(hold(0.5), J(1, 20));
  EXPECT_EQ(linear(0.75), J(2, 20));
  EXPECT_EQ(linear(1.0), J(3, 20));
  EXPECT_EQ(linear(1.5), J(0, 0));  // outside the sampled interval
  EXPECT_THROW(interpolation_from_string("cubic"), std::invalid_argument);
}

}  // namespace
}  // namespace spacearm
