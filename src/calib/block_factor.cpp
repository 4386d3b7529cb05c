#include "block_factor.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include <Eigen/Eigenvalues>
#include <Eigen/QR>
#include <Eigen/SVD>

namespace sph::internal {

BlockFactor::BlockFactor(std::vector<Eigen::Index> f_columns, std::vector<Eigen::Index> e_first, Eigen::Index n)
    : f_columns_(std::move(f_columns)),
      e_first_(std::move(e_first)),
      n_(n),
      r_ee_(e_first_.size(), Eigen::Matrix3d::Zero()),
      r_ef_(e_first_.size(), Eigen::MatrixXd::Zero(3, static_cast<Eigen::Index>(f_columns_.size()))),
      r_ff_(static_cast<Eigen::Index>(f_columns_.size())) {}

void BlockFactor::AddSetup(int k, const Eigen::MatrixXd& r_local, const std::vector<int>& f_of_local,
                           Eigen::Index rows) {
  const auto setup = static_cast<std::size_t>(k);
  const auto nf = static_cast<Eigen::Index>(f_columns_.size());
  const auto nl = static_cast<Eigen::Index>(f_of_local.size());
  r_ee_[setup] = r_local.topLeftCorner<3, 3>();
  for (Eigen::Index j = 0; j < nl; ++j)
    r_ef_[setup].col(f_of_local[static_cast<std::size_t>(j)]) = r_local.block(0, 3 + j, 3, 1);
  // What the setup leaves of the shared columns, folded into R_ff.
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> rest = Eigen::MatrixXd::Zero(nl, nf);
  for (Eigen::Index i = 0; i < nl; ++i) {
    for (Eigen::Index j = i; j < nl; ++j) rest(i, f_of_local[static_cast<std::size_t>(j)]) = r_local(3 + i, 3 + j);
  }
  r_ff_.AddRows(rest.data(), nf, nl);
  rows_ += rows;
}

void BlockFactor::AddSharedRow(int f, double weight) {
  Eigen::VectorXd row = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(f_columns_.size()));
  row(f) = weight;
  AddSharedRow(row);
}

void BlockFactor::AddSharedRow(Eigen::VectorXd row) {
  const auto nf = static_cast<Eigen::Index>(f_columns_.size());
  if (chosen_) {
    r_ff_chosen_.conservativeResize(r_ff_chosen_.rows() + 1, Eigen::NoChange);
    r_ff_chosen_.row(r_ff_chosen_.rows() - 1) = row.transpose();
  } else {
    r_ff_.AddRows(row.data(), nf, 1);
  }
  rows_ += 1;
}

BlockFactor BlockFactor::Without(const std::vector<bool>& held) const {
  std::vector<Eigen::Index> number(static_cast<std::size_t>(n_), -1);  // each column's number among the kept
  Eigen::Index kept = 0;
  for (Eigen::Index j = 0; j < n_; ++j) {
    if (!held[static_cast<std::size_t>(j)]) number[static_cast<std::size_t>(j)] = kept++;
  }
  std::vector<Eigen::Index> f_columns, e_first, f_kept;
  for (std::size_t j = 0; j < f_columns_.size(); ++j) {
    const Eigen::Index k = number[static_cast<std::size_t>(f_columns_[j])];
    if (k < 0) continue;
    f_columns.push_back(k);
    f_kept.push_back(static_cast<Eigen::Index>(j));
  }
  for (const Eigen::Index e : e_first_) e_first.push_back(number[static_cast<std::size_t>(e)]);
  BlockFactor out(std::move(f_columns), std::move(e_first), kept);
  out.rows_ = rows_;
  out.r_ee_ = r_ee_;
  const auto nf = static_cast<Eigen::Index>(f_kept.size());
  for (std::size_t k = 0; k < r_ef_.size(); ++k) {
    for (Eigen::Index j = 0; j < nf; ++j) out.r_ef_[k].col(j) = r_ef_[k].col(f_kept[static_cast<std::size_t>(j)]);
  }
  out.chosen_ = true;
  out.r_ff_chosen_.resize(Rff().rows(), nf);
  for (Eigen::Index j = 0; j < nf; ++j) out.r_ff_chosen_.col(j) = Rff().col(f_kept[static_cast<std::size_t>(j)]);
  return out;
}

Eigen::MatrixXd BlockFactor::Dense() const {
  const auto nf = static_cast<Eigen::Index>(f_columns_.size());
  const auto setups = static_cast<Eigen::Index>(e_first_.size());
  Eigen::MatrixXd r = Eigen::MatrixXd::Zero(3 * setups + Rff().rows(), n_);
  for (Eigen::Index k = 0; k < setups; ++k) {
    const auto s = static_cast<std::size_t>(k);
    for (int c = 0; c < 3; ++c) r.block(3 * k, e_first_[s] + c, 3, 1) = r_ee_[s].col(c);
    for (Eigen::Index j = 0; j < nf; ++j)
      r.block(3 * k, f_columns_[static_cast<std::size_t>(j)], 3, 1) = r_ef_[s].col(j);
  }
  for (Eigen::Index j = 0; j < nf; ++j) {
    r.block(3 * setups, f_columns_[static_cast<std::size_t>(j)], Rff().rows(), 1) = Rff().col(j);
  }
  return r;
}

namespace {

// The factor with its columns equilibrated (R D), and products with it and its inverse on
// vectors laid out in the full parameter order.
struct Scaled {
  const std::vector<Eigen::Index>& f;
  const std::vector<Eigen::Index>& e;
  std::vector<Eigen::Matrix3d> ree;
  std::vector<Eigen::MatrixXd> ref;  // 3 x nf
  Eigen::MatrixXd rff;
  Eigen::MatrixXd u, v;  // thin SVD of rff
  Eigen::VectorXd sv, sv_plus;

  Eigen::Index Nf() const { return static_cast<Eigen::Index>(f.size()); }
  Eigen::Index Setups() const { return static_cast<Eigen::Index>(e.size()); }

  Eigen::MatrixXd FRows(const Eigen::MatrixXd& y) const {
    Eigen::MatrixXd out(Nf(), y.cols());
    for (Eigen::Index j = 0; j < Nf(); ++j) out.row(j) = y.row(f[static_cast<std::size_t>(j)]);
    return out;
  }
  // (R D) y: 3 rows per setup, then the nf rows of R_ff.
  Eigen::MatrixXd Apply(const Eigen::MatrixXd& y) const {
    const Eigen::MatrixXd yf = FRows(y);
    Eigen::MatrixXd z(3 * Setups() + rff.rows(), y.cols());
    for (Eigen::Index k = 0; k < Setups(); ++k) {
      const auto s = static_cast<std::size_t>(k);
      z.middleRows(3 * k, 3) = ree[s] * y.middleRows(e[s], 3) + ref[s] * yf;
    }
    z.bottomRows(rff.rows()) = rff * yf;
    return z;
  }
  // (R D)^T z, in the full parameter order.
  Eigen::MatrixXd ApplyTransposed(const Eigen::MatrixXd& z, Eigen::Index n) const {
    Eigen::MatrixXd y = Eigen::MatrixXd::Zero(n, z.cols());
    Eigen::MatrixXd yf = rff.transpose() * z.bottomRows(rff.rows());
    for (Eigen::Index k = 0; k < Setups(); ++k) {
      const auto s = static_cast<std::size_t>(k);
      y.middleRows(e[s], 3) = ree[s].transpose() * z.middleRows(3 * k, 3);
      yf.noalias() += ref[s].transpose() * z.middleRows(3 * k, 3);
    }
    for (Eigen::Index j = 0; j < Nf(); ++j) y.row(f[static_cast<std::size_t>(j)]) = yf.row(j);
    return y;
  }
  // ((R D)^T (R D))^+ y, with R_ff's null space left out (R_ff may have more rows than columns:
  // its thin SVD).
  Eigen::MatrixXd ApplyInverse(const Eigen::MatrixXd& y) const {
    // (R D)^T w = y: the centres' rows first, then R_ff^T w_f = y_f - sum_k R_ef_k^T w_k.
    std::vector<Eigen::MatrixXd> w(static_cast<std::size_t>(Setups()));
    Eigen::MatrixXd rhs = FRows(y);
    for (Eigen::Index k = 0; k < Setups(); ++k) {
      const auto s = static_cast<std::size_t>(k);
      w[s] = ree[s].transpose().triangularView<Eigen::Lower>().solve(y.middleRows(e[s], 3));
      rhs.noalias() -= ref[s].transpose() * w[s];
    }
    const Eigen::MatrixXd wf = u * (sv_plus.asDiagonal() * (v.transpose() * rhs));  // (R_ff^T)^+ rhs
    // (R D) z = w: z_f = R_ff^+ w_f, then each centre.
    const Eigen::MatrixXd zf = v * (sv_plus.asDiagonal() * (u.transpose() * wf));
    Eigen::MatrixXd z = Eigen::MatrixXd::Zero(y.rows(), y.cols());
    for (Eigen::Index j = 0; j < Nf(); ++j) z.row(f[static_cast<std::size_t>(j)]) = zf.row(j);
    for (Eigen::Index k = 0; k < Setups(); ++k) {
      const auto s = static_cast<std::size_t>(k);
      z.middleRows(e[s], 3) = ree[s].triangularView<Eigen::Upper>().solve(w[s] - ref[s] * zf);
    }
    return z;
  }
  // Direction x_f of the shared parameters lifted to the centres: x_e_k = -R_ee_k^-1 R_ef_k x_f.
  Eigen::VectorXd Lift(const Eigen::VectorXd& xf, Eigen::Index n) const {
    Eigen::VectorXd y = Eigen::VectorXd::Zero(n);
    for (Eigen::Index j = 0; j < Nf(); ++j) y(f[static_cast<std::size_t>(j)]) = xf(j);
    for (Eigen::Index k = 0; k < Setups(); ++k) {
      const auto s = static_cast<std::size_t>(k);
      y.segment<3>(e[s]) = -ree[s].triangularView<Eigen::Upper>().solve(ref[s] * xf);
    }
    return y;
  }
};

// The largest eigenvalue of (R D)^T (R D) and its vector, by Lanczos with full reorthogonalisation.
std::pair<double, Eigen::VectorXd> LargestEigen(const Scaled& a, Eigen::Index n) {
  const Eigen::Index steps = std::min<Eigen::Index>(n, 60);
  Eigen::MatrixXd q = Eigen::MatrixXd::Zero(n, steps);
  std::vector<double> alpha, beta;
  q.col(0) = Eigen::VectorXd::Constant(n, 1.0 / std::sqrt(static_cast<double>(n)));
  double top = 0.0;
  Eigen::VectorXd top_vector = q.col(0);
  for (Eigen::Index j = 0; j < steps; ++j) {
    Eigen::VectorXd w = a.ApplyTransposed(a.Apply(q.col(j)), n);
    alpha.push_back(q.col(j).dot(w));
    for (int pass = 0; pass < 2; ++pass) w -= q.leftCols(j + 1) * (q.leftCols(j + 1).transpose() * w);
    const Eigen::Index size = j + 1;
    Eigen::MatrixXd t = Eigen::MatrixXd::Zero(size, size);
    for (Eigen::Index i = 0; i < size; ++i) {
      t(i, i) = alpha[static_cast<std::size_t>(i)];
      if (i + 1 < size) t(i, i + 1) = t(i + 1, i) = beta[static_cast<std::size_t>(i)];
    }
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(t);
    const double theta = eig.eigenvalues()(size - 1);
    top_vector = q.leftCols(size) * eig.eigenvectors().col(size - 1);
    const bool converged = j > 0 && std::abs(theta - top) <= 1e-14 * theta;
    top = theta;
    const double b = w.norm();
    if (converged || !(b > 1e-14 * theta) || j + 1 == steps) break;
    beta.push_back(b);
    q.col(j + 1) = w / b;
  }
  return {top, top_vector.normalized()};
}

// Columns of `y` orthonormalised (thin Q of its QR).
Eigen::MatrixXd Orthonormal(const Eigen::MatrixXd& y) {
  const Eigen::HouseholderQR<Eigen::MatrixXd> qr(y);
  return qr.householderQ() * Eigen::MatrixXd::Identity(y.rows(), y.cols());
}

}  // namespace

NormalInverse BlockFactor::Invert() const {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double eps = std::numeric_limits<double>::epsilon();
  const Eigen::Index n = n_, nf = static_cast<Eigen::Index>(f_columns_.size());
  const auto setups = static_cast<Eigen::Index>(e_first_.size());
  auto inverse_norm = [](double squared) { return squared > 0.0 ? 1.0 / std::sqrt(squared) : 0.0; };
  NormalInverse out;
  out.scale = Eigen::VectorXd::Zero(n);
  Eigen::VectorXd sf(nf);
  {
    Eigen::VectorXd norm2 = Rff().colwise().squaredNorm().transpose();
    for (const Eigen::MatrixXd& b : r_ef_) norm2 += b.colwise().squaredNorm().transpose();
    for (Eigen::Index j = 0; j < nf; ++j)
      out.scale(f_columns_[static_cast<std::size_t>(j)]) = sf(j) = inverse_norm(norm2(j));
  }
  Scaled a{f_columns_, e_first_, {}, {}, {}, {}, {}, {}, {}};
  bool centres_determined = true;
  for (Eigen::Index k = 0; k < setups; ++k) {
    const auto s = static_cast<std::size_t>(k);
    Eigen::Vector3d se;
    for (int c = 0; c < 3; ++c) out.scale(e_first_[s] + c) = se(c) = inverse_norm(r_ee_[s].col(c).squaredNorm());
    a.ree.push_back(r_ee_[s] * se.asDiagonal());
    a.ref.push_back(r_ef_[s] * sf.asDiagonal());
    centres_determined &= se.minCoeff() > 0.0;
  }
  a.rff = Rff() * sf.asDiagonal();
  if (!centres_determined) return InvertNormalFactor(Dense(), rows_);
  const auto [largest, largest_vector] = LargestEigen(a, n);
  const double sigma_max = std::sqrt(std::max(largest, 0.0));
  const double tol = static_cast<double>(std::max(rows_, n)) * eps * sigma_max;
  for (const Eigen::Matrix3d& b : a.ree) {
    // A centre its setup's rows barely hold: the dense analysis decides what is determined.
    if (!(Eigen::JacobiSVD<Eigen::Matrix3d>(b).singularValues()(2) > tol)) return InvertNormalFactor(Dense(), rows_);
  }
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(a.rff, Eigen::ComputeThinU | Eigen::ComputeFullV);
  a.u = svd.matrixU();
  a.v = svd.matrixV();
  a.sv = svd.singularValues();
  a.sv_plus = a.sv.unaryExpr([tol](double x) { return x > tol ? 1.0 / x : 0.0; });

  // The null space: R_ff D_f's, lifted to the centres.
  out.in_null.assign(static_cast<std::size_t>(n), false);
  for (Eigen::Index j = 0; j < n; ++j) out.in_null[static_cast<std::size_t>(j)] = out.scale(j) == 0.0;
  std::vector<Eigen::VectorXd> nulls;
  for (Eigen::Index i = 0; i < nf; ++i) {
    if (a.sv(i) > tol) continue;
    Eigen::VectorXd y = a.Lift(a.v.col(i), n);
    y.normalize();
    for (Eigen::Index j = 0; j < n; ++j) {
      if (std::abs(y(j)) > 1e-6) out.in_null[static_cast<std::size_t>(j)] = true;
    }
    nulls.push_back(y);
  }

  // The inverse, in the equilibrated columns: C_ff = V S^+2 V^T, W_k = R_ee_k^-1 R_ef_k.
  const Eigen::MatrixXd cff = a.v * a.sv_plus.cwiseAbs2().asDiagonal() * a.v.transpose();
  std::vector<Eigen::MatrixXd> w, wc;  // W_k and W_k C_ff, 3 x nf
  for (Eigen::Index k = 0; k < setups; ++k) {
    const auto s = static_cast<std::size_t>(k);
    w.push_back(a.ree[s].triangularView<Eigen::Upper>().solve(a.ref[s]));
    wc.push_back(w.back() * cff);
  }
  Eigen::MatrixXd c(n, n);
  for (Eigen::Index i = 0; i < nf; ++i) {
    for (Eigen::Index j = 0; j < nf; ++j)
      c(f_columns_[static_cast<std::size_t>(i)], f_columns_[static_cast<std::size_t>(j)]) = cff(i, j);
  }
  for (Eigen::Index k = 0; k < setups; ++k) {
    const auto s = static_cast<std::size_t>(k);
    for (Eigen::Index j = 0; j < nf; ++j) {
      const Eigen::Index col = f_columns_[static_cast<std::size_t>(j)];
      for (int r = 0; r < 3; ++r) c(e_first_[s] + r, col) = c(col, e_first_[s] + r) = -wc[s](r, j);
    }
    const Eigen::Matrix3d rinv = a.ree[s].triangularView<Eigen::Upper>().solve(Eigen::Matrix3d::Identity());
    for (Eigen::Index l = 0; l <= k; ++l) {
      const auto t = static_cast<std::size_t>(l);
      Eigen::Matrix3d block = wc[s] * w[t].transpose();
      if (l == k) block += rinv * rinv.transpose();
      c.block<3, 3>(e_first_[s], e_first_[t]) = block;
      c.block<3, 3>(e_first_[t], e_first_[s]) = block.transpose();
    }
  }
  out.inverse = Eigen::MatrixXd::Constant(n, n, nan);
  for (Eigen::Index i = 0; i < n; ++i) {
    if (out.in_null[static_cast<std::size_t>(i)]) continue;
    for (Eigen::Index j = 0; j < n; ++j) {
      if (!out.in_null[static_cast<std::size_t>(j)]) out.inverse(i, j) = out.scale(i) * c(i, j) * out.scale(j);
    }
  }

  // The weakest singular values and directions: inverse subspace iteration from the lifted singular
  // vectors of R_ff D_f, beside the null space.
  Eigen::MatrixXd null_basis(n, static_cast<Eigen::Index>(nulls.size()));
  for (std::size_t i = 0; i < nulls.size(); ++i) null_basis.col(static_cast<Eigen::Index>(i)) = nulls[i];
  if (null_basis.cols() > 0) null_basis = Orthonormal(null_basis);
  const Eigen::Index q = nf - null_basis.cols();
  Eigen::MatrixXd y(n, q);
  for (Eigen::Index i = 0; i < q; ++i) y.col(i) = a.Lift(a.v.col(i), n);
  Eigen::VectorXd theta = Eigen::VectorXd::Zero(q), previous = Eigen::VectorXd::Constant(q, nan);
  Eigen::MatrixXd ritz(n, q);
  for (int iteration = 0; iteration < 50 && q > 0; ++iteration) {
    if (null_basis.cols() > 0) y -= null_basis * (null_basis.transpose() * y);
    const Eigen::MatrixXd basis = Orthonormal(y);
    const Eigen::MatrixXd rb = a.Apply(basis);
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(rb.transpose() * rb);
    theta = eig.eigenvalues();  // ascending
    ritz = basis * eig.eigenvectors();
    // Converged where it matters: every value within a tenth of the largest singular value.
    bool converged = true;
    for (Eigen::Index i = 0; i < q; ++i) {
      if (theta(i) > 1e-2 * largest && i > 0) break;
      converged &= std::abs(theta(i) - previous(i)) <= 1e-12 * std::max(theta(i), eps * largest);
    }
    if (converged) break;
    previous = theta;
    y = a.ApplyInverse(ritz);
  }
  // Largest first, then the weakest descending: those of the subspace and the null space.
  std::vector<std::pair<double, Eigen::VectorXd>> weak;
  for (Eigen::Index i = 0; i < q; ++i) weak.emplace_back(std::sqrt(std::max(theta(i), 0.0)), ritz.col(i));
  for (Eigen::Index i = 0; i < null_basis.cols(); ++i) {
    weak.emplace_back(a.Apply(null_basis.col(i)).norm(), null_basis.col(i));
  }
  std::stable_sort(weak.begin(), weak.end(), [](const auto& l, const auto& r) { return l.first > r.first; });
  const auto count = static_cast<Eigen::Index>(1 + weak.size());
  out.singular_values.resize(count);
  out.v.resize(n, count);
  out.singular_values(0) = sigma_max;
  out.v.col(0) = largest_vector;
  for (std::size_t i = 0; i < weak.size(); ++i) {
    out.singular_values(static_cast<Eigen::Index>(i) + 1) = weak[i].first;
    out.v.col(static_cast<Eigen::Index>(i) + 1) = weak[i].second;
  }
  const double smallest = out.singular_values(count - 1);
  out.condition_number = smallest > 0.0 ? sigma_max / smallest : std::numeric_limits<double>::infinity();
  return out;
}

}  // namespace sph::internal
