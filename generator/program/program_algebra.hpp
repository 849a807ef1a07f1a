// Dense linear algebra unrolled into a straight-line program, for the outputs composed from
// closed forms (forward dynamics, the generalized Jacobian, free-base inverse dynamics). Sizes are
// fixed at generation time, so every loop unrolls and structural zeros of the matrix cost nothing.
// Hand-written: no library emits an unrolled symmetric solve into our program.
#pragma once

#include <vector>

#include "straight_line.hpp"

namespace spacearm {

// A = L D L^T of a symmetric positive definite n x n matrix (no pivoting, which a positive
// definite matrix does not need), with the reciprocals of D.
struct LdltProgram {
  int n = 0;
  std::vector<SRef> d, inv_d;  // D_j and 1 / D_j
  std::vector<SRef> l;         // row-major n x n; entries below the diagonal are L's
};

// a: row-major n x n; only the upper triangle is read.
LdltProgram ldlt(Program& p, const std::vector<SRef>& a, int n);
// x with A x = rhs.
std::vector<SRef> ldlt_solve(Program& p, const LdltProgram& f, const std::vector<SRef>& rhs);
// sum_k a_k b_k.
SRef dot(Program& p, const std::vector<SRef>& a, const std::vector<SRef>& b);

}  // namespace spacearm
