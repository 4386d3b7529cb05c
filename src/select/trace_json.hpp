// Private to sph::calib: the trace's part of the JSON report, for JsonReport() (report.cpp).
// nlohmann/json is a private build dependency of sph::calib: it stays out of the public headers.
#ifndef SPH_SRC_SELECT_TRACE_JSON_HPP_
#define SPH_SRC_SELECT_TRACE_JSON_HPP_

#include <nlohmann/json.hpp>

#include "sph/select/trace_report.hpp"

namespace sph::internal {

/// Adds the trace to the JSON report: effects_added, effects_removed, before, after, effects,
/// effect_reference, harmonic_orders_searched, candidates, ambiguous, unexplained, sphere_form and
/// validation (when given).
void AddTraceJson(nlohmann::json& report, const TraceResult& trace, const Validation* validation);

}  // namespace sph::internal

#endif  // SPH_SRC_SELECT_TRACE_JSON_HPP_
