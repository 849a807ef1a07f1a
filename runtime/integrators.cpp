// The run-time-sized instantiation of integrate() (integrators.hpp): Boost.Odeint's steppers
// on Eigen::VectorXd, compiled once for every program that integrates a DynamicModel.
#include "integrators.hpp"

namespace spacearm {

IntegrationStats integrate_dynamic(const IntegratorOptions& opt, const DynamicSystem& f,
                                   Eigen::VectorXd& x, double t0, double t1, double dt_out,
                                   const DynamicObserver& observe) {
  return detail::integrate_states(opt, f, x, t0, t1, dt_out, observe);
}

}  // namespace spacearm
