// The trace's verdict on what structure remains (RemainingStructure()) and how a set of effects
// and a single one about as good are named (SetAgainstSingle()), both private to the selection.
#include <gtest/gtest.h>

#include "trace_steps.hpp"

namespace sph {
namespace {

StructureGroup Group(const std::string& variable, double p_value, double rms_um) {
  StructureGroup g;
  g.variable = variable;
  g.description = "functions of " + variable;
  g.p_value = p_value;
  g.explained_rms_um = rms_um;
  g.strongest = "f(" + variable + ")";
  g.strongest_rms_um = rms_um;
  return g;
}

// One group below the threshold while the test of every function together is not (its one
// structure diluted among the many functions of the others): the group is described, the verdict
// is not "no structure".
TEST(RemainingStructure, DescribesEveryGroupBelowTheThresholdWhateverTheTestOfAll) {
  ResidualStructure s;
  s.groups = {Group("theta", 0.3, 0.01), Group("t", 4.9e-4, 0.02), Group("direction", 2e-4, 0.03),
              Group("sphere", 0.5, 0.01)};
  s.all = Group("all", 0.02, 0.04);
  TraceOptions options;  // structure_p 1e-3
  const std::vector<Unexplained> u = internal::RemainingStructure(s, options);
  ASSERT_EQ(u.size(), 2u);
  EXPECT_EQ(u[0].variable, "direction");  // the larger first
  EXPECT_EQ(u[1].variable, "t");
  EXPECT_DOUBLE_EQ(u[1].p_value, 4.9e-4);
  EXPECT_NE(u[1].description.find("structure that follows t"), std::string::npos) << u[1].description;
}

// No group below it but all of them together: "structure that no single variable explains"; none
// below it at all: nothing remains.
TEST(RemainingStructure, SaysNoneOnlyWhenNoGroupNorAllIsBelowTheThreshold) {
  ResidualStructure s;
  s.groups = {Group("theta", 0.3, 0.01), Group("t", 0.01, 0.02)};
  s.all = Group("all", 1e-4, 0.04);
  TraceOptions options;
  const std::vector<Unexplained> u = internal::RemainingStructure(s, options);
  ASSERT_EQ(u.size(), 1u);
  EXPECT_EQ(u[0].variable, "all");
  s.all.p_value = 0.5;
  EXPECT_TRUE(internal::RemainingStructure(s, options).empty());
}

CandidateScore Scored(Effect e, double delta_bic, int components) {
  CandidateScore c;
  c.effect = e;
  c.delta_bic = delta_bic;
  c.term.effect = e;
  for (int k = 1; k <= components; ++k) c.term.components.push_back({k, 0, false});
  return c;
}

// A set of two effects about as good as a single one: whichever side the components decided, the
// ambiguity names the set by its members, the scores and components of each, and what separates
// each member from the single (a drift by the time order, a Phi encoder error from a Phi radial
// motion by the height of the sphere).
TEST(SetAgainstSingle, NamesTheSetByItsMembersWithWhatSeparatesEachFromTheSingle) {
  internal::Tried tried;
  tried.push_back({Scored(Effect::kPhiRadialMotion, -212.3, 5), EffectFit{}});
  tried.push_back({Scored(Effect::kPhiEncoder, -190.7, 2), EffectFit{}});
  tried.push_back({Scored(Effect::kProbeDrift, -90.0, 1), EffectFit{}});
  const Ambiguity chosen = internal::SetAgainstSingle(tried, {1, 2}, -215.0, 3, 0, true);
  EXPECT_EQ(chosen.chosen, "phi_encoder + probe_drift");
  EXPECT_EQ(chosen.other, "phi_radial_motion");
  EXPECT_EQ(chosen.chosen_set, (std::vector<std::string>{"phi_encoder", "probe_drift"}));
  EXPECT_TRUE(chosen.other_set.empty());
  EXPECT_DOUBLE_EQ(chosen.delta_bic_chosen, -215.0);
  EXPECT_DOUBLE_EQ(chosen.delta_bic_other, -212.3);
  EXPECT_EQ(chosen.chosen_components, 3);
  EXPECT_EQ(chosen.other_components, 5);
  EXPECT_NE(chosen.separate_by.find("phi_encoder from phi_radial_motion: a second sphere position at another height"),
            std::string::npos)
      << chosen.separate_by;
  EXPECT_NE(chosen.separate_by.find("probe_drift from phi_radial_motion: repeated reference points"), std::string::npos)
      << chosen.separate_by;

  // The single kept, for the set keeps more components: the sides turn.
  tried[0].first = Scored(Effect::kPhiRadialMotion, -212.3, 2);
  const Ambiguity kept = internal::SetAgainstSingle(tried, {1, 2}, -215.0, 3, 0, false);
  EXPECT_EQ(kept.chosen, "phi_radial_motion");
  EXPECT_EQ(kept.other, "phi_encoder + probe_drift");
  EXPECT_TRUE(kept.chosen_set.empty());
  EXPECT_EQ(kept.other_set, (std::vector<std::string>{"phi_encoder", "probe_drift"}));
  EXPECT_DOUBLE_EQ(kept.delta_bic_chosen, -212.3);
  EXPECT_DOUBLE_EQ(kept.delta_bic_other, -215.0);
  EXPECT_EQ(kept.chosen_components, 2);
  EXPECT_EQ(kept.other_components, 3);
}

}  // namespace
}  // namespace sph
