#include "sph/io/output_files.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <fstream>
#include <functional>
#include <iostream>
#include <sstream>
#include <thread>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "sph/io/cleanup.hpp"
#include "sph/core/error.hpp"
#include "test_util.hpp"

namespace sph {
namespace {

using sph::testing::ReadWholeFile;
using ::testing::HasSubstr;
const auto Entries = sph::testing::ListFolder;

void Put(const std::string& path, const std::string& text) { std::ofstream(path, std::ios::binary) << text; }

// The message of the sph::Error that `f` throws ("" when it throws none).
template <typename F>
std::string ErrorOf(F f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

// A device node in the test's own folder (never on /dev); false when this process may not make one.
bool MakeNode(const std::string& path, mode_t type, unsigned major_no, unsigned minor_no) {
  return ::mknod(path.c_str(), type | 0600, makedev(major_no, minor_no)) == 0;
}

struct NodeId {
  mode_t type;
  dev_t rdev;
};
NodeId NodeOf(const std::string& path) {
  struct stat st {};
  if (::lstat(path.c_str(), &st) != 0) return {0, 0};
  return {static_cast<mode_t>(st.st_mode & S_IFMT), st.st_rdev};
}

TEST(WriteFileAtomically, WritesAndReplaces) {
  const std::string dir = sph::testing::MakeTempDir("atomic");
  WriteFileAtomically(dir + "/f.txt", [](std::ostream& o) { o << "one\n"; });
  WriteFileAtomically(dir + "/f.txt", [](std::ostream& o) { o << "two\n"; });
  EXPECT_EQ(ReadWholeFile(dir + "/f.txt"), "two\n");
  EXPECT_EQ(Entries(dir).size(), 1u);
}

TEST(WriteFileAtomically, FailureLeavesNothingBehind) {
  const std::string dir = sph::testing::MakeTempDir("atomic_fail");
  WriteFileAtomically(dir + "/keep.txt", [](std::ostream& o) { o << "old\n"; });
  EXPECT_THROW(WriteFileAtomically(dir + "/keep.txt",
                                   [](std::ostream& o) {
                                     o << "partial";
                                     throw Error("writer failed");
                                   }),
               Error);
  EXPECT_EQ(ReadWholeFile(dir + "/keep.txt"), "old\n");
  EXPECT_EQ(Entries(dir).size(), 1u);
  EXPECT_THROW(WriteFileAtomically(dir + "/no/such/dir/f.txt", [](std::ostream& o) { o << "x"; }), Error);
  EXPECT_EQ(Entries(dir).size(), 1u);
}

TEST(WriteFileAtomically, KeepsTheModeOfTheFileItReplaces) {
  const std::string dir = sph::testing::MakeTempDir("atomic_mode");
  Put(dir + "/f.txt", "old\n");
  ASSERT_EQ(::chmod((dir + "/f.txt").c_str(), 0640), 0);
  WriteFileAtomically(dir + "/f.txt", [](std::ostream& o) { o << "new\n"; });
  struct stat st {};
  ASSERT_EQ(::stat((dir + "/f.txt").c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 07777, 0640u);
}

TEST(WriteFileAtomically, WritesLargeContentWhole) {
  const std::string dir = sph::testing::MakeTempDir("atomic_large");
  std::string expected;
  for (int i = 0; i < 200000; ++i) expected += std::to_string(i) + "\n";
  WriteFileAtomically(dir + "/big.txt", [&](std::ostream& o) { o << expected; });
  EXPECT_EQ(ReadWholeFile(dir + "/big.txt"), expected);
}

TEST(WriteFileAtomically, FollowsASymbolicLinkAndKeepsIt) {
  const std::string dir = sph::testing::MakeTempDir("atomic_link");
  Put(dir + "/real.txt", "old\n");
  ASSERT_EQ(::symlink("real.txt", (dir + "/link.txt").c_str()), 0);
  WriteFileAtomically(dir + "/link.txt", [](std::ostream& o) { o << "new\n"; });
  EXPECT_EQ(ReadWholeFile(dir + "/real.txt"), "new\n");
  EXPECT_EQ(NodeOf(dir + "/link.txt").type, static_cast<mode_t>(S_IFLNK));
  EXPECT_EQ(Entries(dir), (std::vector<std::string>{"link.txt", "real.txt"}));
}

TEST(WriteFileAtomically, RefusesADirectory) {
  const std::string dir = sph::testing::MakeTempDir("atomic_dir");
  ASSERT_EQ(::mkdir((dir + "/sub").c_str(), 0755), 0);
  EXPECT_THAT(ErrorOf([&] { WriteFileAtomically(dir + "/sub", [](std::ostream& o) { o << "x"; }); }),
              HasSubstr(dir + "/sub: is a directory"));
  EXPECT_EQ(Entries(dir), std::vector<std::string>{"sub"});
}

TEST(WriteFileAtomically, WritesIntoAFifoAndLeavesItAFifo) {
  const std::string dir = sph::testing::MakeTempDir("atomic_fifo");
  const std::string fifo = dir + "/pipe";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  std::string received;
  std::thread reader([&] { received = ReadWholeFile(fifo); });
  WriteFileAtomically(fifo, [](std::ostream& o) { o << "through the pipe\n"; });
  reader.join();
  EXPECT_EQ(received, "through the pipe\n");
  EXPECT_EQ(NodeOf(fifo).type, static_cast<mode_t>(S_IFIFO));
  EXPECT_EQ(Entries(dir), std::vector<std::string>{"pipe"});
}

TEST(WriteFileAtomically, CharacterDevicesAreWrittenNeverReplaced) {
  const std::string dir = sph::testing::MakeTempDir("atomic_chr");
  // The numbers of /dev/full (1, 7) and /dev/null (1, 3), as nodes of the test's own.
  if (!MakeNode(dir + "/full", S_IFCHR, 1, 7) || !MakeNode(dir + "/null", S_IFCHR, 1, 3)) {
    GTEST_SKIP() << "cannot make device nodes here (needs CAP_MKNOD): " << std::strerror(errno);
  }
  EXPECT_THAT(ErrorOf([&] { WriteFileAtomically(dir + "/full", [](std::ostream& o) { o << "report\n"; }); }),
              HasSubstr(dir + "/full: cannot write: No space left on device"));
  WriteFileAtomically(dir + "/null", [](std::ostream& o) { o << "discarded\n"; });
  EXPECT_EQ(NodeOf(dir + "/full").type, static_cast<mode_t>(S_IFCHR));
  EXPECT_EQ(NodeOf(dir + "/full").rdev, makedev(1, 7));
  EXPECT_EQ(NodeOf(dir + "/null").type, static_cast<mode_t>(S_IFCHR));
  EXPECT_EQ(NodeOf(dir + "/null").rdev, makedev(1, 3));
  EXPECT_EQ(Entries(dir), (std::vector<std::string>{"full", "null"}));
}

TEST(WriteFileAtomically, RefusesABlockDeviceWithoutOpeningIt) {
  const std::string dir = sph::testing::MakeTempDir("atomic_blk");
  // A node of the first loop device; refused before it would be opened.
  if (!MakeNode(dir + "/disk", S_IFBLK, 7, 0))
    GTEST_SKIP() << "cannot make device nodes here: " << std::strerror(errno);
  EXPECT_THAT(ErrorOf([&] { WriteFileAtomically(dir + "/disk", [](std::ostream& o) { o << "x"; }); }),
              HasSubstr(dir + "/disk: is a block device: refusing to write onto it"));
  EXPECT_EQ(NodeOf(dir + "/disk").type, static_cast<mode_t>(S_IFBLK));
  EXPECT_EQ(Entries(dir), std::vector<std::string>{"disk"});
}

TEST(OutputFiles, NothingChangesUntilEveryFileIsStaged) {
  const std::string dir = sph::testing::MakeTempDir("outputs_all");
  Put(dir + "/a.txt", "old a\n");
  {
    OutputFiles files;
    files.Stage(dir + "/a.txt", [](std::ostream& o) { o << "new a\n"; });
    files.Stage(dir + "/b.txt", [](std::ostream& o) { o << "new b\n"; });
    EXPECT_THROW(files.Stage(dir + "/no/such/c.txt", [](std::ostream& o) { o << "c"; }), Error);
    EXPECT_EQ(ReadWholeFile(dir + "/a.txt"), "old a\n");
  }  // not committed: the staged files go
  EXPECT_EQ(ReadWholeFile(dir + "/a.txt"), "old a\n");
  EXPECT_EQ(Entries(dir), std::vector<std::string>{"a.txt"});
}

TEST(OutputFiles, AFailedDirectWriteKeepsTheRegularFilesUntouched) {
  const std::string dir = sph::testing::MakeTempDir("outputs_direct");
  if (!MakeNode(dir + "/full", S_IFCHR, 1, 7))
    GTEST_SKIP() << "cannot make device nodes here: " << std::strerror(errno);
  Put(dir + "/a.txt", "old a\n");
  OutputFiles files;
  files.Stage(dir + "/a.txt", [](std::ostream& o) { o << "new a\n"; });
  files.Stage(dir + "/full", [](std::ostream& o) { o << "report\n"; });
  EXPECT_THROW(files.Commit(), Error);
  EXPECT_EQ(ReadWholeFile(dir + "/a.txt"), "old a\n");
}

TEST(OutputFiles, AFailedWriteToTheRunsStandardOutputKeepsTheFilesUntouched) {
  const std::string dir = sph::testing::MakeTempDir("outputs_stdout");
  Put(dir + "/a.txt", "old a\n");
  {
    std::ostream report(nullptr);  // every write fails, as on a full disk
    OutputFiles files(report);
    files.Stage(dir + "/a.txt", [](std::ostream& o) { o << "new a\n"; });
    report << "the run's report\n";
    EXPECT_THAT(ErrorOf([&] { files.Commit(); }), HasSubstr("cannot write to standard output"));
    EXPECT_EQ(ReadWholeFile(dir + "/a.txt"), "old a\n");
  }  // what was staged goes
  EXPECT_EQ(Entries(dir), std::vector<std::string>{"a.txt"});
}

TEST(OutputFiles, CommitPutsEveryFileInPlace) {
  const std::string dir = sph::testing::MakeTempDir("outputs_commit");
  OutputFiles files;
  files.Stage(dir + "/a.txt", [](std::ostream& o) { o << "a\n"; });
  const std::string produced = files.StageProduced(dir + "/image.png");
  EXPECT_EQ(produced.substr(0, dir.size() + 1), dir + "/");
  Put(produced, "PNG");
  files.Commit();
  EXPECT_EQ(ReadWholeFile(dir + "/a.txt"), "a\n");
  EXPECT_EQ(ReadWholeFile(dir + "/image.png"), "PNG");
  EXPECT_EQ(Entries(dir), (std::vector<std::string>{"a.txt", "image.png"}));
}

TEST(OutputFiles, ASignalDuringTheWriteLeavesNoTemporaryFile) {
  const std::string dir = sph::testing::MakeTempDir("outputs_signal");
  Put(dir + "/a.txt", "old\n");
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    RemoveTempFilesOnSignals();
    OutputFiles files;
    files.Stage(dir + "/a.txt", [](std::ostream& o) {
      o << "half";
      o.flush();
      std::raise(SIGTERM);
    });
    ::_exit(0);  // not reached
  }
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGTERM) << status;
  EXPECT_EQ(ReadWholeFile(dir + "/a.txt"), "old\n");
  EXPECT_EQ(Entries(dir), std::vector<std::string>{"a.txt"});
}

// A child process that would write a staged file later (a plotting program) is killed, with what
// it started, and waited for before the files are removed: nothing is written afterwards.
TEST(OutputFiles, ASignalEndsARegisteredChildBeforeItWritesAStagedFile) {
  const std::string dir = sph::testing::MakeTempDir("outputs_child");
  const pid_t program = ::fork();
  ASSERT_GE(program, 0);
  if (program == 0) {
    RemoveTempFilesOnSignals();
    OutputFiles files;
    const std::string image = files.StageProduced(dir + "/image.png");
    const pid_t child = ::fork();
    if (child == 0) {
      ::setpgid(0, 0);
      ::execl("/bin/sh", "sh", "-c", ("sleep 0.5; echo drawn > '" + image + "'").c_str(), nullptr);
      ::_exit(127);
    }
    ::setpgid(child, child);
    RegisterChildProcess(child);
    std::raise(SIGTERM);
    ::_exit(0);  // not reached
  }
  int status = 0;
  ASSERT_EQ(::waitpid(program, &status, 0), program);
  EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGTERM) << status;
  std::this_thread::sleep_for(std::chrono::seconds(1));  // a child left running would have written by now
  EXPECT_EQ(Entries(dir), std::vector<std::string>{});
}

TEST(RunPaths, RefusesAnOutputThatIsAnInput) {
  const std::string dir = sph::testing::MakeTempDir("paths_input");
  Put(dir + "/points.txt", "x");
  ASSERT_EQ(::symlink("points.txt", (dir + "/alias.txt").c_str()), 0);
  ASSERT_EQ(::link((dir + "/points.txt").c_str(), (dir + "/hard.txt").c_str()), 0);
  for (const std::string& spelling :
       {dir + "/points.txt", dir + "/./points.txt", dir + "/alias.txt", dir + "/hard.txt"}) {
    RunPaths paths;
    paths.Input("points", dir + "/points.txt");
    EXPECT_THAT(ErrorOf([&] { paths.Output("--output", spelling); }),
                HasSubstr("--output " + spelling + " is also the input points " + dir + "/points.txt"))
        << spelling;
  }
}

TEST(RunPaths, RefusesTwoOutputsOnOneFileEvenBeforeItExists) {
  const std::string dir = sph::testing::MakeTempDir("paths_outputs");
  ASSERT_EQ(::mkdir((dir + "/sub").c_str(), 0755), 0);
  RunPaths paths;
  paths.Output("--json", dir + "/c.json");
  EXPECT_THAT(ErrorOf([&] { paths.Output("--output", dir + "/sub/../c.json"); }),
              HasSubstr("--json " + dir + "/c.json and --output " + dir + "/sub/../c.json are the same file"));
  paths.Output("--csv", dir + "/d.csv");  // another name is fine
  RunPaths std_twice;
  std_twice.Output("--json", "-");
  EXPECT_THAT(ErrorOf([&] { std_twice.Output("--output", "-"); }),
              HasSubstr("--json and --output both write to standard output: give one of them a file"));
}

TEST(RunPaths, StandardOutputRedirectedToAnOutputIsTheSameFile) {
  const std::string dir = sph::testing::MakeTempDir("paths_stdout");
  Put(dir + "/t.json", "");
  std::fflush(stdout);
  const int saved = ::dup(STDOUT_FILENO);
  const int fd = ::open((dir + "/t.json").c_str(), O_WRONLY);
  ASSERT_GE(fd, 0);
  ::dup2(fd, STDOUT_FILENO);
  RunPaths paths;
  paths.Output("--output", "-");
  const std::string message = ErrorOf([&] { paths.Output("--truth", dir + "/t.json"); });
  ::dup2(saved, STDOUT_FILENO);
  ::close(saved);
  ::close(fd);
  EXPECT_THAT(message, HasSubstr("--output - (standard output) and --truth " + dir + "/t.json are the same file"));
}

TEST(SameFile, OneFileByAnyNameAndNoOther) {
  const std::string dir = sph::testing::MakeTempDir("same_file");
  Put(dir + "/a.txt", "a\n");
  Put(dir + "/copy.txt", "a\n");
  ASSERT_EQ(::symlink("a.txt", (dir + "/link.txt").c_str()), 0);
  EXPECT_TRUE(SameFile(dir + "/a.txt", dir + "/link.txt"));
  EXPECT_TRUE(SameFile(dir + "/new.txt", dir + "/./new.txt"));
  EXPECT_FALSE(SameFile(dir + "/a.txt", dir + "/copy.txt"));
  EXPECT_FALSE(SameFile(dir + "/a.txt", dir + "/new.txt"));
}

TEST(RunPaths, CharacterDevicesMayTakeSeveralOutputs) {
  RunPaths paths;
  EXPECT_NO_THROW(paths.Input("points", "/dev/null").Output("--json", "/dev/null").Output("--output", "/dev/null"));
}

TEST(WriteFileAtomically, RefusesToReplaceAFileThatMayNotBeWritten) {
  const std::string dir = sph::testing::MakeTempDir("atomic_read_only");
  Put(dir + "/r.html", "old\n");
  ASSERT_EQ(::chmod((dir + "/r.html").c_str(), 0444), 0);
  ASSERT_EQ(::symlink("r.html", (dir + "/link.html").c_str()), 0);
  for (const std::string name : {"r.html", "link.html"}) {
    // As root too: a file nobody may write is not replaced (cp refuses it for every other user).
    EXPECT_THAT(ErrorOf([&] { WriteFileAtomically(dir + "/" + name, [](std::ostream& o) { o << "new\n"; }); }),
                HasSubstr(dir + "/" + name + ": cannot write: ")) << name;
    EXPECT_THAT(ErrorOf([&] { OutputFiles().StageProduced(dir + "/" + name); }),
                HasSubstr("(mode 0444): refusing to replace a file that may not be written")) << name;
  }
  EXPECT_EQ(ReadWholeFile(dir + "/r.html"), "old\n");
  EXPECT_EQ(Entries(dir), (std::vector<std::string>{"link.html", "r.html"}));
  ASSERT_EQ(::chmod((dir + "/r.html").c_str(), 0644), 0);  // writable again: replaced
  WriteFileAtomically(dir + "/r.html", [](std::ostream& o) { o << "new\n"; });
  EXPECT_EQ(ReadWholeFile(dir + "/r.html"), "new\n");
}

TEST(RunPaths, RefusesAnOutputThatMayNotBeWrittenBeforeAnythingIsComputed) {
  const std::string dir = sph::testing::MakeTempDir("paths_read_only");
  Put(dir + "/c.json", "{}\n");
  ASSERT_EQ(::chmod((dir + "/c.json").c_str(), 0444), 0);
  RunPaths paths;
  EXPECT_THAT(ErrorOf([&] { paths.Output("--output", dir + "/c.json"); }),
              HasSubstr("--output " + dir + "/c.json: cannot write: "));
  EXPECT_NO_THROW(RunPaths().Output("--output", dir + "/new.json").Output("--json", "/dev/null"));
}

// What a program writes to std::cout through its StandardOutput, captured from file descriptor 1.
std::string ThroughStandardOutput(const std::string& dir, const std::function<void()>& write) {
  std::cout.flush();
  const int saved = ::dup(STDOUT_FILENO);
  const int file = ::open((dir + "/stdout").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  ::dup2(file, STDOUT_FILENO);
  ::close(file);
  {
    const StandardOutput standard_output;
    write();
    FlushStandardOutput();
  }
  ::dup2(saved, STDOUT_FILENO);
  ::close(saved);
  return ReadWholeFile(dir + "/stdout");
}

TEST(StandardOutput, WritesWhatATerminalWouldActOnAsText) {
  const std::string dir = sph::testing::MakeTempDir("stdout_escape");
  // A title sequence, a screen clear, a carriage return, DEL, a C1 control (CSI, U+009B) and a byte that
  // is no UTF-8; tabs, line feeds and UTF-8 text as they are.
  EXPECT_EQ(ThroughStandardOutput(dir,
                                  [] {
                                    std::cout << "operator: \x1b]0;pwned\x07\x1b[2J\r\x7F\xC2\x9B caf\xE9\tcaf\xC3\xA9 "
                                                 "\xE2\x82\xAC\n";
                                  }),
            "operator: \\u001b]0;pwned\\u0007\\u001b[2J\\u000d\\u007f\\u009b caf\\xE9\tcaf\xC3\xA9 \xE2\x82\xAC\n");
  // A character split between two writes, and one split by the buffer's end (its first byte the
  // 65536th of the output), pass whole.
  std::string long_text(65529, 'x');
  long_text += "\xC3\xA9\n";
  EXPECT_EQ(ThroughStandardOutput(dir,
                                  [&] {
                                    std::cout << "caf\xC3";
                                    std::cout << "\xA9\n" << long_text;
                                  }),
            "caf\xC3\xA9\n" + long_text);
  // JSON with a DEL in a string stays JSON with the same string.
  EXPECT_EQ(ThroughStandardOutput(dir, [] { std::cout << "{\"a\": \"x\x7Fy\"}\n"; }), "{\"a\": \"x\\u007fy\"}\n");
}

}  // namespace
}  // namespace sph
