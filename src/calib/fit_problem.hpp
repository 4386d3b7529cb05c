// Private to sph::calib: the least-squares problem of every calibration, evaluated fast.
//
//   e_i = |EffectScmsPoint(g, effects; reading_i) - O_setup(i)| - R0
//
// over the parameters x = [g (7) | centre of each setup (3 each, ascending setup) | effect blocks
// (term order)], the column order of every analysis. The readings are held once, one array per
// quantity with their sines and cosines (ReadingTable), and a fit names the rows it uses, so that
// outliers, cross-validation folds and the candidates of a trace share one table. The residuals
// and their gradients come from the hand-derived SphereResidualGradient() in blocks of rows (the
// fixed part of each reading gathered once per block, the loop over the rows vectorised), and
// whoever needs them takes them block by block: Ceres' residual blocks (EvaluateSetupRows()), the
// normal equations and the triangular factor of the Jacobian for the analysis, the residuals. Nothing of size rows x
// parameters is ever held.
//
// The effect terms' basis functions are evaluated per block: harmonics by the angle-addition
// recurrence from the reading's sine and cosine, powers by multiplication (EffectBasis() computes
// the same functions, to rounding).
//
// The sphere's form (EffectModel::form) moves the surface, not the probed point:
//   e_i = |p_i - O| - R0 - F_g(R^T n_i),   n_i = (p_i - O) / |p_i - O|,
// with F_g = sum c_lm S_lm the form of the setup's group g and R its mount rotation. So
//   de/dx = (n - t) . dp/dx,   de/dO = t - n,   de/dc_lm = -S_lm(R^T n),
//   t = dF/dp = (I - n n^T) R grad F(R^T n) / |p - O|,
// t tangent to the sphere and small (about l F / R0). (n - t) . dp/dx is the seven-error gradient
// (n . dp/dx) less the same reverse sweep along t: the gradient of |p - O'| for the point O' one
// unit behind p along t / |t|.
#ifndef SPH_SRC_CALIB_FIT_PROBLEM_HPP_
#define SPH_SRC_CALIB_FIT_PROBLEM_HPP_

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <vector>

#include "block_factor.hpp"
#include "sph/calib/calibrator.hpp"
#include "sph/io/points_file.hpp"
#include "sph/model/effects.hpp"
#include "sph/model/residual_gradient.hpp"
#include "sph/model/row_qr.hpp"

namespace sph::internal {

/// Every parameter of a fit in its one order, that of x and of the fit's analysis: the seven
/// errors, each setup's centre, the effects' values in term order (rad, mm), then the sphere form's
/// coefficients per group (mm).
Eigen::VectorXd PackParameters(const ScmsGeometry& g, const std::vector<Eigen::Vector3d>& centers_mm,
                               const std::vector<std::vector<double>>& values = {},
                               const std::vector<std::vector<double>>& form_values = {});

/// J^T J (full, symmetric), J^T e and the cost 1/2 e^T e at one point.
struct NormalEquations {
  Eigen::MatrixXd jtj;
  Eigen::VectorXd jte;
  double cost = 0.0;

  void SetZero(Eigen::Index n) {
    jtj.setZero(n, n);
    jte.setZero(n);
    cost = 0.0;
  }
};

/// Each setup id of `ids` to its index there.
inline std::map<int, std::size_t> IndexOfSetups(const std::vector<int>& ids) {
  std::map<int, std::size_t> index;
  for (std::size_t k = 0; k < ids.size(); ++k) index[ids[k]] = k;
  return index;
}

/// The samples of a points file as the fits read them, one array per quantity, in file order.
struct ReadingTable {
  std::vector<double> theta_rad, phi_rad, cos_theta, sin_theta, cos_phi, sin_phi, r_mm, t_s;
  /// Half the direction of approach of each axis (MotionDirections()), the reversal terms' basis.
  std::vector<double> theta_half_direction, phi_half_direction;
  std::vector<int> setup;      ///< index into setup_ids of each sample
  std::vector<int> setup_ids;  ///< ascending

  ReadingTable() = default;
  explicit ReadingTable(const PointsData& points);
  std::size_t size() const { return r_mm.size(); }
  /// Sets the probe reading of every sample (the Monte Carlo's noisy copies of fixed readings).
  void SetReadings(const PointsData& points);
};

/// The rows of a table that a fit uses: for each setup index of the table, its samples (ascending).
using RowsOfSetup = std::vector<std::vector<std::uint32_t>>;

/// Every sample of `table`, or every sample not marked in `left_out` (table-indexed).
RowsOfSetup AllRows(const ReadingTable& table, const std::vector<bool>* left_out = nullptr);

/// The ids of the setups that have rows, ascending (a fit's CalibrationResult::setup_ids), appended
/// to `setup_ids`; returns the number of rows in all.
std::size_t SetupsWithRows(const ReadingTable& table, const RowsOfSetup& rows, std::vector<int>* setup_ids);

/// The parameters that the rows of one setup depend on (pointers into x, or into a solver's own
/// copy of each parameter block).
struct SetupParams {
  const double* geometry = nullptr;  ///< the seven errors
  const double* center = nullptr;    ///< the setup's centre
  const double* effects = nullptr;   ///< every effect parameter, in term order (null: none)
  const double* form = nullptr;      ///< the form coefficients of the setup's group (null: none)
};

/// One block of rows as the evaluation produced it.
struct RowBlock {
  int setup = 0;                        ///< problem setup index
  const std::uint32_t* rows = nullptr;  ///< table row of each
  int count = 0;
  const double* e = nullptr;  ///< residuals [mm]
  /// Jacobian columns, column-major with leading dimension kBlockRows: the seven errors, the centre of
  /// this block's setup, the effect parameters, the form coefficients of this setup's group. Null
  /// when the Jacobian was not asked for.
  const double* cols = nullptr;
  int num_cols = 0;  ///< 10 + effect parameters + form terms
};

class SphereFitProblem {
 public:
  static constexpr int kBlockRows = 128;

  /// The problem over `rows` of `table` (which must outlive it) with the effects of `model`, the
  /// probe offset and the sphere radius of each setup from `options`. Setups without rows have no
  /// centre.
  SphereFitProblem(const ReadingTable& table, RowsOfSetup rows, const EffectModel& model,
                   const CalibrationOptions& options);
  ~SphereFitProblem();
  SphereFitProblem(const SphereFitProblem&) = delete;
  SphereFitProblem& operator=(const SphereFitProblem&) = delete;

  Eigen::Index NumParams() const { return num_params_; }
  int NumSetups() const { return static_cast<int>(setups_.size()); }
  /// The table setup index of each of the problem's setups.
  const std::vector<int>& TableSetups() const { return setups_; }
  std::size_t NumRows() const { return num_rows_; }
  const ReadingTable& table() const { return table_; }
  const EffectModel& model() const { return model_; }

  /// x from its parts (PackParameters(); centres: one per problem setup; values: one block per
  /// term; form_values: one block per group of the model's form, missing blocks at zero).
  Eigen::VectorXd Pack(const ScmsGeometry& g, const std::vector<Eigen::Vector3d>& centers_mm,
                       const std::vector<std::vector<double>>& values,
                       const std::vector<std::vector<double>>& form_values = {}) const;
  /// The parts of x.
  void Unpack(const Eigen::VectorXd& x, ScmsGeometry* g, std::vector<Eigen::Vector3d>* centers_mm,
              std::vector<std::vector<double>>* values, std::vector<std::vector<double>>* form_values = nullptr) const;

  /// The column of x of local column `local` (RowBlock::cols) of problem setup `setup`.
  Eigen::Index GlobalColumn(int setup, int local) const {
    if (local < kNumScmsParams) return local;
    if (local < kNumScmsParams + 3) return kNumScmsParams + 3 * setup + (local - kNumScmsParams);
    const int effect = local - kNumScmsParams - 3;
    if (effect < num_effect_params_) return first_effect_ + effect;
    return first_form_ + form_group_[static_cast<std::size_t>(setup)] * num_form_terms_ + (effect - num_effect_params_);
  }

  /// The number of rows of problem setup `setup`.
  int SetupRows(int setup) const { return static_cast<int>(rows_[static_cast<std::size_t>(setup)].size()); }
  /// The table rows of problem setup `setup`, ascending.
  const std::vector<std::uint32_t>& RowsOf(int setup) const { return rows_[static_cast<std::size_t>(setup)]; }
  /// The group of the form that problem setup `setup` belongs to.
  int FormGroupOf(int setup) const { return form_group_[static_cast<std::size_t>(setup)]; }
  int NumEffectParams() const { return num_effect_params_; }
  /// The parameter blocks a setup's rows depend on: the seven errors, its centre, the effects (when
  /// the model has any), its form group's coefficients (when it has a form).
  int NumSetupBlocks() const { return 2 + (num_effect_params_ > 0 ? 1 : 0) + (num_form_terms_ > 0 ? 1 : 0); }
  /// The first column of x of the effects, and of form group `group`.
  Eigen::Index FirstEffectColumn() const { return first_effect_; }
  Eigen::Index FirstFormColumn(int group) const { return first_form_ + group * num_form_terms_; }
  int NumFormTerms() const { return num_form_terms_; }
  /// The parameters of problem setup `setup` in x.
  SetupParams ParamsOf(const double* x, int setup) const;

  /// Rows first.. first + count - 1 of problem setup `setup` at p: their residuals into
  /// residuals[0..count) and, for each non-null jacobians[b] (b: 0 the seven errors, 1 the centre,
  /// 2 the effects, 3 the form; 2 and 3 only where the model has them), that block's Jacobian,
  /// row-major, one row per residual. False when a residual or a derivative is not finite.
  bool EvaluateSetupRows(int setup, const SetupParams& p, int first, int count, double* residuals,
                         double* const* jacobians) const;

  /// The normal equations at x (the analysis of a fit of few setups): J^T J, J^T e and the cost,
  /// summed in one pass over the rows. Not thread-safe (scratch).
  bool Evaluate(const double* x, NormalEquations* ne) const;

  /// Calls fn for every block of rows at x, setup after setup, rows in table order. With r_offset
  /// (table-indexed, mm) the probe readings are r + r_offset[row]; with jacobian the blocks carry
  /// the Jacobian's columns.
  void ForEachBlock(const double* x, const double* r_offset, bool jacobian,
                    const std::function<void(const RowBlock&)>& fn) const;

  /// Residuals at x into out (table-indexed; rows not in the problem untouched).
  void Residuals(const double* x, double* out) const;

  /// The triangular factor of the Jacobian at x (readings r + r_offset when given, each row times
  /// row_weight[its table row] when given), columns as x.
  RowQr FactorJacobian(const double* x, const double* r_offset = nullptr, const double* row_weight = nullptr) const;

  /// The Jacobian's triangular factor at x in blocks, the centres eliminated first (block_factor.hpp),
  /// readings r + r_offset when given, each row times row_weight[its table row] when given.
  BlockFactor FactorBlocks(const double* x, const double* r_offset = nullptr, const double* row_weight = nullptr) const;

  /// ForEachBlock() with the Jacobian's rows in the columns of x: fn(rows, count, jacobian, setup)
  /// with the table row of each, the rows one after the other (NumParams() values each; writable),
  /// and the problem setup they belong to.
  void ForEachGlobalBlock(
      const double* x, const double* r_offset,
      const std::function<void(const std::uint32_t* rows, int count, double* jacobian, int setup)>& fn) const;

  /// The Jacobian at x (readings r + r_offset when given), one row per table row of the problem in
  /// table order (rows not in the problem left out), columns as x.
  Eigen::MatrixXd DenseJacobian(const double* x, const double* r_offset = nullptr) const;

 private:
  struct Scratch;
  // The residuals (and with cols, the Jacobian) of `count` gathered rows with effects and form, of
  // problem setup `setup`.
  void EffectRows(const SetupParams& p, const ScmsErrorTrig<double>& et, double d_plus_dprime, int setup,
                  const std::uint32_t* idx, int count, double* e, double* cols) const;
  // One block (at most kBlockRows) of rows idx[0..count) of problem setup k at p into the scratch's
  // residuals and, with jacobian, its columns (RowBlock::cols).
  void EvaluateBlock(int k, const SetupParams& p, const ScmsErrorTrig<double>& et, const std::uint32_t* idx, int count,
                     const double* r_offset, bool jacobian) const;
  // Its parts: the readings and basis functions of the block's rows (idx), each target's sum of
  // the terms' components, and probe_incidence's change of row i's reading with its derivatives.
  void BlockBasis(const std::uint32_t* idx, int count) const;
  void SumTerms(const double* effect_values, int count) const;
  struct Incidence {
    double dr_mm = 0.0;            // the reading's error
    double de_dc_per_de_dz = 0.0;  // its derivative with respect to c = B . n0, per de/dz
    ResidualGradient dc;           // dc/dx (its e and z unused)
  };
  Incidence IncidenceAt(const double* g, const ScmsErrorTrig<double>& et, const double* center, double radius_mm,
                        const double* effect_values, ResidualInputs in0, int i, bool jacobian) const;
  const ReadingTable& table_;
  RowsOfSetup rows_;         // per problem setup
  std::vector<int> setups_;  // table setup index per problem setup
  EffectModel model_;
  double probe_offset_mm_;
  std::vector<double> radius_mm_;  // the sphere's radius per problem setup
  std::size_t num_rows_ = 0;
  Eigen::Index num_params_ = 0;
  Eigen::Index first_effect_ = 0;
  int num_effect_params_ = 0;
  Eigen::Index first_form_ = 0;
  int num_form_terms_ = 0;
  int num_local_ = 0;                           // columns of a RowBlock
  std::vector<int> form_group_;                 // per problem setup
  std::vector<Eigen::Matrix3d> form_rotation_;  // per problem setup: body frame into the Theta frame
  std::unique_ptr<Scratch> scratch_;
};

}  // namespace sph::internal

#endif  // SPH_SRC_CALIB_FIT_PROBLEM_HPP_
