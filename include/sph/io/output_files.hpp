// The output layer of every sph program: what a run may write, and how it writes it.
//
// Two promises, kept here and nowhere else:
//  - A run never writes over one of its own inputs, and never writes two of its outputs to one
//    file (RunPaths, checked before anything is computed).
//  - Every output file is complete or absent. A regular file (or a name not yet taken) is written
//    to a temporary file beside it, fsync'ed, and renamed over the name only when the whole run
//    succeeded, its standard output included; a symbolic link is followed and its target
//    replaced. A FIFO, a terminal, /dev/null or standard output is written directly and is never
//    replaced by a regular file. A directory, a block device or a socket is refused, and so is an
//    existing file the user may not write or that nobody may (as cp refuses it). A failure
//    or a signal leaves no temporary file behind (OutputFiles, and the signal handlers of
//    sph/io/cleanup.hpp).
#ifndef SPH_IO_OUTPUT_FILES_HPP_
#define SPH_IO_OUTPUT_FILES_HPP_

#include <functional>
#include <memory>
#include <ostream>
#include <string>
#include <vector>

namespace sph {

/// The files one run reads and writes, each with the option or argument that names it, so that a
/// clash is reported in the user's words:
///   "--output same.txt is also the input 'points' (same.txt): refusing to write over an input"
///   "--json c.json and --output c.json are the same file: give each output its own file"
/// "-" is standard output for an output (and standard input for an input). Two paths are the
/// same file when they name the same inode, or, for a file not yet created, the same path after
/// symbolic links and "." and ".." are resolved. Character devices (/dev/null, a terminal) may be
/// shared by several outputs; anything else may not.
class RunPaths {
 public:
  /// Adds an input; an empty path is ignored.
  RunPaths& Input(const std::string& name, const std::string& path);
  /// Adds an output; an empty path is ignored. Throws sph::Error when it is an input or another
  /// output already added, or an existing regular file the user may not write or that grants
  /// writing to nobody (mode 0444: "r.html: cannot write: it is read-only (mode 0444): ...").
  RunPaths& Output(const std::string& name, const std::string& path);

  struct Entry;  ///< one named path and what it is (defined in the implementation)

 private:
  std::vector<std::shared_ptr<const Entry>> inputs_, outputs_;
};

/// The output files of one run, each complete or absent.
///
/// Stage() writes a file's content now, into a temporary file beside it (or, for a FIFO, a
/// character device or standard output, into memory); Commit() puts everything in place: first
/// the direct writes, which can fail (a full device, a closed pipe), then the renames. Until
/// Commit() returns, no existing file has changed. The destructor removes whatever was staged
/// and not committed, so an exception between Stage() and Commit() leaves nothing behind.
///
/// Class invariant: every staged temporary file is registered with the signal cleanup
/// (sph/io/cleanup.hpp) until it is renamed or removed.
class OutputFiles {
 public:
  /// `standard_output` is the run's standard output (a test passes a string stream): it receives
  /// what is staged for "-", and whatever else the run wrote to it (a text report) counts as an
  /// output too: Commit() flushes it and fails when any write to it failed.
  explicit OutputFiles(std::ostream& standard_output);
  /// Files only: "-" is std::cout, flushed and checked by Commit() only when something is staged
  /// for it.
  OutputFiles();
  ~OutputFiles();
  OutputFiles(const OutputFiles&) = delete;
  OutputFiles& operator=(const OutputFiles&) = delete;

  /// Stages `path` ("-": standard output) with what `write` writes. Throws sph::Error naming the
  /// path when it cannot be written (no such folder, no permission, full disk, a directory or
  /// block device) or when `write` throws (its error is passed on).
  void Stage(const std::string& path, const std::function<void(std::ostream&)>& write);
  /// Stages `path` for another program to write (an image drawn by gnuplot): returns the name
  /// of a new empty temporary file in the same folder that the program must write; Commit()
  /// moves it in. `path` must be a regular file or a name not yet taken.
  std::string StageProduced(const std::string& path);
  /// The file that holds what was staged for `path` until Commit(): the temporary file beside it
  /// (for another program that reads the staged content). Throws sph::Error when `path` was not
  /// staged as a regular file.
  std::string StagedName(const std::string& path) const;
  /// Puts every staged file in place: first standard output (what was staged for it, then a
  /// flush that fails when any write to it failed: "cannot write to standard output: Broken
  /// pipe"), then the FIFOs and character devices, and only then, when all of that succeeded, the
  /// renames, in the order staged. Throws sph::Error naming the path on the first failure; the
  /// files not yet put in place are then removed.
  void Commit();

 private:
  struct Staged;
  std::ostream& standard_output_;
  bool run_output_;  ///< standard_output_ is the run's: checked whatever was staged
  std::vector<std::unique_ptr<Staged>> staged_;
};

/// True when `a` and `b` name one file: the same inode, or, for a name not yet created, the same
/// path after symbolic links and "." and ".." are resolved ("-" is standard input).
bool SameFile(const std::string& a, const std::string& b);

/// Writes one file the way OutputFiles does: complete or absent, "-" standard output.
void WriteFileAtomically(const std::string& path, const std::function<void(std::ostream&)>& write);

/// Routes std::cout, while it lives, through a buffer that remembers why its first write failed
/// (std::cout's own state only says that one did) and that writes what a terminal would act on
/// rather than show as text: the control characters but tab and line feed, DEL and U+0080 to
/// U+009F as \u00hh (JSON's escape: JSON stays JSON), bytes that are no UTF-8 as \xHH. Text from
/// a file (a header field a report prints) thus never reaches a terminal raw. A program's main()
/// makes one.
class StandardOutput {
 public:
  StandardOutput();
  ~StandardOutput();  ///< flushes and gives std::cout its own buffer back
  StandardOutput(const StandardOutput&) = delete;
  StandardOutput& operator=(const StandardOutput&) = delete;

 private:
  friend std::string FlushStandardOutput();
  struct Buffer;
  std::unique_ptr<Buffer> buffer_;
  std::streambuf* saved_ = nullptr;
};

/// Flushes standard output and tells a failure of a write since the last call (a full disk, a
/// closed pipe): "" or the reason ("No space left on device"). Each failure is told once.
std::string FlushStandardOutput();

}  // namespace sph

#endif  // SPH_IO_OUTPUT_FILES_HPP_
