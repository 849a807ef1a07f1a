// lane_layout.hpp. Hand-written: no library transposes a 4 x n block between these layouts
// (Eigen's assignment across storage orders copies entry by entry).
#include "lane_layout.hpp"

#if defined(__x86_64__)
#include <immintrin.h>
#endif

#include <limits>

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

// Entries j, j + 1 of two states: (p[0], p[1], r[0], r[1]).
__attribute__((target("avx2"))) inline __m256d pair_of_states(const double* p, const double* r) {
  return _mm256_insertf128_pd(_mm256_castpd128_pd256(_mm_loadu_pd(p)), _mm_loadu_pd(r), 1);
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
  if (j + 2 <= n) {  // two of the last n mod 4 entries: a pair of each state, unpacked
    const __m256d a = pair_of_states(x + j, x + 2 * n + j),
                  b = pair_of_states(x + n + j, x + 3 * n + j);
    const __m256d e = _mm256_unpacklo_pd(a, b), f = _mm256_unpackhi_pd(a, b);
    sum = _mm256_add_pd(sum, _mm256_add_pd(_mm256_mul_pd(e, zero), _mm256_mul_pd(f, zero)));
    _mm256_storeu_pd(lane + 4 * j, e);
    _mm256_storeu_pd(lane + 4 * j + 4, f);
    j += 2;
  }
  if (j < n) {  // the last entry: one register of the four states
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
  if (j + 2 <= n) {  // two of the last n mod 4 entries: unpacked into a pair of each state
    const __m256d e = _mm256_loadu_pd(lane + 4 * j), f = _mm256_loadu_pd(lane + 4 * j + 4);
    sum = _mm256_add_pd(sum, _mm256_add_pd(_mm256_mul_pd(e, zero), _mm256_mul_pd(f, zero)));
    const __m256d a = _mm256_unpacklo_pd(e, f), b = _mm256_unpackhi_pd(e, f);
    _mm_storeu_pd(x + j, _mm256_castpd256_pd128(a));
    _mm_storeu_pd(x + n + j, _mm256_castpd256_pd128(b));
    _mm_storeu_pd(x + 2 * n + j, _mm256_extractf128_pd(a, 1));
    _mm_storeu_pd(x + 3 * n + j, _mm256_extractf128_pd(b, 1));
    j += 2;
  }
  if (j < n) {  // the last entry
    const __m256d e = _mm256_loadu_pd(lane + 4 * j);
    sum = _mm256_add_pd(sum, _mm256_mul_pd(e, zero));
    for (int l = 0; l < 4; ++l) x[l * n + j] = lane[4 * j + l];
  }
  return _mm256_movemask_pd(_mm256_cmp_pd(sum, zero, _CMP_EQ_OQ)) == 0xF;
}
// all_pivots_within_bounds' comparisons, four pairs per register; the rest by it.
__attribute__((target("avx2"))) bool pivots_within_bounds_avx2(const double* d,
                                                               const double* scaled, long n) {
  const __m256d zero = _mm256_setzero_pd(),
                inf = _mm256_set1_pd(std::numeric_limits<double>::infinity()),
                floor = _mm256_set1_pd(1 / kMaxScaledCondition);
  __m256d all = _mm256_castsi256_pd(_mm256_set1_epi64x(-1));
  long i = 0;
  for (; i + 4 <= n; i += 4) {
    const __m256d a = _mm256_loadu_pd(d + i), b = _mm256_loadu_pd(scaled + i);
    const __m256d a_ok =
        _mm256_and_pd(_mm256_cmp_pd(a, zero, _CMP_GT_OQ), _mm256_cmp_pd(a, inf, _CMP_LT_OQ));
    const __m256d b_ok =
        _mm256_and_pd(_mm256_cmp_pd(b, floor, _CMP_GT_OQ), _mm256_cmp_pd(b, inf, _CMP_LT_OQ));
    all = _mm256_and_pd(all, _mm256_and_pd(a_ok, b_ok));
  }
  return _mm256_movemask_pd(all) == 0xF && all_pivots_within_bounds(d + i, scaled + i, n - i);
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

namespace {
// Read once, when the library loads; a file-local name, so that no call here goes through the
// PLT of the shared object (the Python module) that links this.
#if SPACEARM_LANES_AVX2
const bool avx2 = [] {
  __builtin_cpu_init();  // needed before __builtin_cpu_supports in a static initializer
  return __builtin_cpu_supports("avx2") != 0;
}();
#else
constexpr bool avx2 = false;
#endif
}  // namespace

bool uses_avx2() { return avx2; }

bool interleave(const double* x, int n, double* lane) {
#if SPACEARM_LANES_AVX2
  if (avx2) return interleave_avx2(x, n, lane);
#endif
  return interleave_portable(x, n, lane);
}

bool deinterleave(const double* lane, int n, double* x) {
#if SPACEARM_LANES_AVX2
  if (avx2) return deinterleave_avx2(lane, n, x);
#endif
  return deinterleave_portable(lane, n, x);
}

bool pivots_within_bounds(const double* d, const double* scaled, long n) {
#if SPACEARM_LANES_AVX2
  if (avx2) return pivots_within_bounds_avx2(d, scaled, n);
#endif
  return all_pivots_within_bounds(d, scaled, n);
}

}  // namespace spacearm::lanes
