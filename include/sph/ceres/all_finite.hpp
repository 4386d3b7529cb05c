// AllFinite(): whether a residual's value and, for a Jet, every derivative is finite.
#ifndef SPH_CERES_ALL_FINITE_HPP_
#define SPH_CERES_ALL_FINITE_HPP_

#include <cmath>

#include <ceres/jet.h>

namespace sph::internal {

/// Whether a value and, for a Jet, every derivative is finite. A residual functor returns false
/// ("cannot evaluate here") rather than a non-finite value: Ceres then shortens the step instead
/// of logging the evaluation (readings of absurd size, a step into overflow).
inline bool AllFinite(double x) { return std::isfinite(x); }
template <typename T, int N>
bool AllFinite(const ceres::Jet<T, N>& x) {
  return std::isfinite(x.a) && x.v.allFinite();
}

}  // namespace sph::internal

#endif  // SPH_CERES_ALL_FINITE_HPP_
