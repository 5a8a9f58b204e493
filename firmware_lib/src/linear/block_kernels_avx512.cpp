// The row update's 6 x 6 triangularization in AVX-512 registers (x86-64 hosts that have them): a
// block's six rows are the lanes of one 8-lane register (lanes 6-7 unused), so each step of a
// reflection is one instruction for all rows. Every lane runs one row's operations in
// triangularizeRows6's order, so the bits are the portable form's.
#include "lslam/linear/block_kernels.h"

#include <cmath>

#if defined(__x86_64__)
#include <immintrin.h>
#endif

namespace lslam {
namespace detail {

#if defined(__x86_64__)

#define LSLAM_TARGET_AVX512 __attribute__((target("avx512f,avx2,fma")))

namespace {

constexpr __mmask8 kSixRows = 0x3F;

// A column from a small local block (masked: lanes 6-7 read as zeros, never written).
LSLAM_TARGET_AVX512 inline __m512d loadColumn(const double* block, int c) {
  return _mm512_maskz_loadu_pd(kSixRows, block + 6 * c);
}
LSLAM_TARGET_AVX512 inline void storeColumn(double* block, int c, __m512d v) {
  _mm512_mask_storeu_pd(block + 6 * c, kSixRows, v);
}

// Lane `lane` of v in every lane (the zero-masking form: GCC 12 warns of the plain one's undefined
// pass-through operand).
LSLAM_TARGET_AVX512 inline __m512d broadcastLane(__m512i lane, __m512d v) {
  return _mm512_maskz_permutexvar_pd(0xFF, lane, v);
}

}  // namespace

// triangularizeRows6 with row r in lane r: per reflection j, row j's entries are broadcast from
// lane j, the scalars (norm, v0, beta) are computed once, and every row is updated at once (rows
// above j too: their lanes are never read for rows at or below j, and l' keeps the lower triangle).
template <int M>
LSLAM_TARGET_AVX512 bool triangularizeRows6Avx512(const Mat6& l, const Mat6* w, Mat6& l_new,
                                                  Mat6* u, Vec6& beta) {
  __m512d m_l[6];
  __m512d x[M][6];
#pragma GCC unroll 6
  for (int c = 0; c < 6; ++c) m_l[c] = loadColumn(l.data(), c);
#pragma GCC unroll 2
  for (int m = 0; m < M; ++m) {
#pragma GCC unroll 6
    for (int c = 0; c < 6; ++c) x[m][c] = loadColumn(w[m].data(), c);
  }
#pragma GCC unroll 6
  for (int j = 0; j < 6; ++j) {
    const __m512i lane_j = _mm512_set1_epi64(j);
    __m512d row_j[M][6];  // every lane: x[m](j, c)
    __m512d sigma = _mm512_setzero_pd();
#pragma GCC unroll 2
    for (int m = 0; m < M; ++m) {
#pragma GCC unroll 6
      for (int c = 0; c < 6; ++c) row_j[m][c] = broadcastLane(lane_j, x[m][c]);
      const __m512d* y = row_j[m];
      __m512d low = _mm512_mul_pd(y[0], y[0]);
      low = _mm512_fmadd_pd(y[1], y[1], low);
      low = _mm512_fmadd_pd(y[2], y[2], low);
      __m512d high = _mm512_mul_pd(y[3], y[3]);
      high = _mm512_fmadd_pd(y[4], y[4], high);
      high = _mm512_fmadd_pd(y[5], y[5], high);
      const __m512d part = _mm512_add_pd(low, high);
      sigma = m == 0 ? part : _mm512_add_pd(sigma, part);
    }
    const double sigma_j = _mm512_cvtsd_f64(sigma);
    const double alpha = _mm512_cvtsd_f64(broadcastLane(lane_j, m_l[j]));
    const double square = alpha * alpha;
    const double norm = std::sqrt(square + sigma_j);
    if (!(norm > 0.0) || !std::isfinite(norm)) return false;
    if (sigma_j == 0.0 && alpha > 0.0) {
      beta(j) = 0.0;
      for (int m = 0; m < M; ++m) u[m].col(j).setZero();
      continue;
    }
    const double v0 = alpha <= 0.0 ? alpha - norm : -sigma_j / (alpha + norm);
    const double v0_squared = v0 * v0;
    beta(j) = 2.0 * v0_squared / (sigma_j + v0_squared);
    const __m512d inverse = _mm512_set1_pd(1.0 / v0);
    __m512d t = m_l[j];
#pragma GCC unroll 2
    for (int m = 0; m < M; ++m) {
      __m512d* y = row_j[m];
#pragma GCC unroll 6
      for (int c = 0; c < 6; ++c) {
        y[c] = _mm512_mul_pd(y[c], inverse);  // u[m](c, j) in every lane
        u[m](c, j) = _mm512_cvtsd_f64(y[c]);
      }
      __m512d high = _mm512_mul_pd(x[m][3], y[3]);
      high = _mm512_fmadd_pd(x[m][4], y[4], high);
      high = _mm512_fmadd_pd(x[m][5], y[5], high);
#pragma GCC unroll 3
      for (int c = 0; c < 3; ++c) t = _mm512_fmadd_pd(x[m][c], y[c], t);
      t = _mm512_add_pd(t, high);
    }
    const __m512d s = _mm512_mul_pd(_mm512_set1_pd(beta(j)), t);
    m_l[j] = _mm512_sub_pd(m_l[j], s);
#pragma GCC unroll 2
    for (int m = 0; m < M; ++m) {
#pragma GCC unroll 6
      for (int c = 0; c < 6; ++c) x[m][c] = _mm512_fnmadd_pd(s, row_j[m][c], x[m][c]);
    }
  }
  // Column c keeps rows c .. 5; above the diagonal, zero.
#pragma GCC unroll 6
  for (int c = 0; c < 6; ++c) {
    const __mmask8 lower = static_cast<__mmask8>(kSixRows & (kSixRows << c));
    storeColumn(l_new.data(), c, _mm512_maskz_mov_pd(lower, m_l[c]));
  }
  return true;
}

template bool triangularizeRows6Avx512<1>(const Mat6&, const Mat6*, Mat6&, Mat6*, Vec6&);
template bool triangularizeRows6Avx512<2>(const Mat6&, const Mat6*, Mat6&, Mat6*, Vec6&);
template bool triangularizeRows6Avx512<3>(const Mat6&, const Mat6*, Mat6&, Mat6*, Vec6&);

#endif

}  // namespace detail
}  // namespace lslam
