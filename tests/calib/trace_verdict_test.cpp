// The trace's verdict on what structure remains (RemainingStructure(), private to the selection).
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

}  // namespace
}  // namespace sph
