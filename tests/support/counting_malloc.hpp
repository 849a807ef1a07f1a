// A count of the process's allocations, for the tests that prove a hot path allocates nothing:
// counting_malloc.cpp replaces malloc itself (which Eigen and operator new both call), so every
// allocation is seen. Link that file into exactly one test executable each.
#pragma once

namespace spacearm::counting_malloc {

// False under AddressSanitizer, which brings its own malloc (that a replacement would hide):
// there the count stays 0 and the tests skip.
bool enabled();
// Counts the allocations made from start() to stop() (stop() returns them).
void start();
long stop();

}  // namespace spacearm::counting_malloc
