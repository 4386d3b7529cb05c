// The JSON reports' values as the HTML reports print them (sph/io/html_report.hpp). Not part
// of the public API: the libraries' sources that render a JSON report as HTML use it.
#ifndef SPH_INTERNAL_HTML_JSON_HPP_
#define SPH_INTERNAL_HTML_JSON_HPP_

#include <string>

#include <nlohmann/json_fwd.hpp>

namespace sph::html {

/// A value of a JSON report as the HTML report prints it: a number by Number(), a text escaped,
/// true/false "yes"/"no", null "-".
std::string JsonText(const nlohmann::json& value);
/// JsonText() of j[key], "-" when j has no such key.
std::string JsonField(const nlohmann::json& j, const char* key);
/// A <ul> of the array's items by JsonText(), or "<p>None.</p>" for an empty or missing one.
std::string JsonList(const nlohmann::json& items);
/// A report's points file header: the table of its "metadata" and the devices of its "devices"
/// (sph/internal/header_json.hpp), each name kept whole (broken between words only).
std::string HeaderTables(const nlohmann::json& report);

}  // namespace sph::html

#endif  // SPH_INTERNAL_HTML_JSON_HPP_
