// Uses the installed model headers with Eigen alone.
#include <cmath>
#include <cstdio>

#include "sph/model/scms_model.hpp"

int main() {
  const sph::ScmsGeometry g{};
  const Eigen::Vector3d p = sph::ScmsPoint(g, 0.0, sph::kPi / 2, 5.0, 25.0);
  std::printf("p = %g %g %g\n", p.x(), p.y(), p.z());
  return std::abs(p.x() - 20.0) < 1e-12 ? 0 : 1;
}
