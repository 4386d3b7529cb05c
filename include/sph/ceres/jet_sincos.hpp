// SinCosOf() for ceres::Jet: one scalar sin and cos for both results.
//
// The generic SinCosOf() (sph/model/dh.hpp) calls sin(x) and cos(x); for a Jet each of those
// evaluates both the scalar sine and cosine (the derivative of one is the other), so two Jet calls
// cost four scalar transcendental calls. This specialisation costs two. Results are identical.
// Include it before instantiating model code with Jets (sph/ceres/sphere_residual.hpp does).
#ifndef SPH_CERES_JET_SINCOS_HPP_
#define SPH_CERES_JET_SINCOS_HPP_

#include <cmath>

#include <ceres/jet.h>

#include "sph/model/dh.hpp"

namespace sph::internal {

template <typename T, int N>
struct SinCosImpl<ceres::Jet<T, N>> {
  static SinCos<ceres::Jet<T, N>> Eval(const ceres::Jet<T, N>& x) {
    using std::cos;
    using std::sin;
    const T s = sin(x.a);
    const T c = cos(x.a);
    return {ceres::Jet<T, N>(s, c * x.v), ceres::Jet<T, N>(c, -s * x.v)};
  }
};

/// Whether a value and, for a Jet, every derivative is finite. A residual functor returns false
/// ("cannot evaluate here") rather than a non-finite value: Ceres then shortens the step instead
/// of logging the evaluation (readings of absurd size, a step into overflow).
inline bool AllFinite(double x) { return std::isfinite(x); }
template <typename T, int N>
bool AllFinite(const ceres::Jet<T, N>& x) {
  return std::isfinite(x.a) && x.v.allFinite();
}

}  // namespace sph::internal

#endif  // SPH_CERES_JET_SINCOS_HPP_
