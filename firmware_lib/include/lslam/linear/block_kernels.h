#pragma once
// The inner loops of the factor's updates on D x D blocks: the block product of the numeric
// factorization (t += b s) and the Householder reflections of the row update.
//
// Every multiply-add is fused (std::fma: one rounding), in one fixed order, so that all forms
// compute the same bits. On an x86-64 host the loops that dominate a large factor's updates also
// have AVX2/FMA forms for D = 3 and D = 6: a 3 x 3 block's columns of 3 leave SSE2's 2-lane
// registers a lane short, a 4-lane register takes a column in one instruction (a column of 6 in a
// 4-lane and a 2-lane one), and a fused multiply-add is one instruction where a multiply and an
// add are two. They are chosen at run time (cpuHasAvxFma), so the host binary still runs on any
// x86-64; a host without FMA computes the same bits through std::fma in software, only slower.
// The Cortex-M7's FPU fuses in hardware (vfma.f64). Elsewhere cpuHasAvxFma() is false.
// Hosts with AVX-512 (cpuHasAvx512) take an 8-lane form of the row update's 6 x 6
// triangularization, the same bits again.
// Other block sizes have no AVX2 form, so no second form's bits to match: on x86-64 they take
// Eigen's products and unfused multiply-adds, as std::fma without -mfma is a call into libm.
#include <cmath>

#include "lslam/eigen.h"
#include "lslam/linear/index.h"

namespace lslam {
namespace detail {

// a * b + c for the kernels of block size D: fused (std::fma) where the bits must match a fused
// form (D = 3 and 6 on x86-64) and on targets that fuse in hardware; unfused for other D on x86-64.
template <int D>
inline double multiplyAdd(double a, double b, double c) {
#if defined(__x86_64__)
  if constexpr (D != 3 && D != 6) return a * b + c;
#endif
  return std::fma(a, b, c);
}

// Whether the kernels of block size D run the fused scalar forms below (else Eigen's products).
template <int D>
inline constexpr bool kFusedScalarKernels =
#if defined(__x86_64__)
    D == 3 || D == 6;
#else
    false;
#endif

// Whether block size D has AVX2/FMA forms to dispatch to (when cpuHasAvxFma()): D = 3 everywhere
// (dead code off x86-64, as before), D = 6 on x86-64 only, so that no other target sees it.
template <int D>
inline constexpr bool kAvxForms =
#if defined(__x86_64__)
    D == 3 || D == 6;
#else
    D == 3;
#endif

// t += b * s: each entry t(i, c) takes b(i, 0) s(0, c), then b(i, 1) s(1, c), ..., each fused.
// On x86-64 for D = 3 and 6 only; elsewhere Eigen's product, the fewest instructions on the scalar
// Cortex-M.
template <int D>
inline void addBlockProduct(Eigen::Matrix<double, D, D>& t, const Eigen::Matrix<double, D, D>& b,
                            const Eigen::Matrix<double, D, D>& s) {
  if constexpr (kFusedScalarKernels<D>) {
    for (int c = 0; c < D; ++c) {
      for (int i = 0; i < D; ++i) {
        double sum = t(i, c);
        for (int k = 0; k < D; ++k) sum = std::fma(b(i, k), s(k, c), sum);
        t(i, c) = sum;
      }
    }
  } else {
    t.noalias() += b * s;
  }
}

// b = b l^T for a lower-triangular l (only its lower triangle is read): each entry b(i, j) becomes
// b(i, 0) l(j, 0), then + b(i, m) l(j, m) for m = 1 .. j, each fused: D (D + 1) / 2 multiply-adds
// per row where the general product takes D^2 (a factorized column's blocks times L(k,k)^-T).
// On x86-64 for D = 3 and 6 only; elsewhere Eigen's product, as addBlockProduct.
template <int D>
inline void multiplyByTransposedLower(Eigen::Matrix<double, D, D>& b,
                                      const Eigen::Matrix<double, D, D>& l) {
  if constexpr (kFusedScalarKernels<D>) {
    const Eigen::Matrix<double, D, D> in = b;
    for (int j = 0; j < D; ++j) {
      for (int i = 0; i < D; ++i) {
        double sum = in(i, 0) * l(j, 0);
        for (int m = 1; m <= j; ++m) sum = std::fma(in(i, m), l(j, m), sum);
        b(i, j) = sum;
      }
    }
  } else {
#if defined(__x86_64__)
    b = (b * l.template triangularView<Eigen::Lower>().transpose()).eval();
#else
    // On the Cortex-M7 the triangular loop takes more instructions than Eigen's product (the
    // factor's l has a zero upper triangle).
    b = (b * l.transpose()).eval();
#endif
  }
}

// Whether the reflections of the fused 6 x 6 kernels (K = 6) sum each factor's six products in two
// chains (0-2 onto t, 3-5 apart, then added) instead of one: a shorter dependency chain for the
// right-hand side's row (the row blocks take applyCompactReflections6).
template <int W, int K>
inline constexpr bool kSplitSums = W == 6 && K == 6;

// [x_l x_w[0] .. x_w[M-1]] H_0 ... H_{C-1} in place, for the rows of x_l (C columns) and of each
// x_w[m] (W columns; any row count): the reflections of the row update, which rotates M factors'
// rows (M = 1, or 2 for two factors taken together) into a column of width C. H_j = I - beta(j)
// v_j v_j^T with v_j = e_j + [0; u[0].col(j); ..; u[M-1].col(j)]. Per row and reflection:
// t = x_l(j) + sum_m sum_c x_w[m](c) u[m](c, j) (m, then c ascending; see kSplitSums), s = beta(j)
// t, x_l(j) -= s, x_w[m](c) -= s u[m](c, j), each multiply-add as multiplyAdd<K>.
template <int C, int W, int M, int K, typename XL, typename XW>
inline void applyReflectionsToRows(const Eigen::Matrix<double, W, C>* u,
                                   const Eigen::Matrix<double, C, 1>& beta, XL& x_l,
                                   XW* const* x_w) {
  for (Eigen::Index i = 0; i < x_l.rows(); ++i) {
    // The row in locals for all C reflections: through the matrices, every store may alias u for
    // all the compiler knows, and the scalar Cortex-M would reload the row after each one.
    double l[C];
    double x[M][W];
#pragma GCC unroll 6
    for (int c = 0; c < C; ++c) l[c] = x_l(i, c);
#pragma GCC unroll 2
    for (int m = 0; m < M; ++m) {
#pragma GCC unroll 6
      for (int c = 0; c < W; ++c) x[m][c] = (*x_w[m])(i, c);
    }
#pragma GCC unroll 6
    for (int j = 0; j < C; ++j) {
      double t = l[j];
#pragma GCC unroll 2
      for (int m = 0; m < M; ++m) {
        if constexpr (kSplitSums<W, K>) {
          // Two chains of three, joined by one add: a shorter dependency chain per reflection.
          double high = x[m][3] * u[m](3, j);
          high = multiplyAdd<K>(x[m][4], u[m](4, j), high);
          high = multiplyAdd<K>(x[m][5], u[m](5, j), high);
#pragma GCC unroll 3
          for (int c = 0; c < 3; ++c) t = multiplyAdd<K>(x[m][c], u[m](c, j), t);
          t += high;
        } else {
#pragma GCC unroll 6
          for (int c = 0; c < W; ++c) t = multiplyAdd<K>(x[m][c], u[m](c, j), t);
        }
      }
      const double s = beta(j) * t;
      l[j] -= s;
#pragma GCC unroll 2
      for (int m = 0; m < M; ++m) {
#pragma GCC unroll 6
        for (int c = 0; c < W; ++c) x[m][c] = multiplyAdd<K>(-s, u[m](c, j), x[m][c]);
      }
    }
#pragma GCC unroll 6
    for (int c = 0; c < C; ++c) x_l(i, c) = l[c];
#pragma GCC unroll 2
    for (int m = 0; m < M; ++m) {
#pragma GCC unroll 6
      for (int c = 0; c < W; ++c) (*x_w[m])(i, c) = x[m][c];
    }
  }
}

// The reflections of one block size D (C = W = D), fused as the AVX2/FMA forms below.
template <int D, int M, typename XL, typename XW>
inline void applyRowReflections(const Eigen::Matrix<double, D, D>* u,
                                const Eigen::Matrix<double, D, 1>& beta, XL& x_l, XW* const* x_w) {
  applyReflectionsToRows<D, D, M, D>(u, beta, x_l, x_w);
}

// The overlaps of the six reflections of a 6 x 6 column with M factors' rows (H_j = I - beta(j)
// v_j v_j^T, v_j = e_j + [0; u[0].col(j); ..]): of[j][i] = v_i . v_j = sum_m u[m].col(i) .
// u[m].col(j) for i < j (the e parts never meet), fused, m then c ascending, from zero. Computed
// once per column, so every form of applyCompactReflections6 reads the same bits.
template <int M>
struct ReflectionOverlaps6 {
  double of[6][6];  // [j][i], i < j

  explicit ReflectionOverlaps6(const Eigen::Matrix<double, 6, 6>* u) {
    for (int j = 0; j < 6; ++j) {
      for (int i = 0; i < j; ++i) {
        double sum = 0.0;
        for (int m = 0; m < M; ++m) {
          for (int c = 0; c < 6; ++c) sum = multiplyAdd<6>(u[m](c, i), u[m](c, j), sum);
        }
        of[j][i] = sum;
      }
    }
  }
};

// [x_l x_w[0] .. x_w[M-1]] H_0 ... H_5 in place for the rows of 6 x 6 blocks (the row update at
// D = 6), in the compact form: with x the row as it came in, H_0 .. H_{j-1} change its product
// with v_j by -sum_{i<j} s_i (v_i . v_j), so per row
//   p_j = x_l(j) + sum_m sum_c x_w[m](c) u[m](c, j)   (m, then c ascending)
//   s_j = beta(j) (p_j - sum_{i<j} s_i overlaps(j, i))  (i ascending)
//   x_l(j) -= s_j,  x_w[m](c) -= sum_j s_j u[m](c, j)  (j ascending)
// every multiply-add fused. Unlike the reflection-by-reflection form the six products p_j and
// the W updates are independent chains, which the AVX2 form runs as small matrix products
// (about 1.1x the multiply-adds, without a reflection's latency between one and the next).
template <int M, typename XL, typename XW>
inline void applyCompactReflections6(const Eigen::Matrix<double, 6, 6>* u,
                                     const Eigen::Matrix<double, 6, 1>& beta,
                                     const ReflectionOverlaps6<M>& overlaps, XL& x_l,
                                     XW* const* x_w) {
  for (Eigen::Index r = 0; r < x_l.rows(); ++r) {
    double x[M][6];  // the row in locals (see applyReflectionsToRows)
    for (int m = 0; m < M; ++m) {
      for (int c = 0; c < 6; ++c) x[m][c] = (*x_w[m])(r, c);
    }
    double s[6];
    for (int j = 0; j < 6; ++j) {
      double p = x_l(r, j);
      for (int m = 0; m < M; ++m) {
        for (int c = 0; c < 6; ++c) p = multiplyAdd<6>(x[m][c], u[m](c, j), p);
      }
      for (int i = 0; i < j; ++i) p = multiplyAdd<6>(-s[i], overlaps.of[j][i], p);
      s[j] = beta(j) * p;
      x_l(r, j) -= s[j];
    }
    for (int m = 0; m < M; ++m) {
      for (int c = 0; c < 6; ++c) {
        double y = x[m][c];
        for (int j = 0; j < 6; ++j) y = multiplyAdd<6>(-s[j], u[m](c, j), y);
        (*x_w[m])(r, c) = y;
      }
    }
  }
}

// The row update's triangularization of one 6 x 6 column with M factors' rows (the uniform D = 6
// path; other sizes keep the general form in the row update): the reflections H_0 .. H_5 with
// [l w_0 .. w_{M-1}] H_0 ... H_5 = [l' 0 ..], l' lower-triangular with a positive diagonal, as
// u[m], beta (see applyReflectionsToRows), and l'. H_j is formed from row j as updated by H_0 ..
// H_{j-1} (Householder, sign chosen so that the kept entry is +norm) and applied to rows j .. 5.
// Every sum in one fixed order, fused (multiplyAdd<6>), so that the AVX-512 form, which runs the
// six rows as lanes, computes the same bits: sigma = sum of w_jc^2 per factor as two chains of
// three (c = 0-2, 3-5) joined by an add, factors in order; u = w_j / v0 as w_j (1 / v0); each row's
// t, s and update as in applyReflectionsToRows. Returns false if a reflection's norm (l'(j, j)
// before rounding) is not positive and finite: l and the rows together lack full rank.
template <int M>
inline bool triangularizeRows6(const Eigen::Matrix<double, 6, 6>& l,
                               const Eigen::Matrix<double, 6, 6>* w,
                               Eigen::Matrix<double, 6, 6>& l_new, Eigen::Matrix<double, 6, 6>* u,
                               Eigen::Matrix<double, 6, 1>& beta) {
  double m_l[6][6];   // [column][row]
  double x[M][6][6];  // [factor][column][row]
  for (int c = 0; c < 6; ++c) {
    for (int r = 0; r < 6; ++r) m_l[c][r] = l(r, c);
  }
  for (int m = 0; m < M; ++m) {
    for (int c = 0; c < 6; ++c) {
      for (int r = 0; r < 6; ++r) x[m][c][r] = w[m](r, c);
    }
  }
  for (int j = 0; j < 6; ++j) {
    const double alpha = m_l[j][j];
    double sigma = 0.0;
    for (int m = 0; m < M; ++m) {
      const double* xj[6] = {&x[m][0][j], &x[m][1][j], &x[m][2][j],
                             &x[m][3][j], &x[m][4][j], &x[m][5][j]};
      double low = *xj[0] * *xj[0];
      low = multiplyAdd<6>(*xj[1], *xj[1], low);
      low = multiplyAdd<6>(*xj[2], *xj[2], low);
      double high = *xj[3] * *xj[3];
      high = multiplyAdd<6>(*xj[4], *xj[4], high);
      high = multiplyAdd<6>(*xj[5], *xj[5], high);
      const double part = low + high;
      sigma = m == 0 ? part : sigma + part;
    }
    const double square = alpha * alpha;
    const double norm = std::sqrt(square + sigma);
    if (!(norm > 0.0) || !std::isfinite(norm)) return false;
    if (sigma == 0.0 && alpha > 0.0) {  // row j is already in place: H_j = I
      beta(j) = 0.0;
      for (int m = 0; m < M; ++m) u[m].col(j).setZero();
      continue;
    }
    // v = x - norm e_j, scaled so that v(j) = 1; for alpha > 0 the difference is formed as
    // -sigma / (alpha + norm), which does not cancel.
    const double v0 = alpha <= 0.0 ? alpha - norm : -sigma / (alpha + norm);
    const double v0_squared = v0 * v0;
    beta(j) = 2.0 * v0_squared / (sigma + v0_squared);
    const double inverse = 1.0 / v0;
    double uj[M][6];
    for (int m = 0; m < M; ++m) {
      for (int c = 0; c < 6; ++c) {
        uj[m][c] = x[m][c][j] * inverse;
        u[m](c, j) = uj[m][c];
      }
    }
    // Rows above j are final (their w is rounding of zero and no longer read).
    for (int r = j; r < 6; ++r) {
      double t = m_l[j][r];
      for (int m = 0; m < M; ++m) {
        double high = x[m][3][r] * uj[m][3];
        high = multiplyAdd<6>(x[m][4][r], uj[m][4], high);
        high = multiplyAdd<6>(x[m][5][r], uj[m][5], high);
        for (int c = 0; c < 3; ++c) t = multiplyAdd<6>(x[m][c][r], uj[m][c], t);
        t = t + high;
      }
      const double s = beta(j) * t;
      m_l[j][r] = m_l[j][r] - s;
      for (int m = 0; m < M; ++m) {
        for (int c = 0; c < 6; ++c) x[m][c][r] = multiplyAdd<6>(-s, uj[m][c], x[m][c][r]);
      }
    }
  }
  // What remains right of the diagonal is rounding of exact zeros.
  for (int c = 0; c < 6; ++c) {
    for (int r = 0; r < 6; ++r) l_new(r, c) = r >= c ? m_l[c][r] : 0.0;
  }
  return true;
}

// How many doubles each column's entry of the solution takes in the back-substitution's array of
// solutions by column position: D, or 4 for D = 3 so that an entry is one 32-byte SIMD load with a
// zero fourth lane (and its address a shift of the row).
template <int D>
inline constexpr int kSolutionStride = D == 3 ? 4 : D;

// x(c) -= sum_{i >= 1} (blocks[i]^T y_i)(c) with y_i the solution of row rows[i] (entries
// solution[4 rows[i] + r], r < 3): the back-substitution's inner loop, in the form of the x86-64
// host. Per entry (r, c) the products
// blocks[i](r, c) y_i(r) are summed over i = 2, 3, ..., size - 1 and then i = 1 (fused, from
// zero), and x(c) takes the three sums of column c as x(c) - ((s_0 + s_1) + s_2): a SIMD lane per
// row, reduced once per column. Row 1 is the column's parent, the column the back-substitution
// solved just before (in a postordered factor): with its product last, the others need not wait
// for its solution, and an out-of-order core overlaps them with the parent's own column.
inline void subtractTransposedProductsFused(Vec3& x, const Mat3* blocks, const Index* rows,
                                            Index size, const double* solution) {
  Mat3 acc = Mat3::Zero();
  const auto add = [&](Index i) {
    const double* y = solution + kSolutionStride<3> * rows[i];
    for (int c = 0; c < 3; ++c) {
      for (int r = 0; r < 3; ++r) acc(r, c) = std::fma(blocks[i](r, c), y[r], acc(r, c));
    }
  };
  for (Index i = 2; i < size; ++i) add(i);
  if (size > 1) add(1);
  for (int c = 0; c < 3; ++c) x(c) -= (acc(0, c) + acc(1, c)) + acc(2, c);
}

#if defined(__x86_64__)
using Mat6 = Eigen::Matrix<double, 6, 6>;
using Vec6 = Eigen::Matrix<double, 6, 1>;

// The sum of six terms in the order of the AVX forms' reductions (one 4-lane and one 2-lane
// register per column): ((p0 + p1) + (p2 + p3)) + (p4 + p5).
inline double sumOfSix(double p0, double p1, double p2, double p3, double p4, double p5) {
  return ((p0 + p1) + (p2 + p3)) + (p4 + p5);
}

// subtractTransposedProductsFused for D = 6 (solution stride 6): per entry (r, c) the products
// blocks[i](r, c) y_i(r) summed over i = 2, .., size - 1, then i = 1 (fused, from zero), and
// x(c) -= sumOfSix of column c's six sums.
inline void subtractTransposedProductsFused(Vec6& x, const Mat6* blocks, const Index* rows,
                                            Index size, const double* solution) {
  Mat6 acc = Mat6::Zero();
  const auto add = [&](Index i) {
    const double* y = solution + kSolutionStride<6> * rows[i];
    for (int c = 0; c < 6; ++c) {
      for (int r = 0; r < 6; ++r) acc(r, c) = std::fma(blocks[i](r, c), y[r], acc(r, c));
    }
  };
  for (Index i = 2; i < size; ++i) add(i);
  if (size > 1) add(1);
  for (int c = 0; c < 6; ++c) {
    x(c) -= sumOfSix(acc(0, c), acc(1, c), acc(2, c), acc(3, c), acc(4, c), acc(5, c));
  }
}

// inverse^T x for D = 6, in the AVX form's order: x'(c) = sumOfSix of inverse(r, c) x(r) (each
// product rounded, unfused).
inline Vec6 multiplyTransposed(const Mat6& inverse, const Vec6& x) {
  Vec6 out;
  for (int c = 0; c < 6; ++c) {
    out(c) = sumOfSix(inverse(0, c) * x(0), inverse(1, c) * x(1), inverse(2, c) * x(2),
                      inverse(3, c) * x(3), inverse(4, c) * x(4), inverse(5, c) * x(5));
  }
  return out;
}
#endif

// Whether this CPU runs the AVX2/FMA forms below (never off x86-64: known at compile time there,
// so the checks cost the target nothing).
#if defined(__x86_64__)
// Inline, as a load and a test of the feature bits that libgcc's constructor fills before any
// ordinary static constructor runs: the solve asks once per column, too often for a call into a
// function with a guarded static. (Hoisted out of the solve, the check would change GCC's inlining
// on the Cortex-M, where it is dead code.)
inline bool cpuHasAvxFma() {
  return __builtin_cpu_supports("avx2") != 0 && __builtin_cpu_supports("fma") != 0;
}
#else
constexpr bool cpuHasAvxFma() {
  return false;
}
#endif

// Whether this CPU also runs the AVX-512 form (512-bit registers) of the row update's
// triangularization at D = 6, where a block's six rows fit one register. Same load and test as
// above.
#if defined(__x86_64__)
inline bool cpuHasAvx512() {
  return cpuHasAvxFma() && __builtin_cpu_supports("avx512f") != 0;
}
#else
constexpr bool cpuHasAvx512() {
  return false;
}
#endif

// The AVX forms' target (on x86-64 only). A function template's declaration must carry it too:
// GCC compiles the template's instances with the attributes of its first declaration.
#if defined(__x86_64__)
#define LSLAM_TARGET_AVX_FMA __attribute__((target("avx2,fma")))
#else
#define LSLAM_TARGET_AVX_FMA
#endif

// applyRowReflections<3, M> on the row blocks x_w[m] = w[m][rows[b]] and x_l, for b in [1, size):
// x_l read from source_blocks[b] for b < kept and from source_blocks[source[b]] beyond (a zero
// block where source[b] is kNoIndex), and written to blocks[b]. The row update's merge into the
// staging area and its reflections in one pass; in place with source_blocks == blocks and
// kept == size (source is then not read). Instantiated for M = 1 and 2.
template <int M>
LSLAM_TARGET_AVX_FMA void applyRowReflectionsFromAvx(const Mat3* u, const Vec3& beta,
                                                     const Mat3* source_blocks, const Index* source,
                                                     Index kept, Mat3* blocks, const Index* rows,
                                                     Index size, Mat3* const* w);

// applyRowReflections<3, M> on one row (the right-hand side's, [d^T b_0^T ..] of the row update),
// compiled for AVX2/FMA: outside such a function std::fma is a call into libm on x86-64. The same
// bits. Instantiated for M = 1 and 2.
template <int M>
LSLAM_TARGET_AVX_FMA void applyRowReflectionsToRowAvx(const Mat3* u, const Vec3& beta,
                                                      Eigen::Matrix<double, 1, 3>& x_l,
                                                      Eigen::Matrix<double, 1, 3>* const* x_w);

// One column's whole step of the back-substitution (detail::solveColumnInPlace for D = 3 on an
// x86-64 host with subtractTransposedProductsFused, the same bits): x = L(k,k)^-T (d - sum_{i >= 1}
// blocks[i]^T y_i), written to the solution entry of position k (fourth lane zero) and to delta;
// returns whether x moved from the entry's old value by more than tolerance (max-norm).
bool solveColumnAvx(const Vec3& d, const Mat3* blocks, const Index* rows, Index size,
                    double* solution, Index k, double tolerance, Vec3& delta);

// multiplyByTransposedLower<3>(blocks[b], l) for b in [0, count), the same bits.
void multiplyByTransposedLowerAvx(Mat3* blocks, Index count, const Mat3& l);

#if defined(__x86_64__)
// The forms above for 6 x 6 blocks (x86-64 only), the same bits as the portable forms at D = 6:
// a block's column is rows 0-3 in a 4-lane register and rows 4-5 in a 2-lane one. The row
// blocks' reflections are applyCompactReflections6 (the compact form), two row blocks at a time:
// rows 0-3 of each and rows 4-5 of both make three full 4-lane groups. The right-hand side's row
// keeps the reflection-by-reflection form (applyRowReflections).
template <int M>
LSLAM_TARGET_AVX_FMA void applyRowReflectionsFromAvx(const Mat6* u, const Vec6& beta,
                                                     const Mat6* source_blocks, const Index* source,
                                                     Index kept, Mat6* blocks, const Index* rows,
                                                     Index size, Mat6* const* w);
template <int M>
LSLAM_TARGET_AVX_FMA void applyRowReflectionsToRowAvx(const Mat6* u, const Vec6& beta,
                                                      Eigen::Matrix<double, 1, 6>& x_l,
                                                      Eigen::Matrix<double, 1, 6>* const* x_w);
// triangularizeRows6<M> with the six rows in AVX-512 lanes (when cpuHasAvx512()), and the portable
// form compiled for AVX2/FMA (std::fma an instruction, not a call into libm): the same bits.
template <int M>
__attribute__((target("avx512f,avx2,fma"))) bool triangularizeRows6Avx512(const Mat6& l,
                                                                          const Mat6* w,
                                                                          Mat6& l_new, Mat6* u,
                                                                          Vec6& beta);
template <int M>
LSLAM_TARGET_AVX_FMA bool triangularizeRows6Avx(const Mat6& l, const Mat6* w, Mat6& l_new, Mat6* u,
                                                Vec6& beta);
// solveColumnInPlace<6> with subtractTransposedProductsFused and multiplyTransposed above.
bool solveColumnAvx(const Vec6& d, const Mat6* blocks, const Index* rows, Index size,
                    double* solution, Index k, double tolerance, Vec6& delta);
void multiplyByTransposedLowerAvx(Mat6* blocks, Index count, const Mat6& l);
void addBlockProductsAvx(const Mat6* blocks, const Index* rows, Index first, Index size,
                         const Mat6& s, const Index* target_rows, Mat6* target);
// subtractOuterProductsOfColumnsAvx (below) at D = 6.
void subtractOuterProductsOfColumnsAvx(const Mat6* const* columns, Index num_columns,
                                       const Index* rows, Index first, Index size,
                                       const Index* target_rows, Mat6* target);
#endif

// triangularizeRows6<M> through the fastest form this CPU runs (the same bits).
template <int M>
inline bool triangularizeRowsOfSix(const Eigen::Matrix<double, 6, 6>& l,
                                   const Eigen::Matrix<double, 6, 6>* w,
                                   Eigen::Matrix<double, 6, 6>& l_new,
                                   Eigen::Matrix<double, 6, 6>* u,
                                   Eigen::Matrix<double, 6, 1>& beta) {
#if defined(__x86_64__)
  if (cpuHasAvx512()) return triangularizeRows6Avx512<M>(l, w, l_new, u, beta);
  if (cpuHasAvxFma()) return triangularizeRows6Avx<M>(l, w, l_new, u, beta);
#endif
  return triangularizeRows6<M>(l, w, l_new, u, beta);
}

// multiplyByTransposedLower<D>(blocks[b], l) for b in [0, count), through the AVX2/FMA form on
// hosts that have it (the same bits).
template <int D>
inline void multiplyBlocksByTransposedLower(Eigen::Matrix<double, D, D>* blocks, Index count,
                                            const Eigen::Matrix<double, D, D>& l) {
  if constexpr (kAvxForms<D>) {
    if (cpuHasAvxFma()) {
      multiplyByTransposedLowerAvx(blocks, count, l);
      return;
    }
  }
  for (Index b = 0; b < count; ++b) multiplyByTransposedLower<D>(blocks[b], l);
}

// addBlockProduct(target[p], blocks[b], s) for b in [first, size), with p the place of rows[b]
// among target_rows (ascending, holding every rows[b]). target_rows[0] is the target column
// itself: from first = the source's row of it, the diagonal block takes its product here too.
void addBlockProductsAvx(const Mat3* blocks, const Index* rows, Index first, Index size,
                         const Mat3& s, const Index* target_rows, Mat3* target);

// The updates of a supernode's columns m = 0 .. num_columns - 1 to one target column: for b in
// [first, size), target[p] += columns[m][b] * s_m with s_m = -columns[m][first]^T, for m in
// order (each product summed as in addBlockProduct, so the target takes the bits that
// addBlockProductsAvx with that s_m gives, column after column), p the place of rows[b] among
// target_rows. The target block is loaded and stored once for all of them, and s_m is read from
// the column itself (a negated multiply-add), not from a transposed copy.
void subtractOuterProductsOfColumnsAvx(const Mat3* const* columns, Index num_columns,
                                       const Index* rows, Index first, Index size,
                                       const Index* target_rows, Mat3* target);

}  // namespace detail
}  // namespace lslam
