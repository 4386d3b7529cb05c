// Many SphereResidual functors that share their parameter blocks, as one ceres::CostFunction.
//
//   residual i = SphereResidual_i(geometry, center)   [mm],  i = 0 .. n-1
//
// Parameter blocks: geometry[kNumScmsParams] (rad, mm), center[3] (mm); n residuals.
//
// Why: with one AutoDiffCostFunction per reading, Ceres' per-residual-block work (evaluation
// bookkeeping, copying Jets in and out, validity checks) and the sin/cos of the three angle
// errors, repeated for every reading, cost more than the model itself. This class evaluates the
// same per-reading functors with the same forward-mode automatic differentiation
// (ceres::Jet<double, kNumScmsParams + 3>, seeded once per evaluation) and computes the angle
// errors' trig once per evaluation. Residuals and Jacobians are those of the per-reading
// AutoDiffCostFunctions (tests/ceres/sphere_residual_test.cpp checks this).
#ifndef SPH_CERES_SPHERE_RESIDUAL_BATCH_HPP_
#define SPH_CERES_SPHERE_RESIDUAL_BATCH_HPP_

#include <utility>
#include <vector>

#include <ceres/cost_function.h>
#include <ceres/jet.h>

#include "sph/ceres/sphere_residual.hpp"

namespace sph {

class SphereResidualBatch final : public ceres::CostFunction {
 public:
  static constexpr int kNumParams = kNumScmsParams + 3;
  using Jet = ceres::Jet<double, kNumParams>;

  /// @param readings one functor per reading; all share the geometry and centre blocks.
  explicit SphereResidualBatch(std::vector<SphereResidual> readings) : readings_(std::move(readings)) {
    set_num_residuals(static_cast<int>(readings_.size()));
    *mutable_parameter_block_sizes() = {kNumScmsParams, 3};
  }

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const double* geometry = parameters[0];
    const double* center = parameters[1];
    if (jacobians == nullptr || (jacobians[0] == nullptr && jacobians[1] == nullptr)) {
      const ScmsErrorTrig<double> trig = ErrorTrigOf(geometry);
      for (std::size_t i = 0; i < readings_.size(); ++i) {
        if (!readings_[i].Evaluate(geometry, trig, center, &residuals[i])) return false;
      }
      return true;
    }
    Jet g[kNumScmsParams];
    Jet c[3];
    for (int k = 0; k < kNumScmsParams; ++k) g[k] = Jet(geometry[k], k);
    for (int k = 0; k < 3; ++k) c[k] = Jet(center[k], kNumScmsParams + k);
    const ScmsErrorTrig<Jet> trig = ErrorTrigOf(g);
    for (std::size_t i = 0; i < readings_.size(); ++i) {
      Jet e;
      if (!readings_[i].Evaluate(g, trig, c, &e)) return false;
      residuals[i] = e.a;
      // Jacobians are row-major, one row per residual.
      if (jacobians[0] != nullptr) {
        for (int k = 0; k < kNumScmsParams; ++k)
          jacobians[0][i * kNumScmsParams + static_cast<std::size_t>(k)] = e.v[k];
      }
      if (jacobians[1] != nullptr) {
        for (int k = 0; k < 3; ++k) jacobians[1][i * 3 + static_cast<std::size_t>(k)] = e.v[kNumScmsParams + k];
      }
    }
    return true;
  }

  std::size_t size() const { return readings_.size(); }

 private:
  std::vector<SphereResidual> readings_;
};

}  // namespace sph

#endif  // SPH_CERES_SPHERE_RESIDUAL_BATCH_HPP_
