// The triangular factor R of a tall matrix A (A = Q R, Q orthonormal), accumulated from blocks of
// rows without ever holding A: memory O(n^2) for any number of rows.
//
// Each block of rows B is folded into the current R by Householder reflections that annihilate B
// against R's diagonal (the QR of [R; B], with R kept triangular), as in the tall-skinny QR of
// Demmel et al. It is the QR of the whole matrix, so R^T R = A^T A and the singular values and
// right singular vectors of R are those of A, to rounding, with the numerical properties of an
// orthogonal factorisation (no squaring of the condition number as with A^T A). Anything that
// depends on A only through inner products of its columns (projections, least-squares fits,
// the SVD's V and singular values) can be computed from R.
//
// R's diagonal may be negative. Cost: 2 n^2 flops per row. Header-only, Eigen only.
#ifndef SPH_MODEL_ROW_QR_HPP_
#define SPH_MODEL_ROW_QR_HPP_

#include <Eigen/Core>
#include <cmath>
#include <cstddef>

namespace sph {

class RowQr {
 public:
  RowQr() = default;
  explicit RowQr(Eigen::Index cols) { Reset(cols); }

  /// Starts over with `cols` columns and no rows.
  void Reset(Eigen::Index cols) {
    r_.setZero(cols, cols);
    rows_ = 0;
  }

  /// Folds `count` rows into R. `block` holds them row after row (row i, column j at
  /// block[i * stride + j], stride >= cols); it is overwritten.
  void AddRows(double* block, Eigen::Index stride, Eigen::Index count) {
    const Eigen::Index n = r_.cols();
    w_.resize(n);
    double* w = w_.data();
    for (Eigen::Index j = 0; j < n; ++j) {
      double sigma = 0.0;
      for (Eigen::Index i = 0; i < count; ++i) sigma += block[i * stride + j] * block[i * stride + j];
      if (!(sigma > 0.0)) continue;  // the column is zero below R: nothing to annihilate
      const double x0 = r_(j, j);
      const double alpha = -std::copysign(std::sqrt(x0 * x0 + sigma), x0);
      const double v0 = x0 - alpha;  // v = [v0; x], H = I - beta v v^T, H [x0; x] = [alpha; 0]
      const double beta = 2.0 / (v0 * v0 + sigma);
      r_(j, j) = alpha;
      // w = v^T [R(j, l); block(:, l)] for the columns l > j, then each column minus beta w_l v. The
      // loops run along the rows of the block, so that they vectorise.
      for (Eigen::Index l = j + 1; l < n; ++l) w[l] = v0 * r_(j, l);
      for (Eigen::Index i = 0; i < count; ++i) {
        const double xi = block[i * stride + j];
        const double* row = block + i * stride;
        for (Eigen::Index l = j + 1; l < n; ++l) w[l] += xi * row[l];
      }
      for (Eigen::Index l = j + 1; l < n; ++l) {
        w[l] *= beta;
        r_(j, l) -= w[l] * v0;
      }
      for (Eigen::Index i = 0; i < count; ++i) {
        const double xi = block[i * stride + j];
        double* row = block + i * stride;
        for (Eigen::Index l = j + 1; l < n; ++l) row[l] -= w[l] * xi;
      }
    }
    rows_ += count;
  }

  /// Folds another factor of the same columns into this one (the QR of [R_this; R_other]).
  void Merge(const RowQr& other) {
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> block = other.r_;
    AddRows(block.data(), block.cols(), block.rows());
    rows_ += other.rows_ - other.r_.rows();
  }

  /// R (cols x cols, upper triangular).
  const Eigen::MatrixXd& r() const { return r_; }
  /// Rows folded in so far.
  Eigen::Index rows() const { return rows_; }

 private:
  Eigen::MatrixXd r_;
  Eigen::VectorXd w_;
  Eigen::Index rows_ = 0;
};

}  // namespace sph

#endif  // SPH_MODEL_ROW_QR_HPP_
