#include "fit_problem.hpp"

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <cstring>
#include <map>

#include "sph/core/error.hpp"
#include "sph/model/residual_gradient.hpp"
#include "sph/model/spherical_harmonics.hpp"
#include "sph/model/units.hpp"

namespace sph::internal {
namespace {

constexpr int kRows = SphereFitProblem::kBlockRows;

// The kernels that take most of a calibration's time (the Gram matrix, the seven-error block) are
// also compiled for AVX2 on x86-64, and the CPU chooses at run time (HasAvx2()). AVX2 without FMA,
// and this file compiled without FMA contraction: the same operations, rounded the same, so results
// do not depend on the CPU. (A plain run-time test, not target_clones: that needs the C library's
// ifunc, which musl lacks, and cannot clone a template.)
#if defined(__x86_64__) && defined(__GNUC__)
#define SPH_AVX2_DISPATCH 1
bool HasAvx2() {
  static const bool avx2 = __builtin_cpu_supports("avx2");
  return avx2;
}
#else
#define SPH_AVX2_DISPATCH 0
#endif

// Where an effect component enters the residual (ResidualInputs).
enum Target : int {
  kDTheta = 0,
  kDPhi,
  kMotionX,
  kMotionY,
  kMotionZ,
  kWobbleX,
  kWobbleY,
  kPhiMotionX,
  kPhiMotionY,
  kPhiMotionZ,
  kTiltX,
  kTiltY,
  kDr,
  kNumTargets
};

// The basis function of one component.
enum class Basis { kThetaHarmonic, kPhiHarmonic, kU, kTau, kIncidence, kThetaDirection, kPhiDirection };

struct Component {
  Target target;
  Basis basis;
  int order;
  bool sine;
};

Target TargetOf(Effect e, int axis) {
  switch (e) {
    case Effect::kThetaEncoder:
    case Effect::kThetaReversal:
      return kDTheta;
    case Effect::kPhiEncoder:
    case Effect::kPhiReversal:
      return kDPhi;
    case Effect::kThetaRadialMotion:
      return axis == 0 ? kMotionX : kMotionY;
    case Effect::kThetaAxialMotion:
      return kMotionZ;
    case Effect::kPhiWobble:
      return axis == 0 ? kWobbleX : kWobbleY;
    case Effect::kPhiRadialMotion:
      return axis == 0 ? kPhiMotionX : kPhiMotionY;
    case Effect::kPhiAxialMotion:
      return kPhiMotionZ;
    case Effect::kThetaTiltMotion:
      return axis == 0 ? kTiltX : kTiltY;
    case Effect::kProbeGain:
    case Effect::kProbeNonlinearity:
    case Effect::kProbeDrift:
    case Effect::kProbeIncidence:
      break;
  }
  return kDr;
}

Basis BasisOf(Effect e) {
  const EffectInfo& info = InfoOf(e);
  if (info.harmonic) return std::strcmp(info.variable, "theta") == 0 ? Basis::kThetaHarmonic : Basis::kPhiHarmonic;
  if (e == Effect::kProbeIncidence) return Basis::kIncidence;
  if (e == Effect::kThetaReversal) return Basis::kThetaDirection;
  if (e == Effect::kPhiReversal) return Basis::kPhiDirection;
  return e == Effect::kProbeDrift ? Basis::kTau : Basis::kU;
}

double Partial(const ResidualGradient& d, Target t) {
  switch (t) {
    case kDTheta:
      return d.theta;
    case kDPhi:
      return d.phi;
    case kMotionX:
      return d.motion[0];
    case kMotionY:
      return d.motion[1];
    case kMotionZ:
      return d.motion[2];
    case kWobbleX:
      return d.wobble_x;
    case kWobbleY:
      return d.wobble_y;
    case kPhiMotionX:
      return d.phi_motion[0];
    case kPhiMotionY:
      return d.phi_motion[1];
    case kPhiMotionZ:
      return d.phi_motion[2];
    case kTiltX:
      return d.tilt_x;
    case kTiltY:
      return d.tilt_y;
    default:
      return d.z;
  }
}

// result += k * d for the derivatives with respect to every input of the residual but z (e and
// de/dz stay).
void AddScaled(const ResidualGradient& d, double k, ResidualGradient* result) {
  for (int j = 0; j < kNumScmsParams; ++j) result->geometry[j] += k * d.geometry[j];
  for (int j = 0; j < 3; ++j) {
    result->center[j] += k * d.center[j];
    result->motion[j] += k * d.motion[j];
    result->phi_motion[j] += k * d.phi_motion[j];
  }
  result->theta += k * d.theta;
  result->phi += k * d.phi;
  result->wobble_x += k * d.wobble_x;
  result->wobble_y += k * d.wobble_y;
  result->tilt_x += k * d.tilt_x;
  result->tilt_y += k * d.tilt_y;
}

// Dot products in four lanes: lane l sums the products of rows l, l + 4, l + 8, ... and the lanes
// are added as ((l0 + l1) + (l2 + l3)). Each lane is its own accumulator, so the sum vectorises
// without reassociating (a strict in-order sum does not), and the result is the same on every
// instruction set: AVX2 holds the four lanes in one register (FourLanes), the baseline's SSE2 in
// two (TwoPairs); the same operations in the same order. (GCC's and Clang's vector extension.)
template <int kSize>
using Vector [[gnu::vector_size(kSize * sizeof(double))]] = double;
template <int kSize>  // kSize values at p, which need only be aligned as a double (and may alias doubles)
using VectorAt [[gnu::vector_size(kSize * sizeof(double)), gnu::aligned(alignof(double)), gnu::may_alias]] = double;
constexpr int kLanes = 4;
static_assert(kRows % kLanes == 0, "AddGram() reads whole groups of four rows of a block's columns");

struct FourLanes {
  Vector<4> s = {};
  [[gnu::always_inline]] void Add(const double* x, const double* y) {
    s += *reinterpret_cast<const VectorAt<4>*>(x) * *reinterpret_cast<const VectorAt<4>*>(y);
  }
  [[gnu::always_inline]] double Sum() const { return (s[0] + s[1]) + (s[2] + s[3]); }
};

struct TwoPairs {
  Vector<2> lo = {}, hi = {};
  [[gnu::always_inline]] void Add(const double* x, const double* y) {
    lo += *reinterpret_cast<const VectorAt<2>*>(x) * *reinterpret_cast<const VectorAt<2>*>(y);
    hi += *reinterpret_cast<const VectorAt<2>*>(x + 2) * *reinterpret_cast<const VectorAt<2>*>(y + 2);
  }
  [[gnu::always_inline]] double Sum() const { return (lo[0] + lo[1]) + (hi[0] + hi[1]); }
};

// gram (n x n, column-major, lower triangle) += C^T C over `count` rows of the column-major C
// (leading dimension ld), in 2 x 2 tiles so that each loaded pair of columns serves four products.
// The rows past `count` up to the next multiple of four must be zero.
template <typename Lanes>
[[gnu::always_inline]] inline void AddGramIn(const double* c, int ld, int n, int count, double* gram) {
  const int end = (count + kLanes - 1) / kLanes * kLanes;
  int a = 0;
  for (; a + 1 < n; a += 2) {
    const double* x0 = c + a * ld;
    const double* x1 = x0 + ld;
    for (int b = 0; b < a; b += 2) {
      const double* y0 = c + b * ld;
      const double* y1 = y0 + ld;
      Lanes s00, s01, s10, s11;
      for (int i = 0; i < end; i += kLanes) {
        s00.Add(x0 + i, y0 + i);
        s01.Add(x0 + i, y1 + i);
        s10.Add(x1 + i, y0 + i);
        s11.Add(x1 + i, y1 + i);
      }
      gram[b * n + a] += s00.Sum();
      gram[(b + 1) * n + a] += s01.Sum();
      gram[b * n + a + 1] += s10.Sum();
      gram[(b + 1) * n + a + 1] += s11.Sum();
    }
    Lanes s00, s10, s11;
    for (int i = 0; i < end; i += kLanes) {
      s00.Add(x0 + i, x0 + i);
      s10.Add(x1 + i, x0 + i);
      s11.Add(x1 + i, x1 + i);
    }
    gram[a * n + a] += s00.Sum();
    gram[a * n + a + 1] += s10.Sum();
    gram[(a + 1) * n + a + 1] += s11.Sum();
  }
  if (a < n) {  // an odd last column
    const double* x0 = c + a * ld;
    for (int b = 0; b <= a; ++b) {
      const double* y0 = c + b * ld;
      Lanes s;
      for (int i = 0; i < end; i += kLanes) s.Add(x0 + i, y0 + i);
      gram[b * n + a] += s.Sum();
    }
  }
}

#if SPH_AVX2_DISPATCH
[[gnu::target("avx2")]] void AddGramAvx2(const double* c, int ld, int n, int count, double* gram) {
  AddGramIn<FourLanes>(c, ld, n, count, gram);
}
#endif

// Zeros the rows `count` up to the next multiple of four of the n columns at c (leading dimension
// kRows), which AddGram() reads.
void PadToLanes(double* c, int n, int count) {
  for (int column = 0; column < n; ++column)
    std::fill_n(c + column * kRows + count, (kLanes - count % kLanes) % kLanes, 0.0);
}

void AddGram(const double* c, int ld, int n, int count, double* gram) {
#if SPH_AVX2_DISPATCH
  if (HasAvx2()) return AddGramAvx2(c, ld, n, count, gram);
#endif
  AddGramIn<TwoPairs>(c, ld, n, count, gram);
}

// The gathered readings of one block: the sines and cosines of the axis readings and the probe
// readings of `count` rows.
struct GatheredReadings {
  const double* __restrict ct;
  const double* __restrict st;
  const double* __restrict cp;
  const double* __restrict sp;
  const double* __restrict r;
  int count;
};

// The seven-error residuals of a block into e and, with kJacobian, their Jacobian into cols
// (columns g0..g6, centre x, y, z; leading dimension kRows). The loop is straight-line code over
// arrays: the compiler vectorises it, and without kJacobian it leaves the gradient out (the same e,
// bit for bit).
template <bool kJacobian>
[[gnu::always_inline]] inline void SevenErrorBlock(const double* g, const ScmsErrorTrig<double>& et,
                                                   double d_plus_dprime, const double* center, double radius_mm,
                                                   const GatheredReadings& in_rows, double* __restrict e,
                                                   double* __restrict cols) {
  // Local copies: the compiler then knows that the stores below leave them unchanged.
  double geometry[kNumScmsParams];
  std::copy(g, g + kNumScmsParams, geometry);
  const double c[3] = {center[0], center[1], center[2]};
  const GatheredReadings rows = in_rows;
  for (int i = 0; i < rows.count; ++i) {
    ResidualInputs in;
    in.theta.sin = rows.st[i];
    in.theta.cos = rows.ct[i];
    in.phi.sin = rows.sp[i];
    in.phi.cos = rows.cp[i];
    in.z = rows.r[i] - d_plus_dprime;
    ResidualGradient out;
    SphereResidualGradient(geometry, et, in, c, radius_mm, &out);
    e[i] = out.e;
    if constexpr (kJacobian) {
      for (int k = 0; k < kNumScmsParams; ++k) cols[k * kRows + i] = out.geometry[k];
      for (int k = 0; k < 3; ++k) cols[(kNumScmsParams + k) * kRows + i] = out.center[k];
    }
  }
}

#if SPH_AVX2_DISPATCH
template <bool kJacobian>
[[gnu::target("avx2")]] void SevenErrorBlockAvx2(const double* g, const ScmsErrorTrig<double>& et, double d_plus_dprime,
                                                 const double* center, double radius_mm, const GatheredReadings& rows,
                                                 double* e, double* cols) {
  SevenErrorBlock<kJacobian>(g, et, d_plus_dprime, center, radius_mm, rows, e, cols);
}
#endif

// SevenErrorBlock() on the widest instruction set of the CPU (cols: null without kJacobian).
template <bool kJacobian>
void SevenErrors(const double* g, const ScmsErrorTrig<double>& et, double d_plus_dprime, const double* center,
                 double radius_mm, const GatheredReadings& rows, double* e, double* cols) {
#if SPH_AVX2_DISPATCH
  if (HasAvx2()) return SevenErrorBlockAvx2<kJacobian>(g, et, d_plus_dprime, center, radius_mm, rows, e, cols);
#endif
  SevenErrorBlock<kJacobian>(g, et, d_plus_dprime, center, radius_mm, rows, e, cols);
}

// out[2 (k - 1) kRows ...] = cos k x, then sin k x, for k = 1..orders, from cos x and sin x of
// `count` rows (the angle-addition recurrence).
void Harmonics(int count, int orders, const double* c1, const double* s1, double* out) {
  for (int order = 1; order <= orders; ++order) {
    double* ck = out + 2 * (order - 1) * kRows;
    double* sk = ck + kRows;
    if (order == 1) {
      std::copy(c1, c1 + count, ck);
      std::copy(s1, s1 + count, sk);
      continue;
    }
    const double* cp = ck - 2 * kRows;
    const double* sp = cp + kRows;
    for (int i = 0; i < count; ++i) {
      ck[i] = cp[i] * c1[i] - sp[i] * s1[i];
      sk[i] = sp[i] * c1[i] + cp[i] * s1[i];
    }
  }
}

// SphereResidualGradient() with the Phi wobble and the Theta tilt terms where the model has them.
void GradientAt(bool wobble, bool tilt, const double* g, const ScmsErrorTrig<double>& et, const ResidualInputs& in,
                const double* center, double radius_mm, ResidualGradient* result) {
  if (wobble && tilt) {
    SphereResidualGradient<true, true>(g, et, in, center, radius_mm, result);
  } else if (wobble) {
    SphereResidualGradient<true, false>(g, et, in, center, radius_mm, result);
  } else if (tilt) {
    SphereResidualGradient<false, true>(g, et, in, center, radius_mm, result);
  } else {
    SphereResidualGradient<false, false>(g, et, in, center, radius_mm, result);
  }
}

// BeamDirection() likewise.
Eigen::Vector3d BeamAt(bool wobble, bool tilt, const ScmsErrorTrig<double>& et, const ResidualInputs& in) {
  Eigen::Vector3d beam;
  if (wobble && tilt) {
    BeamDirection<true, true>(et, in, beam.data());
  } else if (wobble) {
    BeamDirection<true, false>(et, in, beam.data());
  } else if (tilt) {
    BeamDirection<false, true>(et, in, beam.data());
  } else {
    BeamDirection<false, false>(et, in, beam.data());
  }
  return beam;
}

}  // namespace

ReadingTable::ReadingTable(const PointsData& points) {
  const std::size_t m = points.samples.size();
  for (auto* v : {&theta_rad, &phi_rad, &cos_theta, &sin_theta, &cos_phi, &sin_phi, &r_mm, &t_s, &theta_half_direction,
                  &phi_half_direction})
    v->resize(m);
  const std::vector<MotionDirection> directions = MotionDirections(points.samples);
  setup.resize(m);
  setup_ids = points.SetupIds();
  const std::map<int, std::size_t> index = IndexOfSetups(setup_ids);
  for (std::size_t i = 0; i < m; ++i) {
    const Sample& s = points.samples[i];
    theta_rad[i] = s.theta_rad();
    phi_rad[i] = s.phi_rad();
    const SinCos<double> t = SinCosOf(theta_rad[i]), p = SinCosOf(phi_rad[i]);
    cos_theta[i] = t.cos;
    sin_theta[i] = t.sin;
    cos_phi[i] = p.cos;
    sin_phi[i] = p.sin;
    r_mm[i] = s.r_mm;
    t_s[i] = s.t_s;
    theta_half_direction[i] = 0.5 * directions[i].theta;
    phi_half_direction[i] = 0.5 * directions[i].phi;
    setup[i] = index.size() == 1 ? 0 : static_cast<int>(index.at(s.setup));
  }
}

void ReadingTable::SetReadings(const PointsData& points) {
  for (std::size_t i = 0; i < r_mm.size(); ++i) r_mm[i] = points.samples[i].r_mm;
}

RowsOfSetup AllRows(const ReadingTable& table, const std::vector<bool>* left_out) {
  RowsOfSetup rows(table.setup_ids.size());
  for (std::size_t i = 0; i < table.size(); ++i) {
    if (left_out == nullptr || !(*left_out)[i]) {
      rows[static_cast<std::size_t>(table.setup[i])].push_back(static_cast<std::uint32_t>(i));
    }
  }
  return rows;
}

std::size_t SetupsWithRows(const ReadingTable& table, const RowsOfSetup& rows, std::vector<int>* setup_ids) {
  std::size_t n = 0;
  for (std::size_t k = 0; k < rows.size(); ++k) {
    if (rows[k].empty()) continue;
    setup_ids->push_back(table.setup_ids[k]);
    n += rows[k].size();
  }
  return n;
}

struct SphereFitProblem::Scratch {
  // The gathered readings of one block.
  alignas(64) double theta[kRows], phi[kRows], ct[kRows], st[kRows], cp[kRows], sp[kRows], r[kRows], t[kRows];
  // The effects' inputs of each row (Target order) and the basis functions.
  alignas(64) double target[kNumTargets][kRows];
  alignas(64) double u_pow[3][kRows], tau_pow[3][kRows], incidence_pow[kMaxIncidenceOrder][kRows];
  alignas(64) double theta_direction[kRows], phi_direction[kRows];  // half of each, the reversal terms' basis
  std::vector<double> theta_harmonics, phi_harmonics;               // cos k, sin k for k = 1.., kRows each
  std::vector<const double*> basis;                                 // per effect parameter: its values in the block
  std::vector<double> cols;                                         // local Jacobian columns and e last, kRows each
  std::vector<double> gram;                                         // (cols + 1)^2, lower triangle
  std::vector<double> global;                                       // num_params x kRows for the factor
  std::vector<Component> components;                                // per effect parameter
  int theta_orders = 0, phi_orders = 0;
  bool theta_encoder = false, phi_encoder = false, wobble = false, tilt = false;
  int incidence = -1;  // the first effect parameter of the probe_incidence term, or -1
  // The form: the harmonics of degrees form_min..form_max, where each term's value is among them.
  std::unique_ptr<SchmidtHarmonics> harmonics;
  std::vector<int> form_slot;
  std::vector<double> harmonic_values, harmonic_gradients;
};

SphereFitProblem::SphereFitProblem(const ReadingTable& table, RowsOfSetup rows, const EffectModel& model,
                                   const CalibrationOptions& options)
    : table_(table), model_(model), probe_offset_mm_(options.probe_offset_mm), scratch_(std::make_unique<Scratch>()) {
  for (std::size_t k = 0; k < rows.size(); ++k) {
    if (rows[k].empty()) continue;
    num_rows_ += rows[k].size();
    setups_.push_back(static_cast<int>(k));
    rows_.push_back(std::move(rows[k]));
    radius_mm_.push_back(options.SphereRadiusMm(table.setup_ids[k]));
  }
  num_effect_params_ = model.NumParams();
  first_effect_ = kNumScmsParams + 3 * static_cast<Eigen::Index>(setups_.size());
  first_form_ = first_effect_ + num_effect_params_;
  num_form_terms_ = static_cast<int>(model.form.terms.size());
  num_params_ = first_form_ + model.form.NumParams();
  num_local_ = kNumScmsParams + 3 + num_effect_params_ + num_form_terms_;
  for (const int k : setups_) {
    const FormSetup& fs = model.form.SetupOf(table.setup_ids[static_cast<std::size_t>(k)]);
    form_group_.push_back(fs.group);
    form_rotation_.push_back(fs.rotation);
  }
  Scratch& s = *scratch_;
  if (!model.form.Empty()) {
    int l_min = model.form.terms.front().l;
    for (const FormTerm& t : model.form.terms) l_min = std::min(l_min, t.l);
    const int l_max = model.form.MaxDegree();
    s.harmonics = std::make_unique<SchmidtHarmonics>(l_min, l_max);
    for (const FormTerm& t : model.form.terms)
      s.form_slot.push_back(static_cast<int>(HarmonicIndex(t.l, t.m)) - l_min * l_min);
    s.harmonic_values.resize(static_cast<std::size_t>(s.harmonics->size()));
    s.harmonic_gradients.resize(static_cast<std::size_t>(3 * s.harmonics->size()));
  }
  for (const EffectTerm& term : model.terms) {
    if (term.effect == Effect::kProbeIncidence) s.incidence = static_cast<int>(s.components.size());
    for (const EffectComponent& c : term.components) {
      const Component comp{TargetOf(term.effect, c.axis), BasisOf(term.effect), c.order, c.sine};
      s.components.push_back(comp);
      if (comp.basis == Basis::kThetaHarmonic) s.theta_orders = std::max(s.theta_orders, c.order);
      if (comp.basis == Basis::kPhiHarmonic) s.phi_orders = std::max(s.phi_orders, c.order);
    }
    s.theta_encoder |= term.effect == Effect::kThetaEncoder || term.effect == Effect::kThetaReversal;
    s.phi_encoder |= term.effect == Effect::kPhiEncoder || term.effect == Effect::kPhiReversal;
    s.wobble |= term.effect == Effect::kPhiWobble;
    s.tilt |= term.effect == Effect::kThetaTiltMotion;
  }
  s.theta_harmonics.resize(static_cast<std::size_t>(2 * s.theta_orders * kRows));
  s.phi_harmonics.resize(static_cast<std::size_t>(2 * s.phi_orders * kRows));
  s.basis.resize(s.components.size());
  for (std::size_t p = 0; p < s.components.size(); ++p) {
    const Component& c = s.components[p];
    const int slot = 2 * (c.order - 1) + (c.sine ? 1 : 0);
    switch (c.basis) {
      case Basis::kThetaHarmonic:
        s.basis[p] = s.theta_harmonics.data() + slot * kRows;
        break;
      case Basis::kPhiHarmonic:
        s.basis[p] = s.phi_harmonics.data() + slot * kRows;
        break;
      case Basis::kU:
        s.basis[p] = s.u_pow[c.order - 1];
        break;
      case Basis::kTau:
        s.basis[p] = s.tau_pow[c.order - 1];
        break;
      case Basis::kIncidence:
        s.basis[p] = s.incidence_pow[c.order - 1];
        break;
      case Basis::kThetaDirection:
        s.basis[p] = s.theta_direction;
        break;
      case Basis::kPhiDirection:
        s.basis[p] = s.phi_direction;
        break;
    }
  }
  const int local = num_local_;
  s.cols.assign(static_cast<std::size_t>((local + 1) * kRows), 0.0);
  s.gram.assign(static_cast<std::size_t>((local + 1) * (local + 1)), 0.0);
}

SphereFitProblem::~SphereFitProblem() = default;

Eigen::VectorXd PackParameters(const ScmsGeometry& g, const std::vector<Eigen::Vector3d>& centers_mm,
                               const std::vector<std::vector<double>>& values,
                               const std::vector<std::vector<double>>& form_values) {
  std::size_t n = kNumScmsParams + 3 * centers_mm.size();
  for (const auto& blocks : {&values, &form_values}) {
    for (const auto& block : *blocks) n += block.size();
  }
  Eigen::VectorXd x(static_cast<Eigen::Index>(n));
  Eigen::Index k = 0;
  for (double p : g) x(k++) = p;
  for (const Eigen::Vector3d& c : centers_mm) x.segment<3>(k) = c, k += 3;
  for (const auto& blocks : {&values, &form_values}) {
    for (const auto& block : *blocks) {
      for (double v : block) x(k++) = v;
    }
  }
  return x;
}

Eigen::VectorXd SphereFitProblem::Pack(const ScmsGeometry& g, const std::vector<Eigen::Vector3d>& centers_mm,
                                       const std::vector<std::vector<double>>& values,
                                       const std::vector<std::vector<double>>& form_values) const {
  const auto terms = static_cast<std::size_t>(num_form_terms_);
  std::vector<std::vector<double>> form;
  for (std::size_t group = 0; group < static_cast<std::size_t>(model_.form.NumGroups()) && terms > 0; ++group) {
    const bool given = group < form_values.size() && form_values[group].size() == terms;
    form.push_back(given ? form_values[group] : std::vector<double>(terms, 0.0));
  }
  std::vector<std::vector<double>> effects;
  for (std::size_t t = 0; t < model_.terms.size(); ++t) {
    effects.emplace_back(values[t].begin(), values[t].begin() + static_cast<long>(model_.terms[t].components.size()));
  }
  const std::vector<Eigen::Vector3d> centers(centers_mm.begin(), centers_mm.begin() + NumSetups());
  Eigen::VectorXd x = PackParameters(g, centers, effects, form);
  assert(x.size() == num_params_);
  return x;
}

void SphereFitProblem::Unpack(const Eigen::VectorXd& x, ScmsGeometry* g, std::vector<Eigen::Vector3d>* centers_mm,
                              std::vector<std::vector<double>>* values,
                              std::vector<std::vector<double>>* form_values) const {
  for (int k = 0; k < kNumScmsParams; ++k) (*g)[static_cast<std::size_t>(k)] = x(k);
  centers_mm->clear();
  for (std::size_t k = 0; k < setups_.size(); ++k) {
    centers_mm->push_back(x.segment<3>(kNumScmsParams + 3 * static_cast<Eigen::Index>(k)));
  }
  if (values != nullptr) {
    values->assign(model_.terms.size(), {});
    Eigen::Index j = first_effect_;
    for (std::size_t t = 0; t < model_.terms.size(); ++t) {
      for (std::size_t i = 0; i < model_.terms[t].components.size(); ++i) (*values)[t].push_back(x(j++));
    }
  }
  if (form_values != nullptr) {
    form_values->clear();
    if (num_form_terms_ == 0) return;
    for (int group = 0; group < model_.form.NumGroups(); ++group) {
      form_values->emplace_back(x.data() + first_form_ + group * num_form_terms_,
                                x.data() + first_form_ + (group + 1) * num_form_terms_);
    }
  }
}

void SphereFitProblem::BlockBasis(const std::uint32_t* idx, int count) const {
  Scratch& s = *scratch_;
  const EffectReference& ref = model_.reference;
  for (int i = 0; i < count; ++i) {
    s.theta[i] = table_.theta_rad[idx[i]];
    s.phi[i] = table_.phi_rad[idx[i]];
    s.t[i] = table_.t_s[idx[i]];
    s.theta_direction[i] = table_.theta_half_direction[idx[i]];
    s.phi_direction[i] = table_.phi_half_direction[idx[i]];
  }
  Harmonics(count, s.theta_orders, s.ct, s.st, s.theta_harmonics.data());
  Harmonics(count, s.phi_orders, s.cp, s.sp, s.phi_harmonics.data());
  for (int i = 0; i < count; ++i) {
    const double u = (s.r[i] - ref.r_ref_mm) / ref.r_half_range_mm;
    const double tau = (s.t[i] - ref.t_start_s) / ref.t_span_s;
    s.u_pow[0][i] = u;
    s.u_pow[1][i] = u * u;
    s.u_pow[2][i] = u * u * u;
    s.tau_pow[0][i] = tau;
    s.tau_pow[1][i] = tau * tau;
    s.tau_pow[2][i] = tau * tau * tau;
  }
}

void SphereFitProblem::SumTerms(const double* effect_values, int count) const {
  Scratch& s = *scratch_;
  for (auto& t : s.target) std::fill(t, t + count, 0.0);
  std::size_t p = 0;
  for (const EffectTerm& term : model_.terms) {
    if (term.effect == Effect::kProbeIncidence) {  // its basis depends on the row's point: IncidenceAt()
      p += term.components.size();
      continue;
    }
    for (int axis = 0; axis < term.info().axes; ++axis) {
      double sum[kRows];
      std::fill(sum, sum + count, 0.0);
      for (std::size_t c = 0; c < term.components.size(); ++c) {
        if (term.components[c].axis != axis) continue;
        const double v = effect_values[p + c];
        const double* b = s.basis[p + c];
        for (int i = 0; i < count; ++i) sum[i] += v * b[i];
      }
      double* target = s.target[TargetOf(term.effect, axis)];
      for (int i = 0; i < count; ++i) target[i] += sum[i];
    }
    p += term.components.size();
  }
}

// probe_incidence: the reading's error i_k sin^2k psi, psi between the beam B and the normal n0 at
// the point p0 of z0 = r - (d + d') (the reading without the probe's terms). Its derivatives come
// through c = B . n0: dc/dx = gc . dp0/dx + n0 . dB/dx, gc = (B - c n0) / |p0 - O|; the first is the
// reverse sweep at z0 along gc, the second that along n0 at z0 + 1 less that at z0 (p is affine in
// z, so the difference is n0 . dB/dx exactly), and dc/dO = -gc.
SphereFitProblem::Incidence SphereFitProblem::IncidenceAt(const double* g, const ScmsErrorTrig<double>& et,
                                                          const double* center, double radius_mm,
                                                          const double* effect_values, ResidualInputs in0, int i,
                                                          bool jacobian) const {
  Scratch& s = *scratch_;
  Incidence result;
  ResidualGradient at0;
  GradientAt(s.wobble, s.tilt, g, et, in0, center, radius_mm, &at0);
  const Eigen::Vector3d n0(-at0.center[0], -at0.center[1], -at0.center[2]);
  const double dist0 = at0.e + radius_mm;
  const Eigen::Vector3d p0 = Eigen::Map<const Eigen::Vector3d>(center) + dist0 * n0;
  const Eigen::Vector3d beam = BeamAt(s.wobble, s.tilt, et, in0);
  const double c = beam.dot(n0), sin2 = 1.0 - c * c;
  double power = 1.0;
  for (int k = 1; k <= kMaxIncidenceOrder; ++k) {
    const double previous = power;  // sin^2(k-1) psi
    power *= sin2;
    s.incidence_pow[k - 1][i] = power;
    for (std::size_t q = static_cast<std::size_t>(s.incidence); q < s.components.size(); ++q) {
      const Component& comp = s.components[q];
      if (comp.basis != Basis::kIncidence || comp.order != k) continue;
      result.dr_mm += effect_values[q] * power;
      result.de_dc_per_de_dz += effect_values[q] * k * previous * (-2.0 * c);
    }
  }
  if (!jacobian) return result;
  ResidualGradient& dc = result.dc;
  const Eigen::Vector3d gc = (beam - c * n0) / dist0;
  const double gc_norm = gc.norm();
  if (gc_norm > 0.0) {
    const Eigen::Vector3d behind = p0 - gc / gc_norm;
    ResidualGradient along_gc;
    GradientAt(s.wobble, s.tilt, g, et, in0, behind.data(), radius_mm, &along_gc);
    AddScaled(along_gc, gc_norm, &dc);
  }
  ResidualInputs in1 = in0;
  in1.z = in0.z + 1.0;
  const Eigen::Vector3d behind1 = (p0 + beam) - n0;
  ResidualGradient at1;
  GradientAt(s.wobble, s.tilt, g, et, in1, behind1.data(), radius_mm, &at1);
  AddScaled(at1, 1.0, &dc);
  AddScaled(at0, -1.0, &dc);
  for (int j = 0; j < 3; ++j) dc.center[j] = -gc[j];
  return result;
}

void SphereFitProblem::EffectRows(const SetupParams& p, const ScmsErrorTrig<double>& et, double d_plus_dprime,
                                  int setup, const std::uint32_t* idx, int count, double* e, double* cols) const {
  Scratch& s = *scratch_;
  const double* center = p.center;
  const bool form = num_form_terms_ > 0;
  const double* form_values = p.form;
  const Eigen::Matrix3d& rotation = form_rotation_[static_cast<std::size_t>(setup)];
  const double radius_mm = radius_mm_[static_cast<std::size_t>(setup)];
  const double* g = p.geometry;
  const double* effect_values = p.effects;
  BlockBasis(idx, count);
  SumTerms(effect_values, count);  // each term's sums, per target, as EffectScmsPoint() adds them
  const int n_eff = num_effect_params_;
  for (int i = 0; i < count; ++i) {
    ResidualInputs in;
    in.theta = s.theta_encoder ? SinCosOf(s.theta[i] + s.target[kDTheta][i]) : SinCos<double>{s.st[i], s.ct[i]};
    in.phi = s.phi_encoder ? SinCosOf(s.phi[i] + s.target[kDPhi][i]) : SinCos<double>{s.sp[i], s.cp[i]};
    in.motion[0] = s.target[kMotionX][i];
    in.motion[1] = s.target[kMotionY][i];
    in.motion[2] = s.target[kMotionZ][i];
    in.phi_motion[0] = s.target[kPhiMotionX][i];
    in.phi_motion[1] = s.target[kPhiMotionY][i];
    in.phi_motion[2] = s.target[kPhiMotionZ][i];
    if (s.wobble) {
      in.wobble_x = SinCosOf(s.target[kWobbleX][i]);
      in.wobble_y = SinCosOf(s.target[kWobbleY][i]);
      in.pivot_mm = model_.phi_wobble_pivot_mm;
    }
    if (s.tilt) {
      in.tilt_x = SinCosOf(s.target[kTiltX][i]);
      in.tilt_y = SinCosOf(s.target[kTiltY][i]);
    }
    Incidence incidence;
    if (s.incidence >= 0) {
      ResidualInputs in0 = in;
      in0.z = s.r[i] - d_plus_dprime;
      incidence = IncidenceAt(g, et, center, radius_mm, effect_values, in0, i, cols != nullptr);
    }
    in.z = (s.r[i] + (s.target[kDr][i] + incidence.dr_mm)) - d_plus_dprime;
    ResidualGradient out;
    // The gradient of e (centre o) with the chain through the incidence angle; returns the unit
    // normal n = (p - o) / |p - o| = -de/do of |p - o| alone (before that chain, which adds to de/do).
    auto gradient = [&](const double* o, ResidualGradient* result) {
      GradientAt(s.wobble, s.tilt, g, et, in, o, radius_mm, result);
      const Eigen::Vector3d normal(-result->center[0], -result->center[1], -result->center[2]);
      if (s.incidence >= 0 && cols != nullptr) AddScaled(incidence.dc, result->z * incidence.de_dc_per_de_dz, result);
      return normal;
    };
    const Eigen::Vector3d n = gradient(center, &out);
    e[i] = out.e;
    if (form) {
      // See the header: e -= F(R^T n), and the gradient along t = dF/dp taken off.
      const double dist = out.e + radius_mm;
      const Eigen::Vector3d body = rotation.transpose() * n;
      s.harmonics->Evaluate(body.x(), body.y(), body.z(), s.harmonic_values.data(),
                            cols == nullptr ? nullptr : s.harmonic_gradients.data());
      double f = 0.0;
      Eigen::Vector3d grad_body = Eigen::Vector3d::Zero();
      for (int k = 0; k < num_form_terms_; ++k) {
        const auto slot = static_cast<std::size_t>(s.form_slot[static_cast<std::size_t>(k)]);
        f += form_values[k] * s.harmonic_values[slot];
        if (cols != nullptr)
          grad_body += form_values[k] * Eigen::Map<const Eigen::Vector3d>(&s.harmonic_gradients[3 * slot]);
      }
      e[i] -= f;
      if (cols != nullptr) {
        const Eigen::Vector3d grad = rotation * grad_body;
        const Eigen::Vector3d t = (grad - n * n.dot(grad)) / dist;
        const double t_norm = t.norm();
        if (t_norm > 0.0) {
          const Eigen::Vector3d point = Eigen::Map<const Eigen::Vector3d>(center) + dist * n;
          const Eigen::Vector3d behind = point - t / t_norm;
          ResidualGradient along;
          gradient(behind.data(), &along);
          AddScaled(along, -t_norm, &out);
          out.z -= t_norm * along.z;
        }
        for (int k = 0; k < num_form_terms_; ++k) {
          const auto slot = static_cast<std::size_t>(s.form_slot[static_cast<std::size_t>(k)]);
          cols[(kNumScmsParams + 3 + n_eff + k) * kRows + i] = -s.harmonic_values[slot];
        }
      }
    }
    if (cols == nullptr) continue;
    for (int j = 0; j < kNumScmsParams; ++j) cols[j * kRows + i] = out.geometry[j];
    for (int j = 0; j < 3; ++j) cols[(kNumScmsParams + j) * kRows + i] = out.center[j];
    for (int q = 0; q < n_eff; ++q) {
      const Component& c = s.components[static_cast<std::size_t>(q)];
      cols[(kNumScmsParams + 3 + q) * kRows + i] = Partial(out, c.target) * s.basis[static_cast<std::size_t>(q)][i];
    }
  }
}

SetupParams SphereFitProblem::ParamsOf(const double* x, int setup) const {
  SetupParams p;
  p.geometry = x;
  p.center = x + kNumScmsParams + 3 * setup;
  p.effects = num_effect_params_ > 0 ? x + first_effect_ : nullptr;
  p.form =
      num_form_terms_ > 0 ? x + first_form_ + form_group_[static_cast<std::size_t>(setup)] * num_form_terms_ : nullptr;
  return p;
}

void SphereFitProblem::EvaluateBlock(int k, const SetupParams& p, const ScmsErrorTrig<double>& et,
                                     const std::uint32_t* idx, int count, const double* r_offset, bool jacobian) const {
  Scratch& s = *scratch_;
  const double d_plus_dprime = probe_offset_mm_ + p.geometry[kDPrime];
  double* e = s.cols.data() + num_local_ * kRows;
  double* cols = jacobian ? s.cols.data() : nullptr;
  for (int i = 0; i < count; ++i) {
    const std::uint32_t row = idx[i];
    s.ct[i] = table_.cos_theta[row];
    s.st[i] = table_.sin_theta[row];
    s.cp[i] = table_.cos_phi[row];
    s.sp[i] = table_.sin_phi[row];
    s.r[i] = r_offset ? table_.r_mm[row] + r_offset[row] : table_.r_mm[row];
  }
  const auto setup = static_cast<std::size_t>(k);
  if (model_.terms.empty() && num_form_terms_ == 0) {
    const GatheredReadings gathered{s.ct, s.st, s.cp, s.sp, s.r, count};
    if (jacobian) {
      SevenErrors<true>(p.geometry, et, d_plus_dprime, p.center, radius_mm_[setup], gathered, e, cols);
    } else {
      SevenErrors<false>(p.geometry, et, d_plus_dprime, p.center, radius_mm_[setup], gathered, e, nullptr);
    }
  } else {
    EffectRows(p, et, d_plus_dprime, k, idx, count, e, cols);
  }
}

void SphereFitProblem::ForEachBlock(const double* x, const double* r_offset, bool jacobian,
                                    const std::function<void(const RowBlock&)>& fn) const {
  Scratch& s = *scratch_;
  const ScmsErrorTrig<double> et = ErrorTrigOf(x);
  for (std::size_t k = 0; k < setups_.size(); ++k) {
    const SetupParams p = ParamsOf(x, static_cast<int>(k));
    const std::vector<std::uint32_t>& rows = rows_[k];
    for (std::size_t first = 0; first < rows.size(); first += kRows) {
      const int count = static_cast<int>(std::min<std::size_t>(kRows, rows.size() - first));
      const std::uint32_t* idx = rows.data() + first;
      EvaluateBlock(static_cast<int>(k), p, et, idx, count, r_offset, jacobian);
      RowBlock block;
      block.setup = static_cast<int>(k);
      block.rows = idx;
      block.count = count;
      block.e = s.cols.data() + num_local_ * kRows;
      block.cols = jacobian ? s.cols.data() : nullptr;
      block.num_cols = num_local_;
      fn(block);
    }
  }
}

bool SphereFitProblem::EvaluateSetupRows(int setup, const SetupParams& p, int first, int count, double* residuals,
                                         double* const* jacobians) const {
  Scratch& s = *scratch_;
  const ScmsErrorTrig<double> et = ErrorTrigOf(p.geometry);
  const std::uint32_t* rows = rows_[static_cast<std::size_t>(setup)].data() + first;
  const bool jacobian = jacobians != nullptr && std::any_of(jacobians, jacobians + NumSetupBlocks(),
                                                            [](const double* j) { return j != nullptr; });
  // Each block's columns within the local columns of RowBlock::cols: first and width.
  const int n_eff = num_effect_params_;
  const std::array<std::array<int, 2>, 4> blocks{{{0, kNumScmsParams},
                                                  {kNumScmsParams, 3},
                                                  {kNumScmsParams + 3, n_eff},
                                                  {kNumScmsParams + 3 + n_eff, num_form_terms_}}};
  const double* e = s.cols.data() + num_local_ * kRows;
  bool finite = true;
  for (int done = 0; done < count; done += kRows) {
    const int n = std::min(kRows, count - done);
    EvaluateBlock(setup, p, et, rows + done, n, nullptr, jacobian);
    for (int i = 0; i < n; ++i) {
      residuals[done + i] = e[i];
      finite &= std::isfinite(e[i]);
    }
    if (!jacobian) continue;
    int b = 0;
    for (std::size_t which = 0; which < blocks.size(); ++which) {
      const auto [col0, width] = blocks[which];
      if (width == 0) continue;
      double* jac = jacobians[b++];
      if (jac == nullptr) continue;
      for (int c = 0; c < width; ++c) {
        const double* column = s.cols.data() + (col0 + c) * kRows;
        for (int i = 0; i < n; ++i) {
          const double v = column[i];
          jac[(done + i) * width + c] = v;
          finite &= std::isfinite(v);
        }
      }
    }
  }
  return finite;
}

bool SphereFitProblem::Evaluate(const double* x, NormalEquations* ne) const {
  Scratch& s = *scratch_;
  const int local = num_local_;
  const int n = local + 1;  // the residual as the last column: J^T e and e^T e come with J^T J
  ne->SetZero(num_params_);
  int current = -1;
  auto flush = [&] {
    if (current < 0) return;
    for (int a = 0; a < n; ++a) {
      for (int b = 0; b <= a; ++b) {
        const double v = s.gram[static_cast<std::size_t>(b * n + a)];
        if (a == local) {
          if (b == local) {
            ne->cost += 0.5 * v;
          } else {
            ne->jte(GlobalColumn(current, b)) += v;
          }
          continue;
        }
        const Eigen::Index ga = GlobalColumn(current, a), gb = GlobalColumn(current, b);
        ne->jtj(ga, gb) += v;
        if (ga != gb) ne->jtj(gb, ga) += v;
      }
    }
  };
  ForEachBlock(x, nullptr, true, [&](const RowBlock& block) {
    if (block.setup != current) {
      flush();
      std::fill(s.gram.begin(), s.gram.end(), 0.0);
      current = block.setup;
    }
    PadToLanes(s.cols.data(), n, block.count);
    AddGram(s.cols.data(), kRows, n, block.count, s.gram.data());
  });
  flush();
  return std::isfinite(ne->cost);
}

void SphereFitProblem::Residuals(const double* x, double* out) const {
  ForEachBlock(x, nullptr, false, [&](const RowBlock& block) {
    for (int i = 0; i < block.count; ++i) out[block.rows[i]] = block.e[i];
  });
}

RowQr SphereFitProblem::FactorJacobian(const double* x, const double* r_offset, const double* row_weight) const {
  RowQr qr(num_params_);
  ForEachGlobalBlock(x, r_offset, [&](const std::uint32_t* table_rows, int count, double* rows, int) {
    if (row_weight != nullptr) {
      for (int i = 0; i < count; ++i) {
        const double w = row_weight[table_rows[i]];
        for (Eigen::Index j = 0; j < num_params_; ++j) rows[i * num_params_ + j] *= w;
      }
    }
    qr.AddRows(rows, num_params_, count);
  });
  return qr;
}

BlockFactor SphereFitProblem::FactorBlocks(const double* x, const double* r_offset, const double* row_weight) const {
  std::vector<Eigen::Index> f_columns, e_first;
  for (Eigen::Index j = 0; j < kNumScmsParams; ++j) f_columns.push_back(j);
  for (Eigen::Index j = first_effect_; j < num_params_; ++j) f_columns.push_back(j);
  for (std::size_t k = 0; k < setups_.size(); ++k) e_first.push_back(kNumScmsParams + 3 * static_cast<Eigen::Index>(k));
  BlockFactor factor(std::move(f_columns), std::move(e_first), num_params_);
  // Each setup's rows over its local columns, the centre's first: [centre | g | effects | form].
  const int local = num_local_;
  std::vector<double> rows(static_cast<std::size_t>(kRows * local));
  std::vector<int> f_of_local(static_cast<std::size_t>(local - 3));
  RowQr qr;
  int current = -1;
  Eigen::Index count = 0;
  auto finish = [&] {
    if (current >= 0) factor.AddSetup(current, qr.r(), f_of_local, count);
  };
  ForEachBlock(x, r_offset, true, [&](const RowBlock& b) {
    if (b.setup != current) {
      finish();
      current = b.setup;
      qr.Reset(local);
      count = 0;
      const int group = form_group_[static_cast<std::size_t>(current)];
      for (int j = 0; j < local - 3; ++j) {
        const int shared = j - kNumScmsParams - num_effect_params_;  // a form term, when >= 0
        f_of_local[static_cast<std::size_t>(j)] =
            shared < 0 ? j : kNumScmsParams + num_effect_params_ + group * num_form_terms_ + shared;
      }
    }
    for (int i = 0; i < b.count; ++i) {
      const double w = row_weight != nullptr ? row_weight[b.rows[i]] : 1.0;
      double* row = rows.data() + static_cast<std::size_t>(i * local);
      for (int c = 0; c < 3; ++c) row[c] = w * b.cols[(kNumScmsParams + c) * kRows + i];
      for (int c = 0; c < kNumScmsParams; ++c) row[3 + c] = w * b.cols[c * kRows + i];
      for (int c = kNumScmsParams + 3; c < local; ++c) row[c] = w * b.cols[c * kRows + i];
    }
    qr.AddRows(rows.data(), local, b.count);
    count += b.count;
  });
  finish();
  return factor;
}

void SphereFitProblem::ForEachGlobalBlock(
    const double* x, const double* r_offset,
    const std::function<void(const std::uint32_t* rows, int count, double* jacobian, int setup)>& fn) const {
  Scratch& s = *scratch_;
  const auto n = static_cast<std::size_t>(num_params_);
  s.global.assign(n * kRows, 0.0);
  ForEachBlock(x, r_offset, true, [&](const RowBlock& block) {
    std::fill(s.global.begin(), s.global.end(), 0.0);
    for (int c = 0; c < block.num_cols; ++c) {
      const auto col = static_cast<std::size_t>(GlobalColumn(block.setup, c));
      for (int i = 0; i < block.count; ++i) s.global[static_cast<std::size_t>(i) * n + col] = block.cols[c * kRows + i];
    }
    fn(block.rows, block.count, s.global.data(), block.setup);
  });
}

Eigen::MatrixXd SphereFitProblem::DenseJacobian(const double* x, const double* r_offset) const {
  std::vector<std::uint32_t> order;
  for (const auto& rows : rows_) order.insert(order.end(), rows.begin(), rows.end());
  std::sort(order.begin(), order.end());
  std::vector<Eigen::Index> position(table_.size(), -1);
  for (std::size_t i = 0; i < order.size(); ++i) position[order[i]] = static_cast<Eigen::Index>(i);
  Eigen::MatrixXd jac = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(order.size()), num_params_);
  ForEachBlock(x, r_offset, true, [&](const RowBlock& block) {
    for (int c = 0; c < block.num_cols; ++c) {
      const Eigen::Index col = GlobalColumn(block.setup, c);
      for (int i = 0; i < block.count; ++i) jac(position[block.rows[i]], col) = block.cols[c * kRows + i];
    }
  });
  return jac;
}

}  // namespace sph::internal
