#include "sph/io/points_writer.hpp"

#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <fstream>
#include <cstdlib>
#include <limits>
#include <map>
#include <sstream>
#include <tuple>

#include <gtest/gtest.h>

#include "sph/core/error.hpp"
#include "test_util.hpp"

namespace sph {
namespace {

PointsHeader Header() {
  PointsHeader h;
  h.sphere_radius_mm = 20.0;
  h.probe_offset_mm = 25.0;
  h.metadata = {{"generator", "test"}};
  return h;
}

PointsWriterOptions WithSetup() {
  PointsWriterOptions o;
  o.has_setup = true;
  o.fsync_interval_s = 0.0;
  return o;
}

TEST(PointsWriter, WritesWhatReadPointsFileReads) {
  const std::string path = sph::testing::MakeTempDir("pw_basic") + "/p.txt";
  {
    PointsWriter w(path, Header(), WithSetup());
    EXPECT_FALSE(w.resumed());
    w.Write({1.25, 7.5, 5.0912345678, 1700000000.123456, 2});
    w.WriteComment("incomplete: 3 cycles");  // would be a header key before the first sample
    w.Write({15.0, 7.5, 5.1, 1700000000.2, 2});
    w.Close();
  }
  const PointsData d = ReadPointsFile(path);
  ASSERT_EQ(d.samples.size(), 2U);
  EXPECT_DOUBLE_EQ(d.samples[0].theta_deg, 1.25);
  EXPECT_DOUBLE_EQ(d.samples[0].r_mm, 5.0912345678);
  EXPECT_NEAR(d.samples[0].t_s, 1700000000.123456, 1e-6);
  EXPECT_EQ(d.samples[1].setup, 2);
  EXPECT_EQ(d.header.sphere_radius_mm, std::optional<double>(20.0));
  EXPECT_EQ(d.header.probe_offset_mm, std::optional<double>(25.0));
  EXPECT_TRUE(d.has_time && d.has_setup);
  EXPECT_NE(sph::testing::ReadWholeFile(path).find("# note incomplete: 3 cycles\n"), std::string::npos);
}

TEST(PointsWriter, FormatsRowsOfTheLargestFiniteValuesWhole) {
  // Values at the reader's bounds come back exactly.
  const Sample s{-kMaxAngleDeg, kMaxAngleDeg, -kMaxReadingMm, -kMaxTimeS, std::numeric_limits<int>::min()};
  const std::string row = PointsWriter::FormatRow(s, true, true);
  ASSERT_FALSE(row.empty());
  EXPECT_EQ(row.back(), '\n');
  EXPECT_EQ(row.find('\n'), row.size() - 1);
  std::istringstream in("# columns: theta_deg phi_deg r_mm t_s setup\n" + row);
  const PointsData d = ParsePoints(in, "row");
  ASSERT_EQ(d.samples.size(), 1U);
  EXPECT_EQ(d.samples[0].theta_deg, -kMaxAngleDeg);
  EXPECT_EQ(d.samples[0].phi_deg, kMaxAngleDeg);
  EXPECT_EQ(d.samples[0].r_mm, -kMaxReadingMm);
  EXPECT_EQ(d.samples[0].t_s, -kMaxTimeS);
  EXPECT_EQ(d.samples[0].setup, std::numeric_limits<int>::min());

  // The largest finite double is written whole (no inf, no rounding); the reader refuses it.
  constexpr double kMax = std::numeric_limits<double>::max();
  std::istringstream big(PointsWriter::FormatRow({-kMax, kMax, -kMax, 0.0, 0}, false, false));
  std::string theta, phi, r;
  big >> theta >> phi >> r;
  EXPECT_EQ(std::strtod(theta.c_str(), nullptr), -kMax);
  EXPECT_EQ(std::strtod(phi.c_str(), nullptr), kMax);
  EXPECT_EQ(std::strtod(r.c_str(), nullptr), -kMax);
}

TEST(PointsWriter, CommentsBeforeTheFirstSampleNeverBecomeHeaderFields) {
  const std::string path = sph::testing::MakeTempDir("pw_comment") + "/p.txt";
  {
    PointsWriter w(path, Header(), WithSetup());
    w.WriteComment("resumed: twice");
    w.WriteComment("resumed: twice");
    w.WriteComment("sph-points 2");
    w.Write({1.0, 2.0, 3.0, 4.0, 0});
  }
  EXPECT_EQ(ReadPointsFile(path).samples.size(), 1U);
}

TEST(PointsWriter, ARestartAppendsAndNeverRewrites) {
  const std::string path = sph::testing::MakeTempDir("pw_restart") + "/p.txt";
  {
    PointsWriter w(path, Header(), WithSetup());
    w.Write({1.0, 2.0, 3.0, 4.0, 0});
  }
  const std::string first = sph::testing::ReadWholeFile(path);
  {
    PointsWriter w(path, Header(), WithSetup());
    EXPECT_TRUE(w.resumed());
    w.Write({5.0, 6.0, 7.0, 8.0, 0});
  }
  const std::string both = sph::testing::ReadWholeFile(path);
  EXPECT_EQ(both.rfind(first, 0), 0U) << "the first run's bytes must be unchanged";
  EXPECT_EQ(ReadPointsFile(path).samples.size(), 2U);
}

TEST(PointsWriter, RefusesToContinueAFileOfAnotherShape) {
  const std::string path = sph::testing::MakeTempDir("pw_shape") + "/p.txt";
  { PointsWriter w(path, Header(), WithSetup()); }
  PointsWriterOptions no_setup;
  EXPECT_THROW(PointsWriter(path, Header(), no_setup), Error);
  PointsHeader other = Header();
  other.sphere_radius_mm = 12.7;
  try {
    PointsWriter w(path, other, WithSetup());
    FAIL() << "no throw";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), path + ": has sphere_radius_mm 20 but this run writes 12.7: use another file");
  }
}

TEST(PointsWriter, WritesTheMountRotationsAndContinuesOnlyAFileOfTheSame) {
  const std::string path = sph::testing::MakeTempDir("pw_mount") + "/p.txt";
  PointsHeader h = Header();
  h.mount_rotations = {{1, MountRotation::Known(Eigen::Vector3d(0, 0, 90))}, {2, MountRotation::Unknown()}};
  {
    PointsWriter w(path, h, WithSetup());
    w.Write({1.0, 2.0, 3.0, 4.0, 1});
    w.Write({1.0, 2.0, 3.0, 5.0, 2});
  }
  EXPECT_EQ(ReadPointsFile(path).header.mount_rotations, h.mount_rotations);
  { PointsWriter again(path, h, WithSetup()); }  // the same rotations: continued
  PointsHeader turned = h;
  turned.mount_rotations[1] = MountRotation::Known(Eigen::Vector3d(0, 0, 45));
  try {
    PointsWriter w(path, turned, WithSetup());
    FAIL() << "no throw";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()),
              path + ": has mount_rotation_deg@1 0 0 90 but this run writes 0 0 45: use another file");
  }
  PointsHeader known = h;
  known.mount_rotations[2] = MountRotation::Known(Eigen::Vector3d(1, 0, 0));
  EXPECT_THROW(PointsWriter(path, known, WithSetup()), Error);
}

// A run that measures another sphere writes its radius for its setup: in the header of a new file,
// before the setup's first row when it continues one; a file that gives that setup another radius
// is refused.
TEST(PointsWriter, WritesTheRadiusOfAnotherSphereAndContinuesOnlyAFileOfTheSame) {
  const std::string path = sph::testing::MakeTempDir("pw_radius") + "/p.txt";
  PointsHeader first = Header();
  first.sphere_radii_mm = {{1, 10.0}};
  {
    PointsWriter w(path, first, WithSetup());
    w.Write({1.0, 2.0, 3.0, 4.0, 1});
  }
  PointsHeader second = Header();
  second.sphere_radii_mm = {{2, 12.5}};
  {
    PointsWriter w(path, second, WithSetup());
    w.Write({1.0, 2.0, 3.0, 5.0, 2});
  }
  const PointsData d = ReadPointsFile(path);
  EXPECT_EQ(d.header.sphere_radii_mm, (std::map<int, double>{{1, 10.0}, {2, 12.5}}));
  { PointsWriter again(path, first, WithSetup()); }  // the same radius: continued
  PointsHeader other = Header();
  other.sphere_radii_mm = {{2, 12.0}};
  try {
    PointsWriter w(path, other, WithSetup());
    FAIL() << "no throw";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), path + ": has sphere_radius_mm@2 12.5 but this run writes 12: use another file");
  }
}

// A setup's fields apply to all of its rows: a run that continues a file may not give a setup
// that has rows an orientation or a sphere they were not recorded with.
TEST(PointsWriter, RefusesToRelabelTheRowsOfASetup) {
  const std::string path = sph::testing::MakeTempDir("pw_relabel") + "/p.txt";
  {
    PointsWriter w(path, Header(), WithSetup());  // setup 0 in the reference orientation, of the reference sphere
    w.Write({1.0, 2.0, 3.0, 4.0, 0});
    w.Write({1.0, 2.0, 3.0, 5.0, 0});
  }
  const std::string before = sph::testing::ReadWholeFile(path);
  PointsHeader turned = Header();
  turned.mount_rotations = {{0, MountRotation::Known(Eigen::Vector3d(0, 90, 0))}};
  const std::string rotation_refused =
      path +
      ": setup 0 has rows (the first at line 6) in the reference orientation (no mount_rotation_deg@0 before them): "
      "this run's mount_rotation_deg@0 0 90 0 would apply to them too: give this placement a setup of its own";
  try {
    PointsWriter::CheckContinuable(path, turned, WithSetup());
    FAIL() << "no throw";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), rotation_refused);
  }
  try {
    PointsWriter w(path, turned, WithSetup());
    FAIL() << "no throw";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), rotation_refused);
  }
  PointsHeader other = Header();
  other.sphere_radii_mm = {{0, 10.0}};
  try {
    PointsWriter w(path, other, WithSetup());
    FAIL() << "no throw";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()),
              path +
                  ": setup 0 has rows (the first at line 6) of the reference sphere (no sphere_radius_mm@0 before "
                  "them): this run's sphere_radius_mm@0 10 would apply to them too: give this placement a setup "
                  "of its own");
  }
  EXPECT_EQ(sph::testing::ReadWholeFile(path), before);
  // The reference orientation, however written, is what the rows have: continued, no field written.
  PointsHeader reference = Header();
  reference.mount_rotations = {{0, MountRotation::Known(Eigen::Vector3d(0, 0, 360))}};
  {
    PointsWriter w(path, reference, WithSetup());
    w.Write({1.0, 2.0, 3.0, 6.0, 0});
  }
  // A new setup gets its fields before its first row.
  turned.mount_rotations = {{1, MountRotation::Known(Eigen::Vector3d(0, 90, 0))}};
  turned.sphere_radii_mm = {{1, 10.0}};
  {
    PointsWriter w(path, turned, WithSetup());
    w.Write({1.0, 2.0, 3.0, 7.0, 1});
  }
  const PointsData d = ReadPointsFile(path);
  EXPECT_EQ(d.samples.size(), 4u);
  EXPECT_EQ(d.header.mount_rotations, turned.mount_rotations);
  EXPECT_EQ(d.header.sphere_radii_mm, turned.sphere_radii_mm);
}

// "0 -270 0" is the file's "0 90 0": one orientation.
TEST(PointsWriter, ComparesMountRotationsAsRotations) {
  const std::string path = sph::testing::MakeTempDir("pw_same") + "/p.txt";
  PointsHeader h = Header();
  h.mount_rotations = {{1, MountRotation::Known(Eigen::Vector3d(0, 90, 0))}};
  {
    PointsWriter w(path, h, WithSetup());
    w.Write({1.0, 2.0, 3.0, 4.0, 1});
  }
  PointsHeader same = Header();
  same.mount_rotations = {{1, MountRotation::Known(Eigen::Vector3d(0, -270, 0))}};
  PointsWriter::CheckContinuable(path, same, WithSetup());
  {
    PointsWriter w(path, same, WithSetup());
    w.Write({1.0, 2.0, 3.0, 5.0, 1});
  }
  const PointsData d = ReadPointsFile(path);
  EXPECT_EQ(d.samples.size(), 2u);
  EXPECT_EQ(d.header.mount_rotations, h.mount_rotations);  // the file's field, written once
  PointsHeader other = Header();
  other.mount_rotations = {{1, MountRotation::Known(Eigen::Vector3d(0, 90.001, 0))}};
  EXPECT_THROW(PointsWriter::CheckContinuable(path, other, WithSetup()), Error);
}

TEST(PointsWriter, AnIncompleteLastLineIsCutOff) {
  const std::string path = sph::testing::MakeTempDir("pw_tail") + "/p.txt";
  {
    PointsWriter w(path, Header(), WithSetup());
    w.Write({1.0, 2.0, 3.0, 4.0, 0});
  }
  { std::ofstream(path, std::ios::app) << "5.0 6.0 7."; }  // a machine crash mid-record
  {
    PointsWriter w(path, Header(), WithSetup());
    EXPECT_EQ(w.truncated_bytes(), 10U);
    w.Write({5.0, 6.0, 7.0, 8.0, 0});
  }
  const PointsData d = ReadPointsFile(path);
  ASSERT_EQ(d.samples.size(), 2U);
  EXPECT_DOUBLE_EQ(d.samples[1].r_mm, 7.0);
}

TEST(PointsWriter, RefusesAFileThatIsNoPointsFileBeforeOpeningIt) {
  const std::string dir = sph::testing::MakeTempDir("pw_notes");
  const std::string notes = dir + "/notes.txt", other = dir + "/other.txt";
  const std::string text = "my notes\nthe last line has no newline";
  { std::ofstream(notes, std::ios::binary) << text; }
  // A points file of other columns, its last row cut short: refused, and not cut either.
  const std::string points = "# sph-points 1\n# columns: theta_deg phi_deg r_mm\n0 7.5 4.9\n0 22.5 4.";
  { std::ofstream(other, std::ios::binary) << points; }
  for (const auto& [path, content, message] :
       {std::tuple{notes, text,
                   notes + ": is not a points file (its first line is not '# sph-points 1'): refusing "
                           "to append to it; use another file"},
        std::tuple{other, points,
                   other + ": has columns 'theta_deg phi_deg r_mm' but this run writes 'theta_deg "
                           "phi_deg r_mm t_s setup': use another file"}}) {
    try {
      PointsWriter::CheckContinuable(path, Header(), WithSetup());
      FAIL() << "no throw";
    } catch (const Error& e) {
      EXPECT_EQ(std::string(e.what()), message);
    }
    EXPECT_THROW(PointsWriter(path, Header(), WithSetup()), Error);
    EXPECT_EQ(sph::testing::ReadWholeFile(path), content) << "the file must be as it was";
  }
}

TEST(PointsWriter, AHeaderCutShortByACrashIsWrittenAgain) {
  const std::string path = sph::testing::MakeTempDir("pw_cut_header") + "/p.txt";
  { std::ofstream(path, std::ios::binary) << "# sph-po"; }
  {
    PointsWriter w(path, Header(), WithSetup());
    EXPECT_FALSE(w.resumed());
    EXPECT_EQ(w.truncated_bytes(), 8U);
    w.Write({1.0, 2.0, 3.0, 4.0, 0});
  }
  EXPECT_EQ(ReadPointsFile(path).samples.size(), 1U);
}

TEST(PointsWriter, RefusesADirectoryAndAMissingFolderWithoutMakingAFile) {
  const std::string dir = sph::testing::MakeTempDir("pw_kinds");
  for (const std::string& path : {dir, dir + "/no/p.txt"}) {
    EXPECT_THROW(PointsWriter::CheckContinuable(path, Header(), WithSetup()), Error) << path;
    EXPECT_THROW(PointsWriter(path, Header(), WithSetup()), Error) << path;
  }
  EXPECT_NE(::access((dir + "/no").c_str(), F_OK), 0);
}

TEST(PointsWriter, FullDiskLeavesNoPartialRecord) {
  // RLIMIT_FSIZE makes write() stop at a size, like a full disk; in a child, so the test runner's
  // own files are not limited.
  const std::string path = sph::testing::MakeTempDir("pw_full") + "/p.txt";
  std::size_t header_size = 0;
  {
    PointsWriter w(path, Header(), WithSetup());
    w.Write({1.0, 2.0, 3.0, 4.0, 0});
    header_size = sph::testing::ReadWholeFile(path).size();
  }
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    std::signal(SIGXFSZ, SIG_IGN);
    rlimit lim{static_cast<rlim_t>(header_size + 20), static_cast<rlim_t>(header_size + 20)};
    setrlimit(RLIMIT_FSIZE, &lim);
    PointsWriter w(path, Header(), WithSetup());
    try {
      w.Write({5.0, 6.0, 7.0, 8.0, 0});  // 52 bytes: only 20 fit
    } catch (const Error& e) {
      const std::string what = e.what();
      _exit(what.find("cannot write: File too large") != std::string::npos ? 42 : 1);
    }
    _exit(2);
  }
  int status = 0;
  waitpid(pid, &status, 0);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 42) << "the write must fail with a clear error";
  EXPECT_EQ(sph::testing::ReadWholeFile(path).size(), header_size) << "the partial record must be cut off";
  EXPECT_EQ(ReadPointsFile(path).samples.size(), 1U);
}

TEST(PointsWriter, DevFullGivesAClearError) {
  PointsWriterOptions o;
  try {
    PointsWriter w("/dev/full", Header(), o);
    FAIL() << "no throw";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("/dev/full: cannot write: No space left on device"), std::string::npos)
        << e.what();
  }
}

TEST(AppendFile, SyncsAtTheInterval) {
  const std::string path = sph::testing::MakeTempDir("af_sync") + "/a.txt";
  AppendFile every(path, 0.0);
  every.Append("a\n");
  every.Append("b\n");
  EXPECT_EQ(every.syncs(), 2U);
  AppendFile later(path + "2", 3600.0);
  later.Append("a\n");
  later.SyncIfDue();
  EXPECT_EQ(later.syncs(), 0U);
  later.Close();
  EXPECT_EQ(later.syncs(), 0U);  // Close syncs without counting through Sync()
  EXPECT_EQ(sph::testing::ReadWholeFile(path + "2"), "a\n");
}

}  // namespace
}  // namespace sph
