// lane_layout.hpp. Hand-written: no library transposes a 4 x n block between these layouts
// (Eigen's assignment across storage orders copies entry by entry).
#include "lane_layout.hpp"

#if defined(__x86_64__)
#include <immintrin.h>
#endif

#include "dynamics_checks.hpp"

namespace spacearm::lanes {
namespace {

#if defined(__x86_64__) && !(defined(__FINITE_MATH_ONLY__) && __FINITE_MATH_ONLY__)
#define SPACEARM_LANES_AVX2 1
// Rows r0..r3 (four entries of one state each) to columns (one entry of the four states each),
// and back: the same register transpose.
__attribute__((target("avx2"))) inline void transpose(__m256d& a, __m256d& b, __m256d& c,
                                                      __m256d& d) {
  const __m256d t0 = _mm256_unpacklo_pd(a, b), t1 = _mm256_unpackhi_pd(a, b);
  const __m256d t2 = _mm256_unpacklo_pd(c, d), t3 = _mm256_unpackhi_pd(c, d);
  a = _mm256_permute2f128_pd(t0, t2, 0x20);
  b = _mm256_permute2f128_pd(t1, t3, 0x20);
  c = _mm256_permute2f128_pd(t0, t2, 0x31);
  d = _mm256_permute2f128_pd(t1, t3, 0x31);
}

// sum + a * 0 + b * 0 + c * 0 + d * 0: x * 0 is 0 for a finite x and NaN otherwise
// (all_finite_array's test), on whole registers.
__attribute__((target("avx2"))) inline __m256d plus_times_zero(__m256d sum, __m256d a, __m256d b,
                                                               __m256d c, __m256d d) {
  const __m256d zero = _mm256_setzero_pd();
  return _mm256_add_pd(
      sum, _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(a, zero), _mm256_mul_pd(b, zero)),
                         _mm256_add_pd(_mm256_mul_pd(c, zero), _mm256_mul_pd(d, zero))));
}

__attribute__((target("avx2"))) bool interleave_avx2(const double* x, int n, double* lane) {
  const __m256d zero = _mm256_setzero_pd();
  __m256d sum = zero;
  int j = 0;
  for (; j + 4 <= n; j += 4) {
    __m256d a = _mm256_loadu_pd(x + j), b = _mm256_loadu_pd(x + n + j);
    __m256d c = _mm256_loadu_pd(x + 2 * n + j), d = _mm256_loadu_pd(x + 3 * n + j);
    sum = plus_times_zero(sum, a, b, c, d);
    transpose(a, b, c, d);
    _mm256_storeu_pd(lane + 4 * j, a);
    _mm256_storeu_pd(lane + 4 * j + 4, b);
    _mm256_storeu_pd(lane + 4 * j + 8, c);
    _mm256_storeu_pd(lane + 4 * j + 12, d);
  }
  for (; j < n; ++j) {  // the last n mod 4 entries: one register of the four states each
    const __m256d e = _mm256_set_pd(x[3 * n + j], x[2 * n + j], x[n + j], x[j]);
    sum = _mm256_add_pd(sum, _mm256_mul_pd(e, zero));
    _mm256_storeu_pd(lane + 4 * j, e);
  }
  return _mm256_movemask_pd(_mm256_cmp_pd(sum, zero, _CMP_EQ_OQ)) == 0xF;
}

__attribute__((target("avx2"))) bool deinterleave_avx2(const double* lane, int n, double* x) {
  const __m256d zero = _mm256_setzero_pd();
  __m256d sum = zero;
  int j = 0;
  for (; j + 4 <= n; j += 4) {
    __m256d a = _mm256_loadu_pd(lane + 4 * j), b = _mm256_loadu_pd(lane + 4 * j + 4);
    __m256d c = _mm256_loadu_pd(lane + 4 * j + 8), d = _mm256_loadu_pd(lane + 4 * j + 12);
    sum = plus_times_zero(sum, a, b, c, d);
    transpose(a, b, c, d);
    _mm256_storeu_pd(x + j, a);
    _mm256_storeu_pd(x + n + j, b);
    _mm256_storeu_pd(x + 2 * n + j, c);
    _mm256_storeu_pd(x + 3 * n + j, d);
  }
  for (; j < n; ++j) {
    const __m256d e = _mm256_loadu_pd(lane + 4 * j);
    sum = _mm256_add_pd(sum, _mm256_mul_pd(e, zero));
    for (int l = 0; l < 4; ++l) x[l * n + j] = lane[4 * j + l];
  }
  return _mm256_movemask_pd(_mm256_cmp_pd(sum, zero, _CMP_EQ_OQ)) == 0xF;
}
#else
#define SPACEARM_LANES_AVX2 0
#endif

}  // namespace

bool interleave_portable(const double* x, int n, double* lane) {
  for (int j = 0; j < n; ++j)
    for (int l = 0; l < 4; ++l) lane[4 * j + l] = x[l * n + j];
  return all_finite_array(x, 4L * n);
}
bool deinterleave_portable(const double* lane, int n, double* x) {
  for (int j = 0; j < n; ++j)
    for (int l = 0; l < 4; ++l) x[l * n + j] = lane[4 * j + l];
  return all_finite_array(lane, 4L * n);
}

bool uses_avx2() {
#if SPACEARM_LANES_AVX2
  static const bool avx2 = __builtin_cpu_supports("avx2");
  return avx2;
#else
  return false;
#endif
}

bool interleave(const double* x, int n, double* lane) {
#if SPACEARM_LANES_AVX2
  if (uses_avx2()) return interleave_avx2(x, n, lane);
#endif
  return interleave_portable(x, n, lane);
}

bool deinterleave(const double* lane, int n, double* x) {
#if SPACEARM_LANES_AVX2
  if (uses_avx2()) return deinterleave_avx2(lane, n, x);
#endif
  return deinterleave_portable(lane, n, x);
}

}  // namespace spacearm::lanes
