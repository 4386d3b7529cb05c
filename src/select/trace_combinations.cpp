// The search over combinations in a round of the trace: when the best candidate has rivals, sets of
// the round's eligible candidates fitted together, so that two effects that together explain the
// residual better than a third that imitates part of each are not missed by a search that adds one
// effect at a time (BestCombination(), declared in trace_steps.hpp).
#include <memory>

#include "trace_steps.hpp"

namespace sph::internal {
namespace {

// The beam's width: the best sets of one size that are grown by one member.
constexpr std::size_t kBeamWidth = 3;

// A set of candidates fitted together.
struct SetScore {
  std::vector<std::size_t> members;  // indices into `tried`, in the order of the fit's terms
  EffectFit fit;
  double delta_bic = std::numeric_limits<double>::quiet_NaN();
  int components = 0;
  double cv_rms_um = std::numeric_limits<double>::quiet_NaN();
  bool checked = false, qualifies = false;
};

std::vector<std::size_t> Sorted(std::vector<std::size_t> v) {
  std::sort(v.begin(), v.end());
  return v;
}

class Search {
 public:
  Search(const Readings& data, const CalibrationOptions& options, const TracedFit& current, const Tried& tried,
         const FormSelection& form, const SpherePattern& sphere, const TraceOptions& trace_options)
      : data_(data),
        options_(options),
        current_(current),
        tried_(tried),
        form_(form),
        sphere_(sphere),
        o_(trace_options),
        one_placement_(OnePlacement(current.fit)) {}

  // `base` (a set, or one candidate) with candidate q added, fitted and scored; false when the fit
  // leaves nothing of q, does not settle or does not determine every parameter.
  bool Grow(const std::vector<std::size_t>& base, const EffectFit& base_fit, std::size_t q, SetScore* out) const {
    std::string note;
    EffectFit f = FitCandidate(data_, options_, base_fit,
                               DefaultTerm(tried_[q].first.effect, o_.harmonics, o_.drift_order), o_, &note);
    const std::size_t k = base.size() + 1;
    const std::size_t n0 = current_.fit.model.terms.size();
    if (f.model.terms.size() != n0 + k || !f.calibration.converged || !f.calibration.analysis.AllDetermined()) {
      return false;
    }
    out->members = base;
    out->members.push_back(q);
    out->delta_bic = f.Bic() - current_.fit.Bic() + SubsetSearchPenalty(Scored(), static_cast<int>(k)) -
                     SubsetSearchPenalty(Scored(), 1);
    out->components = 0;
    for (std::size_t t = n0; t < f.model.terms.size(); ++t) {
      out->delta_bic += SearchPenalty(f.model.terms[t], o_);
      out->components += static_cast<int>(f.model.terms[t].components.size());
    }
    out->fit = std::move(f);
    return true;
  }

  // The score of a subset already fitted (a single candidate, or a set of the level below); NaN
  // when it was not fitted.
  double ScoreOf(const std::vector<std::size_t>& subset) const {
    if (subset.size() == 1) return tried_[subset[0]].first.delta_bic;
    const auto s = scores_.find(Sorted(subset));
    return s == scores_.end() ? std::numeric_limits<double>::quiet_NaN() : s->second->delta_bic;
  }

  // Rule 2: every member is needed, the set lower than each subset without it by min_delta_bic.
  bool EveryMemberNeeded(const SetScore& s) const {
    for (std::size_t m = 0; m < s.members.size(); ++m) {
      std::vector<std::size_t> rest = s.members;
      rest.erase(rest.begin() + static_cast<std::ptrdiff_t>(m));
      if (!(s.delta_bic - ScoreOf(rest) <= -o_.min_delta_bic)) return false;
    }
    return s.delta_bic <= -o_.min_delta_bic;
  }

  void Remember(SetScore* s) { scores_[Sorted(s->members)] = s; }

  // The costly checks of a set, once: Admissible() with a cross-validated RMS below those of its
  // subsets too, and some member, last beside the others, passing the checks against the form.
  bool Qualifies(SetScore& s) {
    if (s.checked) return s.qualifies;
    s.checked = true;
    CandidateScore c;
    c.effect = tried_[s.members.back()].first.effect;
    c.term = s.fit.model.terms.back();
    c.delta_bic = s.delta_bic;
    c.determined = true;
    c.cv_rms_um = CrossValidated(data_, options_, s.fit.model, EffectFitStart::From(s.fit), o_.folds, o_.seed);
    TransferTest(data_, options_, current_, s.fit, &c);
    if (!Admissible(c, current_, o_)) return false;
    for (std::size_t m = 0; m < s.members.size(); ++m) {
      std::vector<std::size_t> rest = s.members;
      rest.erase(rest.begin() + static_cast<std::ptrdiff_t>(m));
      const SetScore* sub = rest.size() == 1 ? nullptr : scores_.at(Sorted(rest));
      const double sub_cv = sub == nullptr ? tried_[rest[0]].first.cv_rms_um : sub->cv_rms_um;
      if (!(c.cv_rms_um < sub_cv)) return false;
    }
    s.cv_rms_um = c.cv_rms_um;
    for (std::size_t m = 0; m < s.members.size(); ++m) {
      if (ShownBesideTheOthers(s, m)) return s.qualifies = true;
    }
    return false;
  }

 private:
  int Scored() const { return static_cast<int>(tried_.size()); }

  // The fit of set s without member m, and whether that subset qualifies itself.
  const EffectFit* Without(const SetScore& s, std::size_t m, bool* qualifies) {
    std::vector<std::size_t> rest = s.members;
    rest.erase(rest.begin() + static_cast<std::ptrdiff_t>(m));
    if (rest.size() == 1) {
      *qualifies = FirstBesideTheSphere(tried_[rest[0]].first);
      return &tried_[rest[0]].second;
    }
    SetScore* sub = scores_.at(Sorted(rest));
    *qualifies = EveryMemberNeeded(*sub) && Qualifies(*sub);
    return &sub->fit;
  }

  // Whether an eligible candidate of the round could be added first, as the round's choice: a
  // pattern on the sphere that explains about as much as it (the round's competitor, `sphere_`)
  // leaves it only when its own variable shows it beyond one (ShownBeyondSphere()). The round's
  // best passed that against the pattern; a candidate that scored worse may not.
  bool FirstBesideTheSphere(const CandidateScore& c) const {
    if (form_.separable) return true;
    return !PatternAboutAsGood(sphere_, c.delta_bic, o_) || ShownBeyondSphere(c, current_.factor, one_placement_, o_);
  }

  // Whether member m, added last to the others, passes what a later round asks of a candidate: with
  // a pattern on the sphere that explains about as much as it, that its own variable shows it
  // beyond such a pattern (ShownBeyondSphere()); with a design that separates the form, that it
  // qualifies beside the form of the highest degree searched (ShownBeyondForm()).
  bool ShownBesideTheOthers(const SetScore& s, std::size_t m) {
    bool rest_qualifies = false;
    const EffectFit* rest = Without(s, m, &rest_qualifies);
    if (!rest_qualifies) return false;
    const auto index = static_cast<std::size_t>(s.fit.model.Find(tried_[s.members[m]].first.effect));
    CandidateScore c;
    c.effect = tried_[s.members[m]].first.effect;
    c.term = s.fit.model.terms[index];
    c.delta_bic = s.fit.Bic() - rest->Bic() + SearchPenalty(c.term, o_);
    if (!(c.delta_bic <= -o_.min_delta_bic)) return false;
    const TracedFit& beside = FactoredOf(*rest);
    if (!form_.separable) {
      if (PatternAboutAsGood(BestSpherePattern(beside.factor), c.delta_bic, o_) &&
          !ShownBeyondSphere(c, beside.factor, OnePlacement(*rest), o_)) {
        return false;
      }
    } else if (form_.degree_limit > form_.degree_max) {
      double beyond = 0.0;
      if (!ShownBeyondForm(data_, options_, c, FullForm(data_, options_, beside, form_), o_, &beyond)) return false;
    }
    return true;
  }

  const TracedFit& FactoredOf(const EffectFit& fit) {
    auto f = factored_.find(&fit);
    if (f == factored_.end()) f = factored_.emplace(&fit, Factored(fit, data_, options_)).first;
    return f->second;
  }

  const Readings& data_;
  const CalibrationOptions& options_;
  const TracedFit& current_;
  const Tried& tried_;
  const FormSelection& form_;
  const SpherePattern& sphere_;
  const TraceOptions& o_;
  bool one_placement_;
  std::map<std::vector<std::size_t>, SetScore*> scores_;  // sorted members -> the set fitted
  std::map<const EffectFit*, TracedFit> factored_;
};
}  // namespace

ChosenSet BestCombination(const Readings& data, const CalibrationOptions& options, const TracedFit& current,
                          const Tried& tried, std::size_t best, const std::vector<std::size_t>& eligible,
                          const FormSelection& form, const SpherePattern& sphere, int max_size,
                          const TraceOptions& trace_options) {
  ChosenSet chosen;
  std::vector<std::size_t> seeds{best};
  for (const std::size_t i : eligible) {
    if (i != best && Rival(data, options, current, tried, i, best, trace_options)) seeds.push_back(i);
  }
  if (seeds.size() < 2 || max_size < 2) return chosen;
  Search search(data, options, current, tried, form, sphere, trace_options);
  std::vector<std::unique_ptr<SetScore>> all;  // every set fitted
  // Pairs: each seed with each other eligible candidate, fitted from the better one's fit; all the
  // pairs are fitted on up to trace_options.threads threads, each into its own slot.
  std::vector<std::vector<std::size_t>> todo;
  std::set<std::vector<std::size_t>> seen;
  for (const std::size_t a : seeds) {
    for (const std::size_t q : eligible) {
      if (q == a || !seen.insert(Sorted({a, q})).second) continue;
      const bool a_first = tried[a].first.delta_bic <= tried[q].first.delta_bic;
      todo.push_back(a_first ? std::vector<std::size_t>{a, q} : std::vector<std::size_t>{q, a});
    }
  }
  std::vector<SetScore*> level;  // the sets of the current size that keep every member needed
  for (int size = 2; size <= max_size && !todo.empty(); ++size) {
    std::vector<std::unique_ptr<SetScore>> fitted(todo.size());
    std::vector<std::exception_ptr> failures(todo.size());
    auto grow = [&](std::size_t i) {
      try {
        const std::vector<std::size_t> base(todo[i].begin(), todo[i].end() - 1);
        const SetScore* from = nullptr;
        for (const SetScore* s : level) {
          if (s->members == base) from = s;
        }
        const EffectFit& base_fit = from != nullptr ? from->fit : tried[base[0]].second;
        auto s = std::make_unique<SetScore>();
        if (search.Grow(base, base_fit, todo[i].back(), s.get())) fitted[i] = std::move(s);
      } catch (...) {
        failures[i] = std::current_exception();
      }
    };
    ParallelFor(todo.size(), trace_options.threads, [&] { return grow; });
    for (const std::exception_ptr& f : failures) {
      if (f) std::rethrow_exception(f);
    }
    std::vector<SetScore*> next;
    for (std::unique_ptr<SetScore>& s : fitted) {
      if (!s) continue;
      search.Remember(s.get());
      if (search.EveryMemberNeeded(*s)) next.push_back(s.get());
      all.push_back(std::move(s));
    }
    // The beam: the best kBeamWidth sets of this size, each grown by every other eligible candidate.
    std::sort(next.begin(), next.end(), [](const SetScore* x, const SetScore* y) { return x->delta_bic < y->delta_bic; });
    if (next.empty()) break;
    level = next;
    todo.clear();
    for (std::size_t b = 0; b < std::min(kBeamWidth, next.size()); ++b) {
      for (const std::size_t q : eligible) {
        std::vector<std::size_t> grown = next[b]->members;
        if (std::find(grown.begin(), grown.end(), q) != grown.end()) continue;
        grown.push_back(q);
        if (seen.insert(Sorted(grown)).second) todo.push_back(grown);
      }
    }
  }
  // Every set that keeps each member needed, the lowest scores first; the single is always a choice.
  std::vector<SetScore*> ranked;
  for (const std::unique_ptr<SetScore>& s : all) {
    if (search.EveryMemberNeeded(*s)) ranked.push_back(s.get());
  }
  std::sort(ranked.begin(), ranked.end(), [](const SetScore* x, const SetScore* y) { return x->delta_bic < y->delta_bic; });
  const CandidateScore& single = tried[best].first;
  // The best set that qualifies, by its score (between sets that the data cannot tell apart, as
  // between the candidates of a round, the lower score); none worse than the single by
  // ambiguity_bic or more counts.
  const SetScore* winner = nullptr;
  for (SetScore* s : ranked) {
    if (!(s->delta_bic < single.delta_bic + trace_options.ambiguity_bic)) break;
    if (search.Qualifies(*s)) {
      winner = s;
      break;
    }
  }
  // A set that holds the single is left to the rounds: the single is added now, and the next round
  // judges the others beside it with its components chosen again. So is a set about as good as a
  // set fitted that holds the single (within ambiguity_bic): the rounds reach an explanation about
  // as good, and the set differs from it only by effects the data cannot tell apart.
  if (winner != nullptr) {
    for (const std::unique_ptr<SetScore>& s : all) {
      if (std::find(s->members.begin(), s->members.end(), best) != s->members.end() &&
          s->delta_bic < winner->delta_bic + trace_options.ambiguity_bic) {
        winner = nullptr;
        break;
      }
    }
  }
  // It replaces the single when it scores clearly better; about equal (within ambiguity_bic either
  // way), the one with fewer components kept, then fewer effects, then the lower score.
  if (winner != nullptr && !(winner->delta_bic <= single.delta_bic - trace_options.ambiguity_bic)) {
    if (!(winner->components < static_cast<int>(single.term.components.size()))) {
      chosen.about_equal = winner->members;
      chosen.about_equal_delta_bic = winner->delta_bic;
      chosen.about_equal_components = winner->components;
      winner = nullptr;
    }
  }
  if (winner == nullptr) return chosen;
  chosen.members = winner->members;
  chosen.fit = winner->fit;
  chosen.delta_bic = winner->delta_bic;
  chosen.components = winner->components;
  return chosen;
}
}  // namespace sph::internal
