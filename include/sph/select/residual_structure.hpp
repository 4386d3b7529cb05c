// What is left in the residuals of a fit: is there structure, and what does it follow?
//
// The residuals e of a least-squares fit with Jacobian J are regressed on groups of smooth
// functions of the readings: harmonics of theta, a cosine series of phi, powers of the normalised
// probe reading u and of the normalised time tau, the direction of motion of each axis (d = +-1,
// MotionDirections(): the residual's mean per direction and its once-per-turn part, what a reversal
// value leaves), and spherical harmonics of the probed direction (a pattern fixed on the sphere,
// such as its form error). Each group's columns are first
// projected off the columns of J, so that under white noise the explained sum of squares is
// exactly s^2 chi^2 with the group's rank r, and
//   F = (explained / r) / ((RSS - explained) / (m - n - r))
// follows F(r, m - n - r). A small p-value means structure that the fitted model does not have.
//
// That holds where J and the functions carry none of the noise that e is. The probe reading r is
// noisy, and J's columns (a probe gain's through u, an incidence error's through the point), the
// powers of u and the directions depend on it: all are evaluated at the readings where the fitted
// model's residual vanishes (ExpectedReadings()), which differ from the true ones by the part of
// the noise that the fit absorbed, independent of e to first order. [J | functions] can be nearly
// rank-deficient, and then even a small share of the noise left there shows as structure
// (docs/method/tracing-the-residual.md).
//
// Everything here depends on the columns of J, of the functions and of e only through their inner
// products, so it is computed from the triangular factor R of [J | functions | e] (J = Q R),
// accumulated in one pass over the rows (StructureFactor): memory O(columns^2) for any number of
// readings, with the accuracy of an orthogonal factorisation. The projections, Gram-Schmidt steps
// and regressions then run on the columns of R, as they would on the m-row columns.
#ifndef SPH_SELECT_RESIDUAL_STRUCTURE_HPP_
#define SPH_SELECT_RESIDUAL_STRUCTURE_HPP_

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "sph/calib/effect_fit.hpp"
#include "sph/io/points_file.hpp"
#include "sph/model/effects.hpp"

namespace sph {

/// The regression of the residuals on one group of functions.
struct StructureGroup {
  std::string variable;           ///< "theta", "phi", "r", "t", "direction", "sphere" or "all"
  std::string description;        ///< the functions, in words
  int rank = 0;                   ///< independent columns after projection
  double explained_rms_um = 0.0;  ///< RMS of the part of the residuals the group explains
  double f = 0.0;                 ///< the F statistic
  double p_value = 1.0;           ///< P(F(r, m - n - r) >= f)
  std::string strongest;          ///< the single function that explains most, e.g. "cos(2 theta)"
  double strongest_rms_um = 0.0;  ///< RMS of what it explains alone [um]
  /// The change of the BIC if the group's functions were added to the fit (linearised):
  /// m ln((RSS - explained) / RSS) + rank ln m.
  double delta_bic = 0.0;
};

struct ResidualStructure {
  std::vector<StructureGroup> groups;      ///< theta, phi, r, t, direction, sphere
  StructureGroup all;                      ///< every function together: the test of remaining structure
  /// The amplitude of harmonic k = 1.. of theta, fitted alone [um]; the trace sets NaN for an order
  /// above what the readings' pattern resolves (PatternOrders()), which has none of its own.
  std::vector<double> theta_harmonics_um;
  /// The F test of harmonic k = 1.. of theta (cos and sin) alone against white noise, off the fit's
  /// Jacobian as the groups: its p-value (1 when the fit absorbs it).
  std::vector<double> theta_harmonic_p;
  std::vector<double> phi_cos_p;  ///< the same for cos(k phi), k = 1..
  /// The group with the smallest p-value (index into groups), or -1 when none.
  int Strongest() const;
};

/// The rows of a fit's Jacobian, given block by block (any order, each row once).
class JacobianBlocks {
 public:
  /// fn(samples, count, rows, stride, group): `count` rows of J, samples[i] the index in the fit's
  /// points of row i, its column j at rows[i * stride + j]; `group` the group of rows the block
  /// belongs to (GroupColumns()), or -1.
  using BlockFn =
      std::function<void(const std::uint32_t* samples, int count, const double* rows, int stride, int group)>;
  virtual ~JacobianBlocks() = default;
  virtual Eigen::Index Cols() const = 0;
  virtual void ForEach(const BlockFn& fn) const = 0;
  /// Where the rows come in groups that each depend on three columns of their own besides the
  /// shared ones (a setup's readings on its centre): the first of each group's three columns;
  /// ForEach() then gives each block's group, a group's blocks one after the other. Empty: none.
  virtual std::vector<Eigen::Index> GroupColumns() const { return {}; }
};

/// A Jacobian held in memory (row i: sample i) as JacobianBlocks.
class DenseJacobianBlocks final : public JacobianBlocks {
 public:
  explicit DenseJacobianBlocks(const Eigen::MatrixXd& jacobian) : jacobian_(jacobian) {}
  Eigen::Index Cols() const override { return jacobian_.cols(); }
  void ForEach(const BlockFn& fn) const override;

 private:
  const Eigen::MatrixXd& jacobian_;
};

/// What the analysis needs of a fit to `points`: its residuals (file order, mm), the readings at
/// which its residual vanishes (ExpectedReadings(), file order, mm: u is taken there), its Jacobian
/// and the unit direction from the fitted centre to each probed point (sphere frame), both at those
/// readings, and the reference that normalises r and t.
struct FitResiduals {
  const PointsData& points;
  const std::vector<double>& residuals_mm;
  const std::vector<double>& expected_r_mm;
  const JacobianBlocks& jacobian;
  const EffectReference& reference;
  const std::vector<Eigen::Vector3d>& directions;
};

/// The triangular factor of [J | functions of every group | e] of a fit (see the file comment), or
/// of [J | the sphere group's functions | signal], from one pass over its rows.
struct StructureFactor {
  Eigen::MatrixXd r;               ///< R, upper triangular, columns in the order above
  Eigen::Index rows = 0;           ///< m
  Eigen::Index jacobian_cols = 0;  ///< n (with `eliminated`: the shared columns of J)
  bool has_signal = false;         ///< the columns are those with a signal
  /// With many groups of rows (JacobianBlocks::GroupColumns(), a fit of many setups) each group's
  /// own three columns are eliminated from its rows first, at a cost linear in the number of
  /// groups: R then holds the other columns projected off them, `eliminated` is their rank and
  /// `norms` the norm of every column of R's before that projection, `gram` the inner products of
  /// the functions' and e's columns before it. Otherwise 0 and empty (R's columns then have them).
  Eigen::Index eliminated = 0;
  Eigen::VectorXd norms;
  Eigen::MatrixXd gram;
};

/// The probe reading of each sample of `points` (file order, mm) at which the residual of `fit`
/// vanishes: the reading the fitted model expects at the sample's angles and time, found by the
/// secant method on r (to 1e-12 mm). Every setup of `points` must be one of the fit's.
std::vector<double> ExpectedReadings(const PointsData& points, const CalibrationOptions& options, const EffectFit& fit);

/// The factor of a fit; with `signal_mm` (file order) its column is added (SpherePatternFraction()).
StructureFactor FactorResidualStructure(const FitResiduals& fit, const std::vector<double>* signal_mm = nullptr);

/// Analyses the residuals of a fit (see the file comment).
ResidualStructure AnalyseResidualStructure(const StructureFactor& factor);
ResidualStructure AnalyseResidualStructure(const FitResiduals& fit);

/// The highest degree of the spherical harmonics that the analysis takes for a pattern fixed on the
/// sphere (its "sphere" group, from degree 2).
inline constexpr int kSpherePatternDegree = 5;

/// The best small pattern fixed on the sphere: spherical harmonics of degree 2..5 of the direction
/// from the centre chosen one at a time (each the one that explains most of what is left) while
/// the extended BIC falls (SubsetSearchPenalty() of the functions chosen from all of them), as a
/// fit that added them would (linearised). It competes with the effects of the library, which
/// keep only their significant components too and are charged for that search in the same way:
/// two searched explanations compared on equal terms.
struct SpherePattern {
  double delta_bic = 0.0;  ///< extended BIC of adding the chosen functions (0: none chosen)
  double explained_rms_um = 0.0;
  std::vector<std::string> functions;  ///< e.g. "S(3,2)", in the order chosen
};
SpherePattern BestSpherePattern(const StructureFactor& factor);
SpherePattern BestSpherePattern(const FitResiduals& fit);

/// The same choice among other functions: the `count` columns of the factor from column `first`
/// (after its Jacobian's), named `names`, the residual its last column (a pattern for each set of
/// form of the setups, for one).
SpherePattern BestPatternAmong(const StructureFactor& factor, Eigen::Index first, Eigen::Index count,
                               const std::vector<std::string>& names);

/// The share of a signal (file order, mm; e.g. what an effect added to the fitted readings) that
/// is a pattern fixed on the sphere: of its part outside the columns of the fit's Jacobian, the
/// fraction that spherical harmonics of degree 2..5 of the direction from the centre explain.
/// The factor must hold the signal (FactorResidualStructure(fit, &signal)).
double SpherePatternFraction(const StructureFactor& factor);
double SpherePatternFraction(const FitResiduals& fit, const std::vector<double>& signal_mm);

/// The linearised change of the BIC when functions of one variable ("t": tau^1..3 as 0..2, "r":
/// u^1..3 as 0..2, ...; indices within its group) are added to the fit's Jacobian together with
/// every spherical harmonic of degree 2..5 of the direction from the centre: whether the variable
/// shows structure that no pattern fixed on the sphere explains. 0 for the sphere group itself.
double DeltaBicBeyondSphere(const StructureFactor& factor, const std::string& variable,
                            const std::vector<int>& functions);

/// 2 ln C(searched, kept): what the extended BIC (Chen and Chen 2008, gamma = 1) adds to the BIC of
/// a model whose `kept` components were chosen from `searched` candidates. The plain BIC charges
/// ln m for each component kept, however many were tried: the largest of many noise components
/// then passes it, and a selection that keeps only its significant components adds noise.
double SubsetSearchPenalty(int searched, int kept);

/// P(F(d1, d2) >= f), the upper tail of Fisher's F distribution.
double FUpperTail(double f, double d1, double d2);

}  // namespace sph

#endif  // SPH_SELECT_RESIDUAL_STRUCTURE_HPP_
