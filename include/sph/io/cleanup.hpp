// Temporary files that must not outlive a program killed by a signal, and the child processes
// that might write them.
#ifndef SPH_IO_CLEANUP_HPP_
#define SPH_IO_CLEANUP_HPP_

#include <sys/types.h>

#include <string>

namespace sph {

/// Registers a temporary file to be removed should the process be ended by a signal before
/// UnregisterTempFile(). Returns a handle for UnregisterTempFile(), or -1 when the table (64
/// files) is full or the path too long; the file is then only removed by its owner.
int RegisterTempFile(const std::string& path);
/// Forgets a registration (the file was renamed into place or removed). -1 is ignored.
void UnregisterTempFile(int handle);
/// Registers a child process that leads its own process group (a program the run started, such
/// as gnuplot, which may write a registered file) to be killed with its group and waited for
/// should the process be ended by a signal before UnregisterChildProcess(). Returns a handle, or
/// -1 when the table (8 processes) is full.
int RegisterChildProcess(pid_t pid);
/// Forgets a registration (the child was waited for). -1 is ignored.
void UnregisterChildProcess(int handle);
/// Kills every registered child process group with SIGKILL and waits for each child, then
/// removes every registered file: a child cannot write a file after it was removed.
/// Async-signal-safe: a program's own signal handler may call it.
void RemoveRegisteredTempFiles() noexcept;
/// Installs handlers for SIGINT, SIGTERM, SIGHUP and SIGPIPE that call RemoveRegisteredTempFiles()
/// and then end the process by the same signal, as its default action would. A program that
/// handles SIGINT or SIGTERM itself (to stop cleanly) installs its handlers afterwards; its
/// normal shutdown then removes what it staged.
void RemoveTempFilesOnSignals();

}  // namespace sph

#endif  // SPH_IO_CLEANUP_HPP_
