// printf into a std::string, for report cells and messages. Not part of the public API.
#ifndef SPH_INTERNAL_FORMAT_HPP_
#define SPH_INTERNAL_FORMAT_HPP_

#include <cstdio>
#include <string>

namespace sph::internal {

/// snprintf into a std::string of at most 255 characters (table cells and message fragments).
template <typename... Args>
std::string Format(const char* format, Args... args) {
  char buffer[256];
  std::snprintf(buffer, sizeof buffer, format, args...);
  return buffer;
}

}  // namespace sph::internal

#endif  // SPH_INTERNAL_FORMAT_HPP_
