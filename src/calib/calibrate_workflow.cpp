#include "sph/calib/calibrate_workflow.hpp"

#include <algorithm>
#include <cmath>
#include <exception>
#include <limits>
#include <map>
#include <memory>
#include <utility>

#include <Eigen/Eigenvalues>

#include "fit_problem.hpp"
#include "solve_fit.hpp"
#include "sph/calib/misreading.hpp"
#include "sph/core/cancellation.hpp"
#include "sph/core/error.hpp"
#include "sph/core/ranges.hpp"
#include "sph/core/valid_range.hpp"
#include "sph/internal/format.hpp"
#include "sph/io/output_files.hpp"
#include "sph/io/parameter_settings.hpp"
#include "sph/io/setup_checks.hpp"
#include "sph/model/units.hpp"
#include "sph/stats/gum.hpp"

namespace sph {

namespace {

using internal::Format;

// The known forms' files: the reference sphere's (empty: none) and another sphere's by the setup
// that names it in CalibrationOptions::other_form_priors.
struct KnownFormFiles {
  std::string reference;
  std::map<int, std::string> others;
};

// The budget of the calibration reported (the trace's final fit when `extended`); none, with a
// warning, when the fit was not analysed or a refit fails.
void MakeBudget(CalibrationWorkflowResult& run, const CalibrationWorkflowOptions& o) {
  const CalibrationResult& result = run.Reported();
  if (result.analysis.Empty() || !result.converged) return;
  const EffectFit* extended = run.Extended() ? &run.trace->after.fit : nullptr;
  BudgetRefit refit = [&](const PointsData& p, const CalibrationOptions& q) {
    if (extended == nullptr) {
      CalibrationOptions start = q;
      start.initial_geometry = result.geometry;
      const CalibrationResult r = Calibrate(p, start);
      return internal::PackParameters(r.geometry, r.centers_mm);
    }
    const EffectFit fit = FitEffects(p, q, extended->model, EffectFitStart::From(*extended));
    return internal::PackParameters(fit.calibration.geometry, fit.calibration.centers_mm, fit.values, fit.form_values);
  };
  try {
    run.budget = MakeCalibrationBudget(WithoutOutliers(run.points, result), run.settings, result, run.inputs, refit);
  } catch (const Cancelled&) {
    throw;
  } catch (const std::exception& e) {
    run.warnings.push_back(std::string("no uncertainty budget: ") + e.what());
    if (o.on_warning) o.on_warning(run.warnings.back());
  }
}

// The certificate's bound of the form: the options', else the header's [um].
std::optional<double> FormBoundUm(const CalibrationWorkflowResult& run, const CalibrationWorkflowOptions& o) {
  return o.conditions.sphere_form_rms_um ? o.conditions.sphere_form_rms_um
                                         : ConditionsOf(run.points.header).sphere_form_rms_um;
}

void Tell(const std::function<void(const std::string&)>& f, const std::string& text) {
  if (f) f(text);
}

void Warn(CalibrationWorkflowResult& run, const CalibrationWorkflowOptions& o, const std::string& warning) {
  run.warnings.push_back(warning);
  Tell(o.on_warning, warning);
}

// A sphere of the points: the reference (setups empty) or another, by the setups that measured it.
struct PointsSphere {
  std::string name;  // in messages: "R0" or "sphere_radius_mm@2,3"
  double radius_mm = 0.0;
  double u_um = 0.0;
  std::vector<int> setups;
  std::string file;  // the form's file matched to it
};

std::vector<PointsSphere> SpheresOf(const CalibrationWorkflowResult& run) {
  std::vector<PointsSphere> spheres{{"R0", run.settings.sphere_radius_mm, run.inputs.sphere_radius_u_um, {}, ""}};
  std::map<std::string, std::size_t> index;  // by the radius, as PointsHeader::FormKey() writes it
  for (const auto& [setup, radius_mm] : run.settings.sphere_radii_mm) {
    const auto [it, is_new] = index.emplace(internal::Shortest(radius_mm), spheres.size());
    if (is_new) spheres.push_back({"sphere_radius_mm@", radius_mm, 0.0, {}, ""});
    PointsSphere& s = spheres[it->second];
    s.name += (s.setups.empty() ? "" : ",") + std::to_string(setup);
    s.setups.push_back(setup);
  }
  return spheres;
}

std::string SpheresText(const std::vector<PointsSphere>& spheres) {
  std::string text;
  for (const PointsSphere& s : spheres) {
    text += (text.empty() ? "" : ", ") + s.name + " " + Format("%.9g", s.radius_mm) + " mm (u " + Format("%g", s.u_um) +
            " um)";
  }
  return text;
}

// The sphere of the points whose form `file` holds (by its R0), refused when none or several.
PointsSphere& SphereOfFile(std::vector<PointsSphere>& spheres, const CalibrationFile& file, const std::string& path,
                           const std::string& points_path) {
  if (!file.sphere_radius_mm) {
    throw Error(path + ": states no sphere_radius_mm, so it cannot be told which of the points' spheres (" +
                SpheresText(spheres) + ") its form belongs to");
  }
  double file_u_um = 0.0;
  for (const CalibrationFile::CovarianceInput& in : file.covariance_inputs) {
    if (in.input == "R0 (certificate)" && in.unit == "um") file_u_um = in.u;
  }
  std::vector<std::size_t> matches;
  for (std::size_t i = 0; i < spheres.size(); ++i) {
    const double difference_um = std::abs(spheres[i].radius_mm - *file.sphere_radius_mm) * kUmPerMm;
    if (difference_um <= spheres[i].u_um + file_u_um + 1e-3) matches.push_back(i);
  }
  const std::string its = path + ": its sphere, sphere_radius_mm " + Format("%.9g", *file.sphere_radius_mm) +
                          " mm (u " + Format("%g", file_u_um) + " um), ";
  if (matches.empty()) {
    throw Error(its + "is none of the spheres of " + points_path + " (" + SpheresText(spheres) +
                ") within their standard uncertainties: the known form belongs to its own sphere");
  }
  if (matches.size() > 1) {
    std::vector<PointsSphere> both;
    for (const std::size_t i : matches) both.push_back(spheres[i]);
    throw Error(its + "could be any of the spheres of " + points_path + " " + SpheresText(both) +
                " within their standard uncertainties: which sphere's form it holds is ambiguous");
  }
  PointsSphere& sphere = spheres[matches.front()];
  if (!sphere.file.empty()) {
    throw Error(path + " and " + sphere.file + " both hold a form of the sphere " + sphere.name + " of " + points_path);
  }
  sphere.file = path;
  return sphere;
}

// Whether a setup of the reference sphere (no radius of its own) is of known orientation: what
// the reference sphere's known form and its certificate's bound apply to.
bool ReferenceOrientationKnown(const CalibrationWorkflowResult& run) {
  const PointsHeader& h = run.points.header;
  for (const Sample& s : run.points.samples) {
    if (h.sphere_radii_mm.count(s.setup) != 0) continue;
    const auto r = h.mount_rotations.find(s.setup);
    if (r == h.mount_rotations.end() || r->second.known()) return true;
  }
  return false;
}

// The spheres' forms as known: each file's (matched to its sphere), else the reference sphere's
// certificate's bound.
KnownFormFiles SettleKnownForm(CalibrationWorkflowResult& run, const CalibrationWorkflowOptions& o) {
  KnownFormFiles files;
  const std::optional<double> bound_um = FormBoundUm(run, o);
  std::vector<PointsSphere> spheres = SpheresOf(run);
  for (const std::string& path : o.sphere_form_paths) {
    const CalibrationFile file = ReadCalibrationFile(path);
    if (spheres.size() == 1) {  // one sphere: the file's R0 must be the points'
      CheckSameSphere(file, path, run.settings.sphere_radius_mm, run.inputs.sphere_radius_u_um, run.points_path);
      if (!spheres[0].file.empty()) {
        throw Error(path + " and " + spheres[0].file + " both hold a form of the sphere R0 of " + run.points_path);
      }
      spheres[0].file = path;
    } else {
      SphereOfFile(spheres, file, path, run.points_path);
    }
    std::vector<std::string> notes;
    FormPrior prior = FormPriorOfFile(file, path, &notes);
    for (const std::string& n : notes) Warn(run, o, n);
    const PointsSphere& sphere =
        *std::find_if(spheres.begin(), spheres.end(), [&](const PointsSphere& s) { return s.file == path; });
    if (sphere.setups.empty()) {
      if (!ReferenceOrientationKnown(run)) {
        throw Error(path + ": holds the form of the reference sphere of " + run.points_path +
                    ", but every setup of that sphere is of unknown orientation (mount_rotation_deg@<setup>: "
                    "unknown): the known form applies to none of them");
      }
      run.settings.form_prior = std::move(prior);
      continue;
    }
    const auto known = std::find_if(sphere.setups.begin(), sphere.setups.end(), [&](int setup) {
      const auto r = run.points.header.mount_rotations.find(setup);
      return r == run.points.header.mount_rotations.end() || r->second.known();
    });
    if (known == sphere.setups.end()) {
      throw Error(path + ": holds the form of the sphere " + sphere.name + " of " + run.points_path +
                  ", but every setup of that sphere is of unknown orientation (mount_rotation_deg@<setup>: unknown), "
                  "where a known form does not apply");
    }
    run.settings.other_form_priors[*known] = std::move(prior);
    files.others[*known] = path;
  }
  if (run.settings.form_prior.Empty() && bound_um && o.trace) {
    const int l_max = FormDegreeLimit(run.points, o.trace_options);
    // The bound as a prior on the form of the setups of known orientation: with none, or no form
    // the pattern resolves, it applies to nothing (refused when the options give it, a warning for
    // the header's, which states the sphere's certificate whatever the run does with it).
    const std::string nothing = !ReferenceOrientationKnown(run)
                                    ? "every setup of the reference sphere is of unknown orientation "
                                      "(mount_rotation_deg@<setup>: unknown), whose forms are each their own"
                                : l_max < 2 ? "the pattern resolves no form of degree 2 or more"
                                            : "";
    if (nothing.empty()) {
      run.settings.form_prior = CertificateFormPrior(*bound_um * kMmPerUm, l_max);
    } else if (o.conditions.sphere_form_rms_um) {
      throw Error("--sphere-form-rms-um " + Format("%g", *bound_um) + ": " + nothing +
                  ": the certificate's bound applies to nothing");
    } else {
      Warn(run, o,
           "sphere_form_rms_um (the header of " + run.points_path + "): " + nothing +
               ": the certificate's bound is not used");
    }
  } else if (bound_um && !o.trace && !o.conditions.sphere_form_rms_um) {
    Warn(run, o,
         "sphere_form_rms_um (the header of " + run.points_path +
             "): the seven errors alone (no trace) have no form: the certificate's bound is not used");
  }
  if (!files.others.empty() && run.settings.form_prior.Empty()) {
    throw Error(run.points_path + ": a known form of another sphere (" + files.others.begin()->second +
                ") needs the reference sphere's form known too: a --sphere-form file of it (R0 " +
                Format("%.9g", run.settings.sphere_radius_mm) +
                " mm), or its certificate's bound (--sphere-form-rms-um)");
  }
  files.reference = spheres[0].file;
  return files;
}

// A fixed value or a prior of an effect's parameter states that the effect exists: refused
// (sph::Error, where it came from and why) when the calibration's model cannot hold the effect: the
// seven errors alone (no trace), or a fixed model (`effects`) without it.
void RefuseEffectStatementsOfNothing(const CalibrationWorkflowResult& run, const CalibrationWorkflowOptions& o) {
  const auto refuse = [&](const std::string& name, const std::string& kind, const std::string& text) {
    const auto dot = name.find('.');
    if (dot == std::string::npos) return;  // one of the seven errors: every calibration has it
    Effect e{};
    if (!EffectFromId(name.substr(0, dot), &e)) return;  // CheckParameterSettings() names it
    const std::string id = InfoOf(e).id;
    const std::string& origin = run.statement_origins.at(name);
    const std::string what = origin.rfind("--", 0) == 0 ? origin + " " + text : kind + " " + text + " (" + origin + ")";
    if (!o.trace) {
      throw Error(what + ": " + name + " is a parameter of the effect " + id +
                  ", which a calibration of the seven errors alone (--no-trace) does not have: the statement "
                  "applies to nothing. With the trace, " +
                  id + " is in the model from the start");
    }
    if (!o.effects.empty() && std::find(o.effects.begin(), o.effects.end(), e) == o.effects.end()) {
      std::string fitted;
      for (const Effect f : o.effects) fitted += (fitted.empty() ? "" : ",") + std::string(InfoOf(f).id);
      throw Error(what + ": " + name + " is a parameter of the effect " + id + ", which the fixed model --effects " +
                  fitted + " does not have: the statement applies to nothing; add " + id + " to --effects");
    }
  };
  for (const FixedParameter& f : run.settings.fixed) refuse(f.name, "fix", FixedParameterText(f));
  for (const ParameterPrior& p : run.settings.priors) refuse(p.name, "prior", ParameterPriorText(p));
}

// The fit's settings from the options and the points' header (the options win); run.inputs gets
// the measuring conditions of both. Returns the known forms' files.
KnownFormFiles Settle(CalibrationWorkflowResult& run, const CalibrationWorkflowOptions& o) {
  const PointsHeader& header = run.points.header;
  const auto radius = o.sphere_radius_mm ? o.sphere_radius_mm : header.sphere_radius_mm;
  const auto offset = o.probe_offset_mm ? o.probe_offset_mm : header.probe_offset_mm;
  if (!radius) {
    throw Error(run.points_path +
                ": the reference sphere radius R0 is not given: add a header line "
                "'# sphere_radius_mm: <R0>' to the file or pass --sphere-radius-mm");
  }
  if (!offset) {
    throw Error(run.points_path +
                ": the nominal probe zero distance d is not given: add a header line "
                "'# probe_offset_mm: <d>' to the file or pass --probe-offset-mm");
  }
  run.inputs = CalibrationInputs().With(ConditionsOf(header)).With(o.conditions);
  if (o.coverage) run.inputs.coverage.probability = *o.coverage;
  run.settings = o.fit;
  run.settings.sphere_radius_mm = run.inputs.RadiusAtTemperatureMm(*radius);
  run.settings.sphere_radii_mm.clear();
  for (const auto& [setup, radius_mm] : header.sphere_radii_mm) {
    run.settings.sphere_radii_mm[setup] = run.inputs.RadiusAtTemperatureMm(radius_mm);  // same temperature, CTE
  }
  run.settings.probe_offset_mm = *offset;
  // What the header holds and informs, then the options' (which win for a parameter both name).
  auto named = [&](const std::string& name) {
    return std::any_of(o.fit.fixed.begin(), o.fit.fixed.end(),
                       [&](const FixedParameter& f) { return f.name == name; }) ||
           std::any_of(o.fit.priors.begin(), o.fit.priors.end(),
                       [&](const ParameterPrior& p) { return p.name == name; });
  };
  run.settings.fixed.clear();
  run.settings.priors.clear();
  const std::string in_header = "the header of " + run.points_path;
  for (const FixedParameter& f : FixedParametersOf(header)) {
    if (named(f.name)) continue;
    run.settings.fixed.push_back(f);
    run.statement_origins[f.name] = in_header;
  }
  for (const ParameterPrior& p : ParameterPriorsOf(header)) {
    if (named(p.name)) continue;
    run.settings.priors.push_back(p);
    run.statement_origins[p.name] = in_header;
  }
  run.settings.fixed.insert(run.settings.fixed.end(), o.fit.fixed.begin(), o.fit.fixed.end());
  run.settings.priors.insert(run.settings.priors.end(), o.fit.priors.begin(), o.fit.priors.end());
  for (const FixedParameter& f : o.fit.fixed) run.statement_origins[f.name] = "--fix";
  for (const ParameterPrior& p : o.fit.priors) run.statement_origins[p.name] = "--prior";
  RefuseEffectStatementsOfNothing(run, o);
  if (o.fit.robust_loss != RobustLoss::kNone && o.trace && o.effects.empty()) {
    throw Error(
        "--robust-loss keeps every reading at a weight, which the trace's selection of effects does not "
        "(it judges outliers by their residuals): use it with --no-trace, or with --effects for a fixed "
        "model");
  }
  KnownFormFiles files = SettleKnownForm(run, o);
  run.probe_range_mm = o.conditions.probe_range_mm ? o.conditions.probe_range_mm : ConditionsOf(header).probe_range_mm;
  if (run.probe_range_mm) {
    CheckReadingsInProbeRange(run.points, *run.probe_range_mm,
                              o.conditions.probe_range_mm ? "--probe-range-mm" : "probe_range_mm");
  }
  return files;
}

// The residual traced to further effects (or the fixed effects fitted), and its validation.
void Trace(CalibrationWorkflowResult& run, const CalibrationWorkflowOptions& o) {
  TraceOptions trace_options = o.trace_options;
  trace_options.probe_range_mm = run.probe_range_mm;
  if (o.effects.empty()) {
    run.trace = TraceResidual(run.points, run.settings, run.seven, trace_options);
  } else {
    std::vector<Effect> fixed;
    for (const Effect& e : o.effects) {
      if (std::find(fixed.begin(), fixed.end(), e) == fixed.end()) fixed.push_back(e);
    }
    run.trace = FitFixedEffects(run.points, run.settings, run.seven, fixed, trace_options);
  }
  if (o.validate_path.empty()) return;
  Validation& v = run.validation.emplace(Validate(o.validate_path, run.settings.probe_offset_mm, *run.trace));
  if (SameFile(o.validate_path, run.points_path)) {
    v.note =
        "the validation file is the calibration's own points file: this shows how the model fits its own data, "
        "not an independent check" +
        (v.note.empty() ? std::string() : "; " + v.note);
  }
}

// The seven-error calibration as a fit without effects (what the statements are tested on
// without a trace).
EffectFit SevenAsFit(const CalibrationWorkflowResult& run) {
  EffectFit fit;
  fit.model.reference = EffectReferenceOf(run.points.samples);
  fit.calibration = run.seven;
  fit.n_params = kNumScmsParams + 3 * static_cast<int>(run.seven.centers_mm.size());
  return fit;
}

// "mount_rotation_deg@0: 0 0 90" for each setup of `setups` (all the setups of known orientation
// of the reference sphere when empty), "the reference orientation" for a setup without the field.
std::string OrientationsText(const CalibrationWorkflowResult& run, const std::vector<int>& setups) {
  const PointsHeader& h = run.points.header;
  std::vector<int> ids = setups;
  if (ids.empty()) {
    for (const int id : run.seven.setup_ids) {
      const auto r = h.mount_rotations.find(id);
      if (h.sphere_radii_mm.count(id) == 0 && (r == h.mount_rotations.end() || r->second.known())) ids.push_back(id);
    }
  }
  std::string text;
  for (const int id : ids) {
    const auto r = h.mount_rotations.find(id);
    text += (text.empty() ? "" : ", ") + (r == h.mount_rotations.end()
                                              ? "setup " + std::to_string(id) + " in the reference orientation"
                                              : MountRotationKey(id) + ": " + MountRotationValue(r->second));
  }
  return text;
}

// What the readings say of a known form's orientation: the turn by right angles of one of its
// setups that fits them best with the form held (BestRightAngleTurn()), whether it fits clearly
// better than the stated orientation, and the workflow run with it stated (when it does, or when
// the orientation the readings support is searched).
struct TurnEvidence {
  std::optional<MountRotationFit> best;
  bool better = false;  // the readings' sum of squares lower by at least 10 sigma^2
  std::shared_ptr<const CalibrationWorkflowResult> at_turn;
};

// The setups of known orientation of the sphere of the known form `prior_setup` (< 0: the reference
// sphere's).
std::vector<int> SetupsOfForm(const CalibrationWorkflowResult& run, int prior_setup) {
  const PointsHeader& h = run.points.header;
  const std::optional<double> radius =
      prior_setup < 0 ? std::nullopt : std::optional<double>(run.settings.sphere_radii_mm.at(prior_setup));
  std::vector<int> setups;
  for (const int id : run.seven.setup_ids) {
    const auto r = h.mount_rotations.find(id);
    if (r != h.mount_rotations.end() && !r->second.known()) continue;
    const auto own = run.settings.sphere_radii_mm.find(id);
    if (radius ? (own != run.settings.sphere_radii_mm.end() && own->second == *radius)
               : own == run.settings.sphere_radii_mm.end()) {
      setups.push_back(id);
    }
  }
  return setups;
}

TurnEvidence BestTurnOf(const CalibrationWorkflowResult& run, int prior_setup) {
  TurnEvidence ev;
  const EffectFit fit = run.Extended() ? run.trace->after.fit : SevenAsFit(run);
  for (const int id : SetupsOfForm(run, prior_setup)) {
    MountRotationFit f = BestRightAngleTurn(run.points, run.settings, fit, id, prior_setup);
    if (!ev.best || f.rms_um * f.rms_um - f.stated_rms_um * f.stated_rms_um <
                        ev.best->rms_um * ev.best->rms_um - ev.best->stated_rms_um * ev.best->stated_rms_um) {
      ev.best = f;
    }
  }
  if (!ev.best) return ev;
  const double sigma_um =
      fit.calibration.analysis.Empty() ? fit.calibration.rms_um : fit.calibration.analysis.residual_sigma_mm * kUmPerMm;
  const double m = static_cast<double>(fit.calibration.n_points);
  ev.better = sigma_um > 0.0 && (ev.best->stated_rms_um * ev.best->stated_rms_um - ev.best->rms_um * ev.best->rms_um) *
                                        m / (sigma_um * sigma_um) >=
                                    10.0;
  return ev;
}

// `run`'s workflow again with setup's mount rotation `rotation_deg` in place of the file's
// (options without the comparison, the validation and the orientation's search).
std::shared_ptr<const CalibrationWorkflowResult> TurnedRun(const CalibrationWorkflowResult& run,
                                                           const CalibrationWorkflowOptions& options, int setup,
                                                           const Eigen::Vector3d& rotation_deg) {
  PointsData turned = run.points;
  turned.header.mount_rotations[setup] = MountRotation::Known(rotation_deg);
  CalibrationWorkflowOptions again = options;
  again.search_orientation = false;
  again.accept_rejected = false;
  again.compare_path.clear();
  again.validate_path.clear();
  again.on_stage = nullptr;
  again.on_warning = nullptr;
  again.trace_options.progress = nullptr;
  return std::make_shared<const CalibrationWorkflowResult>(
      RunCalibrationWorkflow(std::move(turned), run.points_path, again));
}

// The check of the known form `prior_setup` (< 0: the reference sphere's) of `points` on `fit`.
KnownFormCheck CheckOn(const CalibrationWorkflowResult& run, const CalibrationWorkflowOptions& o,
                       const KnownFormFiles& files, int prior_setup, const PointsData& points, const EffectFit& fit) {
  if (prior_setup >= 0)
    return CheckOtherKnownForm(points, run.settings, fit, prior_setup, files.others.at(prior_setup));
  const std::string& file = files.reference;
  return CheckKnownForm(points, run.settings, fit, file.empty() ? "the certificate's bound" : file, FormBoundUm(run, o),
                        !file.empty());
}

// How the readings agree with the known forms, their warnings among the run's. A form of a file
// is tested with the effects the trace found beside it, and, when another turn of its sphere by
// right angles fits the readings clearly better (`evidence`, with the workflow there), with the
// effects found under that turn too: effects found beside a wrongly turned form can take up its
// misfit, which the test with them kept then does not see.
void CheckForm(CalibrationWorkflowResult& run, const CalibrationWorkflowOptions& o, const KnownFormFiles& files,
               std::map<int, TurnEvidence>* evidence) {
  if (run.settings.form_prior.Empty() || !run.trace || run.trace->after.fit.model.form.Empty()) return;
  const EffectFit& fit = run.trace->after.fit;
  run.known_form = CheckOn(run, o, files, -1, run.points, fit);
  for (const auto& [setup, path] : files.others) {
    run.other_known_forms.push_back(CheckOn(run, o, files, setup, run.points, fit));
  }
  std::vector<std::pair<int, KnownFormCheck*>> forms;
  if (!files.reference.empty()) forms.emplace_back(-1, &*run.known_form);
  std::size_t i = 0;
  for (const auto& [setup, path] : files.others) forms.emplace_back(setup, &run.other_known_forms[i++]);
  for (const auto& [prior_setup, check] : forms) {
    if (!o.search_orientation) break;
    TurnEvidence ev = BestTurnOf(run, prior_setup);
    if (ev.better) {
      ev.at_turn = TurnedRun(run, o, ev.best->setup, ev.best->right_angle_deg);
      const CalibrationWorkflowResult& there = *ev.at_turn;
      if (there.trace && !there.trace->after.fit.model.terms.empty()) {
        // The stated orientation with the effects found under the turn that fits better.
        const PointsData kept = WithoutOutliers(run.points, fit.calibration);
        EffectModel model = fit.model;
        model.terms = there.trace->after.fit.model.terms;
        model.reference = there.trace->after.fit.model.reference;
        EffectFitStart start = EffectFitStart::From(there.trace->after.fit);
        start.form_values = fit.form_values;
        const EffectFit with = FitEffects(kept, run.settings, model, start);
        KnownFormCheck k = CheckOn(run, o, files, prior_setup, kept, with);
        if (!k.agrees && check->agrees) {
          std::string ids;
          for (const EffectTerm& t : model.terms) ids += (ids.empty() ? "" : ", ") + std::string(t.info().id);
          k.verdict += "; tested with the effects found under the turn that fits the readings better (" + ids +
                       "), for those found beside the form as stated (" + std::to_string(fit.model.terms.size()) +
                       ") may take up its misfit";
          for (std::string& w : k.warnings)
            w += " (tested with " + ids + ", the effects found under the turn " + "that fits the readings better)";
          *check = std::move(k);
        }
      }
    }
    (*evidence)[prior_setup] = std::move(ev);
  }
  for (const std::string& w : run.known_form->warnings) Warn(run, o, w);
  for (const KnownFormCheck& k : run.other_known_forms) {
    for (const std::string& w : k.warnings) Warn(run, o, w);
  }
}

std::string VectorText(const Eigen::Vector3d& v) {
  const auto clean = [](double x) { return std::abs(x) < 5e-5 ? 0.0 : x; };
  return Format("%.4g %.4g %.4g", clean(v.x()), clean(v.y()), clean(v.z()));
}

const StatementCheck* FormStatement(const CalibrationWorkflowResult& run, StatementKind kind, std::size_t nth) {
  std::size_t i = 0;
  for (const StatementCheck& c : run.statements) {
    if (c.kind == kind && (kind == StatementKind::kKnownForm || i++ == nth)) return &c;
  }
  return nullptr;
}

// SupportedOrientationOf() from what BestTurnOf() found (and its workflow at the turn, when run).
SupportedOrientation SupportedOrientationFrom(const CalibrationWorkflowResult& run,
                                              const CalibrationWorkflowOptions& options, int prior_setup,
                                              TurnEvidence ev) {
  SupportedOrientation out;
  if (!ev.best) return out;
  const PointsHeader& h = run.points.header;
  out.setup = ev.best->setup;
  const auto stated = h.mount_rotations.find(out.setup);
  out.stated_deg = stated == h.mount_rotations.end() ? Eigen::Vector3d::Zero() : *stated->second.rotation_deg;
  out.right_angle_deg = ev.best->right_angle_deg;
  const StatementKind kind = prior_setup < 0 ? StatementKind::kKnownForm : StatementKind::kOtherForm;
  std::size_t nth = 0;  // the other sphere's statement: by its place among them
  for (const auto& [key, prior] : run.settings.other_form_priors) {
    if (key == prior_setup) break;
    ++nth;
  }
  // The workflow at that turn; the rotation refined from it with the effects found there.
  if (!ev.at_turn) ev.at_turn = TurnedRun(run, options, out.setup, out.right_angle_deg);
  const CalibrationWorkflowResult& at_turn = *ev.at_turn;
  const EffectFit there = at_turn.Extended() ? at_turn.trace->after.fit : SevenAsFit(at_turn);
  const MountRotationFit refined = RefineMountRotation(at_turn.points, at_turn.settings, there, out.setup, prior_setup);
  out.fitted_deg = refined.fitted_deg;
  out.u_deg = refined.u_deg;
  out.offset_deg = refined.offset_deg;
  // The turn by right angles when the fitted rotation is within its uncertainty of it (3 u, at
  // least half a degree), else the fitted one, is tested.
  const bool right_angle =
      std::isfinite(out.u_deg) ? out.offset_deg <= std::max(3.0 * out.u_deg, 0.5) : out.offset_deg <= 0.5;
  const StatementCheck* test = FormStatement(at_turn, kind, nth);
  std::shared_ptr<const CalibrationWorkflowResult> at_fitted;
  if (!right_angle) {
    at_fitted = TurnedRun(run, options, out.setup, out.fitted_deg);
    test = FormStatement(*at_fitted, kind, nth);
  }
  if (test != nullptr) {
    out.p_value = test->p_value;
    out.agrees = !test->rejected;
  }
  const std::string u = std::isfinite(out.u_deg) ? Format("u %.2g deg", out.u_deg)
                                                 : std::string(
                                                       "the turn about one axis not determined: the form looks "
                                                       "the same turned about it");
  const std::string turn = VectorText(right_angle ? out.right_angle_deg : out.fitted_deg);
  const std::string detail =
      Format("p %.2g; ", out.p_value) +
      (right_angle ? "fitted with the form held " + VectorText(out.fitted_deg) + " deg, " + u
                   : u + ", " + Format("%.3g", out.offset_deg) + " deg from the turn by right angles " +
                         VectorText(out.right_angle_deg));
  const std::string key = MountRotationKey(out.setup);
  out.text = (out.agrees ? "the readings fit the known form turned " + turn + " (" + detail + ")"
                         : "no mount orientation of the known form agrees with the readings: the closest, turned " +
                               turn + ", is rejected too (" + detail +
                               "); the sphere may have changed since its form was separated, or the form is another "
                               "sphere's") +
             "; " + run.points_path +
             (stated == h.mount_rotations.end() ? " states no " + key + " (the reference orientation)"
                                                : " states " + key + ": " + VectorText(out.stated_deg));
  return out;
}

// For each known form the readings reject, the orientation they support, named in its statement's
// verdict and among the warnings.
void SearchOrientations(CalibrationWorkflowResult& run, const CalibrationWorkflowOptions& o,
                        std::map<int, TurnEvidence>& evidence) {
  auto other = run.settings.other_form_priors.begin();
  for (StatementCheck& c : run.statements) {
    if (c.kind != StatementKind::kKnownForm && c.kind != StatementKind::kOtherForm) continue;
    const int prior_setup = c.kind == StatementKind::kKnownForm ? -1 : (other++)->first;
    if (!c.rejected) continue;
    Tell(o.on_stage, "searching the mount orientation the readings support");
    const auto known = evidence.find(prior_setup);
    c.orientation = SupportedOrientationFrom(run, o, prior_setup,
                                             known != evidence.end() ? known->second : BestTurnOf(run, prior_setup));
    c.verdict += "; " + c.orientation->text;
    Warn(run, o, c.orientation->text);
  }
}

// The statements of the lab tested against the readings (sph/calib/statements.hpp), into
// run.statements and its warnings. A rejected one (accepted or not) leaves the trace's additions
// out: the reported calibration is then the model of the statements alone (the known form, the
// effects a fixed value or a prior names), and run.withheld names what the trace had added.
void CheckStatements(CalibrationWorkflowResult& run, const CalibrationWorkflowOptions& o, const KnownFormFiles& files) {
  if (run.known_form) {
    const bool bound = files.reference.empty();
    const std::optional<double> b = FormBoundUm(run, o);
    const std::string statement = !bound ? "--sphere-form " + files.reference + " at " + OrientationsText(run, {})
                                  : o.conditions.sphere_form_rms_um ? "--sphere-form-rms-um " + Format("%g", *b)
                                                                    : "sphere_form_rms_um " + Format("%g", *b) +
                                                                          " (the header of " + run.points_path + ")";
    run.statements.push_back(
        StatementOf(*run.known_form, bound ? StatementKind::kFormBound : StatementKind::kKnownForm, statement));
  }
  for (const KnownFormCheck& k : run.other_known_forms) {
    run.statements.push_back(StatementOf(k, StatementKind::kOtherForm,
                                         "--sphere-form " + k.source + " at " + OrientationsText(run, k.setups)));
  }
  const EffectFit fit = run.Extended() ? run.trace->after.fit : SevenAsFit(run);
  for (StatementCheck& c : CheckParameterStatements(run.points, run.settings, fit, run.statement_origins)) {
    run.statements.push_back(std::move(c));
  }
  bool rejected = false;
  for (StatementCheck& c : run.statements) {
    if (!c.rejected) continue;
    rejected = true;
    c.accepted = o.accept_rejected;
    if (c.kind == StatementKind::kPrior || c.kind == StatementKind::kFixed) Warn(run, o, c.verdict);
  }
  if (!rejected || !run.trace) return;
  std::vector<EffectTerm> stated;
  for (const EffectTerm& t : run.trace->after.fit.model.terms) {
    if (std::find(run.trace->stated.begin(), run.trace->stated.end(), t.effect) != run.trace->stated.end()) {
      stated.push_back(t);
    } else {
      run.withheld.push_back(t.effect);
    }
  }
  const bool form_added = run.settings.form_prior.Empty() && !run.trace->after.fit.model.form.Empty();
  if (run.withheld.empty() && !form_added) return;
  TraceOptions trace_options = o.trace_options;
  trace_options.probe_range_mm = run.probe_range_mm;
  trace_options.progress = nullptr;
  run.trace = FitGivenModel(run.points, run.settings, run.seven, stated, {}, trace_options);
  run.trace->stated.clear();
  for (const EffectTerm& t : stated) run.trace->stated.push_back(t.effect);
  std::string ids;
  for (const Effect e : run.withheld) ids += (ids.empty() ? "" : ", ") + std::string(InfoOf(e).id);
  Warn(run, o,
       "the trace adds nothing on top of a statement the readings reject: " +
           (ids.empty() ? std::string("the sphere's form it fitted") : ids) +
           " not applied; the calibration is the model of the statements alone");
}

// What the comparison takes from the earlier calibration file `previous` (named `path`): its model,
// which states that the machine has none of the effects today's own model found beyond it. Tested
// on today's fit: their parameters against zero with today's covariance, chi-square on as many
// degrees of freedom. Nothing when today's model holds no effect the earlier lacks. The comparison
// informs: a rejection is told, it does not make the calibration unusable.
std::optional<StatementCheck> EarlierModelStatement(const CalibrationWorkflowResult& run,
                                                    const CalibrationFile& previous, const std::string& path) {
  if (!run.Extended()) return std::nullopt;
  const EffectFit& fit = run.trace->after.fit;
  const ObservabilityReport& a = fit.calibration.analysis;
  std::vector<int> columns;
  std::vector<double> values;
  std::string ids, earlier;
  for (const EffectTerm& t : previous.effects.terms)
    earlier += (earlier.empty() ? "" : ", ") + std::string(t.info().id);
  if (!previous.probe_drift_powers.empty()) earlier += (earlier.empty() ? "" : ", ") + std::string("probe_drift");
  for (std::size_t t = 0; t < fit.model.terms.size(); ++t) {
    const Effect e = fit.model.terms[t].effect;
    const bool held = e == Effect::kProbeDrift ? !previous.probe_drift_powers.empty() : previous.effects.Find(e) >= 0;
    if (held) continue;
    ids += (ids.empty() ? "" : ", ") + std::string(InfoOf(e).id);
    for (std::size_t i = 0; i < fit.values[t].size(); ++i) {
      columns.push_back(fit.TermOffset(t) + static_cast<int>(i));
      values.push_back(fit.values[t][i]);
    }
  }
  if (columns.empty() || a.Empty()) return std::nullopt;
  StatementCheck s;
  s.kind = StatementKind::kEarlierModel;
  s.statement =
      "--compare " + path + ": its model (" + (earlier.empty() ? std::string("the seven errors") : earlier) + ")";
  s.stated = "no " + ids;
  const auto n = static_cast<Eigen::Index>(columns.size());
  Eigen::MatrixXd c(n, n);
  Eigen::VectorXd v(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    v(i) = values[static_cast<std::size_t>(i)];
    for (Eigen::Index j = 0; j < n; ++j) {
      c(i, j) = a.covariance(columns[static_cast<std::size_t>(i)], columns[static_cast<std::size_t>(j)]);
    }
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(c);
  for (Eigen::Index i = 0; i < n; ++i) {
    const double ev = eig.eigenvalues()(i);
    if (!(ev > 0.0) || !std::isfinite(ev)) continue;
    const double along = eig.eigenvectors().col(i).dot(v);
    s.chi_square += along * along / ev;
    ++s.dof;
  }
  s.readings = ids + " in today's own model";
  if (s.dof > 0) s.p_value = gum::ChiSquareSf(s.chi_square, s.dof);
  s.rejected = s.dof > 0 && s.p_value < kStatementP;
  s.verdict = Format(
      "today's readings %s the model of the earlier calibration %s: they show %s, which it lacks "
      "(chi-square %.3g for %d degrees of freedom, p %s)%s",
      s.rejected ? "reject" : "do not reject", path.c_str(), ids.c_str(), s.chi_square, s.dof,
      PValueText(s.p_value).c_str(),
      s.rejected ? ": the like-for-like comparison refits them with a model they do not support; the "
                   "machine has changed in what it has, or the earlier calibration missed it"
                 : "");
  return s;
}

// The calibration file's content, usable or not: the seven errors, the trace's effects but
// probe_drift (`*drift_left_out` says whether one was left out), the covariance.
CalibrationFile FileOf(const CalibrationWorkflowResult& run, bool* drift_left_out) {
  CalibrationFile file = MakeCalibrationFile(run.Reported(), run.Context());
  const bool drift = run.Extended() && AddEffectsToCalibrationFile(run.trace->after.fit, file);
  if (drift_left_out != nullptr) *drift_left_out = drift;
  std::vector<int> columns;
  for (int p = 0; p < kNumScmsParams; ++p) columns.push_back(p);
  if (run.Extended()) columns = AppliedColumns(run.trace->after.fit);
  AddCovarianceToCalibrationFile(columns, run.Reported(), run.budget ? &*run.budget : nullptr, file);
  std::string accepted;  // statements the readings reject, accepted as stated
  for (const StatementCheck& c : run.statements) {
    if (c.rejected && c.accepted) accepted += (accepted.empty() ? "" : "; ") + c.verdict;
  }
  if (!accepted.empty()) file.source.emplace_back("accepted_against_the_readings", accepted);
  return file;
}

// Whether two calibration files hold one model: the same parameters (the effects' components and
// the form's terms), in any order, and the same drift fitted beside them.
bool SameModel(const CalibrationFile& a, const CalibrationFile& b) {
  auto sorted = [](const CalibrationFile& f) {
    std::vector<std::string> names = CalibrationParameterNames(f);
    std::sort(names.begin(), names.end());
    return names;
  };
  return sorted(a) == sorted(b) && a.probe_drift_powers == b.probe_drift_powers;
}

// `run`'s readings calibrated with the model of `previous` (CompareWithEarlier()): the reported
// calibration, its budget and its usability; warnings kept in its own.
CalibrationWorkflowResult RefitWithModelOf(const CalibrationWorkflowResult& run, const CalibrationFile& previous,
                                           const CalibrationWorkflowOptions& o) {
  CalibrationWorkflowResult like;
  like.points = run.points;
  like.points_path = run.points_path;
  like.settings = run.settings;
  like.inputs = run.inputs;
  like.probe_range_mm = run.probe_range_mm;
  like.program = run.program;
  like.seven = run.seven;
  std::vector<EffectTerm> terms = previous.effects.terms;
  if (!previous.probe_drift_powers.empty()) {  // the file's drift is left out, its powers are not
    EffectTerm drift{Effect::kProbeDrift, {}};
    for (int power : previous.probe_drift_powers) drift.components.push_back({power, 0, false});
    terms.push_back(drift);
  }
  if (!terms.empty() || !previous.form_terms.empty() || !run.settings.form_prior.Empty()) {
    TraceOptions trace_options = o.trace_options;
    trace_options.probe_range_mm = run.probe_range_mm;
    trace_options.progress = nullptr;
    like.trace = FitGivenModel(like.points, like.settings, like.seven, terms, previous.form_terms, trace_options,
                               &previous.effects.reference);
  }
  CalibrationWorkflowOptions quiet = o;
  quiet.on_warning = nullptr;
  MakeBudget(like, quiet);
  like.usability = JudgeUsability(like.Reported(), like.Context());
  return like;
}

}  // namespace

CalibrationComparison CompareWithEarlier(const CalibrationWorkflowResult& run, const CalibrationFile& previous,
                                         const std::string& previous_source,
                                         const CalibrationWorkflowOptions& options) {
  const CalibrationFile today = FileOf(run, nullptr);
  CalibrationComparison own = CompareCalibrations(previous, today, previous_source);
  if (SameModel(previous, today)) return own;
  std::string why;
  try {
    const CalibrationWorkflowResult like = RefitWithModelOf(run, previous, options);
    if (like.usability.usable && like.warnings.empty()) {
      return LikeForLike(CompareCalibrations(previous, FileOf(like, nullptr), previous_source), own);
    }
    for (const std::string& reason : like.usability.reasons) why += (why.empty() ? "" : "; ") + reason;
    for (const std::string& warning : like.warnings) why += (why.empty() ? "" : "; ") + warning;
  } catch (const Cancelled&) {
    throw;
  } catch (const std::exception& e) {
    why = e.what();
  }
  return NotLikeForLike(std::move(own), why);
}

SupportedOrientation SupportedOrientationOf(const CalibrationWorkflowResult& run,
                                            const CalibrationWorkflowOptions& options, int prior_setup) {
  return SupportedOrientationFrom(run, options, prior_setup, BestTurnOf(run, prior_setup));
}

void CalibrationWorkflowOptions::Check() const {
  const std::string what = "calibration options: ";
  if (sphere_radius_mm) CheckedValue(*sphere_radius_mm, ranges::kSphereRadiusMm, what + "sphere_radius_mm");
  if (probe_offset_mm) CheckedValue(*probe_offset_mm, ranges::kProbeOffsetMm, what + "probe_offset_mm");
  CheckedValue(fit.max_std_um, ranges::kStdUm, what + "fit.max_std_um");
  CheckedValue(fit.max_iterations, ranges::kMaxIterations, what + "fit.max_iterations");
  CheckedValue(trace_options.harmonics.theta, ranges::kHarmonicOrder, what + "trace_options.harmonics.theta");
  CheckedValue(trace_options.harmonics.phi, ranges::kHarmonicOrder, what + "trace_options.harmonics.phi");
  CheckedValue(trace_options.drift_order, ranges::kDriftOrder, what + "trace_options.drift_order");
  CheckedValue(trace_options.phi_wobble_pivot_mm, ranges::kPivotMm, what + "trace_options.phi_wobble_pivot_mm");
  if (coverage) CheckedValue(*coverage, ranges::kCoverageProbability, what + "coverage");
  // 0: the robust loss' own default scale.
  if (fit.robust_scale_sigma != 0.0) {
    CheckedValue(fit.robust_scale_sigma, ranges::kRobustScaleSigma, what + "fit.robust_scale_sigma");
  }
  for (const ConditionField& f : kConditionFields) {
    const std::optional<double>& v = conditions.*f.field;
    if (v) CheckedValue(*v, ValidRange{f.min, f.max, f.unit}, what + "conditions." + f.key);
  }
  // The options' own fixed values and priors (a parameter held twice, held and informed): the
  // points header's join them later, checked with the file.
  internal::CheckParameterSettings(fit, "calibration options");
  if (!trace && !effects.empty()) throw Error(what + "effects need trace (a fixed model is fitted in its place)");
  if (!trace && conditions.sphere_form_rms_um) {
    throw Error(what +
                "conditions.sphere_form_rms_um needs trace (the certificate's bound is a prior on the sphere's form, "
                "which the seven errors alone do not have)");
  }
  if (!trace && !sphere_form_paths.empty()) {
    throw Error(what + "sphere_form_paths needs trace (the known form is fitted with the effects' model)");
  }
  if (!trace && !validate_path.empty()) {
    throw Error(what + "validate_path needs trace (it compares the seven errors with the trace's model)");
  }
}

bool CalibrationWorkflowResult::Extended() const {
  return trace && !(trace->after.fit.model.Empty() && trace->after.fit.model.form.Empty());
}

const CalibrationResult& CalibrationWorkflowResult::Reported() const {
  return Extended() ? trace->after.fit.calibration : seven;
}

ReportContext CalibrationWorkflowResult::Context() const {
  ReportContext ctx;
  ctx.budget = budget ? &*budget : nullptr;
  ctx.program = program;
  ctx.points_path = points_path;
  ctx.sphere_radius_mm = settings.sphere_radius_mm;
  ctx.sphere_radii_mm = settings.sphere_radii_mm;
  ctx.probe_offset_mm = settings.probe_offset_mm;
  ctx.max_std_um = settings.max_std_um;
  ctx.probe_range_mm = probe_range_mm;
  ctx.metadata = points.header.metadata;
  ctx.trace = trace ? &*trace : nullptr;
  ctx.validation = validation ? &*validation : nullptr;
  ctx.comparison = comparison ? &*comparison : nullptr;
  ctx.known_form = known_form ? &*known_form : nullptr;
  ctx.other_known_forms = &other_known_forms;
  ctx.statements = &statements;
  ctx.withheld = &withheld;
  ctx.run_warnings = &warnings;
  ctx.requirement = &requirement;
  ctx.likely_cause = likely_cause;
  return ctx;
}

void CalibrationWorkflowResult::WriteTextReport(std::ostream& out) const {
  sph::WriteTextReport(out, Reported(), Context());
}

std::string CalibrationWorkflowResult::JsonReport() const { return sph::JsonReport(Reported(), Context()); }

CalibrationFile CalibrationWorkflowResult::MakeCalibrationFile(bool* drift_left_out) const {
  if (!usability.usable) throw Error("the calibration is not usable: no calibration file");
  return FileOf(*this, drift_left_out);
}

CalibrationWorkflowResult RunCalibrationWorkflow(const std::string& points_path,
                                                 const CalibrationWorkflowOptions& options) {
  Tell(options.on_stage, "reading " + points_path);
  return RunCalibrationWorkflow(ReadPointsFile(points_path), points_path, options);
}

CalibrationWorkflowResult RunCalibrationWorkflow(PointsData points, const std::string& points_path,
                                                 const CalibrationWorkflowOptions& options) {
  options.Check();
  CalibrationWorkflowResult run;
  run.points = std::move(points);
  run.points_path = points_path;
  run.program = options.program.empty() ? std::string("sph_calibrate " SPH_VERSION) : options.program;
  const KnownFormFiles form_files = Settle(run, options);
  std::optional<CalibrationFile> previous;
  if (!options.compare_path.empty()) {  // bad input is told before the fit
    Tell(options.on_stage, "reading " + options.compare_path);
    previous = ReadCalibrationFile(options.compare_path);
    CalibrationFile now;
    now.probe_offset_mm = run.settings.probe_offset_mm;
    CheckComparable(*previous, now, options.compare_path);
  }
  // Readings that parse but look wrong: said first, whatever follows.
  Tell(options.on_stage, "checking " + std::to_string(run.points.samples.size()) + " samples");
  for (const std::string& w : PlausibilityWarnings(run.points)) {
    run.warnings.push_back(w);
    Tell(options.on_warning, w);
  }
  Tell(options.on_stage, "calibrating the seven errors");
  run.seven = Calibrate(run.points, run.settings);
  if (options.trace) Trace(run, options);
  std::map<int, TurnEvidence> evidence;
  CheckForm(run, options, form_files, &evidence);
  CheckStatements(run, options, form_files);
  if (options.search_orientation) SearchOrientations(run, options, evidence);
  MakeBudget(run, options);
  run.requirement = options.requirement;
  const ObservabilityReport& seven = run.seven.analysis;
  if (options.requirement.target_u.empty() && !options.requirement.max_std_stated && !seven.Empty()) {
    run.requirement.reference_noise_um = seven.residual_sigma_mm * kUmPerMm;
    run.requirement.reference_um = ReferenceUncertaintyUm(run.settings.sphere_radius_mm, run.settings.probe_offset_mm,
                                                          run.seven.geometry, run.requirement.reference_noise_um);
    for (int p = 0; p < kNumScmsParams; ++p) {
      const ParameterDescription& d = seven.parameters[static_cast<std::size_t>(p)];
      const double u = seven.IsHeld(p) || !seven.determined[static_cast<std::size_t>(p)]
                           ? std::numeric_limits<double>::infinity()
                           : seven.std(p) * (d.quantity == Quantity::kAngle ? d.lever_mm : 1.0) * kUmPerMm;
      run.requirement.seven_um.push_back(u);
    }
  }
  if (const auto m = LikelyMisreading(run.points, run.settings, run.seven)) run.likely_cause = m->Reason();
  run.usability = JudgeUsability(run.Reported(), run.Context());
  if (previous) {
    Tell(options.on_stage, "comparing with " + options.compare_path);
    run.comparison = CompareWithEarlier(run, *previous, options.compare_path, options);
    if (run.comparison->model == kTodaysModel && !run.comparison->models.empty()) {
      Warn(run, options, run.comparison->models);
    }
    if (std::optional<StatementCheck> earlier = EarlierModelStatement(run, *previous, options.compare_path)) {
      if (earlier->rejected) Warn(run, options, earlier->verdict);
      run.statements.push_back(std::move(*earlier));
    }
  }
  return run;
}

}  // namespace sph
