// Whole-file output that is either complete or absent.
#ifndef SPH_CORE_ATOMIC_FILE_HPP_
#define SPH_CORE_ATOMIC_FILE_HPP_

#include <functional>
#include <ostream>
#include <string>

namespace sph {

/// Writes a file through `write`, atomically: the content goes to a temporary file in the same
/// directory, which is flushed, fsync'ed and renamed over `path` only when everything succeeded.
/// On any failure (exception from `write`, stream error, full disk) the temporary file is removed,
/// an existing `path` is left untouched, and sph::Error is thrown naming the path.
/// `path` "-" writes to standard output instead.
void WriteFileAtomically(const std::string& path, const std::function<void(std::ostream&)>& write);

}  // namespace sph

#endif  // SPH_CORE_ATOMIC_FILE_HPP_
