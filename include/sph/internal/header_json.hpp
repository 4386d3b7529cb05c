// The points file's header as the JSON reports hold it: its fields ("metadata") and the devices
// sph_acquired identified ("devices"; docs/formats/reports.md). Not part of the public API.
#ifndef SPH_INTERNAL_HEADER_JSON_HPP_
#define SPH_INTERNAL_HEADER_JSON_HPP_

#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json_fwd.hpp>

namespace sph::internal {

/// The header's fields as one object, key to value as written.
nlohmann::json MetadataJson(const std::vector<std::pair<std::string, std::string>>& metadata);
/// DevicesOf(metadata) as an array: each device's role, the identity fields its line gives, and
/// "other", its other items as written.
nlohmann::json DevicesJson(const std::vector<std::pair<std::string, std::string>>& metadata);

}  // namespace sph::internal

#endif  // SPH_INTERNAL_HEADER_JSON_HPP_
