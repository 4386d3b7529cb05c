// Ceres residual of one reading against the reference sphere (Eq. (2)-(5) of the paper):
//
//   e = |p_sphere(g; theta, phi, r) - O_s| - R0      [mm]
//
// Parameter blocks, in this order:
//   geometry[kNumScmsParams]  the seven errors (sph/model/scms_model.hpp; rad and mm)
//   center[3]                 sphere centre O_s of this reading's setup [mm]
// The readings are fixed, so sin and cos of theta and phi are computed once, in the constructor.
#ifndef SPH_CERES_SPHERE_RESIDUAL_HPP_
#define SPH_CERES_SPHERE_RESIDUAL_HPP_

#include <cmath>

#include <ceres/autodiff_cost_function.h>

#include "sph/ceres/all_finite.hpp"
#include "sph/model/scms_model.hpp"

namespace sph {

class SphereResidual {
 public:
  /// @param theta_rad, phi_rad axis readings; r_mm probe reading; d_mm nominal probe zero
  ///        distance; radius_mm R0 of the reference sphere.
  SphereResidual(double theta_rad, double phi_rad, double r_mm, double d_mm, double radius_mm)
      : SphereResidual(SinCosOf(theta_rad), SinCosOf(phi_rad), r_mm, d_mm, radius_mm) {}

  /// As above, with sin and cos of the readings already computed.
  SphereResidual(const SinCos<double>& theta, const SinCos<double>& phi, double r_mm, double d_mm, double radius_mm)
      : theta_(theta), phi_(phi), r_mm_(r_mm), d_mm_(d_mm), radius_mm_(radius_mm) {}

  template <typename T>
  bool operator()(const T* const geometry, const T* const center, T* residual) const {
    return Evaluate(geometry, ErrorTrigOf(geometry), center, residual);
  }

  /// operator() with the angle errors' sin and cos given (ErrorTrigOf(geometry)), so that code
  /// evaluating many readings at one geometry computes them once (SphereResidualBatch).
  template <typename T>
  bool Evaluate(const T* const geometry, const ScmsErrorTrig<T>& trig, const T* const center, T* residual) const {
    using std::sqrt;
    const Vec3<T> p = ScmsPoint(geometry, trig, theta_, phi_, T(r_mm_), T(d_mm_));
    const T dx = p[0] - center[0];
    const T dy = p[1] - center[1];
    const T dz = p[2] - center[2];
    residual[0] = sqrt(dx * dx + dy * dy + dz * dz) - T(radius_mm_);
    return internal::AllFinite(residual[0]);
  }

  /// The autodiff cost function for one reading (the caller, usually ceres::Problem, owns it).
  static ceres::CostFunction* Create(double theta_rad, double phi_rad, double r_mm, double d_mm, double radius_mm) {
    return new ceres::AutoDiffCostFunction<SphereResidual, 1, kNumScmsParams, 3>(
        new SphereResidual(theta_rad, phi_rad, r_mm, d_mm, radius_mm));
  }

 private:
  SinCos<double> theta_;
  SinCos<double> phi_;
  double r_mm_;
  double d_mm_;
  double radius_mm_;
};

}  // namespace sph

#endif  // SPH_CERES_SPHERE_RESIDUAL_HPP_
