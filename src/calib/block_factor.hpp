// Private to sph::calib: the analysis of a fit of many setups through the block structure of its
// Jacobian, at a cost linear in the number of setups.
//
// Every reading depends on the parameters that all setups share (f: the seven errors, the effects,
// the form) and on the centre of its own setup (e, three columns per setup). With the centres
// eliminated first, the triangular factor of the Jacobian (J = Q R, columns reordered) is
//   R = [ R_ee_1                R_ef_1 ]
//       [         ...            ...   ]
//       [               R_ee_K  R_ef_K ]
//       [                        R_ff  ]
// each setup's part from the QR of its own rows, R_ff from folding what each leaves of the f
// columns into one factor (the Schur complement's: R_ff^T R_ff = A_ff - sum_k A_fe_k A_ee_k^-1 A_ef_k).
// The analysis (observability.hpp) then needs no SVD of all n columns:
// - the covariance from R_ff alone: C_ff = (R_ff^T R_ff)^-1 through the SVD of the column-
//   equilibrated R_ff (its null space as well, each null direction lifted to the centres by
//   x_e_k = -R_ee_k^-1 R_ef_k x_f), C_ef_k = -W_k C_ff, C_ee_kl = delta_kl (R_ee_k^T R_ee_k)^-1 +
//   W_k C_ff W_l^T with W_k = R_ee_k^-1 R_ef_k;
// - the largest singular value of J D by Lanczos on (R D)^T (R D) (D the column equilibration);
// - the weakest ones and their directions by inverse subspace iteration on (R D)^T (R D) from the
//   lifted singular vectors of R_ff D_f, one vector per shared parameter: these are the nearly
//   dependent combinations the report lists (a weak direction of the centres alone, which a setup
//   whose points barely hold its centre would have, is found only as far as it reaches them).
// A setup whose centre its rows do not determine (R_ee_k singular) leaves the problem to the dense
// analysis (InvertNormalFactor() of the assembled R).
#ifndef SPH_SRC_CALIB_BLOCK_FACTOR_HPP_
#define SPH_SRC_CALIB_BLOCK_FACTOR_HPP_

#include <vector>

#include <Eigen/Core>

#include "sph/calib/observability.hpp"
#include "sph/model/row_qr.hpp"

namespace sph::internal {

class BlockFactor {
 public:
  /// A factor over `n` parameters: `f_columns` the shared ones (ascending), `e_first` the first of
  /// the three columns of each setup's centre.
  BlockFactor(std::vector<Eigen::Index> f_columns, std::vector<Eigen::Index> e_first, Eigen::Index n);

  /// Folds setup k's factor in: `r_local` the upper triangular factor of its rows over its centre's
  /// three columns followed by the shared columns it depends on, f_of_local[j] the index into
  /// f_columns of local column 3 + j; `rows` the number of rows it factors.
  void AddSetup(int k, const Eigen::MatrixXd& r_local, const std::vector<int>& f_of_local, Eigen::Index rows);

  /// Folds one more row in that has a single entry, `weight` in shared column f (a prior's row).
  void AddSharedRow(int f, double weight);
  /// Folds one more row in over the shared columns (`row`: one entry per f column; a row of a
  /// prior on several of them).
  void AddSharedRow(Eigen::VectorXd row);

  /// The factor of the columns not held (held[j] for each of the n columns; centres are never
  /// held), numbered as they follow one another: the Jacobian of a fit of the others.
  BlockFactor Without(const std::vector<bool>& held) const;

  /// The inverse of J^T J and what the SVD of J D tells (observability.hpp): the covariance and
  /// null space exactly, the largest singular value and the weakest ones with their directions
  /// as the file comment says (NormalInverse::singular_values holds those: the largest first, then
  /// the weakest, descending; v their directions).
  NormalInverse Invert() const;

  /// R with the columns in the full parameter order (R^T R = J^T J), n x n.
  Eigen::MatrixXd Dense() const;

  Eigen::Index Rows() const { return rows_; }

 private:
  std::vector<Eigen::Index> f_columns_, e_first_;
  Eigen::Index n_ = 0;
  Eigen::Index rows_ = 0;
  // R_ff: the factor folded so far, or (Without()) a matrix with its Gram: its columns chosen.
  const Eigen::MatrixXd& Rff() const { return chosen_ ? r_ff_chosen_ : r_ff_.r(); }

  std::vector<Eigen::Matrix3d> r_ee_;
  std::vector<Eigen::MatrixXd> r_ef_;  // 3 x n_f
  RowQr r_ff_;
  bool chosen_ = false;
  Eigen::MatrixXd r_ff_chosen_;
};

/// Whether a fit of `setups` setups and `shared` parameters besides their centres is analysed
/// through its block structure: with many setups, whose centres are then most of the parameters.
inline bool AnalyseByBlocks(int setups, int shared) { return setups >= 16 && 3 * setups >= shared; }

}  // namespace sph::internal

#endif  // SPH_SRC_CALIB_BLOCK_FACTOR_HPP_
