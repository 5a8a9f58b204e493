// The information matrices the pose graph stores: checkInformation judges the symmetric part of
// a matrix symmetric only to rounding, symmetricPart gives it, and an exactly symmetric matrix
// passes through bit for bit. The references are computed here: (A + A^T) / 2, and its smallest
// eigenvalue by Eigen's symmetric eigensolver.
#include <doctest/doctest.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <cstring>
#include <random>

#include "lslam/factors/information.h"

using namespace lslam;

namespace {

Mat3 meanWithTranspose(const Mat3& a) {
  return 0.5 * (a + a.transpose());
}

double smallestEigenvalue(const Mat3& symmetric) {
  return Eigen::SelfAdjointEigenSolver<Mat3>(symmetric, Eigen::EigenvaluesOnly)
      .eigenvalues()
      .minCoeff();
}

// [1 c 0; c 1 0; 0 0 1] with c = 1 - delta (smallest eigenvalue delta), its (0, 1) entry moved by
// -t and its (1, 0) entry by +t: asymmetric by 2t, so the lower triangle's matrix has the
// smallest eigenvalue delta - t and the symmetric part delta.
Mat3 nearlySingular(double delta, double t) {
  Mat3 m = Mat3::Identity();
  m(0, 1) = 1.0 - delta - t;
  m(1, 0) = 1.0 - delta + t;
  return m;
}

}  // namespace

TEST_CASE(
    "checkInformation judges the symmetric part: positive definite or not as (A + A^T) / 2 is, "
    "whichever the lower triangle alone is") {
  // Asymmetry 0.9e-9 of the largest entry, inside the tolerance; the smallest eigenvalue of the
  // symmetric part +-0.2e-9, that of the lower triangle's matrix 0.45e-9 lower or higher.
  const double t = 0.45e-9;
  struct Case {
    double delta;
    double t;
  };
  for (const Case c : {Case{0.2e-9, t}, Case{-0.2e-9, -t}, Case{0.2e-9, -t}, Case{-0.2e-9, t}}) {
    CAPTURE(c.delta);
    CAPTURE(c.t);
    const Mat3 a = nearlySingular(c.delta, c.t);
    const bool definite = smallestEigenvalue(meanWithTranspose(a)) > 0.0;
    REQUIRE(definite == (c.delta > 0.0));  // the construction did what it says
    CHECK(checkInformation(a) == (definite ? Status::Ok : Status::InformationNotPositiveDefinite));
  }
}

TEST_CASE(
    "symmetricPart is (A + A^T) / 2, and an exactly symmetric matrix comes back bit for bit") {
  std::mt19937 rng(2024);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::uniform_int_distribution<int> decade(-8, 8);
  for (int c = 0; c < 2000; ++c) {
    CAPTURE(c);
    Mat3 g;
    for (int i = 0; i < 9; ++i) g(i) = u(rng);
    // (A product g g^T is often not symmetric to the bit: its lower triangle, mirrored, is.)
    const Mat3 product = (g * g.transpose() + 0.1 * Mat3::Identity()) * std::pow(10.0, decade(rng));
    const Mat3 symmetric = product.selfadjointView<Eigen::Lower>();
    const Mat3 s = symmetricPart(symmetric);
    CHECK(std::memcmp(s.data(), symmetric.data(), sizeof(Mat3)) == 0);
    Mat3 asymmetric = symmetric;
    for (int i = 0; i < 9; ++i) asymmetric(i) *= 1.0 + 4e-10 * u(rng);
    const Mat3 a = symmetricPart(asymmetric);
    const Mat3 reference = meanWithTranspose(asymmetric);
    CHECK(std::memcmp(a.data(), a.transpose().eval().data(), sizeof(Mat3)) == 0);
    CHECK((a - reference).cwiseAbs().maxCoeff() <= 1e-15 * reference.cwiseAbs().maxCoeff());
  }
}
