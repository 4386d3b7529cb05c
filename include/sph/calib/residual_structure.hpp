// What is left in the residuals of a fit: is there structure, and what does it follow?
//
// The residuals e of a least-squares fit with Jacobian J are regressed on groups of smooth
// functions of the readings: harmonics of theta, a cosine series of phi, powers of the normalised
// probe reading u and of the normalised time tau, and spherical harmonics of the probed direction
// (a pattern fixed on the sphere, such as its form error). Each group's columns are first
// projected off the columns of J, so that under white noise the explained sum of squares is
// exactly s^2 chi^2 with the group's rank r, and
//   F = (explained / r) / ((RSS - explained) / (m - n - r))
// follows F(r, m - n - r). A small p-value means structure that the fitted model does not have.
#ifndef SPH_CALIB_RESIDUAL_STRUCTURE_HPP_
#define SPH_CALIB_RESIDUAL_STRUCTURE_HPP_

#include <string>
#include <vector>

#include <Eigen/Core>

#include "sph/core/points_file.hpp"
#include "sph/model/effects.hpp"

namespace sph {

/// The regression of the residuals on one group of functions.
struct StructureGroup {
  std::string variable;        ///< "theta", "phi", "r", "t", "sphere" or "all"
  std::string description;     ///< the functions, in words
  int rank = 0;                ///< independent columns after projection
  double explained_rms_um = 0.0;  ///< RMS of the part of the residuals the group explains
  double f = 0.0;              ///< the F statistic
  double p_value = 1.0;        ///< P(F(r, m - n - r) >= f)
  std::string strongest;       ///< the single function that explains most, e.g. "cos(2 theta)"
  double strongest_rms_um = 0.0;  ///< RMS of what it explains alone [um]
  /// The change of the BIC if the group's functions were added to the fit (linearised):
  /// m ln((RSS - explained) / RSS) + rank ln m.
  double delta_bic = 0.0;
};

struct ResidualStructure {
  std::vector<StructureGroup> groups;  ///< theta, phi, r, t, sphere
  StructureGroup all;                  ///< every function together: the test of remaining structure
  std::vector<double> theta_harmonics_um;  ///< amplitude of harmonic k = 1.. of theta, fitted alone [um]
  /// The group with the smallest p-value (index into groups), or -1 when none.
  int Strongest() const;
};

/// What the analysis needs of a fit to `points`: its residuals (file order, mm), its Jacobian
/// (m x n, at the readings the fit expects: EffectFit::structure_jacobian), the reference that
/// normalises r and t, and the unit direction from the fitted centre to each probed point (sphere
/// frame).
struct FitResiduals {
  const PointsData& points;
  const std::vector<double>& residuals_mm;
  const Eigen::MatrixXd& jacobian;
  const EffectReference& reference;
  const std::vector<Eigen::Vector3d>& directions;
};

/// Analyses the residuals of a fit (see the file comment).
ResidualStructure AnalyseResidualStructure(const FitResiduals& fit);

/// The best small pattern fixed on the sphere: spherical harmonics of degree 2..5 of the direction
/// from the centre chosen one at a time (each the one that explains most of what is left) while
/// the BIC falls, as a fit that added them would (linearised). It competes with the effects of
/// the library, which keep only their significant components too.
struct SpherePattern {
  double delta_bic = 0.0;               ///< of adding the chosen functions (0: none chosen)
  double explained_rms_um = 0.0;
  std::vector<std::string> functions;   ///< e.g. "S(3,2)", in the order chosen
};
SpherePattern BestSpherePattern(const FitResiduals& fit);

/// The share of a signal (file order, mm; e.g. what an effect added to the fitted readings) that
/// is a pattern fixed on the sphere: of its part outside the columns of the fit's Jacobian, the
/// fraction that spherical harmonics of degree 2..5 of the direction from the centre explain.
double SpherePatternFraction(const FitResiduals& fit, const std::vector<double>& signal_mm);

/// P(F(d1, d2) >= f), the upper tail of Fisher's F distribution.
double FUpperTail(double f, double d1, double d2);

}  // namespace sph

#endif  // SPH_CALIB_RESIDUAL_STRUCTURE_HPP_
