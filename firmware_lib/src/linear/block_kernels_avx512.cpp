// The row update's reflections at D = 6 in AVX-512 registers (x86-64 hosts that have them).
//
// A 6 x 6 block's column is one 8-lane register with lanes 6-7 unused, so a row block's reflections
// take one instruction per column where the AVX2 form takes a 4-lane and (paired) half a 2-lane
// one. The 32 registers hold two factors' W columns of two row blocks at once (where AVX2's 16
// spill); their reflections are independent chains, which keeps both multiply-add pipes busy
// through each chain's latency. Every lane runs one row's operations in applyRowReflections' order,
// so the bits are the portable form's. The 6 x 6 triangularization's AVX-512 form (rows as lanes)
// is here too.
#include "lslam/linear/block_kernels.h"
#include "reflection_coefficients.h"

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

// A column of the factor or of the update rows, as rows 0-3 and 4-5 (lanes 6-7 unspecified, never
// stored): masked accesses to blocks that miss the cache made the row update as slow as the AVX2
// form. (Masked inserts and extracts: GCC 12 warns of the plain ones' undefined pass-through.)
LSLAM_TARGET_AVX512 inline __m512d loadPoolColumn(const double* block, int c) {
  const double* p = block + 6 * c;
  const __m512d low = _mm512_castpd256_pd512(_mm256_loadu_pd(p));
  return _mm512_mask_insertf64x4(low, 0xFF, low, _mm256_castpd128_pd256(_mm_loadu_pd(p + 4)), 1);
}
LSLAM_TARGET_AVX512 inline void storePoolColumn(double* block, int c, __m512d v) {
  double* p = block + 6 * c;
  _mm256_storeu_pd(p, _mm512_maskz_extractf64x4_pd(0xF, v, 0));
  _mm_storeu_pd(p + 4, _mm256_castpd256_pd128(_mm512_maskz_extractf64x4_pd(0xF, v, 1)));
}

// Lane `lane` of v in every lane (the zero-masking form: GCC 12 warns of the plain one's undefined
// pass-through operand).
LSLAM_TARGET_AVX512 inline __m512d broadcastLane(__m512i lane, __m512d v) {
  return _mm512_maskz_permutexvar_pd(0xFF, lane, v);
}

// [l w[0] .. w[M-1]] H_0 ... H_5 for B row blocks: l from l_in[b] to l_out[b] (which may be
// l_in[b]), w[b][m] in place. Reflection j reads and writes column j of l alone, so l is loaded
// and stored there; only W stays in registers.
template <int M, int B>
LSLAM_TARGET_AVX512 inline void reflectRowBlocks(const ReflectionCoefficients<6, M>& h,
                                                 const double* const* l_in, double* const* l_out,
                                                 double* const (*w)[M]) {
  __m512d x[B][M][6];
#pragma GCC unroll 4
  for (int b = 0; b < B; ++b) {
#pragma GCC unroll 2
    for (int m = 0; m < M; ++m) {
#pragma GCC unroll 6
      for (int c = 0; c < 6; ++c) x[b][m][c] = loadPoolColumn(w[b][m], c);
    }
  }
#pragma GCC unroll 6
  for (int j = 0; j < 6; ++j) {
    const double* coefficient = h.of[j];
#pragma GCC unroll 4
    for (int b = 0; b < B; ++b) {
      // As applyRowReflections: t = l_j + sum_m sum_c w_mc u_mc (per factor, products 3-5 apart,
      // then added), s = beta t, l_j -= s, w_mc -= s u_mc (fused).
      const __m512d l = loadPoolColumn(l_in[b], j);
      __m512d t = l;
#pragma GCC unroll 2
      for (int m = 0; m < M; ++m) {
        const double* u = coefficient + 6 * m;
        __m512d high = _mm512_mul_pd(x[b][m][3], _mm512_set1_pd(u[3]));
        high = _mm512_fmadd_pd(x[b][m][4], _mm512_set1_pd(u[4]), high);
        high = _mm512_fmadd_pd(x[b][m][5], _mm512_set1_pd(u[5]), high);
#pragma GCC unroll 3
        for (int c = 0; c < 3; ++c) t = _mm512_fmadd_pd(x[b][m][c], _mm512_set1_pd(u[c]), t);
        t = _mm512_add_pd(t, high);
      }
      const __m512d s = _mm512_mul_pd(_mm512_set1_pd(coefficient[6 * M]), t);
      storePoolColumn(l_out[b], j, _mm512_sub_pd(l, s));
#pragma GCC unroll 2
      for (int m = 0; m < M; ++m) {
#pragma GCC unroll 6
        for (int c = 0; c < 6; ++c) {
          x[b][m][c] = _mm512_fnmadd_pd(s, _mm512_set1_pd(coefficient[6 * m + c]), x[b][m][c]);
        }
      }
    }
  }
#pragma GCC unroll 4
  for (int b = 0; b < B; ++b) {
#pragma GCC unroll 2
    for (int m = 0; m < M; ++m) {
#pragma GCC unroll 6
      for (int c = 0; c < 6; ++c) storePoolColumn(w[b][m], c, x[b][m][c]);
    }
  }
}

// Row blocks [first, first + B) of applyRowReflectionsFromAvx512.
template <int M, int B, typename Input>
LSLAM_TARGET_AVX512 inline void reflectGroup(const ReflectionCoefficients<6, M>& h, Input input,
                                             Mat6* blocks, const Index* rows, Index first,
                                             Mat6* const* w) {
  const double* l_in[B];
  double* l_out[B];
  double* w_of[B][M];
  for (int b = 0; b < B; ++b) {
    l_in[b] = input(first + b);
    l_out[b] = blocks[first + b].data();
    for (int m = 0; m < M; ++m) w_of[b][m] = w[m][rows[first + b]].data();
  }
  reflectRowBlocks<M, B>(h, l_in, l_out, w_of);
}

// Row blocks per group: two factors' columns of two row blocks take 24 of the 32 registers.
constexpr int kGroup = 2;

}  // namespace

template <int M>
LSLAM_TARGET_AVX512 void applyRowReflectionsFromAvx512(const Mat6* u, const Vec6& beta,
                                                       const Mat6* source_blocks,
                                                       const Index* source, Index kept,
                                                       Mat6* blocks, const Index* rows, Index size,
                                                       Mat6* const* w) {
  const ReflectionCoefficients<6, M> h(u, beta);
  const ReflectionSources<6> input{source_blocks, source, kept};
  constexpr int kB = kGroup;
  Index b = 1;
  for (; b + kB <= size; b += kB) reflectGroup<M, kB>(h, input, blocks, rows, b, w);
  if (b < size) reflectGroup<M, 1>(h, input, blocks, rows, b, w);  // the odd one
}

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
template void applyRowReflectionsFromAvx512<2>(const Mat6*, const Vec6&, const Mat6*, const Index*,
                                               Index, Mat6*, const Index*, Index, Mat6* const*);

#endif

}  // namespace detail
}  // namespace lslam
