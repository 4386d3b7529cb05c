// The CLI11 classes the apps' headers name, declared without CLI11 itself.
//
// <CLI/CLI.hpp> (CLI11 2.1, header-only in Debian) costs about 6 s of compile time in every
// translation unit that includes it, more than the code of most of them. The headers of the apps
// therefore pass CLI::App by reference only; the sources that set up options, and main() through
// RunApp() in app_common.cpp, are the only ones that include CLI11.
#ifndef SPH_APPS_CLI_FWD_HPP_
#define SPH_APPS_CLI_FWD_HPP_

namespace CLI {
class App;
class Option;
class Validator;
}  // namespace CLI

#endif  // SPH_APPS_CLI_FWD_HPP_
