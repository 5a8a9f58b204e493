// The block kernels (lslam/linear/block_kernels.h): the portable forms against dense Eigen
// references (the block product, and the reflections of one and of two factors' rows as explicit
// matrices, reflection by reflection and at D = 6 in the compact form), and the AVX forms (single
// and several source columns, reflections of one and of two factors, in place and from a source,
// the back-substitution's column step; at D = 3 and D = 6) bit for bit against the portable forms,
// and the 6 x 6 triangularization (portable, AVX2 and AVX-512) against dense products, on many
// random cases from a fixed seed.
#include <doctest/doctest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <random>
#include <vector>

#include "lslam/linear/block_kernels.h"

namespace {

using lslam::Index;

template <int D>
Eigen::Matrix<double, D, D> randomBlock(std::mt19937& rng) {
  std::uniform_real_distribution<double> uniform(-2.0, 2.0);
  Eigen::Matrix<double, D, D> m;
  for (int c = 0; c < D; ++c) {
    for (int r = 0; r < D; ++r) m(r, c) = uniform(rng);
  }
  return m;
}

// H_0 ... H_{D-1} as one dense (M + 1) D square matrix, v_j = e_j + [0; u[0].col(j); ..].
template <int D, int M>
Eigen::Matrix<double, (M + 1) * D, (M + 1) * D> denseReflections(
    const Eigen::Matrix<double, D, D>* u, const Eigen::Matrix<double, D, 1>& beta) {
  using Square = Eigen::Matrix<double, (M + 1) * D, (M + 1) * D>;
  Square q = Square::Identity();
  for (int j = 0; j < D; ++j) {
    Eigen::Matrix<double, (M + 1) * D, 1> v = Eigen::Matrix<double, (M + 1) * D, 1>::Zero();
    v(j) = 1.0;
    for (int m = 0; m < M; ++m) v.template segment<D>(D * (m + 1)) = u[m].col(j);
    q = (q * (Square::Identity() - beta(j) * v * v.transpose())).eval();
  }
  return q;
}

// The reflections of M factors' rows against the explicit matrix (relative to the result's size:
// random u and beta make no orthogonal Q, so entries grow).
template <int D, int M>
void checkReflections(std::mt19937& rng) {
  Eigen::Matrix<double, D, D> u[M];
  for (auto& block : u) block = randomBlock<D>(rng);
  const Eigen::Matrix<double, D, 1> beta = randomBlock<D>(rng).col(0).cwiseAbs();
  auto x_l = randomBlock<D>(rng);
  Eigen::Matrix<double, D, D> x_w[M];
  Eigen::Matrix<double, D, D>* x_w_of[M];
  Eigen::Matrix<double, D, (M + 1) * D> x;
  x.template leftCols<D>() = x_l;
  for (int m = 0; m < M; ++m) {
    x_w[m] = randomBlock<D>(rng);
    x_w_of[m] = &x_w[m];
    x.template middleCols<D>(D * (m + 1)) = x_w[m];
  }
  const Eigen::Matrix<double, D, (M + 1)* D> reflected = x * denseReflections<D, M>(u, beta);
  const double tolerance = 1e-13 * (1.0 + reflected.cwiseAbs().maxCoeff());
  auto check_against_dense = [&](const Eigen::Matrix<double, D, D>& l,
                                 const Eigen::Matrix<double, D, D>* w) {
    CHECK((l - reflected.template leftCols<D>()).cwiseAbs().maxCoeff() < tolerance);
    for (int m = 0; m < M; ++m) {
      CHECK((w[m] - reflected.template middleCols<D>(D * (m + 1))).cwiseAbs().maxCoeff() <
            tolerance);
    }
  };
  const auto x_l_in = x_l;
  Eigen::Matrix<double, D, D> x_w_in[M];
  for (int m = 0; m < M; ++m) x_w_in[m] = x_w[m];
  lslam::detail::applyRowReflections<D, M>(u, beta, x_l, x_w_of);
  check_against_dense(x_l, x_w);
  if constexpr (D == 6) {
    x_l = x_l_in;
    for (int m = 0; m < M; ++m) x_w[m] = x_w_in[m];
    const lslam::detail::ReflectionOverlaps6<M> overlaps(u);
    lslam::detail::applyCompactReflections6<M>(u, beta, overlaps, x_l, x_w_of);
    check_against_dense(x_l, x_w);
  }
}

template <int D>
void checkPortableForms(int cases) {
  std::mt19937 rng(17 + D);
  for (int n = 0; n < cases; ++n) {
    const auto b = randomBlock<D>(rng);
    const auto s = randomBlock<D>(rng);
    auto t = randomBlock<D>(rng);
    const Eigen::Matrix<double, D, D> expected = t + b * s;
    lslam::detail::addBlockProduct<D>(t, b, s);
    CHECK((t - expected).cwiseAbs().maxCoeff() < 1e-12);
    checkReflections<D, 1>(rng);
    checkReflections<D, 2>(rng);
  }
}

template <int D>
bool sameBits(const Eigen::Matrix<double, D, D>& a, const Eigen::Matrix<double, D, D>& b) {
  return std::equal(a.data(), a.data() + D * D, b.data());
}

using Mat6 = Eigen::Matrix<double, 6, 6>;
using Vec6 = Eigen::Matrix<double, 6, 1>;

// The 6 x 6 triangularization of [l w_0 ..]: l' lower-triangular with a positive diagonal and
// l' l'^T = l l^T + sum_m w_m w_m^T (dense), the returned reflections take [l w] to [l' 0] (the
// portable applyRowReflections, itself checked against explicit matrices above, and the compact
// form of the row blocks, applyCompactReflections6), and the AVX2 and AVX-512 forms give the
// portable form's bits. Case n: l zero (an added column) every fifth, and
// rows of w zero (a reflection that is the identity) every seventh.
template <int M>
void checkTriangularization(std::mt19937& rng, int n) {
  Mat6 l = Mat6::Zero();
  if (n % 5 != 0) {
    l = randomBlock<6>(rng).triangularView<Eigen::Lower>();
    l.diagonal() = l.diagonal().cwiseAbs() + Vec6::Constant(0.1);
  }
  Mat6 w[M];
  for (auto& block : w) block = randomBlock<6>(rng);
  // Some cases make reflection j the identity: row j of the rows zero and of l zero left of the
  // diagonal, so H_0 .. H_{j-1} leave it alone. -1: none.
  const int identity_row = n % 7 == 0 && n % 5 != 0 ? (n / 7) % 6 : -1;
  if (identity_row >= 0) {
    for (auto& block : w) block.row(identity_row).setZero();
    l.row(identity_row).head(identity_row).setZero();
  }
  Mat6 l_new;
  Mat6 u[M];
  Vec6 beta;
  REQUIRE(lslam::detail::triangularizeRows6<M>(l, w, l_new, u, beta));
  Mat6 expected = l * l.transpose();
  for (const auto& block : w) expected += block * block.transpose();
  CHECK((l_new * l_new.transpose() - expected).cwiseAbs().maxCoeff() <
        1e-12 * (1.0 + expected.cwiseAbs().maxCoeff()));
  CHECK(l_new.diagonal().minCoeff() > 0.0);
  if (identity_row >= 0) CHECK(beta(identity_row) == 0.0);
  Mat6 x_l = l;
  Mat6 x_w[M];
  Mat6* x_w_of[M];
  for (int m = 0; m < M; ++m) {
    x_w[m] = w[m];
    x_w_of[m] = &x_w[m];
  }
  lslam::detail::applyRowReflections<6, M>(u, beta, x_l, x_w_of);
  const double tolerance = 1e-12 * (1.0 + l_new.cwiseAbs().maxCoeff());
  CHECK((x_l - l_new).cwiseAbs().maxCoeff() < tolerance);
  for (const auto& block : x_w) CHECK(block.cwiseAbs().maxCoeff() < tolerance);
  // The compact form (the row blocks') too.
  x_l = l;
  for (int m = 0; m < M; ++m) x_w[m] = w[m];
  const lslam::detail::ReflectionOverlaps6<M> overlaps(u);
  lslam::detail::applyCompactReflections6<M>(u, beta, overlaps, x_l, x_w_of);
  CHECK((x_l - l_new).cwiseAbs().maxCoeff() < tolerance);
  for (const auto& block : x_w) CHECK(block.cwiseAbs().maxCoeff() < tolerance);
#if defined(__x86_64__)
  auto check_form = [&](auto form) {
    Mat6 l_form = Mat6::Constant(7.0);
    Mat6 u_form[M];
    Vec6 beta_form;
    REQUIRE(form(l, w, l_form, u_form, beta_form));
    CHECK(sameBits<6>(l_form, l_new));
    for (int m = 0; m < M; ++m) CHECK(sameBits<6>(u_form[m], u[m]));
    CHECK(std::equal(beta.data(), beta.data() + 6, beta_form.data()));
  };
  if (lslam::detail::cpuHasAvxFma()) check_form(lslam::detail::triangularizeRows6Avx<M>);
  if (lslam::detail::cpuHasAvx512()) check_form(lslam::detail::triangularizeRows6Avx512<M>);
#endif
}

// Rows that leave l' singular: every form says so.
void checkRankDeficientTriangularization() {
  const Mat6 l = Mat6::Zero();
  Mat6 w[1] = {Mat6::Identity()};
  w[0](3, 3) = 0.0;
  Mat6 l_new;
  Mat6 u[1];
  Vec6 beta;
  CHECK_FALSE(lslam::detail::triangularizeRows6<1>(l, w, l_new, u, beta));
#if defined(__x86_64__)
  if (lslam::detail::cpuHasAvxFma()) {
    CHECK_FALSE(lslam::detail::triangularizeRows6Avx<1>(l, w, l_new, u, beta));
  }
  if (lslam::detail::cpuHasAvx512()) {
    CHECK_FALSE(lslam::detail::triangularizeRows6Avx512<1>(l, w, l_new, u, beta));
  }
#endif
}

}  // namespace

TEST_CASE("the 6 x 6 triangularization of the row update matches dense products in every form") {
  std::mt19937 rng(29);
  for (int n = 0; n < 300; ++n) {
    checkTriangularization<1>(rng, n);
    checkTriangularization<2>(rng, n);
  }
  checkRankDeficientTriangularization();
#if defined(__x86_64__)
  if (!lslam::detail::cpuHasAvx512()) MESSAGE("skipped the AVX-512 form: this CPU has none");
#endif
}

TEST_CASE("the portable block kernels match dense products and explicit reflections") {
  checkPortableForms<2>(300);
  checkPortableForms<3>(300);
  checkPortableForms<6>(300);
}

namespace {

template <int D>
void checkMultiplyByTransposedLower(int cases) {
  std::mt19937 rng(31 + D);
  for (int n = 0; n < cases; ++n) {
    const Eigen::Matrix<double, D, D> b = randomBlock<D>(rng);
    // Lower-triangular, with garbage above the diagonal that must not be read.
    Eigen::Matrix<double, D, D> l = randomBlock<D>(rng);
    const Eigen::Matrix<double, D, D> lower = l.template triangularView<Eigen::Lower>();
    Eigen::Matrix<double, D, D> out = b;
    lslam::detail::multiplyByTransposedLower<D>(out, l);
    const Eigen::Matrix<double, D, D> expected = b * lower.transpose();
    CHECK((out - expected).cwiseAbs().maxCoeff() < 1e-12);
  }
}

// The AVX form against the portable one, bit for bit, over a column of blocks.
template <int D>
void checkMultiplyByTransposedLowerAvx(int cases) {
  using Block = Eigen::Matrix<double, D, D>;
  std::mt19937 rng(37 + D);
  std::uniform_int_distribution<int> size_of(1, 20);
  for (int n = 0; n < cases; ++n) {
    std::vector<Block> blocks(static_cast<std::size_t>(size_of(rng)));
    for (auto& b : blocks) b = randomBlock<D>(rng);
    const Block l = randomBlock<D>(rng);
    const Block lower = l.template triangularView<Eigen::Lower>();
    std::vector<Block> avx = blocks;
    lslam::detail::multiplyByTransposedLowerAvx(avx.data(), static_cast<Index>(avx.size()), l);
    for (std::size_t i = 0; i < blocks.size(); ++i) {
      const Block expected = blocks[i] * lower.transpose();
      lslam::detail::multiplyByTransposedLower<D>(blocks[i], l);
      CHECK(sameBits<D>(avx[i], blocks[i]));
      CHECK((avx[i] - expected).cwiseAbs().maxCoeff() < 1e-12);
    }
  }
}

}  // namespace

TEST_CASE("a block times a lower-triangular block's transpose matches the dense product") {
  checkMultiplyByTransposedLower<2>(300);
  checkMultiplyByTransposedLower<3>(300);
  checkMultiplyByTransposedLower<6>(300);
  if (!lslam::detail::cpuHasAvxFma()) {
    MESSAGE("skipped the AVX forms: this CPU has no AVX2/FMA");
    return;
  }
  checkMultiplyByTransposedLowerAvx<3>(300);
#if defined(__x86_64__)
  checkMultiplyByTransposedLowerAvx<6>(300);
#endif
}

namespace {

// L(k,k)^-T x in the portable form's order: Eigen's product at D = 3, multiplyTransposed at 6.
template <int D>
Eigen::Matrix<double, D, 1> transposedInverseTimes(const Eigen::Matrix<double, D, D>& inverse,
                                                   const Eigen::Matrix<double, D, 1>& x) {
#if defined(__x86_64__)
  if constexpr (D == 6) return lslam::detail::multiplyTransposed(inverse, x);
#endif
  return inverse.transpose() * x;
}

template <int D>
void checkBackSubstitution(int cases) {
  using Block = Eigen::Matrix<double, D, D>;
  using Vector = Eigen::Matrix<double, D, 1>;
  std::mt19937 rng(23 + (D == 3 ? 0 : D));
  std::uniform_int_distribution<int> size_of(1, 30);
  for (int n = 0; n < cases; ++n) {
    const Index size = size_of(rng);
    std::vector<Block> blocks(size);
    for (auto& b : blocks) b = randomBlock<D>(rng);
    // The solutions by position, kSolutionStride doubles each (any padding zero, as the solve
    // keeps it), the rows spread over them out of order.
    constexpr Index kStride = lslam::detail::kSolutionStride<D>;
    const Index positions = size + 5;
    std::vector<double> solution(static_cast<std::size_t>(kStride * positions), 0.0);
    std::vector<Vector> y(positions);
    for (Index p = 0; p < positions; ++p) {
      y[p] = randomBlock<D>(rng).col(1);
      for (int r = 0; r < D; ++r) solution[kStride * p + r] = y[p](r);
    }
    std::vector<Index> rows(size);
    for (Index i = 0; i < size; ++i) rows[i] = (i * 3 + 1 + n % 5) % positions;
    Vector expected = randomBlock<D>(rng).col(2);
    Vector x = expected;
    for (Index i = 1; i < size; ++i) expected -= blocks[i].transpose() * y[rows[i]];
    lslam::detail::subtractTransposedProductsFused(x, blocks.data(), rows.data(), size,
                                                   solution.data());
    CHECK((x - expected).cwiseAbs().maxCoeff() < 1e-12);
    if (lslam::detail::cpuHasAvxFma()) {
      // The whole column step: the AVX kernel against the portable one, bit for bit, from an old
      // entry that moved by more than the tolerance in one coordinate, and from one that did not.
      const Vector d = randomBlock<D>(rng).col(0);
      Vector portable = d;
      lslam::detail::subtractTransposedProductsFused(portable, blocks.data(), rows.data(), size,
                                                     solution.data());
      portable = transposedInverseTimes<D>(blocks[0], portable);
      Vector dense = d;
      for (Index i = 1; i < size; ++i) dense -= blocks[i].transpose() * y[rows[i]];
      dense = (blocks[0].transpose() * dense).eval();
      CHECK((portable - dense).cwiseAbs().maxCoeff() < 1e-11 * (1.0 + dense.cwiseAbs().maxCoeff()));
      // The column's own entry, after every entry its rows read.
      const Index k = positions;
      std::vector<double> with_own = solution;
      with_own.resize(static_cast<std::size_t>(kStride * (positions + 1)), 0.0);
      for (const double shift : {0.1, -0.5}) {  // within the tolerance 0.3, and past it
        std::vector<double> avx_solution = with_own;
        Vector old = portable;
        old(n % D) += shift;
        for (int r = 0; r < D; ++r) avx_solution[kStride * k + r] = old(r);
        const bool portable_moved = (portable - old).cwiseAbs().maxCoeff() > 0.3;
        Vector delta = Vector::Constant(7.0);
        const bool moved = lslam::detail::solveColumnAvx(d, blocks.data(), rows.data(), size,
                                                         avx_solution.data(), k, 0.3, delta);
        CHECK(portable_moved == (shift < 0.0));
        CHECK(moved == portable_moved);
        CHECK(std::equal(delta.data(), delta.data() + D, portable.data()));
        CHECK(std::equal(avx_solution.data() + kStride * k, avx_solution.data() + kStride * k + D,
                         portable.data()));
        for (Index r = D; r < kStride; ++r) {
          CHECK(avx_solution[kStride * k + r] == 0.0);  // the padding stays zero
        }
        // Every other entry is untouched.
        for (Index p = 0; p < positions; ++p) {
          CHECK(std::equal(avx_solution.data() + kStride * p,
                           avx_solution.data() + kStride * (p + 1), solution.data() + kStride * p));
        }
      }
    }
  }
}

}  // namespace

TEST_CASE("the fused back-substitution step matches the dense transposed products") {
  checkBackSubstitution<3>(300);
#if defined(__x86_64__)
  checkBackSubstitution<6>(300);
#endif
  if (!lslam::detail::cpuHasAvxFma()) MESSAGE("skipped the AVX forms: this CPU has no AVX2/FMA");
}

namespace {

// The AVX reflections of M factors' rows against the portable form, bit for bit: on a column's row
// blocks in place, with W kept per row as in the row update, and read from elsewhere (the row
// update's merge: each row block comes from a source block, or is zero for fill).
template <int D, int M>
void checkAvxReflections(std::mt19937& rng, const std::vector<Index>& rows,
                         std::vector<Eigen::Matrix<double, D, D>> blocks, std::size_t num_rows,
                         int n) {
  using Block = Eigen::Matrix<double, D, D>;
  using Vector = Eigen::Matrix<double, D, 1>;
  std::bernoulli_distribution keep(0.6);
  const Index size = static_cast<Index>(rows.size());
  Block u[M];
  for (auto& block : u) block = randomBlock<D>(rng);
  const Vector beta = randomBlock<D>(rng).col(0).cwiseAbs();
  std::vector<Block> w[M];
  for (auto& array : w) {
    array.resize(num_rows);
    for (auto& x : array) x = randomBlock<D>(rng);
  }
  // The portable form of the row blocks' reflections: the compact one at D = 6.
  auto reflect_expected = [&](std::vector<Block>& l, std::vector<Block>* x) {
    for (Index b = 1; b < size; ++b) {
      Block* x_of[M];
      for (int m = 0; m < M; ++m) x_of[m] = &x[m][rows[b]];
      if constexpr (D == 6) {
        const lslam::detail::ReflectionOverlaps6<M> overlaps(u);
        lslam::detail::applyCompactReflections6<M>(u, beta, overlaps, l[b], x_of);
      } else {
        lslam::detail::applyRowReflections<D, M>(u, beta, l[b], x_of);
      }
    }
  };
  auto arrays = [](std::vector<Block>* x, Block** of) {
    for (int m = 0; m < M; ++m) of[m] = x[m].data();
  };
  std::vector<Block> blocks_expected = blocks;
  std::vector<Block> w_expected[M];
  for (int m = 0; m < M; ++m) w_expected[m] = w[m];
  reflect_expected(blocks_expected, w_expected);
  Block* w_of[M];
  arrays(w, w_of);
  lslam::detail::applyRowReflectionsFromAvx<M>(u, beta, blocks.data(), nullptr, size, blocks.data(),
                                               rows.data(), size, w_of);
  for (std::size_t b = 0; b < blocks.size(); ++b) CHECK(sameBits<D>(blocks[b], blocks_expected[b]));
  for (int m = 0; m < M; ++m) {
    for (std::size_t r = 0; r < num_rows; ++r) CHECK(sameBits<D>(w[m][r], w_expected[m][r]));
  }

  std::vector<Block> sources(rows.size());
  for (auto& b : sources) b = randomBlock<D>(rng);
  std::vector<Index> source(rows.size(), lslam::kNoIndex);
  for (Index b = 1; b < size; ++b) {
    if (keep(rng)) source[b] = static_cast<Index>((b * 7 + n) % size);
  }
  // The first `kept` rows are the old column's, in place (their source implied, not read).
  const Index kept = 1 + static_cast<Index>(n) % size;
  for (Index b = 1; b < kept; ++b) source[b] = (b * 5 + n) % size;
  std::vector<Block> staged(rows.size(), randomBlock<D>(rng));
  std::vector<Block> staged_expected = staged;
  for (Index b = 1; b < size; ++b) {
    if (b < kept) {
      staged_expected[b] = sources[b];
    } else {
      staged_expected[b] = source[b] == lslam::kNoIndex ? Block::Zero() : sources[source[b]];
    }
  }
  reflect_expected(staged_expected, w_expected);
  lslam::detail::applyRowReflectionsFromAvx<M>(u, beta, sources.data(), source.data(), kept,
                                               staged.data(), rows.data(), size, w_of);
  for (std::size_t b = 0; b < staged.size(); ++b) CHECK(sameBits<D>(staged[b], staged_expected[b]));
  for (int m = 0; m < M; ++m) {
    for (std::size_t r = 0; r < num_rows; ++r) CHECK(sameBits<D>(w[m][r], w_expected[m][r]));
  }
  // The right-hand side's row, through the AVX-compiled instance of the portable form.
  using Row = Eigen::Matrix<double, 1, D>;
  Row d = randomBlock<D>(rng).row(0);
  Row b_rows[M];
  Row* b_of[M];
  for (int m = 0; m < M; ++m) {
    b_rows[m] = randomBlock<D>(rng).row(1);
    b_of[m] = &b_rows[m];
  }
  Row d_expected = d;
  Row b_expected[M];
  Row* b_expected_of[M];
  for (int m = 0; m < M; ++m) {
    b_expected[m] = b_rows[m];
    b_expected_of[m] = &b_expected[m];
  }
  lslam::detail::applyRowReflections<D, M>(u, beta, d_expected, b_expected_of);
  lslam::detail::applyRowReflectionsToRowAvx<M>(u, beta, d, b_of);
  CHECK(std::equal(d.data(), d.data() + D, d_expected.data()));
  for (int m = 0; m < M; ++m)
    CHECK(std::equal(b_rows[m].data(), b_rows[m].data() + D, b_expected[m].data()));
}

// Several source columns at once (a supernode): each target block takes their products in column
// order, each column's multiplier its own block at `first` (negated, transposed), as the same
// number of single-column passes with that multiplier would give it.
template <int D>
void checkSupernodeProducts(std::mt19937& rng, const std::vector<Index>& rows,
                            const std::vector<Index>& target_rows, Index first, Index size, int n,
                            std::vector<Eigen::Matrix<double, D, D>>& target) {
  using Block = Eigen::Matrix<double, D, D>;
  const Index width = 1 + n % 8;
  std::vector<std::vector<Block>> columns(width, std::vector<Block>(rows.size()));
  std::vector<const Block*> column_of(width);
  for (Index m = 0; m < width; ++m) {
    for (auto& b : columns[m]) b = randomBlock<D>(rng);
    column_of[m] = columns[m].data();
  }
  std::vector<Block> multi_expected = target;
  for (Index m = 0; m < width; ++m) {
    const Block s_m = -columns[m][first].transpose();
    for (Index b = first; b < size; ++b) {
      const Index p = static_cast<Index>(
          std::lower_bound(target_rows.begin(), target_rows.end(), rows[b]) - target_rows.begin());
      lslam::detail::addBlockProduct<D>(multi_expected[p], columns[m][b], s_m);
    }
  }
  lslam::detail::subtractOuterProductsOfColumnsAvx(column_of.data(), width, rows.data(), first,
                                                   size, target_rows.data(), target.data());
  for (std::size_t p = 0; p < target.size(); ++p) CHECK(sameBits<D>(target[p], multi_expected[p]));
}

// The AVX block products (one source column, and several) and reflections (one to three factors)
// against the portable forms, bit for bit, and the block products against the dense product.
template <int D>
void checkAvxKernels() {
  using Block = Eigen::Matrix<double, D, D>;
  std::mt19937 rng(D == 3 ? 5 : 5 + D);
  std::uniform_int_distribution<int> size_of(2, 40);
  std::bernoulli_distribution keep(0.6);
  for (int n = 0; n < 200; ++n) {
    // A column (rows[0] is its own) and a target column whose rows hold every row of it.
    const int size = size_of(rng);
    std::vector<Index> target_rows{0};
    std::vector<Index> rows{0};
    for (Index r = 1; static_cast<int>(rows.size()) < size; ++r) {
      target_rows.push_back(r);
      if (keep(rng)) rows.push_back(r);
    }
    std::vector<Block> blocks(rows.size());
    for (auto& b : blocks) b = randomBlock<D>(rng);
    std::vector<Block> target(target_rows.size());
    for (auto& t : target) t = randomBlock<D>(rng);
    const Block s = randomBlock<D>(rng);
    const Index first = std::min<Index>(n % 4, size - 1);  // 0: from the diagonal block

    const std::vector<Block> original = target;
    std::vector<Block> expected = target;
    for (Index b = first; b < size; ++b) {
      const Index p = static_cast<Index>(
          std::lower_bound(target_rows.begin(), target_rows.end(), rows[b]) - target_rows.begin());
      lslam::detail::addBlockProduct<D>(expected[p], blocks[b], s);
    }
    lslam::detail::addBlockProductsAvx(blocks.data(), rows.data(), first, size, s,
                                       target_rows.data(), target.data());
    for (std::size_t p = 0; p < target.size(); ++p) CHECK(sameBits<D>(target[p], expected[p]));
    for (Index b = first; b < size; ++b) {
      const Index p = static_cast<Index>(
          std::lower_bound(target_rows.begin(), target_rows.end(), rows[b]) - target_rows.begin());
      const Block dense = original[p] + blocks[b] * s;
      CHECK((target[p] - dense).cwiseAbs().maxCoeff() < 1e-12);
    }
    checkSupernodeProducts<D>(rng, rows, target_rows, first, size, n, target);
    checkAvxReflections<D, 1>(rng, rows, blocks, target_rows.size(), n);
    checkAvxReflections<D, 2>(rng, rows, blocks, target_rows.size(), n);
    checkAvxReflections<D, 3>(rng, rows, blocks, target_rows.size(), n);
  }
}

}  // namespace

TEST_CASE("the AVX block kernels compute the portable forms' bits") {
  if (!lslam::detail::cpuHasAvxFma()) {
    MESSAGE("skipped: this CPU has no AVX2/FMA (the portable forms run everywhere)");
    return;
  }
  checkAvxKernels<3>();
#if defined(__x86_64__)
  checkAvxKernels<6>();
#endif
}
