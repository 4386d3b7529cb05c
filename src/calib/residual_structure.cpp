#include "sph/calib/residual_structure.hpp"

#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <limits>

#include "sph/internal/format.hpp"
#include "sph/model/spherical_harmonics.hpp"
#include "sph/model/units.hpp"

namespace sph {
namespace {

using internal::Format;

constexpr int kThetaHarmonics = 8;
constexpr int kPhiTerms = 6;
constexpr int kPowers = 3;
constexpr int kSphereDegree = 5;

// Continued fraction of the regularised incomplete beta function (modified Lentz).
double BetaContinuedFraction(double a, double b, double x) {
  constexpr double kTiny = 1e-300;
  double c = 1.0, d = 1.0 - (a + b) * x / (a + 1.0);
  if (std::abs(d) < kTiny) d = kTiny;
  d = 1.0 / d;
  double h = d;
  for (int m = 1; m <= 500; ++m) {
    const double m2 = 2.0 * m;
    double aa = m * (b - m) * x / ((a - 1.0 + m2) * (a + m2));
    d = 1.0 + aa * d;
    d = std::abs(d) < kTiny ? 1.0 / kTiny : 1.0 / d;
    c = 1.0 + aa / c;
    if (std::abs(c) < kTiny) c = kTiny;
    h *= d * c;
    aa = -(a + m) * (a + b + m) * x / ((a + m2) * (a + 1.0 + m2));
    d = 1.0 + aa * d;
    d = std::abs(d) < kTiny ? 1.0 / kTiny : 1.0 / d;
    c = 1.0 + aa / c;
    if (std::abs(c) < kTiny) c = kTiny;
    const double del = d * c;
    h *= del;
    if (std::abs(del - 1.0) < 1e-15) break;
  }
  return h;
}

// I_x(a, b).
double IncompleteBeta(double a, double b, double x) {
  if (x <= 0.0) return 0.0;
  if (x >= 1.0) return 1.0;
  const double front =
      std::exp(std::lgamma(a + b) - std::lgamma(a) - std::lgamma(b) + a * std::log(x) + b * std::log1p(-x));
  if (x < (a + 1.0) / (a + b + 2.0)) return front * BetaContinuedFraction(a, b, x) / a;
  return 1.0 - front * BetaContinuedFraction(b, a, 1.0 - x) / b;
}

struct Basis {
  std::string variable, description;
  Eigen::MatrixXd columns;
  std::vector<std::string> names;
};

// Regresses e on the columns of `basis` projected off `q` (orthonormal basis of col(J)).
StructureGroup Regress(const Basis& basis, const Eigen::MatrixXd& q, const Eigen::VectorXd& e, int n_fit) {
  StructureGroup g;
  g.variable = basis.variable;
  g.description = basis.description;
  const Eigen::Index m = e.size();
  // Gram-Schmidt of the unit columns against col(J) and against the columns kept before them. A
  // column whose remainder is below 1 % of itself is dropped: the functions are computed at the
  // readings the fit expects, which still carry the part of the noise the fit absorbed, and a
  // small remainder is mostly that part, amplified; regressing the residual on it would fit the
  // noise with itself. (At 0.1 %, the union of all groups after a fit with a probe gain showed
  // p = 1e-7 on white noise; at 1 %, p spreads over (0, 1) as it should.)
  constexpr double kMinRemainder = 1e-2;
  Eigen::MatrixXd b(m, basis.columns.cols());
  Eigen::Index kept = 0;
  for (Eigen::Index j = 0; j < basis.columns.cols(); ++j) {
    const double norm = basis.columns.col(j).norm();
    if (!(norm > 0.0)) continue;
    Eigen::VectorXd rest = basis.columns.col(j) / norm;
    for (int pass = 0; pass < 2; ++pass) {  // twice: classical Gram-Schmidt loses orthogonality once
      rest -= q * (q.transpose() * rest);
      rest -= b.leftCols(kept) * (b.leftCols(kept).transpose() * rest);
    }
    const double left = rest.norm();
    if (left >= kMinRemainder) b.col(kept++) = rest / left;
  }
  g.rank = static_cast<int>(kept);
  const double rss = e.squaredNorm();
  if (g.rank == 0 || m - n_fit - g.rank <= 0) return g;
  const double explained = (b.leftCols(kept).transpose() * e).squaredNorm();
  g.explained_rms_um = std::sqrt(explained / static_cast<double>(m)) * kUmPerMm;
  const double d2 = static_cast<double>(m - n_fit - g.rank);
  g.delta_bic = static_cast<double>(m) * std::log(std::max(rss - explained, 1e-300) / std::max(rss, 1e-300)) +
                g.rank * std::log(static_cast<double>(m));
  const double rest = std::max(rss - explained, std::numeric_limits<double>::min());
  g.f = (explained / g.rank) / (rest / d2);
  g.p_value = FUpperTail(g.f, g.rank, d2);
  // The single function that explains most, with its coefficient in the raw (unprojected) units.
  double best = -1.0;
  for (Eigen::Index j = 0; j < basis.columns.cols(); ++j) {
    const double norm = basis.columns.col(j).norm();
    if (!(norm > 0.0)) continue;
    const Eigen::VectorXd col = basis.columns.col(j) - q * (q.transpose() * basis.columns.col(j));
    const double nn = col.squaredNorm();
    if (!(std::sqrt(nn) >= kMinRemainder * norm)) continue;
    const double dot = col.dot(e);
    if (dot * dot / nn > best) {
      best = dot * dot / nn;
      g.strongest = basis.names[static_cast<std::size_t>(j)];
      g.strongest_rms_um = std::abs(dot) / std::sqrt(nn * static_cast<double>(m)) * kUmPerMm;
    }
  }
  return g;
}

}  // namespace

double FUpperTail(double f, double d1, double d2) {
  if (!(f > 0.0)) return 1.0;
  return IncompleteBeta(d2 / 2.0, d1 / 2.0, d2 / (d2 + d1 * f));
}

int ResidualStructure::Strongest() const {
  int best = -1;
  for (std::size_t i = 0; i < groups.size(); ++i) {
    if (best < 0 || groups[i].p_value < groups[static_cast<std::size_t>(best)].p_value ||
        (groups[i].p_value == groups[static_cast<std::size_t>(best)].p_value &&
         groups[i].explained_rms_um > groups[static_cast<std::size_t>(best)].explained_rms_um)) {
      best = static_cast<int>(i);
    }
  }
  return best;
}

namespace {

// The groups of functions of the readings (see the header); `e` is the fit's residual, used to
// take u from the reading the fit expects.
std::vector<Basis> BuildBases(const PointsData& points, const Eigen::VectorXd& e, const EffectReference& ref,
                              const std::vector<Eigen::Vector3d>& directions) {
  const auto m = static_cast<Eigen::Index>(points.samples.size());
  std::vector<Basis> bases(5);
  bases[0] = {"theta", "harmonics k = 1.." + std::to_string(kThetaHarmonics) + " of theta", Eigen::MatrixXd(m, 2 * kThetaHarmonics), {}};
  bases[1] = {"phi", "cos(k phi), k = 1.." + std::to_string(kPhiTerms), Eigen::MatrixXd(m, kPhiTerms), {}};
  bases[2] = {"r", "powers 1..3 of the probe reading", Eigen::MatrixXd(m, kPowers), {}};
  bases[3] = {"t", "powers 1..3 of the acquisition time", Eigen::MatrixXd(m, kPowers), {}};
  const int n_sphere = (kSphereDegree + 1) * (kSphereDegree + 1) - 4;  // degrees 2..5
  bases[4] = {"sphere", "spherical harmonics of degree 2.." + std::to_string(kSphereDegree) +
                            " of the direction from the centre (a pattern fixed on the sphere)",
              Eigen::MatrixXd(m, n_sphere), {}};
  for (int k = 1; k <= kThetaHarmonics; ++k) {
    bases[0].names.push_back("cos(" + std::to_string(k) + " theta)");
    bases[0].names.push_back("sin(" + std::to_string(k) + " theta)");
  }
  for (int k = 1; k <= kPhiTerms; ++k) bases[1].names.push_back("cos(" + std::to_string(k) + " phi)");
  for (int k = 1; k <= kPowers; ++k) {
    bases[2].names.push_back("u^" + std::to_string(k));
    bases[3].names.push_back("tau^" + std::to_string(k));
  }
  for (int l = 2; l <= kSphereDegree; ++l) {
    for (int mm = -l; mm <= l; ++mm) bases[4].names.push_back("S(" + std::to_string(l) + "," + std::to_string(mm) + ")");
  }
  for (Eigen::Index i = 0; i < m; ++i) {
    const Sample& s = points.samples[static_cast<std::size_t>(i)];
    const double th = s.theta_deg * kRadPerDeg, ph = s.phi_deg * kRadPerDeg;
    for (int k = 1; k <= kThetaHarmonics; ++k) {
      bases[0].columns(i, 2 * k - 2) = std::cos(k * th);
      bases[0].columns(i, 2 * k - 1) = std::sin(k * th);
    }
    for (int k = 1; k <= kPhiTerms; ++k) bases[1].columns(i, k - 1) = std::cos(k * ph);
    // u of the reading the fit expects, r + e (de/dr is -1 for a probe aimed at the centre): the
    // measured r carries the very noise the residual is, and powers of it would fit that noise.
    // (The Jacobian to project off is evaluated there too: EffectFit::structure_jacobian.)
    const double u = (s.r_mm + e(i) - ref.r_ref_mm) / ref.r_half_range_mm;
    const double tau = (s.t_s - ref.t_start_s) / ref.t_span_s;
    for (int k = 1; k <= kPowers; ++k) {
      bases[2].columns(i, k - 1) = std::pow(u, k);
      bases[3].columns(i, k - 1) = std::pow(tau, k);
    }
    const Eigen::Vector3d& dir = directions[static_cast<std::size_t>(i)];
    const double lon = std::atan2(dir.y(), dir.x());
    int col = 0;
    for (int l = 2; l <= kSphereDegree; ++l) {
      for (int mm = -l; mm <= l; ++mm) bases[4].columns(i, col++) = SchmidtHarmonic(l, mm, lon, dir.z());
    }
  }
  return bases;
}

// Orthonormal basis of the Jacobian's column space (its numerical rank).
Eigen::MatrixXd ColumnSpace(const Eigen::MatrixXd& jacobian) {
  Eigen::MatrixXd jn = jacobian;
  for (Eigen::Index j = 0; j < jn.cols(); ++j) {
    const double norm = jn.col(j).norm();
    if (norm > 0.0) jn.col(j) /= norm;
  }
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(jn);
  qr.setThreshold(1e-12);
  return qr.householderQ() * Eigen::MatrixXd::Identity(jn.rows(), qr.rank());
}

}  // namespace

ResidualStructure AnalyseResidualStructure(const FitResiduals& fit) {
  const PointsData& points = fit.points;
  const auto m = static_cast<Eigen::Index>(points.samples.size());
  const Eigen::Map<const Eigen::VectorXd> e(fit.residuals_mm.data(), m);
  const std::vector<Basis> bases = BuildBases(points, e, fit.reference, fit.directions);
  Basis all{"all", "all of the above", Eigen::MatrixXd(m, 0), {}};
  for (const Basis& b : bases) {
    Eigen::MatrixXd joined(m, all.columns.cols() + b.columns.cols());
    joined << all.columns, b.columns;
    all.columns = joined;
    all.names.insert(all.names.end(), b.names.begin(), b.names.end());
  }
  const Eigen::MatrixXd q = ColumnSpace(fit.jacobian);
  const int n_fit = static_cast<int>(q.cols());  // the Jacobian's rank: the parameters the fit determines

  ResidualStructure out;
  for (const Basis& b : bases) out.groups.push_back(Regress(b, q, e, n_fit));
  out.all = Regress(all, q, e, n_fit);
  for (int k = 1; k <= kThetaHarmonics; ++k) {
    Eigen::MatrixXd two(m, 2);
    two << bases[0].columns.col(2 * k - 2), bases[0].columns.col(2 * k - 1);
    const Eigen::Vector2d coef = two.colPivHouseholderQr().solve(e);
    out.theta_harmonics_um.push_back(coef.norm() * kUmPerMm);
  }
  return out;
}

SpherePattern BestSpherePattern(const FitResiduals& fit) {
  const auto m = static_cast<Eigen::Index>(fit.points.samples.size());
  const Eigen::Map<const Eigen::VectorXd> e(fit.residuals_mm.data(), m);
  const Eigen::MatrixXd q = ColumnSpace(fit.jacobian);
  const Basis sphere = BuildBases(fit.points, e, fit.reference, fit.directions)[4];
  // Unit remainders of the functions off col(J), as in Regress().
  constexpr double kMinRemainder = 1e-2;
  std::vector<Eigen::VectorXd> rest;
  std::vector<std::string> names;
  for (Eigen::Index j = 0; j < sphere.columns.cols(); ++j) {
    const double norm = sphere.columns.col(j).norm();
    if (!(norm > 0.0)) continue;
    Eigen::VectorXd r = sphere.columns.col(j) / norm;
    r -= q * (q.transpose() * r);
    r -= q * (q.transpose() * r);
    if (r.norm() >= kMinRemainder) {
      rest.push_back(r);
      names.push_back(sphere.names[static_cast<std::size_t>(j)]);
    }
  }
  SpherePattern out;
  const double rss0 = e.squaredNorm(), log_m = std::log(static_cast<double>(m));
  double rss = rss0;
  Eigen::VectorXd left = e;
  std::vector<bool> used(rest.size(), false);
  for (std::size_t step = 0; step < rest.size(); ++step) {
    int best = -1;
    double gain = 0.0;
    for (std::size_t j = 0; j < rest.size(); ++j) {
      if (used[j]) continue;
      const double nn = rest[j].squaredNorm();
      if (!(nn >= kMinRemainder * kMinRemainder)) continue;
      const double g = std::pow(rest[j].dot(left), 2) / nn;
      if (g > gain) {
        gain = g;
        best = static_cast<int>(j);
      }
    }
    if (best < 0) break;
    const double next_bic = static_cast<double>(m) * std::log(std::max(rss - gain, 1e-300) / rss0) +
                            static_cast<double>(step + 1) * log_m;
    if (next_bic >= out.delta_bic) break;  // the BIC no longer falls
    out.delta_bic = next_bic;
    rss -= gain;
    const Eigen::VectorXd dir = rest[static_cast<std::size_t>(best)] / rest[static_cast<std::size_t>(best)].norm();
    left -= dir * dir.dot(left);
    used[static_cast<std::size_t>(best)] = true;
    out.functions.push_back(names[static_cast<std::size_t>(best)]);
    for (std::size_t j = 0; j < rest.size(); ++j) {
      if (!used[j]) rest[j] -= dir * dir.dot(rest[j]);  // keep the others orthogonal to what is chosen
    }
  }
  out.explained_rms_um = std::sqrt(std::max(rss0 - rss, 0.0) / static_cast<double>(m)) * kUmPerMm;
  return out;
}

double SpherePatternFraction(const FitResiduals& fit, const std::vector<double>& signal_mm) {
  const auto m = static_cast<Eigen::Index>(fit.points.samples.size());
  const Eigen::Map<const Eigen::VectorXd> e(fit.residuals_mm.data(), m);
  const Eigen::MatrixXd q = ColumnSpace(fit.jacobian);
  const Eigen::Map<const Eigen::VectorXd> raw(signal_mm.data(), m);
  const Eigen::VectorXd s = raw - q * (q.transpose() * raw);
  const double total = s.squaredNorm();
  if (!(total > 0.0)) return 0.0;
  const StructureGroup g =
      Regress(BuildBases(fit.points, e, fit.reference, fit.directions)[4], q, s, static_cast<int>(q.cols()));
  const double explained = g.explained_rms_um * g.explained_rms_um / (kUmPerMm * kUmPerMm) * static_cast<double>(m);
  return explained / total;
}

}  // namespace sph
