// The block kernels (lslam/linear/block_kernels.h): the portable forms against dense Eigen
// references (the block product, and the reflections as explicit 2D x 2D matrices), and the AVX
// forms (single and several source columns, reflections in place and from a source) bit for bit
// against the portable forms, on many random cases from a fixed seed.
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

// H_0 ... H_{D-1} as one dense 2D x 2D matrix.
template <int D>
Eigen::Matrix<double, 2 * D, 2 * D> denseReflections(const Eigen::Matrix<double, D, D>& u,
                                                     const Eigen::Matrix<double, D, 1>& beta) {
  using Square = Eigen::Matrix<double, 2 * D, 2 * D>;
  Square q = Square::Identity();
  for (int j = 0; j < D; ++j) {
    Eigen::Matrix<double, 2 * D, 1> v;
    for (int i = 0; i < D; ++i) {
      v(i) = i == j ? 1.0 : 0.0;
      v(D + i) = u(i, j);
    }
    q = (q * (Square::Identity() - beta(j) * v * v.transpose())).eval();
  }
  return q;
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

    const auto u = randomBlock<D>(rng);
    const Eigen::Matrix<double, D, 1> beta = randomBlock<D>(rng).col(0).cwiseAbs();
    auto x_l = randomBlock<D>(rng);
    auto x_w = randomBlock<D>(rng);
    Eigen::Matrix<double, D, 2 * D> x;
    x << x_l, x_w;
    const Eigen::Matrix<double, D, 2 * D> reflected = x * denseReflections<D>(u, beta);
    lslam::detail::applyRowReflections<D>(u, beta, x_l, x_w);
    CHECK((x_l - reflected.template leftCols<D>()).cwiseAbs().maxCoeff() < 1e-10);
    CHECK((x_w - reflected.template rightCols<D>()).cwiseAbs().maxCoeff() < 1e-10);
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
      Eigen::Vector3d x_avx = x;
      Eigen::Vector3d x_fused = x;
      lslam::detail::subtractTransposedProductsAvx(x_avx, blocks.data(), rows.data(), size,
                                                   solution.data());
      lslam::detail::subtractTransposedProductsFused(x_fused, blocks.data(), rows.data(), size,
                                                     solution.data());
      CHECK(std::equal(x_avx.data(), x_avx.data() + 3, x_fused.data()));
    }
  }
}

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
    const Index first = std::min<Index>(1 + n % 3, size - 1);

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
    // column order, as the same number of single-column passes would give it.
    const Index width = 1 + n % 8;
    std::vector<std::vector<Eigen::Matrix3d>> columns(width,
                                                      std::vector<Eigen::Matrix3d>(rows.size()));
    std::vector<Eigen::Matrix3d> s_of(width);
    std::vector<const Eigen::Matrix3d*> column_of(width);
    for (Index m = 0; m < width; ++m) {
      for (auto& b : columns[m]) b = randomBlock<3>(rng);
      s_of[m] = randomBlock<3>(rng);
      column_of[m] = columns[m].data();
    }
    std::vector<Eigen::Matrix3d> multi_expected = target;
    for (Index m = 0; m < width; ++m) {
      for (Index b = first; b < size; ++b) {
        const Index p =
            static_cast<Index>(std::lower_bound(target_rows.begin(), target_rows.end(), rows[b]) -
                               target_rows.begin());
        lslam::detail::addBlockProduct<3>(multi_expected[p], columns[m][b], s_of[m]);
      }
    }
    lslam::detail::addBlockProductsOfColumnsAvx(column_of.data(), s_of.data(), width, rows.data(),
                                                first, size, target_rows.data(), target.data());
    for (std::size_t p = 0; p < target.size(); ++p) CHECK(sameBits(target[p], multi_expected[p]));

    // The reflections on the column's row blocks, with W kept per row as in the row update.
    const Eigen::Matrix3d u = randomBlock<3>(rng);
    const Eigen::Vector3d beta = randomBlock<3>(rng).col(0).cwiseAbs();
    std::vector<Eigen::Matrix3d> w(target_rows.size());
    for (auto& x : w) x = randomBlock<3>(rng);
    std::vector<Eigen::Matrix3d> blocks_expected = blocks;
    std::vector<Eigen::Matrix3d> w_expected = w;
    for (Index b = 1; b < size; ++b) {
      lslam::detail::applyRowReflections<3>(u, beta, blocks_expected[b], w_expected[rows[b]]);
    }
    lslam::detail::applyRowReflectionsAvx(u, beta, blocks.data(), rows.data(), size, w.data());
    for (std::size_t b = 0; b < blocks.size(); ++b) CHECK(sameBits(blocks[b], blocks_expected[b]));
    for (std::size_t r = 0; r < w.size(); ++r) CHECK(sameBits(w[r], w_expected[r]));

    // The same reflections read from elsewhere (the row update's merge): each row block comes
    // from a source block, or is zero (fill), and is written to its own place.
    std::vector<Eigen::Matrix3d> sources(rows.size());
    for (auto& b : sources) b = randomBlock<3>(rng);
    std::vector<Index> source(rows.size(), lslam::kNoIndex);
    for (Index b = 1; b < size; ++b) {
      if (keep(rng)) source[b] = static_cast<Index>((b * 7 + n) % size);
    }
    std::vector<Eigen::Matrix3d> staged(rows.size(), randomBlock<3>(rng));
    std::vector<Eigen::Matrix3d> staged_expected = staged;
    for (Index b = 1; b < size; ++b) {
      staged_expected[b] =
          source[b] == lslam::kNoIndex ? Eigen::Matrix3d::Zero() : sources[source[b]];
      lslam::detail::applyRowReflections<3>(u, beta, staged_expected[b], w_expected[rows[b]]);
    }
    lslam::detail::applyRowReflectionsFromAvx(u, beta, sources.data(), source.data(), staged.data(),
                                              rows.data(), size, w.data());
    for (std::size_t b = 0; b < staged.size(); ++b) CHECK(sameBits(staged[b], staged_expected[b]));
    for (std::size_t r = 0; r < w.size(); ++r) CHECK(sameBits(w[r], w_expected[r]));
  }
}
