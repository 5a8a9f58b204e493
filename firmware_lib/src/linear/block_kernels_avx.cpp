#include "lslam/linear/block_kernels.h"
#include "reflection_coefficients.h"

#if defined(__x86_64__)
#include <immintrin.h>
#endif

namespace lslam {
namespace detail {

#if defined(__x86_64__)

namespace {

// A column of a column-major 3 x 3 block in lanes 0-2 (lane 3: whatever follows it in memory,
// or zero for the last column, which must not be read past the block).
LSLAM_TARGET_AVX_FMA inline __m256d loadColumn(const double* block, int c) {
  if (c < 2) return _mm256_loadu_pd(block + 3 * c);
  return _mm256_insertf128_pd(_mm256_castpd128_pd256(_mm_loadu_pd(block + 6)),
                              _mm_load_sd(block + 8), 1);
}

// Stores the three columns back. Columns 0 and 1 are stored whole, in order, so that lane 3 of
// each (the next column's row 0) is overwritten by the next store; column 2 stops at the block.
LSLAM_TARGET_AVX_FMA inline void storeColumns(double* block, __m256d c0, __m256d c1, __m256d c2) {
  _mm256_storeu_pd(block, c0);
  _mm256_storeu_pd(block + 3, c1);
  _mm_storeu_pd(block + 6, _mm256_castpd256_pd128(c2));
  _mm_store_sd(block + 8, _mm256_extractf128_pd(c2, 1));
}

// Column c of t + b s, each product fused in order k = 0, 1, 2 (as addBlockProduct).
LSLAM_TARGET_AVX_FMA inline __m256d addProductColumn(__m256d b0, __m256d b1, __m256d b2,
                                                     const Mat3& s, int c, __m256d t) {
  t = _mm256_fmadd_pd(b0, _mm256_broadcast_sd(&s(0, c)), t);
  t = _mm256_fmadd_pd(b1, _mm256_broadcast_sd(&s(1, c)), t);
  return _mm256_fmadd_pd(b2, _mm256_broadcast_sd(&s(2, c)), t);
}

// One row block of applyRowReflectionsFromAvx: [l w[0] .. w[M-1]] H... from l_in to l_out, w in
// place.
template <int M>
LSLAM_TARGET_AVX_FMA inline void reflectRowBlock(const ReflectionCoefficients<3, M>& h,
                                                 const double* l_in, double* l_out,
                                                 double* const* w) {
  __m256d l[3] = {loadColumn(l_in, 0), loadColumn(l_in, 1), loadColumn(l_in, 2)};
  __m256d x[M][3];
  for (int m = 0; m < M; ++m) {
    for (int c = 0; c < 3; ++c) x[m][c] = loadColumn(w[m], c);
  }
  for (int j = 0; j < 3; ++j) {
    // Per row, as applyRowReflections: t = l_j + w0 u0 + w1 u1 + w2 u2 (fused, in that order,
    // factor by factor), s = beta t, l_j -= s, w_c -= s u_c (fused).
    const double* coefficient = h.of[j];
    __m256d t = l[j];
    for (int m = 0; m < M; ++m) {
      for (int c = 0; c < 3; ++c) {
        t = _mm256_fmadd_pd(x[m][c], _mm256_set1_pd(coefficient[3 * m + c]), t);
      }
    }
    const __m256d s = _mm256_mul_pd(_mm256_set1_pd(coefficient[3 * M]), t);
    l[j] = _mm256_sub_pd(l[j], s);
    for (int m = 0; m < M; ++m) {
      for (int c = 0; c < 3; ++c) {
        x[m][c] = _mm256_fnmadd_pd(s, _mm256_set1_pd(coefficient[3 * m + c]), x[m][c]);
      }
    }
  }
  storeColumns(l_out, l[0], l[1], l[2]);
  for (int m = 0; m < M; ++m) storeColumns(w[m], x[m][0], x[m][1], x[m][2]);
}

}  // namespace

template <int M>
LSLAM_TARGET_AVX_FMA void applyRowReflectionsFromAvx(const Mat3* u, const Vec3& beta,
                                                     const Mat3* source_blocks, const Index* source,
                                                     Index kept, Mat3* blocks, const Index* rows,
                                                     Index size, Mat3* const* w) {
  static const Mat3 kZero = Mat3::Zero();
  const ReflectionCoefficients<3, M> h(u, beta);
  for (Index b = 1; b < kept; ++b) {
    double* w_data[M];
    for (int m = 0; m < M; ++m) w_data[m] = w[m][rows[b]].data();
    reflectRowBlock<M>(h, source_blocks[b].data(), blocks[b].data(), w_data);
  }
  for (Index b = kept; b < size; ++b) {
    // A select, not a branch: fill rows sit anywhere in the column.
    const Mat3* l_in = source[b] != kNoIndex ? source_blocks + source[b] : &kZero;
    double* w_data[M];
    for (int m = 0; m < M; ++m) w_data[m] = w[m][rows[b]].data();
    reflectRowBlock<M>(h, l_in->data(), blocks[b].data(), w_data);
  }
}

template <int M>
LSLAM_TARGET_AVX_FMA void applyRowReflectionsToRowAvx(const Mat3* u, const Vec3& beta,
                                                      Eigen::Matrix<double, 1, 3>& x_l,
                                                      Eigen::Matrix<double, 1, 3>* const* x_w) {
  applyRowReflections<3, M>(u, beta, x_l, x_w);
}

LSLAM_TARGET_AVX_FMA void multiplyByTransposedLowerAvx(Mat3* blocks, Index count, const Mat3& l) {
  const __m256d l00 = _mm256_broadcast_sd(&l(0, 0));
  const __m256d l10 = _mm256_broadcast_sd(&l(1, 0));
  const __m256d l11 = _mm256_broadcast_sd(&l(1, 1));
  const __m256d l20 = _mm256_broadcast_sd(&l(2, 0));
  const __m256d l21 = _mm256_broadcast_sd(&l(2, 1));
  const __m256d l22 = _mm256_broadcast_sd(&l(2, 2));
  for (Index b = 0; b < count; ++b) {
    double* block = blocks[b].data();
    const __m256d b0 = loadColumn(block, 0);
    const __m256d b1 = loadColumn(block, 1);
    const __m256d b2 = loadColumn(block, 2);
    // Column j: b0 l(j, 0), then + b1 l(j, 1), + b2 l(j, 2) up to m = j, fused in that order.
    const __m256d c0 = _mm256_mul_pd(b0, l00);
    const __m256d c1 = _mm256_fmadd_pd(b1, l11, _mm256_mul_pd(b0, l10));
    const __m256d c2 = _mm256_fmadd_pd(b2, l22, _mm256_fmadd_pd(b1, l21, _mm256_mul_pd(b0, l20)));
    storeColumns(block, c0, c1, c2);
  }
}

// acc_c += column c of block b times y, lane by lane (one column of b^T y per accumulator).
LSLAM_TARGET_AVX_FMA inline void addTransposedProduct(const double* b, const double* y_entry,
                                                      __m256d& acc0, __m256d& acc1, __m256d& acc2) {
  // One load: the entry's fourth lane is zero, and meets the next column's first entry in
  // loadColumn, a finite number.
  const __m256d y = _mm256_loadu_pd(y_entry);
  acc0 = _mm256_fmadd_pd(loadColumn(b, 0), y, acc0);
  acc1 = _mm256_fmadd_pd(loadColumn(b, 1), y, acc1);
  acc2 = _mm256_fmadd_pd(loadColumn(b, 2), y, acc2);
}

// Lanes 0-2 of a, b and c each summed as (lane 0 + lane 1) + lane 2, into lanes 0, 1 and 2 of the
// result; lane 3 zero. Lane 3 of each input must be zero (a zero sums exactly).
LSLAM_TARGET_AVX_FMA inline __m256d sumLanesOfThree(__m256d a, __m256d b, __m256d c) {
  const __m256d ab = _mm256_hadd_pd(a, b);  // a0+a1, b0+b1, a2+a3, b2+b3
  const __m256d cc = _mm256_hadd_pd(c, c);  // c0+c1, c0+c1, c2+c3, c2+c3
  const __m256d sum =
      _mm256_add_pd(_mm256_permute2f128_pd(ab, cc, 0x20), _mm256_permute2f128_pd(ab, cc, 0x31));
  return _mm256_blend_pd(sum, _mm256_setzero_pd(), 0x8);
}

LSLAM_TARGET_AVX_FMA bool solveColumnAvx(const Vec3& d, const Mat3* blocks, const Index* rows,
                                         Index size, double* solution, Index k, double tolerance,
                                         Vec3& delta) {
  // Three named accumulators, not an array: GCC keeps an array on the stack around the loop.
  __m256d acc0 = _mm256_setzero_pd();
  __m256d acc1 = _mm256_setzero_pd();
  __m256d acc2 = _mm256_setzero_pd();
  // The parent's product last (see subtractTransposedProductsFused).
  for (Index i = 2; i < size; ++i) {
    addTransposedProduct(blocks[i].data(), solution + kSolutionStride<3> * rows[i], acc0, acc1,
                         acc2);
  }
  if (size > 1) {
    addTransposedProduct(blocks[1].data(), solution + kSolutionStride<3> * rows[1], acc0, acc1,
                         acc2);
  }
  // Every lane 3 is zero: the solution's padding times a finite block entry.
  const __m256d d_lanes = _mm256_insertf128_pd(_mm256_castpd128_pd256(_mm_loadu_pd(d.data())),
                                               _mm_load_sd(d.data() + 2), 1);
  const __m256d r = _mm256_sub_pd(d_lanes, sumLanesOfThree(acc0, acc1, acc2));
  // x(c) = column c of L(k,k)^-1 (blocks[0]) times r, unfused, as the portable form's product.
  const double* inverse = blocks[0].data();
  const __m256d x = sumLanesOfThree(_mm256_mul_pd(loadColumn(inverse, 0), r),
                                    _mm256_mul_pd(loadColumn(inverse, 1), r),
                                    _mm256_mul_pd(loadColumn(inverse, 2), r));
  double* entry = solution + kSolutionStride<3> * k;
  const __m256d change =
      _mm256_andnot_pd(_mm256_set1_pd(-0.0), _mm256_sub_pd(x, _mm256_loadu_pd(entry)));
  const int moved =
      _mm256_movemask_pd(_mm256_cmp_pd(change, _mm256_set1_pd(tolerance), _CMP_GT_OQ));
  // One store, whole: a child's load of this entry then forwards from it (a load that spans two
  // stores waits until both reach the cache).
  _mm256_storeu_pd(entry, x);
  _mm_storeu_pd(delta.data(), _mm256_castpd256_pd128(x));
  _mm_store_sd(delta.data() + 2, _mm256_extractf128_pd(x, 1));
  return moved != 0;
}

LSLAM_TARGET_AVX_FMA void addBlockProductsAvx(const Mat3* blocks, const Index* rows, Index first,
                                              Index size, const Mat3& s, const Index* target_rows,
                                              Mat3* target) {
  Index p = 0;
  for (Index b = first; b < size; ++b) {
    while (target_rows[p] < rows[b]) ++p;
    LSLAM_DEBUG_ASSERT(target_rows[p] == rows[b]);
    const double* b_data = blocks[b].data();
    double* t_data = target[p].data();
    const __m256d b0 = loadColumn(b_data, 0);
    const __m256d b1 = loadColumn(b_data, 1);
    const __m256d b2 = loadColumn(b_data, 2);
    __m256d t[3];
    for (int c = 0; c < 3; ++c) t[c] = addProductColumn(b0, b1, b2, s, c, loadColumn(t_data, c));
    storeColumns(t_data, t[0], t[1], t[2]);
  }
}

// Column c of t - b l^T, each product fused in order k = 0, 1, 2: t + b s for s = -l^T, as
// addProductColumn gives it (a fused -(b l) + t is b (-l) + t exactly: negation does not round).
LSLAM_TARGET_AVX_FMA inline __m256d subtractProductColumnTransposed(__m256d b0, __m256d b1,
                                                                    __m256d b2, const double* l,
                                                                    int c, __m256d t) {
  t = _mm256_fnmadd_pd(b0, _mm256_broadcast_sd(l + c), t);
  t = _mm256_fnmadd_pd(b1, _mm256_broadcast_sd(l + 3 + c), t);
  return _mm256_fnmadd_pd(b2, _mm256_broadcast_sd(l + 6 + c), t);
}

LSLAM_TARGET_AVX_FMA void subtractOuterProductsOfColumnsAvx(const Mat3* const* columns,
                                                            Index num_columns, const Index* rows,
                                                            Index first, Index size,
                                                            const Index* target_rows,
                                                            Mat3* target) {
  Index p = 0;
  Index b = first;
  // Two rows at a time: each broadcast of a multiplier entry (the loads, not the multiply-adds,
  // set the pace here) serves both. Every target entry still sums its products in the same order.
  for (; b + 1 < size; b += 2) {
    while (target_rows[p] < rows[b]) ++p;
    LSLAM_DEBUG_ASSERT(target_rows[p] == rows[b]);
    Index q = p + 1;
    while (target_rows[q] < rows[b + 1]) ++q;
    LSLAM_DEBUG_ASSERT(target_rows[q] == rows[b + 1]);
    double* t_data = target[p].data();
    double* u_data = target[q].data();
    __m256d t[3] = {loadColumn(t_data, 0), loadColumn(t_data, 1), loadColumn(t_data, 2)};
    __m256d u[3] = {loadColumn(u_data, 0), loadColumn(u_data, 1), loadColumn(u_data, 2)};
    for (Index m = 0; m < num_columns; ++m) {
      const double* b_data = columns[m][b].data();
      const double* c_data = columns[m][b + 1].data();
      const double* l = columns[m][first].data();
      const __m256d b0 = loadColumn(b_data, 0);
      const __m256d b1 = loadColumn(b_data, 1);
      const __m256d b2 = loadColumn(b_data, 2);
      const __m256d c0 = loadColumn(c_data, 0);
      const __m256d c1 = loadColumn(c_data, 1);
      const __m256d c2 = loadColumn(c_data, 2);
      for (int c = 0; c < 3; ++c) {
        const __m256d l0 = _mm256_broadcast_sd(l + c);
        const __m256d l1 = _mm256_broadcast_sd(l + 3 + c);
        const __m256d l2 = _mm256_broadcast_sd(l + 6 + c);
        t[c] = _mm256_fnmadd_pd(b2, l2, _mm256_fnmadd_pd(b1, l1, _mm256_fnmadd_pd(b0, l0, t[c])));
        u[c] = _mm256_fnmadd_pd(c2, l2, _mm256_fnmadd_pd(c1, l1, _mm256_fnmadd_pd(c0, l0, u[c])));
      }
    }
    storeColumns(t_data, t[0], t[1], t[2]);
    storeColumns(u_data, u[0], u[1], u[2]);
    p = q;
  }
  for (; b < size; ++b) {
    while (target_rows[p] < rows[b]) ++p;
    LSLAM_DEBUG_ASSERT(target_rows[p] == rows[b]);
    double* t_data = target[p].data();
    __m256d t[3] = {loadColumn(t_data, 0), loadColumn(t_data, 1), loadColumn(t_data, 2)};
    for (Index m = 0; m < num_columns; ++m) {
      const double* b_data = columns[m][b].data();
      const double* l = columns[m][first].data();
      const __m256d b0 = loadColumn(b_data, 0);
      const __m256d b1 = loadColumn(b_data, 1);
      const __m256d b2 = loadColumn(b_data, 2);
      for (int c = 0; c < 3; ++c) t[c] = subtractProductColumnTransposed(b0, b1, b2, l, c, t[c]);
    }
    storeColumns(t_data, t[0], t[1], t[2]);
  }
}

// ---- 6 x 6 blocks: a column's rows 0-3 in a 4-lane register, rows 4-5 in a 2-lane one. ----

namespace {

// The operations of the 6 x 6 block products on rows 0-3 (Lanes4) or rows 4-5 (Lanes2) of a
// column, so that one template serves both halves.
struct Lanes4 {
  using V = __m256d;
  static constexpr int kFirstRow = 0;
  LSLAM_TARGET_AVX_FMA static V load(const double* p) { return _mm256_loadu_pd(p); }
  LSLAM_TARGET_AVX_FMA static void store(double* p, V v) { _mm256_storeu_pd(p, v); }
  LSLAM_TARGET_AVX_FMA static V broadcast(const double* p) { return _mm256_broadcast_sd(p); }
  LSLAM_TARGET_AVX_FMA static V fmadd(V a, V b, V c) { return _mm256_fmadd_pd(a, b, c); }
  LSLAM_TARGET_AVX_FMA static V fnmadd(V a, V b, V c) { return _mm256_fnmadd_pd(a, b, c); }
};

struct Lanes2 {
  using V = __m128d;
  static constexpr int kFirstRow = 4;
  LSLAM_TARGET_AVX_FMA static V load(const double* p) { return _mm_loadu_pd(p); }
  LSLAM_TARGET_AVX_FMA static void store(double* p, V v) { _mm_storeu_pd(p, v); }
  LSLAM_TARGET_AVX_FMA static V broadcast(const double* p) { return _mm_loaddup_pd(p); }
  LSLAM_TARGET_AVX_FMA static V fmadd(V a, V b, V c) { return _mm_fmadd_pd(a, b, c); }
  LSLAM_TARGET_AVX_FMA static V fnmadd(V a, V b, V c) { return _mm_fnmadd_pd(a, b, c); }
};

// Rows 4-5 of two row blocks in one 4-lane register (lanes 0-1: block p, 2-3: block q).
LSLAM_TARGET_AVX_FMA inline __m256d loadBottomPair(const double* p, const double* q) {
  return _mm256_insertf128_pd(_mm256_castpd128_pd256(_mm_loadu_pd(p)), _mm_loadu_pd(q), 1);
}
LSLAM_TARGET_AVX_FMA inline void storeBottomPair(double* p, double* q, __m256d v) {
  _mm_storeu_pd(p, _mm256_castpd256_pd128(v));
  _mm_storeu_pd(q, _mm256_extractf128_pd(v, 1));
}

// Two row blocks p and q of applyRowReflectionsFromAvx at D = 6, as three 4-lane groups: rows
// 0-3 of p, rows 0-3 of q, and rows 4-5 of both (p in lanes 0-1). Per group the compact form's
// three steps are small matrix products with the coefficients broadcast once for all three
// groups: P = L + X U, then S row by row from P and the overlaps, then X -= S U^T. Each lane runs
// applyCompactReflections6's operations on its row in that order (the same bits).
template <int M>
struct RowBlockPair6 {
  const double* l_in[2];
  double* l_out[2];
  double* w[2][M];

  // Group g's column k of W (rows 4-5 from `bottom`, packed once) and column j of L.
  LSLAM_TARGET_AVX_FMA __m256d wColumn(int g, int k, const __m256d* bottom) const {
    return g < 2 ? _mm256_loadu_pd(w[g][k / 6] + 6 * (k % 6)) : bottom[k];
  }
  LSLAM_TARGET_AVX_FMA __m256d lColumn(int g, int j) const {
    return g < 2 ? _mm256_loadu_pd(l_in[g] + 6 * j)
                 : loadBottomPair(l_in[0] + 6 * j + 4, l_in[1] + 6 * j + 4);
  }
  // Column j of L, or column k of W, of all three groups.
  LSLAM_TARGET_AVX_FMA void storeLColumn(int j, const __m256d* v) const {
    storeColumnOfGroups(l_out[0] + 6 * j, l_out[1] + 6 * j, v);
  }
  LSLAM_TARGET_AVX_FMA void storeWColumn(int k, const __m256d* v) const {
    storeColumnOfGroups(w[0][k / 6] + 6 * (k % 6), w[1][k / 6] + 6 * (k % 6), v);
  }
  LSLAM_TARGET_AVX_FMA static void storeColumnOfGroups(double* p, double* q, const __m256d* v) {
    _mm256_storeu_pd(p, v[0]);
    _mm256_storeu_pd(q, v[1]);
    storeBottomPair(p + 4, q + 4, v[2]);
  }
};

template <int M>
LSLAM_TARGET_AVX_FMA inline void reflectRowBlockPair6(const ReflectionCoefficients<6, M>& h,
                                                      const ReflectionOverlaps6<M>& overlaps,
                                                      const RowBlockPair6<M>& io) {
  // The W columns, k = 6 m + c; the loops over them are unrolled whole up to M = 3 (an index
  // left to run time costs a division per access).
  constexpr int kInner = 6 * M;
  // Rows 4-5 of W packed once; the rest is read where it lies (the multiply-adds' memory operands).
  __m256d bottom_w[kInner];
#pragma GCC unroll 18
  for (int k = 0; k < kInner; ++k) {
    bottom_w[k] =
        loadBottomPair(io.w[0][k / 6] + 6 * (k % 6) + 4, io.w[1][k / 6] + 6 * (k % 6) + 4);
  }
  // P = L + X U three columns at a time (nine accumulators), then those columns' S and L. In
  // place (l_in == l_out) column j is read before it is written.
  __m256d s[3][6];
#pragma GCC unroll 2
  for (int j0 = 0; j0 < 6; j0 += 3) {
    __m256d p[3][3];
#pragma GCC unroll 3
    for (int g = 0; g < 3; ++g) {
#pragma GCC unroll 3
      for (int jj = 0; jj < 3; ++jj) p[g][jj] = io.lColumn(g, j0 + jj);
    }
#pragma GCC unroll 18
    for (int k = 0; k < kInner; ++k) {
      __m256d coefficient[3];
#pragma GCC unroll 3
      for (int jj = 0; jj < 3; ++jj) coefficient[jj] = _mm256_broadcast_sd(&h.of[j0 + jj][k]);
#pragma GCC unroll 3
      for (int g = 0; g < 3; ++g) {
        const __m256d x = io.wColumn(g, k, bottom_w);
#pragma GCC unroll 3
        for (int jj = 0; jj < 3; ++jj) p[g][jj] = _mm256_fmadd_pd(x, coefficient[jj], p[g][jj]);
      }
    }
#pragma GCC unroll 3
    for (int jj = 0; jj < 3; ++jj) {
      const int j = j0 + jj;
      const __m256d beta = _mm256_broadcast_sd(&h.of[j][kInner]);
#pragma GCC unroll 3
      for (int g = 0; g < 3; ++g) {
        __m256d t = p[g][jj];
#pragma GCC unroll 5
        for (int i = 0; i < j; ++i) {
          t = _mm256_fnmadd_pd(s[g][i], _mm256_broadcast_sd(&overlaps.of[j][i]), t);
        }
        s[g][j] = _mm256_mul_pd(beta, t);
      }
      __m256d l[3];
#pragma GCC unroll 3
      for (int g = 0; g < 3; ++g) l[g] = _mm256_sub_pd(io.lColumn(g, j), s[g][j]);
      io.storeLColumn(j, l);
    }
  }
  // X -= S U^T, three W columns at a time.
#pragma GCC unroll 6
  for (int k0 = 0; k0 < kInner; k0 += 3) {
    __m256d x[3][3];
#pragma GCC unroll 3
    for (int g = 0; g < 3; ++g) {
#pragma GCC unroll 3
      for (int kk = 0; kk < 3; ++kk) x[g][kk] = io.wColumn(g, k0 + kk, bottom_w);
    }
#pragma GCC unroll 6
    for (int j = 0; j < 6; ++j) {
      __m256d coefficient[3];
#pragma GCC unroll 3
      for (int kk = 0; kk < 3; ++kk) coefficient[kk] = _mm256_broadcast_sd(&h.of[j][k0 + kk]);
#pragma GCC unroll 3
      for (int g = 0; g < 3; ++g) {
#pragma GCC unroll 3
        for (int kk = 0; kk < 3; ++kk) {
          x[g][kk] = _mm256_fnmadd_pd(s[g][j], coefficient[kk], x[g][kk]);
        }
      }
    }
#pragma GCC unroll 3
    for (int kk = 0; kk < 3; ++kk) {
      const __m256d column[3] = {x[0][kk], x[1][kk], x[2][kk]};
      io.storeWColumn(k0 + kk, column);
    }
  }
}

// Column c of a 6 x 6 block: rows 0-3 and rows 4-5.
LSLAM_TARGET_AVX_FMA inline __m256d loadTop(const double* block, int c) {
  return _mm256_loadu_pd(block + 6 * c);
}
LSLAM_TARGET_AVX_FMA inline __m128d loadBottom(const double* block, int c) {
  return _mm_loadu_pd(block + 6 * c + 4);
}

// Each column's six lanes (rows 0-3 in top[c], rows 4-5 in bottom[c]) summed as sumOfSix, into
// lanes c of sum_top (c < 4) and c - 4 of sum_bottom.
LSLAM_TARGET_AVX_FMA inline void sumColumnsOfSix(const __m256d* top, const __m128d* bottom,
                                                 __m256d& sum_top, __m128d& sum_bottom) {
  const __m256d h01 = _mm256_hadd_pd(top[0], top[1]);  // 0:01, 1:01, 0:23, 1:23
  const __m256d h23 = _mm256_hadd_pd(top[2], top[3]);  // 2:01, 3:01, 2:23, 3:23
  const __m256d first_four =
      _mm256_add_pd(_mm256_permute2f128_pd(h01, h23, 0x20), _mm256_permute2f128_pd(h01, h23, 0x31));
  const __m256d fourth_fifth =
      _mm256_insertf128_pd(_mm256_castpd128_pd256(_mm_hadd_pd(bottom[0], bottom[1])),
                           _mm_hadd_pd(bottom[2], bottom[3]), 1);
  sum_top = _mm256_add_pd(first_four, fourth_fifth);
  const __m256d h45 = _mm256_hadd_pd(top[4], top[5]);  // 4:01, 5:01, 4:23, 5:23
  const __m128d last_four = _mm_add_pd(_mm256_castpd256_pd128(h45), _mm256_extractf128_pd(h45, 1));
  sum_bottom = _mm_add_pd(last_four, _mm_hadd_pd(bottom[4], bottom[5]));
}

// acc += block b's columns times y lane by lane (one column of b^T y per accumulator pair).
LSLAM_TARGET_AVX_FMA inline void addTransposedProduct6(const double* b, const double* y_entry,
                                                       __m256d* top, __m128d* bottom) {
  const __m256d y_top = _mm256_loadu_pd(y_entry);
  const __m128d y_bottom = _mm_loadu_pd(y_entry + 4);
#pragma GCC unroll 6
  for (int c = 0; c < 6; ++c) {
    top[c] = _mm256_fmadd_pd(loadTop(b, c), y_top, top[c]);
    bottom[c] = _mm_fmadd_pd(loadBottom(b, c), y_bottom, bottom[c]);
  }
}

}  // namespace

namespace {

// The overlaps with std::fma an instruction (flatten: see triangularizeRows6Avx).
template <int M>
__attribute__((flatten)) LSLAM_TARGET_AVX_FMA ReflectionOverlaps6<M> overlapsAvx(const Mat6* u) {
  return ReflectionOverlaps6<M>(u);
}

}  // namespace

template <int M>
LSLAM_TARGET_AVX_FMA void applyRowReflectionsFromAvx(const Mat6* u, const Vec6& beta,
                                                     const Mat6* source_blocks, const Index* source,
                                                     Index kept, Mat6* blocks, const Index* rows,
                                                     Index size, Mat6* const* w) {
  const ReflectionCoefficients<6, M> h(u, beta);
  const ReflectionOverlaps6<M> overlaps = overlapsAvx<M>(u);
  const ReflectionSources<6> input{source_blocks, source, kept};
  Index b = 1;
  for (; b + 1 < size; b += 2) {
    RowBlockPair6<M> io{{input(b), input(b + 1)}, {blocks[b].data(), blocks[b + 1].data()}, {}};
    for (int m = 0; m < M; ++m) {
      io.w[0][m] = w[m][rows[b]].data();
      io.w[1][m] = w[m][rows[b + 1]].data();
    }
    reflectRowBlockPair6<M>(h, overlaps, io);
  }
  if (b < size) {  // the odd one, paired with a zero block whose results are dropped
    Mat6 spare_l;
    Mat6 spare_w[M];
    RowBlockPair6<M> io{
        {input(b), ReflectionSources<6>::kZero}, {blocks[b].data(), spare_l.data()}, {}};
    for (int m = 0; m < M; ++m) {
      spare_w[m].setZero();
      io.w[0][m] = w[m][rows[b]].data();
      io.w[1][m] = spare_w[m].data();
    }
    reflectRowBlockPair6<M>(h, overlaps, io);
  }
}

template <int M>
LSLAM_TARGET_AVX_FMA void applyRowReflectionsToRowAvx(const Mat6* u, const Vec6& beta,
                                                      Eigen::Matrix<double, 1, 6>& x_l,
                                                      Eigen::Matrix<double, 1, 6>* const* x_w) {
  applyRowReflections<6, M>(u, beta, x_l, x_w);
}

LSLAM_TARGET_AVX_FMA bool solveColumnAvx(const Vec6& d, const Mat6* blocks, const Index* rows,
                                         Index size, double* solution, Index k, double tolerance,
                                         Vec6& delta) {
  __m256d top[6];
  __m128d bottom[6];
#pragma GCC unroll 6
  for (int c = 0; c < 6; ++c) {
    top[c] = _mm256_setzero_pd();
    bottom[c] = _mm_setzero_pd();
  }
  // The parent's product last (see subtractTransposedProductsFused).
  for (Index i = 2; i < size; ++i) {
    addTransposedProduct6(blocks[i].data(), solution + kSolutionStride<6> * rows[i], top, bottom);
  }
  if (size > 1) {
    addTransposedProduct6(blocks[1].data(), solution + kSolutionStride<6> * rows[1], top, bottom);
  }
  __m256d sum_top;
  __m128d sum_bottom;
  sumColumnsOfSix(top, bottom, sum_top, sum_bottom);
  const __m256d r_top = _mm256_sub_pd(_mm256_loadu_pd(d.data()), sum_top);
  const __m128d r_bottom = _mm_sub_pd(_mm_loadu_pd(d.data() + 4), sum_bottom);
  // x(c) = column c of L(k,k)^-1 (blocks[0]) times r, unfused, as multiplyTransposed.
  const double* inverse = blocks[0].data();
#pragma GCC unroll 6
  for (int c = 0; c < 6; ++c) {
    top[c] = _mm256_mul_pd(loadTop(inverse, c), r_top);
    bottom[c] = _mm_mul_pd(loadBottom(inverse, c), r_bottom);
  }
  __m256d x_top;
  __m128d x_bottom;
  sumColumnsOfSix(top, bottom, x_top, x_bottom);
  double* entry = solution + kSolutionStride<6> * k;
  const __m256d sign_top = _mm256_set1_pd(-0.0);
  const __m128d sign_bottom = _mm_set1_pd(-0.0);
  const __m256d change_top =
      _mm256_andnot_pd(sign_top, _mm256_sub_pd(x_top, _mm256_loadu_pd(entry)));
  const __m128d change_bottom =
      _mm_andnot_pd(sign_bottom, _mm_sub_pd(x_bottom, _mm_loadu_pd(entry + 4)));
  const int moved =
      _mm256_movemask_pd(_mm256_cmp_pd(change_top, _mm256_set1_pd(tolerance), _CMP_GT_OQ)) |
      _mm_movemask_pd(_mm_cmp_pd(change_bottom, _mm_set1_pd(tolerance), _CMP_GT_OQ));
  _mm256_storeu_pd(entry, x_top);
  _mm_storeu_pd(entry + 4, x_bottom);
  _mm256_storeu_pd(delta.data(), x_top);
  _mm_storeu_pd(delta.data() + 4, x_bottom);
  return moved != 0;
}

LSLAM_TARGET_AVX_FMA void multiplyByTransposedLowerAvx(Mat6* blocks, Index count, const Mat6& l) {
  for (Index b = 0; b < count; ++b) {
    double* block = blocks[b].data();
    // Every input column in registers before the first store (the product is in place).
    __m256d top[6];
    __m128d bottom[6];
#pragma GCC unroll 6
    for (int c = 0; c < 6; ++c) {
      top[c] = loadTop(block, c);
      bottom[c] = loadBottom(block, c);
    }
    // Column j: b_0 l(j, 0), then + b_m l(j, m) for m = 1 .. j, fused in that order.
    __m256d out_top[6];
    __m128d out_bottom[6];
#pragma GCC unroll 6
    for (int j = 0; j < 6; ++j) {
      __m256d t = _mm256_mul_pd(top[0], _mm256_broadcast_sd(&l(j, 0)));
      __m128d u = _mm_mul_pd(bottom[0], _mm_loaddup_pd(&l(j, 0)));
#pragma GCC unroll 6
      for (int m = 1; m <= j; ++m) {
        t = _mm256_fmadd_pd(top[m], _mm256_broadcast_sd(&l(j, m)), t);
        u = _mm_fmadd_pd(bottom[m], _mm_loaddup_pd(&l(j, m)), u);
      }
      out_top[j] = t;
      out_bottom[j] = u;
    }
#pragma GCC unroll 6
    for (int c = 0; c < 6; ++c) {
      _mm256_storeu_pd(block + 6 * c, out_top[c]);
      _mm_storeu_pd(block + 6 * c + 4, out_bottom[c]);
    }
  }
}

// The rows of Lanes (0-3 or 4-5) of the 6 x 6 blocks: t[c] (+ or -)= sum_k b(:, k) m(k, c), each
// product fused in order k = 0 .. 5 (as addBlockProduct), with m(k, c) at mult[k step_k + c
// step_c]. Those rows of b are held in registers whole: loaded once, where column by column the
// stores to t (which may alias b as far as the compiler knows) would reload them each time.
template <class Lanes, bool kSubtract>
LSLAM_TARGET_AVX_FMA inline void addProductsOnRows(const double* b_data, const double* mult,
                                                   int step_k, int step_c, typename Lanes::V* t) {
  typename Lanes::V b[6];
#pragma GCC unroll 6
  for (int k = 0; k < 6; ++k) b[k] = Lanes::load(b_data + 6 * k + Lanes::kFirstRow);
#pragma GCC unroll 6
  for (int c = 0; c < 6; ++c) {
#pragma GCC unroll 6
    for (int k = 0; k < 6; ++k) {
      const typename Lanes::V m = Lanes::broadcast(mult + k * step_k + c * step_c);
      t[c] = kSubtract ? Lanes::fnmadd(b[k], m, t[c]) : Lanes::fmadd(b[k], m, t[c]);
    }
  }
}

template <class Lanes>
LSLAM_TARGET_AVX_FMA inline void loadRows(const double* block, typename Lanes::V* t) {
#pragma GCC unroll 6
  for (int c = 0; c < 6; ++c) t[c] = Lanes::load(block + 6 * c + Lanes::kFirstRow);
}

template <class Lanes>
LSLAM_TARGET_AVX_FMA inline void storeRows(double* block, const typename Lanes::V* t) {
#pragma GCC unroll 6
  for (int c = 0; c < 6; ++c) Lanes::store(block + 6 * c + Lanes::kFirstRow, t[c]);
}

LSLAM_TARGET_AVX_FMA void addBlockProductsAvx(const Mat6* blocks, const Index* rows, Index first,
                                              Index size, const Mat6& s, const Index* target_rows,
                                              Mat6* target) {
  Index p = 0;
  for (Index b = first; b < size; ++b) {
    while (target_rows[p] < rows[b]) ++p;
    LSLAM_DEBUG_ASSERT(target_rows[p] == rows[b]);
    double* t_data = target[p].data();
    // t + b s: s(k, c) at s.data()[k + 6 c].
    __m256d top[6];
    loadRows<Lanes4>(t_data, top);
    addProductsOnRows<Lanes4, false>(blocks[b].data(), s.data(), 1, 6, top);
    __m128d bottom[6];
    loadRows<Lanes2>(t_data, bottom);
    addProductsOnRows<Lanes2, false>(blocks[b].data(), s.data(), 1, 6, bottom);
    storeRows<Lanes4>(t_data, top);
    storeRows<Lanes2>(t_data, bottom);
  }
}

// As addBlockProductsAvx above, for every column of the supernode before the target block is
// stored: each half of the target stays in registers across the columns.
LSLAM_TARGET_AVX_FMA void subtractOuterProductsOfColumnsAvx(const Mat6* const* columns,
                                                            Index num_columns, const Index* rows,
                                                            Index first, Index size,
                                                            const Index* target_rows,
                                                            Mat6* target) {
  Index p = 0;
  for (Index b = first; b < size; ++b) {
    while (target_rows[p] < rows[b]) ++p;
    LSLAM_DEBUG_ASSERT(target_rows[p] == rows[b]);
    double* t_data = target[p].data();
    __m256d top[6];
    __m128d bottom[6];
    loadRows<Lanes4>(t_data, top);
    loadRows<Lanes2>(t_data, bottom);
    // t - b l^T: l(c, k) at l.data()[6 k + c].
    for (Index m = 0; m < num_columns; ++m) {
      const double* l = columns[m][first].data();
      addProductsOnRows<Lanes4, true>(columns[m][b].data(), l, 6, 1, top);
      addProductsOnRows<Lanes2, true>(columns[m][b].data(), l, 6, 1, bottom);
    }
    storeRows<Lanes4>(t_data, top);
    storeRows<Lanes2>(t_data, bottom);
  }
}

// flatten: GCC does not inline the header template here of its own accord, and its out-of-line
// copy (no FMA target) calls libm's fma for every multiply-add.
template <int M>
__attribute__((flatten)) LSLAM_TARGET_AVX_FMA bool triangularizeRows6Avx(const Mat6& l,
                                                                         const Mat6* w, Mat6& l_new,
                                                                         Mat6* u, Vec6& beta) {
  return triangularizeRows6<M>(l, w, l_new, u, beta);
}

// The reflections of one to three factors (kMaxJointFactors, at one block size) at D = 6.
#define LSLAM_INSTANTIATE_REFLECTIONS_6(M)                                                         \
  template bool triangularizeRows6Avx<M>(const Mat6&, const Mat6*, Mat6&, Mat6*, Vec6&);           \
  template void applyRowReflectionsToRowAvx<M>(const Mat6*, const Vec6&,                           \
                                               Eigen::Matrix<double, 1, 6>&,                       \
                                               Eigen::Matrix<double, 1, 6>* const*);               \
  template void applyRowReflectionsFromAvx<M>(const Mat6*, const Vec6&, const Mat6*, const Index*, \
                                              Index, Mat6*, const Index*, Index, Mat6* const*);
LSLAM_INSTANTIATE_REFLECTIONS_6(1)
LSLAM_INSTANTIATE_REFLECTIONS_6(2)
LSLAM_INSTANTIATE_REFLECTIONS_6(3)
#undef LSLAM_INSTANTIATE_REFLECTIONS_6

#else

// Never called (cpuHasAvxFma() is false here), but the calls behind it must link.
template <int M>
void applyRowReflectionsFromAvx(const Mat3*, const Vec3&, const Mat3*, const Index*, Index, Mat3*,
                                const Index*, Index, Mat3* const*) {
  LSLAM_ASSERT(false);
}
bool solveColumnAvx(const Vec3&, const Mat3*, const Index*, Index, double*, Index, double, Vec3&) {
  LSLAM_ASSERT(false);
  return false;
}
void multiplyByTransposedLowerAvx(Mat3*, Index, const Mat3&) {
  LSLAM_ASSERT(false);
}
template <int M>
void applyRowReflectionsToRowAvx(const Mat3*, const Vec3&, Eigen::Matrix<double, 1, 3>&,
                                 Eigen::Matrix<double, 1, 3>* const*) {
  LSLAM_ASSERT(false);
}
void addBlockProductsAvx(const Mat3*, const Index*, Index, Index, const Mat3&, const Index*,
                         Mat3*) {
  LSLAM_ASSERT(false);
}
void subtractOuterProductsOfColumnsAvx(const Mat3* const*, Index, const Index*, Index, Index,
                                       const Index*, Mat3*) {
  LSLAM_ASSERT(false);
}

#endif

// The reflections of one to three factors (kMaxJointFactors, at one block size), from either
// branch above.
#define LSLAM_INSTANTIATE_REFLECTIONS_3(M)                                                         \
  template void applyRowReflectionsToRowAvx<M>(const Mat3*, const Vec3&,                           \
                                               Eigen::Matrix<double, 1, 3>&,                       \
                                               Eigen::Matrix<double, 1, 3>* const*);               \
  template void applyRowReflectionsFromAvx<M>(const Mat3*, const Vec3&, const Mat3*, const Index*, \
                                              Index, Mat3*, const Index*, Index, Mat3* const*);
LSLAM_INSTANTIATE_REFLECTIONS_3(1)
LSLAM_INSTANTIATE_REFLECTIONS_3(2)
LSLAM_INSTANTIATE_REFLECTIONS_3(3)
#undef LSLAM_INSTANTIATE_REFLECTIONS_3

}  // namespace detail
}  // namespace lslam
