// The one exception type that sph throws at its library boundary (files, options, sockets).
#ifndef SPH_CORE_ERROR_HPP_
#define SPH_CORE_ERROR_HPP_

#include <stdexcept>
#include <string>

namespace sph {

/// Bad input or a failed system call. what() names the file (and line) and the problem, e.g.
/// "points.txt:12: expected 3 columns (theta_deg phi_deg r_mm), found 2".
class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace sph

#endif  // SPH_CORE_ERROR_HPP_
