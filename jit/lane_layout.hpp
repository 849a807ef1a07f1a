// Four states in and out of the lanes of a 4-lane function (cpp_printer.hpp: entry j of lane l at
// [4 j + l]) for batches, whose states come one after the other (entry j of state l at
// [l n + j]). A 4 x n transpose of small n in scalar code costs as much as the function it
// feeds; on a CPU with AVX2 these move 4 x 4 blocks with a register transpose (chosen at run
// time: the library is built for any x86-64).
#pragma once

namespace spacearm::lanes {

// The four states at x (n entries each) into lane; false where an entry is not finite.
bool interleave(const double* x, int n, double* lane);
// The four lanes at lane (n entries each) back into four states one after the other at x;
// false where an entry is not finite.
bool deinterleave(const double* lane, int n, double* x);
// all_pivots_within_bounds (dynamics_checks.hpp) on n pairs, four at a time with AVX2: the
// test of a group's forward-dynamics pivots, in any one layout.
bool pivots_within_bounds(const double* d, const double* scaled, long n);
// Whether the AVX2 versions are in use (the CPU has AVX2).
bool uses_avx2();
// The portable versions, which the two above are without AVX2.
bool interleave_portable(const double* x, int n, double* lane);
bool deinterleave_portable(const double* lane, int n, double* x);

}  // namespace spacearm::lanes
