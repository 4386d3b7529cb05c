#include "sph/internal/header_json.hpp"

#include <nlohmann/json.hpp>

#include "sph/io/points_file.hpp"

namespace sph::internal {

nlohmann::json MetadataJson(const std::vector<std::pair<std::string, std::string>>& metadata) {
  nlohmann::json meta = nlohmann::json::object();
  for (const auto& [k, v] : metadata) meta[k] = v;
  return meta;
}

nlohmann::json DevicesJson(const std::vector<std::pair<std::string, std::string>>& metadata) {
  nlohmann::json devices = nlohmann::json::array();
  for (const HeaderDevice& d : DevicesOf(metadata)) {
    nlohmann::json dev = {{"role", d.role}};
    const std::pair<const char*, const std::string*> fields[] = {
        {"node", &d.node},         {"name", &d.name},    {"vendor_id", &d.vendor_id}, {"product_code", &d.product_code},
        {"revision", &d.revision}, {"serial", &d.serial}};
    for (const auto& [key, value] : fields) {
      if (!value->empty()) dev[key] = *value;
    }
    dev["other"] = d.other;
    devices.push_back(dev);
  }
  return devices;
}

}  // namespace sph::internal
