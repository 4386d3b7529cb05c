#include "sph/select/residual_structure.hpp"

#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdlib>
#include <limits>

#include "block_factor.hpp"
#include "effect_fit_rows.hpp"
#include "sph/stats/gum.hpp"
#include "sph/internal/format.hpp"
#include "sph/model/row_qr.hpp"
#include "sph/model/spherical_harmonics.hpp"
#include "sph/model/units.hpp"

namespace sph {
namespace {

using internal::Format;

constexpr int kThetaHarmonics = 8;
constexpr int kPhiTerms = 6;
constexpr int kPowers = 3;
constexpr int kDirectionTerms = 6;  // d_theta (1, cos theta, sin theta), d_phi (1, cos phi, sin phi)
constexpr int kSphereDegree = kSpherePatternDegree;
// A function whose remainder off the Jacobian (and the functions kept before it) is below this
// fraction of itself is dropped (see Regress()).
constexpr double kMinRemainder = 1e-2;

// One group of functions as the regression sees it: its columns (of R, see the header) and names.
struct Basis {
  std::string variable, description;
  Eigen::MatrixXd columns;
  std::vector<std::string> names;
  Eigen::VectorXd norms;  ///< of the columns before projection (StructureFactor::norms); empty: theirs

  double NormOf(Eigen::Index j) const { return norms.size() > 0 ? norms(j) : columns.col(j).norm(); }
};

// Regresses e on the columns of `basis` projected off `q` (orthonormal basis of col(J)); vectors
// in the coordinates of R, m the number of readings.
StructureGroup Regress(const Basis& basis, const Eigen::MatrixXd& q, const Eigen::VectorXd& e, int n_fit,
                       Eigen::Index m) {
  StructureGroup g;
  g.variable = basis.variable;
  g.description = basis.description;
  // Gram-Schmidt of the unit columns against col(J) and against the columns kept before them. A
  // column whose remainder is below 1 % of itself is dropped: it adds little that J and the
  // columns before it do not hold. The bound does not make the test exact; the evaluation at the
  // readings where the fitted residual vanishes does (see the header): with it, after a probe gain
  // fitted at 1 mm eccentricity, p spreads over (0, 1) with the bound at 1 %, 0.1 % or 0.01 %.
  Eigen::MatrixXd b(e.size(), basis.columns.cols());
  Eigen::Index kept = 0;
  for (Eigen::Index j = 0; j < basis.columns.cols(); ++j) {
    const double norm = basis.NormOf(j);
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
    const double norm = basis.NormOf(j);
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
  return gum::RegularizedBeta(d2 / (d2 + d1 * f), d2 / 2.0, d1 / 2.0);
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

constexpr int kSphereFunctions = (kSphereDegree + 1) * (kSphereDegree + 1) - 4;  // degrees 2..5
constexpr int kFunctions = 2 * kThetaHarmonics + kPhiTerms + 2 * kPowers + kDirectionTerms + kSphereFunctions;
constexpr int kSphereFirst = kFunctions - kSphereFunctions;  // the sphere group is the last

// The groups of functions of the readings (see the header), as columns first.. first + count of
// the kFunctions functions.
struct Group {
  std::string variable, description;
  int first = 0, count = 0;
  std::vector<std::string> names;
};

constexpr std::size_t kSphereGroup = 5;

const std::vector<Group>& Groups() {
  static const std::vector<Group> groups = [] {
    std::vector<Group> g(6);
    g[0] = {"theta", "harmonics k = 1.." + std::to_string(kThetaHarmonics) + " of theta", 0, 2 * kThetaHarmonics, {}};
    g[1] = {"phi", "cos(k phi), k = 1.." + std::to_string(kPhiTerms), 2 * kThetaHarmonics, kPhiTerms, {}};
    g[2] = {"r", "powers 1..3 of the probe reading", g[1].first + kPhiTerms, kPowers, {}};
    g[3] = {"t", "powers 1..3 of the acquisition time", g[2].first + kPowers, kPowers, {}};
    g[4] = {"direction",
            "the direction of motion: d_theta and d_theta cos, sin theta; d_phi and d_phi cos, sin phi (d = +-1, "
            "the direction in which the axis approached the reading)",
            g[3].first + kPowers,
            kDirectionTerms,
            {"d_theta", "d_theta cos(theta)", "d_theta sin(theta)", "d_phi", "d_phi cos(phi)", "d_phi sin(phi)"}};
    g[5] = {"sphere",
            "spherical harmonics of degree 2.." + std::to_string(kSphereDegree) +
                " of the direction from the centre (a pattern fixed on the sphere)",
            kSphereFirst,
            kSphereFunctions,
            {}};
    for (int k = 1; k <= kThetaHarmonics; ++k) {
      g[0].names.push_back("cos(" + std::to_string(k) + " theta)");
      g[0].names.push_back("sin(" + std::to_string(k) + " theta)");
    }
    for (int k = 1; k <= kPhiTerms; ++k) g[1].names.push_back("cos(" + std::to_string(k) + " phi)");
    for (int k = 1; k <= kPowers; ++k) {
      g[2].names.push_back("u^" + std::to_string(k));
      g[3].names.push_back("tau^" + std::to_string(k));
    }
    for (int l = 2; l <= kSphereDegree; ++l) {
      for (int mm = -l; mm <= l; ++mm) g[5].names.push_back("S(" + std::to_string(l) + "," + std::to_string(mm) + ")");
    }
    return g;
  }();
  return groups;
}

// The kFunctions functions at one sample, harmonics by the angle-addition recurrence; u of the
// reading at which the fit's residual vanishes, `expected_r_mm` (see the header); `approach` the
// direction in which its axes came to it.
void FunctionsAt(const Sample& s, double expected_r_mm, const EffectReference& ref, MotionDirection approach,
                 const Eigen::Vector3d& dir, SchmidtHarmonics& sphere, double* out) {
  auto harmonics = [](double angle, int orders, double* cos_k, double* sin_k) {
    const double c1 = std::cos(angle), s1 = std::sin(angle);
    double c = c1, sn = s1;
    for (int k = 1; k <= orders; ++k) {
      cos_k[k - 1] = c;
      sin_k[k - 1] = sn;
      const double next = c * c1 - sn * s1;
      sn = sn * c1 + c * s1;
      c = next;
    }
  };
  double cos_k[kThetaHarmonics], sin_k[kThetaHarmonics];
  harmonics(s.theta_rad(), kThetaHarmonics, cos_k, sin_k);
  for (int k = 1; k <= kThetaHarmonics; ++k) {
    out[2 * k - 2] = cos_k[k - 1];
    out[2 * k - 1] = sin_k[k - 1];
  }
  double* phi = out + 2 * kThetaHarmonics;
  harmonics(s.phi_rad(), kPhiTerms, phi, sin_k);
  const double u = (expected_r_mm - ref.r_ref_mm) / ref.r_half_range_mm;
  const double tau = (s.t_s - ref.t_start_s) / ref.t_span_s;
  double* powers = phi + kPhiTerms;
  for (int k = 0; k < kPowers; ++k) {
    powers[k] = k == 0 ? u : powers[k - 1] * u;
    powers[kPowers + k] = k == 0 ? tau : powers[kPowers + k - 1] * tau;
  }
  double* direction = powers + 2 * kPowers;
  const double dt = approach.theta, dp = approach.phi;
  direction[0] = dt;
  direction[1] = dt * cos_k[0];
  direction[2] = dt * std::sin(s.theta_rad());
  direction[3] = dp;
  direction[4] = dp * phi[0];
  direction[5] = dp * std::sin(s.phi_rad());
  sphere.Evaluate(dir.x(), dir.y(), dir.z(), out + kSphereFirst);
}

// The norm of column j of the factor's [J | functions | e] over all the rows.
double NormOf(const StructureFactor& factor, Eigen::Index j) {
  return factor.norms.size() > 0 ? factor.norms(j) : factor.r.col(j).norm();
}

// Orthonormal basis of the column space of the factor's J columns (their numerical rank, without
// the eliminated ones), in R's coordinates; the columns equilibrated by their norms over all rows.
Eigen::MatrixXd ColumnSpace(const StructureFactor& factor) {
  Eigen::MatrixXd jn = factor.r.leftCols(factor.jacobian_cols);
  for (Eigen::Index j = 0; j < jn.cols(); ++j) {
    const double norm = NormOf(factor, j);
    if (norm > 0.0) jn.col(j) /= norm;
  }
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(jn);
  qr.setThreshold(1e-12);
  return qr.householderQ() * Eigen::MatrixXd::Identity(jn.rows(), qr.rank());
}

// The norms of `count` columns of the factor from `first` (Basis::norms), empty when R has them.
Eigen::VectorXd Norms(const StructureFactor& factor, Eigen::Index first, Eigen::Index count) {
  return factor.norms.size() > 0 ? Eigen::VectorXd(factor.norms.segment(first, count)) : Eigen::VectorXd();
}

Basis GroupBasis(const StructureFactor& factor, const Group& group, Eigen::Index first_function) {
  const Eigen::Index first = factor.jacobian_cols + first_function + group.first;
  return {group.variable, group.description, factor.r.middleCols(first, group.count), group.names,
          Norms(factor, first, group.count)};
}

}  // namespace

void DenseJacobianBlocks::ForEach(const BlockFn& fn) const {
  constexpr Eigen::Index kBlock = 128;
  std::vector<std::uint32_t> samples(kBlock);
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> rows;
  for (Eigen::Index first = 0; first < jacobian_.rows(); first += kBlock) {
    const Eigen::Index count = std::min(kBlock, jacobian_.rows() - first);
    for (Eigen::Index i = 0; i < count; ++i)
      samples[static_cast<std::size_t>(i)] = static_cast<std::uint32_t>(first + i);
    rows = jacobian_.middleRows(first, count);
    fn(samples.data(), static_cast<int>(count), rows.data(), static_cast<int>(rows.cols()), -1);
  }
}

std::vector<double> ExpectedReadings(const PointsData& points, const CalibrationOptions& options,
                                     const EffectFit& fit) {
  // The secant method on each reading, from r and r + e (a slope of -1: a probe aimed at the
  // centre); the residual is nearly linear in r, and two or three steps reach the tolerance. Block
  // by block of readings, in memory O(kBlock) for any file.
  constexpr double kToleranceMm = 1e-12;
  constexpr int kMaxSteps = 8;
  constexpr std::size_t kBlock = 4096;
  std::vector<double> out(points.samples.size());
  PointsData at;
  at.source = points.source;
  at.header = points.header;
  const std::vector<MotionDirection> approach = MotionDirections(points.samples);  // of the whole file
  std::vector<MotionDirection> approach_of_block;
  for (std::size_t first = 0; first < points.samples.size(); first += kBlock) {
    const auto begin = points.samples.begin() + static_cast<std::ptrdiff_t>(first);
    const auto count = static_cast<std::ptrdiff_t>(std::min(kBlock, points.samples.size() - first));
    at.samples.assign(begin, begin + count);
    approach_of_block.assign(approach.begin() + static_cast<std::ptrdiff_t>(first),
                             approach.begin() + static_cast<std::ptrdiff_t>(first) + count);
    std::vector<double> prev_r(at.samples.size()),
        prev_e = internal::EffectResidualsOf(at, options, fit, approach_of_block);
    for (std::size_t i = 0; i < at.samples.size(); ++i) {
      prev_r[i] = at.samples[i].r_mm;
      at.samples[i].r_mm += prev_e[i];
    }
    for (int step = 0; step < kMaxSteps; ++step) {
      const std::vector<double> e = internal::EffectResidualsOf(at, options, fit, approach_of_block);
      bool moved = false;
      for (std::size_t i = 0; i < e.size(); ++i) {
        double& r = at.samples[i].r_mm;
        const double slope = (e[i] - prev_e[i]) / (r - prev_r[i]);
        if (!(std::abs(e[i]) > kToleranceMm) || !std::isfinite(slope) || slope == 0.0) continue;
        prev_r[i] = r;
        prev_e[i] = e[i];
        r -= e[i] / slope;
        moved = true;
      }
      if (!moved) break;
    }
    for (std::size_t i = 0; i < at.samples.size(); ++i) out[first + i] = at.samples[i].r_mm;
  }
  return out;
}

StructureFactor FactorResidualStructure(const FitResiduals& fit, const std::vector<double>* signal_mm) {
  StructureFactor factor;
  factor.has_signal = signal_mm != nullptr;
  const Eigen::Index n = fit.jacobian.Cols();
  const Eigen::Index functions_cols = (factor.has_signal ? kSphereFunctions : kFunctions) + 1;
  // With many groups of rows each group's three own columns are eliminated from its rows first
  // (block_factor.hpp's reasoning): R holds the shared columns, the functions and e.
  const std::vector<Eigen::Index> group_columns = fit.jacobian.GroupColumns();
  const auto groups = static_cast<int>(group_columns.size());
  const bool eliminate = groups > 0 && internal::AnalyseByBlocks(groups, static_cast<int>(n) - 3 * groups);
  std::vector<Eigen::Index> shared;  // the columns of J that R keeps
  {
    std::vector<bool> own(static_cast<std::size_t>(n), false);
    if (eliminate) {
      for (const Eigen::Index c : group_columns) {
        for (int k = 0; k < 3; ++k) own[static_cast<std::size_t>(c + k)] = true;
      }
    }
    for (Eigen::Index j = 0; j < n; ++j) {
      if (!own[static_cast<std::size_t>(j)]) shared.push_back(j);
    }
  }
  const auto ns = static_cast<Eigen::Index>(shared.size());
  factor.jacobian_cols = ns;
  const Eigen::Index cols = ns + functions_cols;          // [shared J | functions | e]
  const Eigen::Index local = (eliminate ? 3 : 0) + cols;  // a group's rows: [own | shared J | functions | e]
  RowQr qr(cols), group_qr;
  Eigen::VectorXd norms2 = Eigen::VectorXd::Zero(cols);
  if (eliminate) factor.gram = Eigen::MatrixXd::Zero(functions_cols, functions_cols);
  int current = -1;
  auto fold_group = [&] {
    if (current < 0) return;
    // What the group's rows leave of the other columns, off its own three: rows 3.. of its factor.
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> rest =
        group_qr.r().bottomRightCorner(cols, cols);
    qr.AddRows(rest.data(), cols, cols);
    Eigen::Matrix3d own = group_qr.r().topLeftCorner<3, 3>();
    for (int k = 0; k < 3; ++k) {
      const double norm = own.col(k).norm();
      if (norm > 0.0) own.col(k) /= norm;
    }
    Eigen::ColPivHouseholderQR<Eigen::Matrix3d> rank(own);
    rank.setThreshold(1e-12);
    factor.eliminated += rank.rank();
  };
  std::vector<double> block, functions(kFunctions);
  SchmidtHarmonics sphere(2, kSphereDegree);
  // An axis approached the same way at every reading has no direction to test: its functions are
  // left out (zero), for they would only repeat the other groups' (d_theta cos theta = cos theta).
  std::vector<MotionDirection> approach = MotionDirections(fit.points.samples);
  bool theta_turns = false, phi_turns = false;
  for (const MotionDirection& d : approach) {
    theta_turns |= d.theta != approach.front().theta;
    phi_turns |= d.phi != approach.front().phi;
  }
  for (MotionDirection& d : approach) {
    if (!theta_turns) d.theta = 0;
    if (!phi_turns) d.phi = 0;
  }
  fit.jacobian.ForEach([&](const std::uint32_t* samples, int count, const double* jac, int stride, int group) {
    if (eliminate && group != current) {
      fold_group();
      current = group;
      group_qr.Reset(local);
    }
    const Eigen::Index own_first = eliminate ? group_columns[static_cast<std::size_t>(group)] : 0;
    block.resize(static_cast<std::size_t>(count * local));
    for (int i = 0; i < count; ++i) {
      const std::uint32_t sample = samples[i];
      double* row = block.data() + i * local;
      const double* in = jac + i * stride;
      if (eliminate) {
        for (int k = 0; k < 3; ++k) *row++ = in[own_first + k];
      }
      for (Eigen::Index j = 0; j < ns; ++j) row[j] = in[shared[static_cast<std::size_t>(j)]];
      FunctionsAt(fit.points.samples[sample], fit.expected_r_mm[sample], fit.reference, approach[sample],
                  fit.directions[sample], sphere, functions.data());
      if (factor.has_signal) {
        std::copy(functions.begin() + kSphereFirst, functions.end(), row + ns);
        row[cols - 1] = (*signal_mm)[sample];
      } else {
        std::copy(functions.begin(), functions.end(), row + ns);
        row[cols - 1] = fit.residuals_mm[sample];
      }
      if (eliminate) {
        for (Eigen::Index j = 0; j < cols; ++j) norms2(j) += row[j] * row[j];
        const Eigen::Map<const Eigen::VectorXd> tail(row + ns, functions_cols);
        factor.gram.selfadjointView<Eigen::Lower>().rankUpdate(tail);
      }
    }
    (eliminate ? group_qr : qr).AddRows(block.data(), local, count);
    factor.rows += count;
  });
  if (eliminate) {
    fold_group();
    factor.norms = norms2.cwiseSqrt();
    factor.gram = factor.gram.selfadjointView<Eigen::Lower>();
  }
  factor.r = qr.r();
  return factor;
}

ResidualStructure AnalyseResidualStructure(const StructureFactor& factor) {
  const Eigen::Index m = factor.rows;
  const Eigen::Index n = factor.jacobian_cols;
  const Eigen::VectorXd e = factor.r.col(n + kFunctions);
  const Eigen::MatrixXd q = ColumnSpace(factor);
  // The Jacobian's rank: the parameters the fit determines.
  const int n_fit = static_cast<int>(q.cols() + factor.eliminated);

  ResidualStructure out;
  Basis all{"all", "all of the above", factor.r.middleCols(n, kFunctions), {}, Norms(factor, n, kFunctions)};
  for (const Group& group : Groups()) {
    out.groups.push_back(Regress(GroupBasis(factor, group, 0), q, e, n_fit, m));
    all.names.insert(all.names.end(), group.names.begin(), group.names.end());
  }
  out.all = Regress(all, q, e, n_fit, m);
  for (int k = 1; k <= kThetaHarmonics; ++k) {
    const Eigen::MatrixXd two = factor.r.middleCols(n + 2 * k - 2, 2);
    // Fitted alone: on the functions as they are (before the elimination of the centres, if any).
    const Eigen::Vector2d coef = factor.gram.size() == 0
                                     ? Eigen::Vector2d(two.colPivHouseholderQr().solve(e))
                                     : Eigen::Vector2d(factor.gram.block<2, 2>(2 * k - 2, 2 * k - 2)
                                                           .colPivHouseholderQr()
                                                           .solve(factor.gram.block<2, 1>(2 * k - 2, kFunctions)));
    out.theta_harmonics_um.push_back(coef.norm() * kUmPerMm);
    out.theta_harmonic_p.push_back(
        Regress({"theta", "", two, {"cos", "sin"}, Norms(factor, n + 2 * k - 2, 2)}, q, e, n_fit, m).p_value);
  }
  for (int k = 1; k <= kPhiTerms; ++k) {
    const Eigen::Index col = n + 2 * kThetaHarmonics + k - 1;
    out.phi_cos_p.push_back(
        Regress({"phi", "", factor.r.middleCols(col, 1), {"cos"}, Norms(factor, col, 1)}, q, e, n_fit, m).p_value);
  }
  return out;
}

ResidualStructure AnalyseResidualStructure(const FitResiduals& fit) {
  return AnalyseResidualStructure(FactorResidualStructure(fit));
}

double SubsetSearchPenalty(int searched, int kept) {
  if (kept <= 0 || kept >= searched) return 0.0;
  return 2.0 * (std::lgamma(searched + 1.0) - std::lgamma(kept + 1.0) - std::lgamma(searched - kept + 1.0));
}

SpherePattern BestSpherePattern(const StructureFactor& factor) {
  const Group& group = Groups()[kSphereGroup];
  return BestPatternAmong(factor, factor.jacobian_cols + group.first, group.count, group.names);
}

SpherePattern BestPatternAmong(const StructureFactor& factor, Eigen::Index first, Eigen::Index count,
                               const std::vector<std::string>& names_of) {
  const auto m = factor.rows;
  const Eigen::VectorXd e = factor.r.col(factor.r.cols() - 1);
  const Eigen::MatrixXd q = ColumnSpace(factor);
  const Basis sphere{"sphere", "", factor.r.middleCols(first, count), names_of, Norms(factor, first, count)};
  // Unit remainders of the functions off col(J), as in Regress().
  std::vector<Eigen::VectorXd> rest;
  std::vector<std::string> names;
  for (Eigen::Index j = 0; j < sphere.columns.cols(); ++j) {
    const double norm = sphere.NormOf(j);
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
    const int kept = static_cast<int>(step) + 1;
    const double next_bic = static_cast<double>(m) * std::log(std::max(rss - gain, 1e-300) / rss0) + kept * log_m +
                            SubsetSearchPenalty(static_cast<int>(rest.size()), kept);
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

SpherePattern BestSpherePattern(const FitResiduals& fit) { return BestSpherePattern(FactorResidualStructure(fit)); }

double SpherePatternFraction(const StructureFactor& factor) {
  const Eigen::Index m = factor.rows;
  const Eigen::Index n = factor.jacobian_cols;
  const Eigen::MatrixXd q = ColumnSpace(factor);
  const Eigen::VectorXd raw = factor.r.col(n + kSphereFunctions);
  const Eigen::VectorXd s = raw - q * (q.transpose() * raw);
  const double total = s.squaredNorm();
  if (!(total > 0.0)) return 0.0;
  // The sphere group's columns follow J directly in a factor with a signal.
  const StructureGroup g = Regress(GroupBasis(factor, Groups()[kSphereGroup], -kSphereFirst), q, s,
                                   static_cast<int>(q.cols() + factor.eliminated), m);
  const double explained = g.explained_rms_um * g.explained_rms_um / (kUmPerMm * kUmPerMm) * static_cast<double>(m);
  return explained / total;
}

double DeltaBicBeyondSphere(const StructureFactor& factor, const std::string& variable,
                            const std::vector<int>& functions) {
  const Eigen::Index m = factor.rows;
  const Eigen::Index n = factor.jacobian_cols;
  const Eigen::VectorXd e = factor.r.col(n + kFunctions);
  const Group* group = nullptr;
  for (const Group& g : Groups()) {
    if (g.variable == variable) group = &g;
  }
  if (group == nullptr || variable == "sphere") return 0.0;
  // With A = Q R, |A_S x - e| = |R_S x - r_e| for any set S of columns: the fits come from R alone.
  // The columns equilibrated, so that the rank decision does not depend on their units.
  auto rss_and_rank = [&](const Eigen::MatrixXd& a, const std::vector<double>& norms, Eigen::Index* rank) {
    Eigen::MatrixXd an = a;
    for (Eigen::Index j = 0; j < an.cols(); ++j) {
      const double norm = norms[static_cast<std::size_t>(j)];
      if (norm > 0.0) an.col(j) /= norm;
    }
    Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(an);
    qr.setThreshold(1e-10);
    *rank = qr.rank();
    return (e - an * qr.solve(e)).squaredNorm();
  };
  std::vector<Eigen::Index> columns;  // of R: J, the sphere's functions, then the variable's
  for (Eigen::Index j = 0; j < n; ++j) columns.push_back(j);
  for (Eigen::Index j = 0; j < kSphereFunctions; ++j) columns.push_back(n + kSphereFirst + j);
  const auto base_cols = static_cast<Eigen::Index>(columns.size());
  for (const int k : functions) columns.push_back(n + group->first + k);
  Eigen::MatrixXd with(factor.r.rows(), static_cast<Eigen::Index>(columns.size()));
  std::vector<double> norms;
  for (std::size_t k = 0; k < columns.size(); ++k) {
    with.col(static_cast<Eigen::Index>(k)) = factor.r.col(columns[k]);
    norms.push_back(NormOf(factor, columns[k]));
  }
  Eigen::Index rank0 = 0, rank1 = 0;
  const double rss0 = rss_and_rank(with.leftCols(base_cols), norms, &rank0), rss1 = rss_and_rank(with, norms, &rank1);
  if (!(rss0 > 0.0)) return 0.0;
  return static_cast<double>(m) * std::log(std::max(rss1, 1e-300) / rss0) +
         static_cast<double>(rank1 - rank0) * std::log(static_cast<double>(m));
}

double SpherePatternFraction(const FitResiduals& fit, const std::vector<double>& signal_mm) {
  return SpherePatternFraction(FactorResidualStructure(fit, &signal_mm));
}

}  // namespace sph
