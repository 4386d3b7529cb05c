#include "sph/model/fixed_vector.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <vector>

#include "sph/model/compensation.hpp"
#include "sph/model/effect_terms.hpp"

namespace sph {
namespace {

TEST(FixedVector, BehavesAsAVectorWithinItsCapacity) {
  FixedVector<int, 5> v{1, 2, 3};
  EXPECT_EQ(v.size(), 3u);
  EXPECT_EQ(v.capacity(), 5u);
  v.push_back(4);
  v.insert(v.begin() + 1, 9);  // 1 9 2 3 4
  EXPECT_EQ(std::vector<int>(v), (std::vector<int>{1, 9, 2, 3, 4}));
  v.erase(v.begin(), v.begin() + 2);  // 2 3 4
  EXPECT_EQ(v.front(), 2);
  EXPECT_EQ(v.back(), 4);
  v.pop_back();
  v.resize(4, 7);  // 2 3 7 7
  EXPECT_EQ(std::vector<int>(v), (std::vector<int>{2, 3, 7, 7}));
  const FixedVector<int, 5> w = std::vector<int>{2, 3, 7, 7};
  EXPECT_TRUE(v == w);
  v.clear();
  EXPECT_TRUE(v.empty());
  EXPECT_TRUE(v != w);
}

TEST(FixedVector, ConvertsNestedVectorsBothWays) {
  const std::vector<std::vector<double>> values{{1.0, 2.0}, {3.0}};
  const EffectValues<double> fixed = values;
  ASSERT_EQ(fixed.size(), 2u);
  EXPECT_EQ(fixed[0].size(), 2u);
  EXPECT_EQ(fixed[1][0], 3.0);
  const std::vector<double> back = fixed[0];
  EXPECT_EQ(back, values[0]);
}

void PushBeyondTheCapacity() {
  FixedVector<int, 2> v{1, 2};
  v.push_back(3);
}

TEST(FixedVector, StopsTheProgramRatherThanWritePastItsCapacity) { EXPECT_DEATH(PushBeyondTheCapacity(), ""); }

TEST(FixedVector, HoldsTheLargestTermOfTheCatalogue) {
  // The bound of a term's components: both axes of a two-axis effect of the first order 1, cos and
  // sin to the highest order names may carry.
  std::size_t largest = 0;
  for (int e = 0; e < kNumEffects; ++e) {
    largest =
        std::max(largest, DefaultTerm(static_cast<Effect>(e), kMaxEffectHarmonic, kMaxDriftOrder).components.size());
  }
  EXPECT_EQ(largest, kMaxTermComponents);
  EXPECT_EQ(DefaultTerm(Effect::kPhiWobble, kMaxEffectHarmonic).components.size(), kMaxTermComponents);
}

}  // namespace
}  // namespace sph
