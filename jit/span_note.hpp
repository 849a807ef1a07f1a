// A run's failure at run-time parameters that widen the model's span of values past what the
// generator checked names that span (CompiledModel::span_note): the simulate and eval commands
// and Python wrap their runs in with_span_note.
#pragma once

#include <stdexcept>
#include <string>

#include "dynamics_checks.hpp"
#include "integrator_options.hpp"

namespace spacearm {

// Runs f; an IntegrationError, DynamicsError or std::invalid_argument is thrown again, of the
// same kind, with `note` appended.
template <class F>
auto with_span_note(const std::string& note, F&& f) -> decltype(f()) {
  if (note.empty()) return f();
  try {
    return f();
  } catch (const IntegrationError& e) {
    throw IntegrationError(e.what() + note, e.t(), e.state());
  } catch (const DynamicsError& e) {
    throw DynamicsError(e.what() + note);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(e.what() + note);
  }
}

}  // namespace spacearm
