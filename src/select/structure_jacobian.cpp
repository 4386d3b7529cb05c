// A fit's Jacobian as JacobianBlocks (structure_jacobian.hpp).
#include "structure_jacobian.hpp"

#include <cstdint>

#include "effect_fit_rows.hpp"

namespace sph::internal {

StructureJacobian::StructureJacobian(const ReadingTable& table, const CalibrationOptions& options, const EffectFit& fit,
                                     const std::vector<double>& expected_r_mm)
    : problem_(table, AllRows(table), fit.model, options), offset_(expected_r_mm) {
  x_ = problem_.Pack(fit.calibration.geometry,
                     CentersFor(table, AllRows(table), fit.calibration.setup_ids, fit.calibration.centers_mm, ""),
                     fit.values, fit.form_values);
  for (std::size_t i = 0; i < offset_.size(); ++i) offset_[i] -= table.r_mm[i];
}

void StructureJacobian::ForEach(const BlockFn& fn) const {
  const auto n = static_cast<int>(problem_.NumParams());
  problem_.ForEachGlobalBlock(
      x_.data(), offset_.data(),
      [&](const std::uint32_t* rows, int count, double* jacobian, int setup) { fn(rows, count, jacobian, n, setup); });
}

std::vector<Eigen::Index> StructureJacobian::GroupColumns() const {
  std::vector<Eigen::Index> first;
  for (int k = 0; k < problem_.NumSetups(); ++k) first.push_back(kNumScmsParams + 3 * static_cast<Eigen::Index>(k));
  return first;
}

}  // namespace sph::internal
