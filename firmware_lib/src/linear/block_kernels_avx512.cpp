// The row update's reflections at D = 6 in AVX-512 registers (x86-64 hosts that have them).
//
// A 6 x 6 block's column is one 8-lane register with lanes 6-7 masked off (loads read zeros there,
// stores leave memory alone), so a row block's reflections take one instruction per column where
// the AVX2 form takes a 4-lane and (paired) half a 2-lane one. The 32 registers hold the W columns
// of several row blocks at once (M 6 per block); their reflections are independent chains, which
// keeps both multiply-add pipes busy through each chain's latency. Every lane runs one row's
// operations in applyRowReflections' order, so the bits are the portable form's.
#include "lslam/linear/block_kernels.h"
#include "reflection_coefficients.h"

#if defined(__x86_64__)
#include <immintrin.h>
#endif

namespace lslam {
namespace detail {

#if defined(__x86_64__)

#define LSLAM_TARGET_AVX512 __attribute__((target("avx512f,avx2,fma")))

namespace {

constexpr __mmask8 kSixRows = 0x3F;

LSLAM_TARGET_AVX512 inline __m512d loadColumn(const double* block, int c) {
  return _mm512_maskz_loadu_pd(kSixRows, block + 6 * c);
}
LSLAM_TARGET_AVX512 inline void storeColumn(double* block, int c, __m512d v) {
  _mm512_mask_storeu_pd(block + 6 * c, kSixRows, v);
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
      for (int c = 0; c < 6; ++c) x[b][m][c] = loadColumn(w[b][m], c);
    }
  }
#pragma GCC unroll 6
  for (int j = 0; j < 6; ++j) {
    const double* coefficient = h.of[j];
#pragma GCC unroll 4
    for (int b = 0; b < B; ++b) {
      // As applyRowReflections: t = l_j + sum_m sum_c w_mc u_mc (per factor, products 3-5 apart,
      // then added), s = beta t, l_j -= s, w_mc -= s u_mc (fused).
      const __m512d l = loadColumn(l_in[b], j);
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
      storeColumn(l_out[b], j, _mm512_sub_pd(l, s));
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
      for (int c = 0; c < 6; ++c) storeColumn(w[b][m], c, x[b][m][c]);
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

// Row blocks per group: as many chains as the registers hold (M = 2: 24 for W; M = 1: 24 too).
template <int M>
constexpr int kGroup = M == 1 ? 4 : 2;

}  // namespace

template <int M>
LSLAM_TARGET_AVX512 void applyRowReflectionsFromAvx512(const Mat6* u, const Vec6& beta,
                                                       const Mat6* source_blocks,
                                                       const Index* source, Index kept,
                                                       Mat6* blocks, const Index* rows, Index size,
                                                       Mat6* const* w) {
  const ReflectionCoefficients<6, M> h(u, beta);
  const ReflectionSources<6> input{source_blocks, source, kept};
  constexpr int kB = kGroup<M>;
  Index b = 1;
  for (; b + kB <= size; b += kB) reflectGroup<M, kB>(h, input, blocks, rows, b, w);
  // The rest in one smaller group.
  switch (size - b) {
    case 3:
      if constexpr (kB > 3) reflectGroup<M, 3>(h, input, blocks, rows, b, w);
      break;
    case 2:
      if constexpr (kB > 2) reflectGroup<M, 2>(h, input, blocks, rows, b, w);
      break;
    case 1:
      reflectGroup<M, 1>(h, input, blocks, rows, b, w);
      break;
    default:
      break;
  }
}

template void applyRowReflectionsFromAvx512<1>(const Mat6*, const Vec6&, const Mat6*, const Index*,
                                               Index, Mat6*, const Index*, Index, Mat6* const*);
template void applyRowReflectionsFromAvx512<2>(const Mat6*, const Vec6&, const Mat6*, const Index*,
                                               Index, Mat6*, const Index*, Index, Mat6* const*);

#endif

}  // namespace detail
}  // namespace lslam
