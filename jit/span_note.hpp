// A run's failure at run-time parameters that widen the model's span of values past what the
// generator checked names that span (CompiledModel::span_note): the simulate and eval commands
// and Python wrap their runs in with_span_note.
#pragma once

#include <stdexcept>
#include <string>

#include "dynamics_checks.hpp"
#include "integrator_options.hpp"

namespace spacearm {

// Runs f; a failure of the dynamics (IntegrationError, DynamicsError) is thrown again, of the
// same kind, with note() appended, computed only then. Errors of the options or input pass as
// they are.
template <class Note, class F>
auto with_span_note(Note&& note, F&& f) -> decltype(f()) {
  try {
    return f();
  } catch (const IntegrationError& e) {
    throw IntegrationError(e.what() + note(), e.t(), e.state());
  } catch (const DynamicsError& e) {
    throw DynamicsError(e.what() + note());
  }
}

}  // namespace spacearm
