// The firmware promise: every model header compiles and works with Eigen alone. This file is
// part of a test binary that links sph::model and GoogleTest, and nothing of Ceres.
#include "sph/model/compensation.hpp"
#include "sph/model/dh.hpp"
#include "sph/model/effects.hpp"
#include "sph/model/form_model.hpp"
#include "sph/model/scms_model.hpp"
#include "sph/model/spherical_harmonics.hpp"
#include "sph/model/units.hpp"

#include <gtest/gtest.h>

#ifdef CERES_VERSION_MAJOR
#error "a model header pulled in Ceres"
#endif

namespace sph {
namespace {

TEST(ModelOnly, HeadersNeedNoCeres) {
  const ScmsGeometry g{};
  EXPECT_NEAR(ScmsPoint(g, 0.0, kPi / 2, 5.0, 25.0).x(), 20.0, 1e-12);
}

}  // namespace
}  // namespace sph
