// The block kernels (lslam/linear/block_kernels.h): the portable forms against dense Eigen
// references (the block product, and the reflections of one and of two factors' rows as explicit
// matrices), and the AVX forms (single and several source columns, reflections of one and of two
// factors, in place and from a source) bit for bit against the portable forms, on many random
// cases from a fixed seed.
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
  lslam::detail::applyRowReflections<D, M>(u, beta, x_l, x_w_of);
  CHECK((x_l - reflected.template leftCols<D>()).cwiseAbs().maxCoeff() < tolerance);
  for (int m = 0; m < M; ++m) {
    CHECK((x_w[m] - reflected.template middleCols<D>(D * (m + 1))).cwiseAbs().maxCoeff() <
          tolerance);
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

bool sameBits(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  return std::equal(a.data(), a.data() + 9, b.data());
}

}  // namespace

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

}  // namespace

TEST_CASE("a block times a lower-triangular block's transpose matches the dense product") {
  checkMultiplyByTransposedLower<2>(300);
  checkMultiplyByTransposedLower<3>(300);
  checkMultiplyByTransposedLower<6>(300);
  if (!lslam::detail::cpuHasAvxFma()) return;
  // The AVX form against the portable one, bit for bit, over a column of blocks.
  std::mt19937 rng(37);
  std::uniform_int_distribution<int> size_of(1, 20);
  for (int n = 0; n < 300; ++n) {
    std::vector<Eigen::Matrix3d> blocks(static_cast<std::size_t>(size_of(rng)));
    for (auto& b : blocks) b = randomBlock<3>(rng);
    const Eigen::Matrix3d l = randomBlock<3>(rng);
    std::vector<Eigen::Matrix3d> avx = blocks;
    lslam::detail::multiplyByTransposedLowerAvx(avx.data(), static_cast<Index>(avx.size()), l);
    for (std::size_t i = 0; i < blocks.size(); ++i) {
      lslam::detail::multiplyByTransposedLower<3>(blocks[i], l);
      CHECK(sameBits(avx[i], blocks[i]));
    }
  }
}

TEST_CASE("the fused back-substitution step matches the dense transposed products") {
  std::mt19937 rng(23);
  std::uniform_int_distribution<int> size_of(1, 30);
  for (int n = 0; n < 300; ++n) {
    const Index size = size_of(rng);
    std::vector<Eigen::Matrix3d> blocks(size);
    for (auto& b : blocks) b = randomBlock<3>(rng);
    // The solutions by position, kSolutionStride doubles each (the fourth zero, as the solve keeps
    // it), the rows spread over them out of order.
    constexpr Index kStride = lslam::detail::kSolutionStride<3>;
    const Index positions = size + 5;
    std::vector<double> solution(static_cast<std::size_t>(kStride * positions), 0.0);
    std::vector<Eigen::Vector3d> y(positions);
    for (Index p = 0; p < positions; ++p) {
      y[p] = randomBlock<3>(rng).col(1);
      for (int r = 0; r < 3; ++r) solution[kStride * p + r] = y[p](r);
    }
    std::vector<Index> rows(size);
    for (Index i = 0; i < size; ++i) rows[i] = (i * 3 + 1 + n % 5) % positions;
    Eigen::Vector3d expected = randomBlock<3>(rng).col(2);
    Eigen::Vector3d x = expected;
    for (Index i = 1; i < size; ++i) expected -= blocks[i].transpose() * y[rows[i]];
    lslam::detail::subtractTransposedProductsFused(x, blocks.data(), rows.data(), size,
                                                   solution.data());
    CHECK((x - expected).cwiseAbs().maxCoeff() < 1e-12);
    if (lslam::detail::cpuHasAvxFma()) {
      // The whole column step: the AVX kernel against the portable one, bit for bit, from an old
      // entry that moved by more than the tolerance in one coordinate, and from one that did not.
      const Eigen::Vector3d d = randomBlock<3>(rng).col(0);
      Eigen::Vector3d portable = d;
      lslam::detail::subtractTransposedProductsFused(portable, blocks.data(), rows.data(), size,
                                                     solution.data());
      portable = (blocks[0].transpose() * portable).eval();
      // The column's own entry, after every entry its rows read.
      const Index k = positions;
      std::vector<double> with_own = solution;
      with_own.resize(static_cast<std::size_t>(kStride * (positions + 1)), 0.0);
      for (const double shift : {0.1, -0.5}) {  // within the tolerance 0.3, and past it
        std::vector<double> avx_solution = with_own;
        Eigen::Vector3d old = portable;
        old(n % 3) += shift;
        for (int r = 0; r < 3; ++r) avx_solution[kStride * k + r] = old(r);
        const bool portable_moved = (portable - old).cwiseAbs().maxCoeff() > 0.3;
        Eigen::Vector3d delta = Eigen::Vector3d::Constant(7.0);
        const bool moved = lslam::detail::solveColumnAvx(d, blocks.data(), rows.data(), size,
                                                         avx_solution.data(), k, 0.3, delta);
        CHECK(portable_moved == (shift < 0.0));
        CHECK(moved == portable_moved);
        CHECK(std::equal(delta.data(), delta.data() + 3, portable.data()));
        CHECK(std::equal(avx_solution.data() + kStride * k, avx_solution.data() + kStride * k + 3,
                         portable.data()));
        CHECK(avx_solution[kStride * k + 3] == 0.0);  // the padding stays zero
        // Every other entry is untouched.
        for (Index p = 0; p < positions; ++p) {
          CHECK(std::equal(avx_solution.data() + kStride * p,
                           avx_solution.data() + kStride * (p + 1), solution.data() + kStride * p));
        }
      }
    }
  }
}

namespace {

// The AVX reflections of M factors' rows against the portable form, bit for bit: on a column's row
// blocks in place, with W kept per row as in the row update, and read from elsewhere (the row
// update's merge: each row block comes from a source block, or is zero for fill).
template <int M>
void checkAvxReflections(std::mt19937& rng, const std::vector<Index>& rows,
                         std::vector<Eigen::Matrix3d> blocks, std::size_t num_rows, int n) {
  std::bernoulli_distribution keep(0.6);
  const Index size = static_cast<Index>(rows.size());
  Eigen::Matrix3d u[M];
  for (auto& block : u) block = randomBlock<3>(rng);
  const Eigen::Vector3d beta = randomBlock<3>(rng).col(0).cwiseAbs();
  std::vector<Eigen::Matrix3d> w[M];
  for (auto& array : w) {
    array.resize(num_rows);
    for (auto& x : array) x = randomBlock<3>(rng);
  }
  auto reflect_expected = [&](std::vector<Eigen::Matrix3d>& l, std::vector<Eigen::Matrix3d>* x) {
    for (Index b = 1; b < size; ++b) {
      Eigen::Matrix3d* x_of[M];
      for (int m = 0; m < M; ++m) x_of[m] = &x[m][rows[b]];
      lslam::detail::applyRowReflections<3, M>(u, beta, l[b], x_of);
    }
  };
  auto arrays = [](std::vector<Eigen::Matrix3d>* x, Eigen::Matrix3d** of) {
    for (int m = 0; m < M; ++m) of[m] = x[m].data();
  };
  std::vector<Eigen::Matrix3d> blocks_expected = blocks;
  std::vector<Eigen::Matrix3d> w_expected[M];
  for (int m = 0; m < M; ++m) w_expected[m] = w[m];
  reflect_expected(blocks_expected, w_expected);
  Eigen::Matrix3d* w_of[M];
  arrays(w, w_of);
  lslam::detail::applyRowReflectionsFromAvx<M>(u, beta, blocks.data(), nullptr, size, blocks.data(),
                                               rows.data(), size, w_of);
  for (std::size_t b = 0; b < blocks.size(); ++b) CHECK(sameBits(blocks[b], blocks_expected[b]));
  for (int m = 0; m < M; ++m) {
    for (std::size_t r = 0; r < num_rows; ++r) CHECK(sameBits(w[m][r], w_expected[m][r]));
  }

  std::vector<Eigen::Matrix3d> sources(rows.size());
  for (auto& b : sources) b = randomBlock<3>(rng);
  std::vector<Index> source(rows.size(), lslam::kNoIndex);
  for (Index b = 1; b < size; ++b) {
    if (keep(rng)) source[b] = static_cast<Index>((b * 7 + n) % size);
  }
  // The first `kept` rows are the old column's, in place (their source implied, not read).
  const Index kept = 1 + static_cast<Index>(n) % size;
  for (Index b = 1; b < kept; ++b) source[b] = (b * 5 + n) % size;
  std::vector<Eigen::Matrix3d> staged(rows.size(), randomBlock<3>(rng));
  std::vector<Eigen::Matrix3d> staged_expected = staged;
  for (Index b = 1; b < size; ++b) {
    if (b < kept) {
      staged_expected[b] = sources[b];
    } else {
      staged_expected[b] =
          source[b] == lslam::kNoIndex ? Eigen::Matrix3d::Zero() : sources[source[b]];
    }
  }
  reflect_expected(staged_expected, w_expected);
  lslam::detail::applyRowReflectionsFromAvx<M>(u, beta, sources.data(), source.data(), kept,
                                               staged.data(), rows.data(), size, w_of);
  for (std::size_t b = 0; b < staged.size(); ++b) CHECK(sameBits(staged[b], staged_expected[b]));
  for (int m = 0; m < M; ++m) {
    for (std::size_t r = 0; r < num_rows; ++r) CHECK(sameBits(w[m][r], w_expected[m][r]));
  }

  // The right-hand side's row, through the AVX-compiled instance of the portable form.
  using Row = Eigen::Matrix<double, 1, 3>;
  Row d = randomBlock<3>(rng).row(0);
  Row b_rows[M];
  Row* b_of[M];
  for (int m = 0; m < M; ++m) {
    b_rows[m] = randomBlock<3>(rng).row(1);
    b_of[m] = &b_rows[m];
  }
  Row d_expected = d;
  Row b_expected[M];
  Row* b_expected_of[M];
  for (int m = 0; m < M; ++m) {
    b_expected[m] = b_rows[m];
    b_expected_of[m] = &b_expected[m];
  }
  lslam::detail::applyRowReflections<3, M>(u, beta, d_expected, b_expected_of);
  lslam::detail::applyRowReflectionsToRowAvx<M>(u, beta, d, b_of);
  CHECK(std::equal(d.data(), d.data() + 3, d_expected.data()));
  for (int m = 0; m < M; ++m)
    CHECK(std::equal(b_rows[m].data(), b_rows[m].data() + 3, b_expected[m].data()));
}

}  // namespace

TEST_CASE("the AVX block kernels compute the portable forms' bits") {
  if (!lslam::detail::cpuHasAvxFma()) {
    MESSAGE("skipped: this CPU has no AVX2/FMA (the portable forms run everywhere)");
    return;
  }
  std::mt19937 rng(5);
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
    std::vector<Eigen::Matrix3d> blocks(rows.size());
    for (auto& b : blocks) b = randomBlock<3>(rng);
    std::vector<Eigen::Matrix3d> target(target_rows.size());
    for (auto& t : target) t = randomBlock<3>(rng);
    const Eigen::Matrix3d s = randomBlock<3>(rng);
    const Index first = std::min<Index>(n % 4, size - 1);  // 0: from the diagonal block

    std::vector<Eigen::Matrix3d> expected = target;
    for (Index b = first; b < size; ++b) {
      const Index p = static_cast<Index>(
          std::lower_bound(target_rows.begin(), target_rows.end(), rows[b]) - target_rows.begin());
      lslam::detail::addBlockProduct<3>(expected[p], blocks[b], s);
    }
    lslam::detail::addBlockProductsAvx(blocks.data(), rows.data(), first, size, s,
                                       target_rows.data(), target.data());
    for (std::size_t p = 0; p < target.size(); ++p) CHECK(sameBits(target[p], expected[p]));

    // Several source columns at once (a supernode): each target block takes their products in
    // column order, each column's multiplier its own block at `first` (negated, transposed), as
    // the same number of single-column passes with that multiplier would give it.
    const Index width = 1 + n % 8;
    std::vector<std::vector<Eigen::Matrix3d>> columns(width,
                                                      std::vector<Eigen::Matrix3d>(rows.size()));
    std::vector<const Eigen::Matrix3d*> column_of(width);
    for (Index m = 0; m < width; ++m) {
      for (auto& b : columns[m]) b = randomBlock<3>(rng);
      column_of[m] = columns[m].data();
    }
    std::vector<Eigen::Matrix3d> multi_expected = target;
    for (Index m = 0; m < width; ++m) {
      const Eigen::Matrix3d s_m = -columns[m][first].transpose();
      for (Index b = first; b < size; ++b) {
        const Index p =
            static_cast<Index>(std::lower_bound(target_rows.begin(), target_rows.end(), rows[b]) -
                               target_rows.begin());
        lslam::detail::addBlockProduct<3>(multi_expected[p], columns[m][b], s_m);
      }
    }
    lslam::detail::subtractOuterProductsOfColumnsAvx(column_of.data(), width, rows.data(), first,
                                                     size, target_rows.data(), target.data());
    for (std::size_t p = 0; p < target.size(); ++p) CHECK(sameBits(target[p], multi_expected[p]));

    checkAvxReflections<1>(rng, rows, blocks, target_rows.size(), n);
    checkAvxReflections<2>(rng, rows, blocks, target_rows.size(), n);
  }
}
