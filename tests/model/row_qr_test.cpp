#include "sph/model/row_qr.hpp"

#include <random>

#include <gtest/gtest.h>
#include <Eigen/QR>

#include "test_util.hpp"

namespace sph {
namespace {

using sph::testing::MatrixNear;

Eigen::MatrixXd RandomMatrix(Eigen::Index rows, Eigen::Index cols, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g(0.0, 1.0);
  Eigen::MatrixXd a(rows, cols);
  for (Eigen::Index j = 0; j < cols; ++j) {
    for (Eigen::Index i = 0; i < rows; ++i) a(i, j) = g(rng) * std::pow(10.0, static_cast<double>(j % 3));
  }
  return a;
}

// Folds the rows of `a` into a factor in blocks of `block` rows.
RowQr FactorInBlocks(const Eigen::MatrixXd& a, Eigen::Index block) {
  RowQr qr(a.cols());
  for (Eigen::Index first = 0; first < a.rows(); first += block) {
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> rows =
        a.middleRows(first, std::min(block, a.rows() - first));
    qr.AddRows(rows.data(), rows.cols(), rows.rows());
  }
  return qr;
}

// R is the R of Eigen's Householder QR of the whole matrix, up to the sign of each row.
TEST(RowQr, EqualsTheQrOfTheWholeMatrix) {
  const Eigen::MatrixXd a = RandomMatrix(300, 7, 1);
  const Eigen::MatrixXd reference =
      Eigen::HouseholderQR<Eigen::MatrixXd>(a).matrixQR().topRows(7).triangularView<Eigen::Upper>();
  for (const Eigen::Index block : {1, 7, 64, 300}) {
    const RowQr qr = FactorInBlocks(a, block);
    EXPECT_EQ(qr.rows(), 300);
    Eigen::MatrixXd r = qr.r();
    for (Eigen::Index i = 0; i < 7; ++i) {
      if ((r(i, i) < 0.0) != (reference(i, i) < 0.0)) r.row(i) *= -1.0;
    }
    EXPECT_PRED_FORMAT3(MatrixNear, r, reference, 1e-11 * reference.cwiseAbs().maxCoeff()) << "block " << block;
    EXPECT_TRUE(r.isUpperTriangular(0.0));
    // R^T R = A^T A.
    const Eigen::MatrixXd gram = a.transpose() * a;
    EXPECT_PRED_FORMAT3(MatrixNear, qr.r().transpose() * qr.r(), gram, 1e-12 * gram.cwiseAbs().maxCoeff());
  }
}

TEST(RowQr, MergesFactorsOfPartsAndToleratesFewRowsAndZeroColumns) {
  Eigen::MatrixXd a = RandomMatrix(40, 5, 2);
  a.col(3).setZero();  // a column of zeros stays a zero column of R
  const RowQr whole = FactorInBlocks(a, 40);
  RowQr first = FactorInBlocks(a.topRows(3), 3);  // fewer rows than columns
  first.Merge(FactorInBlocks(a.bottomRows(37), 10));
  EXPECT_EQ(first.rows(), 40);
  const Eigen::MatrixXd gram = whole.r().transpose() * whole.r();
  EXPECT_PRED_FORMAT3(MatrixNear, first.r().transpose() * first.r(), gram, 1e-14 * gram.cwiseAbs().maxCoeff());
  EXPECT_EQ(whole.r().col(3).norm(), 0.0);
}

}  // namespace
}  // namespace sph
