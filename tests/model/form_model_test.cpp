#include "sph/model/form_model.hpp"

#include <cmath>

#include <gtest/gtest.h>

namespace sph {
namespace {

// The mean of S_lm^2 over the sphere is 1 / (2l + 1): checked by quadrature on a fine grid, and
// so FormRms() is the RMS of the form over the sphere.
TEST(FormModel, RmsOverTheSphere) {
  const std::vector<FormTerm> terms = {{2, 1}, {3, -2}, {5, 0}, {8, 7}};
  const std::vector<double> c = {0.03, -0.02, 0.04, 0.01};
  double sum = 0.0, weight = 0.0;
  const int n_lat = 400, n_lon = 800;
  for (int i = 0; i < n_lat; ++i) {
    const double polar = (i + 0.5) * 3.14159265358979323846 / n_lat;
    for (int j = 0; j < n_lon; ++j) {
      const double lon = (j + 0.5) * 2.0 * 3.14159265358979323846 / n_lon;
      const Eigen::Vector3d u(std::sin(polar) * std::cos(lon), std::sin(polar) * std::sin(lon), std::cos(polar));
      const double f = FormValue(terms, c.data(), u);
      sum += f * f * std::sin(polar);
      weight += std::sin(polar);
    }
  }
  // The midpoint rule in the polar angle errs by about h^2 / 24 = 3e-6 (h = pi / 400); a wrong
  // normalisation would be off by a factor.
  EXPECT_NEAR(std::sqrt(sum / weight), FormRms(terms, c), 1e-5 * FormRms(terms, c));
}

TEST(FormModel, MountRotationIsAxisTimesAngle) {
  const Eigen::Matrix3d r = MountRotationMatrix(Eigen::Vector3d(0.0, 0.0, 90.0));
  EXPECT_NEAR((r * Eigen::Vector3d::UnitX() - Eigen::Vector3d::UnitY()).norm(), 0.0, 1e-15);
  EXPECT_TRUE(MountRotationMatrix(Eigen::Vector3d::Zero()).isIdentity());
  // A point of the surface at body direction +x is seen at +y after a turn of 90 deg about z, so
  // the form a probe sees at +y is the body's form at +x.
  const std::vector<FormTerm> terms = {{2, 2}};
  const double c = 1.0;
  const Eigen::Vector3d seen = Eigen::Vector3d::UnitY();
  EXPECT_NEAR(FormValue(terms, &c, Eigen::Vector3d(r.transpose() * seen)),
              FormValue(terms, &c, Eigen::Vector3d(Eigen::Vector3d::UnitX())), 1e-15);
}

TEST(FormModel, TermsOfDegrees) {
  const std::vector<FormTerm> t = FormTermsOfDegrees(2, 8);
  EXPECT_EQ(t.size(), 77u);  // sum over l = 2..8 of 2l + 1
  EXPECT_EQ(t.front(), (FormTerm{2, -2}));
  EXPECT_EQ(t.back(), (FormTerm{8, 8}));
}

}  // namespace
}  // namespace sph
