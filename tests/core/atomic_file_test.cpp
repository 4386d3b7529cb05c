#include "sph/core/atomic_file.hpp"

#include <dirent.h>

#include <fstream>
#include <sstream>

#include <gtest/gtest.h>

#include "sph/core/error.hpp"
#include "test_util.hpp"

namespace sph {
namespace {

int CountEntries(const std::string& dir) {
  int n = 0;
  if (DIR* d = opendir(dir.c_str())) {
    while (dirent* e = readdir(d)) {
      if (std::string(e->d_name) != "." && std::string(e->d_name) != "..") ++n;
    }
    closedir(d);
  }
  return n;
}

TEST(WriteFileAtomically, WritesAndReplaces) {
  const std::string dir = sph::testing::MakeTempDir("atomic");
  WriteFileAtomically(dir + "/f.txt", [](std::ostream& o) { o << "one\n"; });
  WriteFileAtomically(dir + "/f.txt", [](std::ostream& o) { o << "two\n"; });
  EXPECT_EQ(sph::testing::ReadWholeFile(dir + "/f.txt"), "two\n");
  EXPECT_EQ(CountEntries(dir), 1);
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
  EXPECT_EQ(sph::testing::ReadWholeFile(dir + "/keep.txt"), "old\n");
  EXPECT_EQ(CountEntries(dir), 1);
  EXPECT_THROW(WriteFileAtomically(dir + "/no/such/dir/f.txt", [](std::ostream& o) { o << "x"; }), Error);
  EXPECT_EQ(CountEntries(dir), 1);
}

}  // namespace
}  // namespace sph
