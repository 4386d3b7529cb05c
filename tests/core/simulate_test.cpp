#include "sph/core/simulate.hpp"

#include <cmath>

#include <gtest/gtest.h>

#include "sph/core/error.hpp"
#include "test_util.hpp"

namespace sph {
namespace {

TEST(GridPattern, IsThePapersGrid) {
  const auto grid = GridPattern(24, 12);
  ASSERT_EQ(grid.size(), 288u);
  EXPECT_DOUBLE_EQ(grid.front().theta_deg, 0.0);
  EXPECT_DOUBLE_EQ(grid.front().phi_deg, 7.5);
  EXPECT_DOUBLE_EQ(grid[23].theta_deg, 345.0);
  EXPECT_DOUBLE_EQ(grid.back().phi_deg, 172.5);
}

TEST(ProbeReading, NominalMachineMeasuresDistanceToTheSurface) {
  // Errors zero, sphere at the origin: r = d - R0 everywhere.
  const auto r = ProbeReading(ScmsGeometry{}, 0.3, 1.2, 25.0, Eigen::Vector3d::Zero(), 20.0);
  ASSERT_TRUE(r);
  EXPECT_NEAR(*r, 5.0, 1e-12);
  // Sphere shifted along +x by e: at theta = 0, phi = 90 deg the surface is e closer to the probe.
  const auto r2 = ProbeReading(ScmsGeometry{}, 0.0, kPi / 2, 25.0, Eigen::Vector3d(2.0, 0.0, 0.0), 20.0);
  ASSERT_TRUE(r2);
  EXPECT_NEAR(*r2, 3.0, 1e-12);
  // ... and at phi = 0 (the pole): the ray along z hits the shifted sphere at height sqrt(R0^2 - e^2).
  const auto r3 = ProbeReading(ScmsGeometry{}, 0.0, 0.0, 25.0, Eigen::Vector3d(2.0, 0.0, 0.0), 20.0);
  ASSERT_TRUE(r3);
  EXPECT_NEAR(*r3, 25.0 - std::sqrt(400.0 - 4.0), 1e-12);
}

TEST(ProbeReading, MissesASphereOutOfReach) {
  EXPECT_FALSE(ProbeReading(ScmsGeometry{}, 0.0, kPi / 2, 25.0, Eigen::Vector3d(0.0, 30.0, 0.0), 5.0).has_value());
}

TEST(Simulate, NoiseHasTheRequestedSigma) {
  SimulationSpec spec;
  spec.pattern = GridPattern(60, 40);
  spec.noise_r_um = 0.5;
  SimulationSpec exact = spec;
  exact.noise_r_um = 0.0;
  const PointsData noisy = Simulate(spec), clean = Simulate(exact);
  ASSERT_EQ(noisy.samples.size(), 2400u);
  double sum = 0.0, sum2 = 0.0;
  for (std::size_t i = 0; i < noisy.samples.size(); ++i) {
    const double e_um = (noisy.samples[i].r_mm - clean.samples[i].r_mm) * 1e3;
    sum += e_um;
    sum2 += e_um * e_um;
    EXPECT_EQ(noisy.samples[i].theta_deg, clean.samples[i].theta_deg);
  }
  const double n = 2400.0, mean = sum / n, sd = std::sqrt(sum2 / n - mean * mean);
  EXPECT_NEAR(mean, 0.0, 4 * 0.5 / std::sqrt(n));  // 4 standard errors
  EXPECT_NEAR(sd, 0.5, 4 * 0.5 / std::sqrt(2 * n));
}

TEST(Simulate, SetupsTimesAndSeeds) {
  SimulationSpec spec;
  spec.centers_mm = {Eigen::Vector3d(2, 0, 0), Eigen::Vector3d(0, 0, 2)};
  spec.sample_period_s = 0.5;
  const PointsData d = Simulate(spec);
  ASSERT_EQ(d.samples.size(), 576u);
  EXPECT_TRUE(d.has_setup);
  EXPECT_EQ(d.samples[287].setup, 0);
  EXPECT_EQ(d.samples[288].setup, 1);
  EXPECT_DOUBLE_EQ(d.samples[3].t_s, 1.5);
  EXPECT_EQ(Simulate(spec).samples[100].r_mm, d.samples[100].r_mm);
  spec.seed = 2;
  EXPECT_NE(Simulate(spec).samples[100].r_mm, d.samples[100].r_mm);
}

TEST(Simulate, RejectsImpossibleSpecs) {
  SimulationSpec spec;
  spec.centers_mm = {Eigen::Vector3d(0, 40, 0)};
  EXPECT_THROW(Simulate(spec), Error);
  spec = SimulationSpec();
  spec.sphere_radius_mm = 0.0;
  EXPECT_THROW(Simulate(spec), Error);
}

}  // namespace
}  // namespace sph
