// The sphere's form in the trace: whether the design separates it from the machine, its degree, and
// the tests of a candidate against a pattern fixed on the sphere (one placement, or beside the form).
#include "trace_steps.hpp"

#include "sph/model/row_qr.hpp"
#include "sph/model/spherical_harmonics.hpp"

namespace sph::internal {

// Whether the design separates the sphere's form from the machine (the sphere measured in at least
// two known orientations), and the highest degree the pattern resolves: a degree-L harmonic has L
// cycles around the sphere, so it needs more than 2L points on each ring and more than L rings.
FormSelection FormDesign(const PointsData& points, const TraceOptions& trace_options) {
  FormSelection f;
  std::vector<Eigen::Matrix3d> orientations;
  int own = 0;  // setups whose form is not the reference sphere's in a known orientation
  for (const int id : points.SetupIds()) {
    if (!points.header.FormKey(id).empty()) {
      ++own;
      continue;
    }
    const auto it = points.header.mount_rotations.find(id);
    const Eigen::Matrix3d r = it == points.header.mount_rotations.end() ? Eigen::Matrix3d::Identity()
                                                                        : MountRotationMatrix(*it->second.rotation_deg);
    bool seen = false;
    for (const Eigen::Matrix3d& o : orientations) seen |= (o - r).norm() < 1e-9;
    if (!seen) orientations.push_back(r);
  }
  std::vector<double> thetas, phis;
  for (const Sample& smp : points.samples) {
    thetas.push_back(std::round(smp.theta_deg * 1e6));
    phis.push_back(std::round(smp.phi_deg * 1e6));
  }
  auto distinct = [](std::vector<double>& v) {
    std::sort(v.begin(), v.end());
    return static_cast<int>(std::unique(v.begin(), v.end()) - v.begin());
  };
  const int resolved = std::min(distinct(phis) - 1, (distinct(thetas) - 1) / 2);
  f.degree_limit = std::min(trace_options.form_degree_max, resolved);
  // No higher than the cross-validation's folds can fit beside the seven errors and the centres.
  const int base_params = kNumScmsParams + 3 * static_cast<int>(points.SetupIds().size());
  const auto fewest = static_cast<int>(FoldSizesOf(points, trace_options.folds).fewest_fitted);
  int fitted = 1;
  while (fitted < f.degree_limit &&
         base_params + FormModelOf(points, FormTermsOfDegrees(2, fitted + 1)).NumParams() < fewest) {
    ++fitted;
  }
  const bool few = fitted < f.degree_limit;
  f.degree_limit = fitted;
  f.separable = orientations.size() >= 2 && f.degree_limit >= 2;
  const std::string unknown_note =
      own > 0 ? "; " + std::to_string(own) +
                    " setup(s) of unknown orientation or on another sphere, with forms of their own"
              : "";
  if (f.separable) {
    f.design = "the sphere measured in " + std::to_string(orientations.size()) +
               " known orientations on its mount: its form (turning with it) is fitted with the machine, degrees 2 "
               "to at most " +
               std::to_string(f.degree_limit) + unknown_note;
  } else if (orientations.size() < 2) {
    f.design = "the sphere in one known orientation" + unknown_note +
               ": a form of the sphere cannot be told from a function of the direction; it competes with the effects "
               "as a pattern fixed on the sphere";
  } else {
    f.design = few ? "the cross-validation's folds (as few as " + std::to_string(fewest) +
                         " samples) cannot fit a form of degree 2 or more beside the seven errors and the centres"
                   : "the pattern resolves no form of degree 2 or more";
  }
  return f;
}

// Which form terms of degrees 2..degree_limit the design cannot tell from the seven errors, the
// centres and the candidates of `pool` (linearised at `base`), in words. They stay in the search
// (the form is fitted before any effect, so no machine term they are confounded with is in the
// model with them); the report says that their split with the machine is not known.
void ConfoundedFormTerms(const Readings& data, const CalibrationOptions& options, const EffectFit& base,
                         const std::vector<Effect>& pool, const TraceOptions& trace_options, FormSelection* sel) {
  EffectModel machine;
  machine.reference = base.model.reference;
  int judged = base.n_params + FormModelOf(data.points, FormTermsOfDegrees(2, sel->degree_limit)).NumParams();
  for (const Effect e : pool) {
    machine.terms.push_back(DefaultTerm(e, trace_options.harmonics, trace_options.drift_order));
    judged += machine.terms.back().size();
  }
  if (data.points.samples.size() <= static_cast<std::size_t>(judged)) {
    sel->design += "; which of its terms the machine's effects would confound is not judged: " +
                   std::to_string(data.points.samples.size()) + " readings are too few for the " +
                   std::to_string(judged) + " parameters of the form and every candidate effect";
    return;
  }
  const FormIdentifiability id =
      IdentifyForm(data.points, options, machine, EffectFitStart::From(base), FormTermsOfDegrees(2, sel->degree_limit));
  for (const ConfoundedCombination& c : id.combinations) sel->confounded.push_back(c.words);
  if (!id.confounded.empty()) {
    std::string names;
    for (const FormTerm& t : id.confounded) {
      names += (names.empty() ? "" : " ") + ("S(" + std::to_string(t.l) + "," + std::to_string(t.m) + ")");
    }
    sel->design += "; " + names +
                   " cannot be told from the machine by this design: fitted as the sphere's, their split is not known";
  }
}

// The fit of `current`'s model with the sphere's form of degrees 2..L, for the L that minimises
// the extended BIC (BIC + 2 ln N, N the degrees searched), or the model without a form when no L
// lowers it by min_delta_bic. sel->delta_ebic gets each degree's score.
EffectFit SelectFormDegree(const Readings& data, const CalibrationOptions& options, const EffectFit& current,
                           const TraceOptions& trace_options, FormSelection* sel) {
  EffectModel plain = current.model;
  plain.form = FormModel{};
  EffectFitStart start = EffectFitStart::From(current);
  start.form_values.clear();
  EffectFit none = current.model.form.Empty()
                       ? current
                       : internal::FitEffectsRows(data.points, data.table, nullptr, options, plain, start);
  const double penalty = 2.0 * std::log(static_cast<double>(std::max(1, sel->degree_limit - 1)));
  EffectFit best = none;
  double best_score = none.Bic();
  sel->degree_max = 0;
  sel->delta_ebic.clear();
  for (int l = 2; l <= sel->degree_limit; ++l) {
    EffectModel model = plain;
    model.form = FormModelOf(data.points, FormTermsOfDegrees(2, l));
    EffectFit fit =
        internal::FitEffectsRows(data.points, data.table, nullptr, options, model, EffectFitStart::From(none));
    const double score = fit.Bic() + penalty;
    sel->delta_ebic.emplace_back(l, score - none.Bic());
    if (!fit.calibration.converged) continue;
    if (score - none.Bic() <= -trace_options.min_delta_bic && score < best_score) {
      best_score = score;
      best = std::move(fit);
      sel->degree_max = l;
    }
  }
  return best;
}

// Whether the sphere sat in one place for every setup (their centres within 10 um): the probe
// reading is then, like the time of a single pass, a function of the direction on the sphere, and
// a smooth one (to first order e . n, e the eccentricity).
bool OnePlacement(const EffectFit& fit) {
  const std::vector<Eigen::Vector3d>& c = fit.calibration.centers_mm;
  return std::all_of(c.begin(), c.end(), [&](const Eigen::Vector3d& x) { return (x - c.front()).norm() <= 0.010; });
}

// Whether the candidate follows a variable that a pattern fixed on the sphere is not (the time for
// probe_drift, the probe reading for the probe terms) and the residual shows its functions of that
// variable beyond any form of degree 2..5: the linearised BIC of J, every such harmonic and the
// term's powers against J and the harmonics alone falls by at least min_delta_bic. Never for a
// probe term with the sphere in one placement: a power of the reading is then a form of low degree
// (u^k of degree about k), and what it shows beyond degrees 2..5 is a higher degree of the form
// (the sphere's own, of degree 6 and more) that the reading's small higher terms happen to follow.
bool ShownBeyondSphere(const CandidateScore& c, const StructureFactor& factor, bool one_placement,
                       const TraceOptions& trace_options) {
  const std::string v = InfoOf(c.effect).variable;
  if ((v != "t" && v != "r") || c.term.components.empty()) return false;
  if (v == "r" && one_placement) return false;
  std::vector<int> functions;
  for (const EffectComponent& comp : c.term.components) functions.push_back(comp.order - 1);
  return DeltaBicBeyondSphere(factor, v, functions) <= -trace_options.min_delta_bic;
}

namespace {

// Whether a setup's form is its own (a setup of unknown orientation, or on another sphere).
bool SomeSetupHasItsOwnForm(const PointsData& points) {
  const std::vector<int> ids = points.SetupIds();
  return std::any_of(ids.begin(), ids.end(), [&](int id) { return !points.header.FormKey(id).empty(); });
}

// The factor R of [J | patterns | tau^powers | e] for a fit's residual e: J its Jacobian, the
// patterns fixed on the sphere spherical harmonics of degree 2..kSpherePatternDegree of the
// direction on the sphere's body, one set for each set of form of the setups (FormModelOf(): the
// setups of known orientation share one, each setup of unknown orientation and each other sphere
// has its own), named in *names ("S(l,m)" and "S(l,m)@<setup>" as the form's parameters are).
StructureFactor EachSetupsFactor(const Readings& data, const CalibrationOptions& options, const TracedFit& current,
                                 const std::vector<int>& powers, std::vector<std::string>* names) {
  const FormModel sets = FormModelOf(data.points, {});
  SchmidtHarmonics harmonics(2, kSpherePatternDegree);
  const Eigen::Index per_set = harmonics.size();
  const StructureJacobian jacobian(data.table, options, current.fit, current.expected_r_mm);
  const Eigen::Index n = jacobian.Cols(), first_time = n + sets.NumGroups() * per_set;
  const Eigen::Index cols = first_time + static_cast<Eigen::Index>(powers.size()) + 1;  // [J | patterns | tau^k | e]
  names->clear();
  for (int g = 0; g < sets.NumGroups(); ++g) {
    for (int l = 2; l <= kSpherePatternDegree; ++l) {
      for (int m = -l; m <= l; ++m) {
        names->push_back("S(" + std::to_string(l) + "," + std::to_string(m) + ")" +
                         sets.group_names[static_cast<std::size_t>(g)]);
      }
    }
  }
  RowQr qr(cols);
  Eigen::VectorXd norms2 = Eigen::VectorXd::Zero(cols);
  const EffectReference& ref = current.fit.model.reference;
  std::vector<double> block;
  jacobian.ForEach([&](const std::uint32_t* samples, int count, const double* jac, int stride, int) {
    block.assign(static_cast<std::size_t>(count * cols), 0.0);
    for (int i = 0; i < count; ++i) {
      const std::uint32_t k = samples[i];
      const Sample& s = data.points.samples[k];
      double* row = block.data() + i * cols;
      std::copy(jac + i * stride, jac + i * stride + n, row);
      const FormSetup& set = sets.SetupOf(s.setup);
      const Eigen::Vector3d u = set.rotation.transpose() * current.directions[k];
      harmonics.Evaluate(u.x(), u.y(), u.z(), row + n + set.group * per_set);
      const double tau = (s.t_s - ref.t_start_s) / ref.t_span_s;
      for (std::size_t j = 0; j < powers.size(); ++j)
        row[first_time + static_cast<Eigen::Index>(j)] = std::pow(tau, powers[j]);
      row[cols - 1] = current.fit.calibration.residuals_mm[k];
      for (Eigen::Index j = 0; j < cols; ++j) norms2(j) += row[j] * row[j];
    }
    qr.AddRows(block.data(), cols, count);
  });
  StructureFactor f;
  f.r = qr.r();
  f.rows = static_cast<Eigen::Index>(data.points.samples.size());
  f.jacobian_cols = n;
  f.norms = norms2.cwiseSqrt();
  return f;
}

// The linearised BIC of a fit's residual against the columns of its Jacobian, beside which the
// patterns of EachSetupsFactor(), and then powers of tau.
struct EachSetupsPattern {
  double delta_bic = 0.0;         // of the patterns against the Jacobian alone
  double explained_rms_um = 0.0;  // what the patterns explain
  double time_delta_bic = 0.0;    // of the powers of tau beside the Jacobian and the patterns
};

EachSetupsPattern BeyondEachSetupsPattern(const Readings& data, const CalibrationOptions& options,
                                          const TracedFit& current, const std::vector<int>& powers) {
  std::vector<std::string> names;
  const StructureFactor f = EachSetupsFactor(data, options, current, powers, &names);
  const Eigen::Index n = f.jacobian_cols, cols = f.r.cols();
  const Eigen::Index first_time = n + static_cast<Eigen::Index>(names.size());
  // With A = Q R, |A_S x - e| = |R_S x - r_e| for the first columns S: the fits come from R alone,
  // the columns equilibrated so that the rank does not depend on their units.
  const Eigen::MatrixXd& r = f.r;
  const Eigen::VectorXd e = r.col(cols - 1);
  const auto rss = [&](Eigen::Index first, Eigen::Index* rank) {
    Eigen::MatrixXd a = r.leftCols(first);
    for (Eigen::Index j = 0; j < first; ++j) {
      if (f.norms(j) > 0.0) a.col(j) /= f.norms(j);
    }
    Eigen::ColPivHouseholderQR<Eigen::MatrixXd> fit(a);
    fit.setThreshold(1e-10);
    *rank = fit.rank();
    return std::max((e - a * fit.solve(e)).squaredNorm(), 1e-300);
  };
  Eigen::Index rank_j = 0, rank_p = 0, rank_t = 0;
  const double rss_j = rss(n, &rank_j), rss_p = rss(first_time, &rank_p), rss_t = rss(cols - 1, &rank_t);
  const double m = static_cast<double>(data.points.samples.size()), log_m = std::log(m);
  EachSetupsPattern out;
  out.delta_bic = m * std::log(rss_p / rss_j) + static_cast<double>(rank_p - rank_j) * log_m;
  out.explained_rms_um = std::sqrt(std::max(rss_j - rss_p, 0.0) / m) * kUmPerMm;
  out.time_delta_bic = m * std::log(rss_t / rss_p) + static_cast<double>(rank_t - rank_p) * log_m;
  return out;
}
}  // namespace

SpherePattern CompetingSpherePattern(const Readings& data, const CalibrationOptions& options,
                                     const TracedFit& current) {
  if (!SomeSetupHasItsOwnForm(data.points)) return BestSpherePattern(current.factor);
  std::vector<std::string> names;
  const StructureFactor f = EachSetupsFactor(data, options, current, {}, &names);
  return BestPatternAmong(f, f.jacobian_cols, static_cast<Eigen::Index>(names.size()), names);
}

void NotBeyondEachSetupsPattern(const Readings& data, const CalibrationOptions& options, const TracedFit& current,
                                const TraceOptions& trace_options, Tried& tried, TraceResult& r,
                                std::set<Effect>* refused) {
  if (r.form.separable || !SomeSetupHasItsOwnForm(data.points)) return;
  const double cur_rms = current.fit.calibration.rms_um;
  for (auto& [c, fit] : tried) {
    if (!Follows(c.effect, "t") || c.held || !Admissible(c, current, trace_options)) continue;
    std::vector<int> powers;
    for (const EffectComponent& comp : c.term.components) powers.push_back(comp.order);
    const EachSetupsPattern p = BeyondEachSetupsPattern(data, options, current, powers);
    if (p.time_delta_bic <= -trace_options.min_delta_bic) continue;
    refused->insert(c.effect);
    c.note += std::string(c.note.empty() ? "" : "; ") +
              Format(
                  "qualifies, but shows no more than a pattern fixed on the sphere would, one for each setup "
                  "of unknown orientation or on another sphere and one for the others (delta BIC %.1f beside "
                  "their spherical harmonics of degree 2..%d)",
                  p.time_delta_bic, kSpherePatternDegree);
    Ambiguity a{"sphere_form", c.Id(), p.delta_bic, c.delta_bic, 0.0, SeparateFromForm(c.effect)};
    a.chosen_rms_um = p.explained_rms_um;
    a.other_rms_um = ExplainedRmsUm(cur_rms, c.rms_um);
    NameOnce(&r.ambiguous, a);
  }
}

// The measurement that separates effect e from a form of the sphere when the sphere was measured
// in one placement.
std::string SeparateFromForm(Effect e) {
  if (e == Effect::kProbeDrift) {
    return "the pattern measured a second time in another order (reversed or shuffled), so that time is no "
           "function of the direction on the sphere, or the sphere turned on its mount";
  }
  if (IsReversal(e)) {
    return "the pattern measured a second time with each axis moving the other way (a reversal follows the "
           "direction of motion, a form the point on the sphere), or the sphere turned on its mount";
  }
  if (InfoOf(e).harmonic) {  // an error of the machine's axes
    return "the sphere turned on its mount (a form turns with the sphere, an error of the machine stays with the "
           "machine), or a second setup at another eccentricity";
  }
  return "a second setup at another eccentricity (the probe then works over another range) or with the sphere turned "
         "on its mount (a form turns with the sphere)";
}

// Whether the structure test of the variable effect e follows (time or probe reading) is significant.
bool ShownByItsVariable(Effect e, const ResidualStructure& structure, const TraceOptions& trace_options) {
  const std::string v = InfoOf(e).variable;
  if (v != "t" && v != "r") return false;
  for (const StructureGroup& g : structure.groups) {
    if (g.variable == v) return g.p_value < trace_options.structure_p;
  }
  return false;
}

std::vector<Unexplained> RemainingStructure(const ResidualStructure& s, const TraceOptions& trace_options) {
  // Every group below the threshold is described, whether or not the test of all the functions
  // together is: a structure in one variable is diluted among the many functions of the others.
  std::vector<Unexplained> out;
  std::vector<const StructureGroup*> groups;
  for (const StructureGroup& g : s.groups) {
    if (g.p_value < trace_options.structure_p) groups.push_back(&g);
  }
  std::sort(groups.begin(), groups.end(),
            [](const StructureGroup* a, const StructureGroup* b) { return a->explained_rms_um > b->explained_rms_um; });
  for (const StructureGroup* g : groups) {
    Unexplained u;
    u.variable = g->variable;
    u.rms_um = g->explained_rms_um;
    u.p_value = g->p_value;
    const std::string what =
        g->variable == "sphere" ? "a pattern fixed on the sphere (its own form error, or an effect outside the library)"
                                : "structure that follows " + g->variable + " (" + g->description + ")";
    u.description = what + ", " + Format("%.3g", g->explained_rms_um) + " um RMS; strongest " + g->strongest + " (" +
                    Format("%.3g", g->strongest_rms_um) + " um RMS alone)";
    out.push_back(u);
  }
  if (out.empty() && s.all.p_value < trace_options.structure_p) {
    Unexplained u;
    u.variable = "all";
    u.rms_um = s.all.explained_rms_um;
    u.p_value = s.all.p_value;
    u.description = "structure that no single variable explains, " + Format("%.3g", s.all.explained_rms_um) + " um RMS";
    out.push_back(u);
  }
  return out;
}

// With a design that separates the form: whether candidate c still lowers the extended BIC by
// min_delta_bic with the form at the highest degree searched in the model, as the time and probe
// effects must beyond a pattern in one placement (ShownBeyondSphere()). A candidate whose signal a
// form of some degree explains as well turns with the sphere in this design: a probe polynomial,
// for one, when the eccentricity points the same way on the sphere's body in every setup. `full`
// is the current model with that form (fitted once per round); *delta_ebic gets the candidate's
// score beside it (NaN where it is not separable from that form).
bool ShownBeyondForm(const Readings& data, const CalibrationOptions& options, const CandidateScore& c,
                     const EffectFit& full, const TraceOptions& trace_options, double* delta_ebic) {
  // A fit that does not settle, the form's alone or with the candidate: not separable from it.
  *delta_ebic = std::numeric_limits<double>::quiet_NaN();
  if (!full.calibration.converged) return false;
  EffectModel model = full.model;
  model.terms.push_back(c.term);
  const EffectFit with =
      internal::FitEffectsRows(data.points, data.table, nullptr, options, model, EffectFitStart::From(full));
  if (!with.calibration.converged) return false;
  *delta_ebic = with.Bic() - full.Bic() + SearchPenalty(c.term, trace_options);
  if (!(*delta_ebic <= -trace_options.min_delta_bic)) return false;
  // Its components must stay separable from that form, as FitCandidate() asks (that one of them
  // is less significant among that many form terms is no sign of the form explaining it).
  const int offset = with.TermOffset(model.terms.size() - 1);
  const Eigen::VectorXd& vif = with.calibration.analysis.vif;
  for (int k = 0; k < c.term.size(); ++k) {
    const int col = offset + k;
    if (col >= vif.size() || !(vif(col) <= trace_options.max_vif)) {
      *delta_ebic = std::numeric_limits<double>::quiet_NaN();
      return false;
    }
  }
  return true;
}

// The current model with the form of degrees 2..limit (its start: the current fit's).
EffectFit FullForm(const Readings& data, const CalibrationOptions& options, const TracedFit& current,
                   const FormSelection& sel) {
  EffectModel model = current.fit.model;
  model.form = FormModelOf(data.points, FormTermsOfDegrees(2, sel.degree_limit));
  return internal::FitEffectsRows(data.points, data.table, nullptr, options, model, EffectFitStart::From(current.fit));
}

void HigherDegrees(const Readings& data, const CalibrationOptions& options, const TracedFit& current,
                   FormSelection* sel) {
  sel->higher_rms_um.clear();
  const FormModel& form = current.fit.model.form;
  if (form.Empty() || form.MaxDegree() >= sel->degree_limit) return;
  const EffectFit full = FullForm(data, options, current, *sel);
  const ObservabilityReport& rep = full.calibration.analysis;
  if (!full.calibration.converged || rep.Empty()) return;
  const auto n = static_cast<Eigen::Index>(full.model.form.terms.size());
  for (int g = 0; g < full.model.form.NumGroups(); ++g) {
    const std::vector<double>& c = full.form_values[static_cast<std::size_t>(g)];
    const int first = full.FormOffset(g);
    const CorrectedRms higher = CorrectedFormRms(full.model.form.terms, Eigen::Map<const Eigen::VectorXd>(c.data(), n),
                                                 rep.covariance.block(first, first, n, n), form.MaxDegree() + 1);
    sel->higher_rms_um.emplace_back(higher.rms_um, higher.std_um);
  }
}
}  // namespace sph::internal
