// The strict reading of the CAN apps' --config files (UseStrictConfig).
#include <sys/stat.h>

#include <cerrno>
#include <cstring>
#include <fstream>
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

// Where each option read from the config file was set ("--setup" -> "x.conf:3: "), so that a
// value CLI11 refuses later (a range, a conversion) is named at its line.
using Origins = std::map<std::string, std::string>;

// CLI11's TOML reader, after the checks of UseStrictConfig.
class StrictConfig : public CLI::ConfigTOML {
 public:
  StrictConfig(CLI::App* app, std::string program, std::string* path_read, std::shared_ptr<CLI::App> also_known,
               std::shared_ptr<Origins> origins)
      : app_(app),
        program_(std::move(program)),
        path_read_(path_read),
        also_known_(std::move(also_known)),
        origins_(std::move(origins)) {}

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
      std::string value;
      if (eq != std::string::npos) {
        value = Trim(t.substr(eq + 1));
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
      // A bare name sets a flag; an option that takes a value needs one ('setup' alone would be
      // read as 'setup = true').
      const bool flag = op->get_type_size_max() == 0 || op->get_expected_max() == 0;
      const std::string bare = Trim(value.substr(0, value.find('#')));
      if (!flag && (eq == std::string::npos || bare.empty())) {  // "" is a value: the empty one
        throw Error(lines.Where() + internal::Quoted(key) + " needs a value: '" + key + " = VALUE'");
      }
      for (const std::string& name : op->get_lnames()) (*origins_)["--" + name] = lines.Where();
      for (const std::string& name : op->get_snames()) (*origins_)["-" + name] = lines.Where();
    }
    std::istringstream checked(text);
    return CLI::ConfigTOML::from_config(checked);
  }

 private:
  CLI::App* app_;
  std::string program_;
  std::string* path_read_;
  std::shared_ptr<CLI::App> also_known_;
  std::shared_ptr<Origins> origins_;
};

// Whether CLI11's message `what` is about the option `name` ("--setup: ...", "Could not convert:
// --setup = x").
bool About(const std::string& what, const std::string& name) {
  const auto at = what.find(name);
  if (at == std::string::npos || (at > 0 && what[at - 1] != ' ')) return false;
  const std::size_t end = at + name.size();
  return end == what.size() || what[end] == ':' || what[end] == ' ' || what[end] == '=';
}

// CLI11's "Could not convert: --setup = x" in the program's words: "--setup: 'x' is not an integer".
std::string Readable(const CLI::App* app, const std::string& what) {
  const std::string prefix = "Could not convert: ";
  const auto eq = what.find(" = ");
  if (what.rfind(prefix, 0) != 0 || eq == std::string::npos) return what;
  const std::string name = what.substr(prefix.size(), eq - prefix.size());
  const std::string value = what.substr(eq + 3);
  const CLI::Option* op = app != nullptr ? app->get_option_no_throw(name) : nullptr;
  const std::string type = op != nullptr ? op->get_type_name() : "";
  const std::string kind = type == "INT" || type == "UINT" ? "an integer"
                           : type == "FLOAT"               ? "a number"
                                                           : "a value " + name + " takes (see --help)";
  return name + ": " + internal::Quoted(value) + " is not " + kind;
}

}  // namespace

void UseStrictConfig(CLI::App& app, const std::string& program, std::string* path_read,
                     std::shared_ptr<CLI::App> also_known) {
  auto origins = std::make_shared<Origins>();
  app.config_formatter(std::make_shared<StrictConfig>(&app, program, path_read, std::move(also_known), origins));
  // The file itself, before CLI11 reads it: a directory or a file that cannot be read is refused
  // in the program's words (CLI11's own: "conf was not readable (missing?)").
  if (CLI::Option* config = app.get_config_ptr()) {
    config->trigger_on_parse()->check(CLI::Validator(
        [](std::string& path) -> std::string {
          struct stat st {};
          if (!path.empty() && ::stat(path.c_str(), &st) == 0 && S_ISDIR(st.st_mode)) {
            throw Error(path + ": is a directory, not a configuration file (--config)");
          }
          std::ifstream probe(path);
          if (!path.empty() && !probe) {
            throw Error(path + ": cannot open the configuration file (--config) for reading: " + std::strerror(errno));
          }
          return "";
        },
        "FILE"));
  }
  // CLI11's refusals, as every other error of the program: "<program>: error: ...", and for a
  // value read from the config file, its file and line.
  app.failure_message([program, origins](const CLI::App* a, const CLI::Error& e) {
    std::string where;
    const std::string what = Readable(a, e.what());
    for (const auto& [name, at] : *origins) {
      if (About(what, name)) where = at;
    }
    return program + ": error: " + where + what + "\nRun with --help for more information.\n";
  });
}

}  // namespace sph::apps
