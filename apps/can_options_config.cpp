// The strict reading of the CAN apps' --config files (UseStrictConfig).
#include <map>
#include <sstream>

#include <CLI/CLI.hpp>

#include "can_options.hpp"
#include "sph/core/error.hpp"
#include "sph/core/text_input.hpp"
#include "sph/internal/format.hpp"

namespace sph::apps {
namespace {

std::string Trim(const std::string& s) {
  const auto first = s.find_first_not_of(" \t\r");
  if (first == std::string::npos) return "";
  return s.substr(first, s.find_last_not_of(" \t\r") - first + 1);
}

// The option a config file's key sets in `app`, as CLI11 looks it up; null when none.
CLI::Option* ConfigOption(CLI::App& app, const std::string& key) {
  CLI::Option* op = app.get_option_no_throw("--" + key);
  if (op == nullptr && key.size() == 1) op = app.get_option_no_throw("-" + key);
  if (op == nullptr) op = app.get_option_no_throw(key);
  return op;
}

// CLI11's TOML reader, after the checks of UseStrictConfig.
class StrictConfig : public CLI::ConfigTOML {
 public:
  StrictConfig(CLI::App* app, std::string program, std::string* path_read, std::shared_ptr<CLI::App> also_known)
      : app_(app), program_(std::move(program)), path_read_(path_read), also_known_(std::move(also_known)) {}

  std::vector<CLI::ConfigItem> from_config(std::istream& input) const override {
    const std::string path = app_->get_config_ptr()->as<std::string>();
    if (path_read_ != nullptr) *path_read_ = path;
    TextLines lines(input, path, "a configuration file");
    std::string text, line;
    std::map<const CLI::Option*, long> seen;
    bool in_array = false;  // a value "[a, b, ...]" continued on the next lines
    while (lines.Next(line)) {
      text += line + "\n";
      const std::string t = Trim(line);
      if (in_array) {
        in_array = t.empty() || t.back() != ']';
        continue;
      }
      if (t.empty() || t[0] == '#' || t[0] == ';') continue;
      if (t[0] == '[') {
        throw Error(lines.Where() + "a section " + internal::Quoted(t) + ": " + program_ +
                    " reads 'name = value' lines without sections");
      }
      const auto eq = t.find('=');
      std::string key = Trim(t.substr(0, eq == std::string::npos ? t.find('#') : eq));
      if (key.size() >= 2 && (key.front() == '"' || key.front() == '\'') && key.back() == key.front()) {
        key = key.substr(1, key.size() - 2);
      }
      if (eq != std::string::npos) {
        const std::string value = Trim(t.substr(eq + 1));
        in_array =
            value.size() > 1 && value[0] == '[' && value.substr(0, value.find('#')).find(']') == std::string::npos;
      }
      if (key.empty()) throw Error(lines.Where() + "expected 'name = value', got " + internal::Quoted(t));
      const CLI::Option* op = ConfigOption(*app_, key);
      if (op == nullptr) {
        if (also_known_ && ConfigOption(*also_known_, key) != nullptr) continue;  // the other program's
        throw Error(lines.Where() + "unknown option " + internal::Quoted(key) + ": not an option of " + program_ +
                    " (see --help; the names are the long options without their dashes)");
      }
      if (!op->get_configurable()) {
        throw Error(lines.Where() + internal::Quoted(key) + " cannot be set in a configuration file");
      }
      const auto [first, fresh] = seen.emplace(op, lines.line_no());
      if (!fresh) {
        throw Error(lines.Where() + internal::Quoted(key) + " is given twice (first at line " +
                    std::to_string(first->second) + "): give each option once");
      }
    }
    std::istringstream checked(text);
    return CLI::ConfigTOML::from_config(checked);
  }

 private:
  CLI::App* app_;
  std::string program_;
  std::string* path_read_;
  std::shared_ptr<CLI::App> also_known_;
};

}  // namespace

void UseStrictConfig(CLI::App& app, const std::string& program, std::string* path_read,
                     std::shared_ptr<CLI::App> also_known) {
  app.config_formatter(std::make_shared<StrictConfig>(&app, program, path_read, std::move(also_known)));
}

}  // namespace sph::apps
