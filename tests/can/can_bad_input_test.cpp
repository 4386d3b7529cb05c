// The bad-input matrix of sph_acquired and sph_cansim: each case runs the real program in a
// folder of its own and checks the exit code, the message (naming the option, or the file and
// line), and that the folder is byte for byte as before (device nodes still device nodes),
// apart from the outputs a successful case makes. Then sph_cansim under SIGINT and SIGTERM.
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "program_run.hpp"
#include "test_util.hpp"

namespace sph::testing {
namespace {

// A small run of the simulator: 2 stops of 1 s, SYNC every 10 ms.
const std::vector<std::string> kSmall = {"--theta-steps", "2", "--phi-steps", "1", "--sync-period-ms", "10"};

// A text that is no points file and no candump log, without a final newline: a refusal must
// leave it byte for byte as it was.
constexpr const char* kNotes = "my notes\nthe last line has no newline";

class CanMatrix : public ::testing::TestWithParam<MatrixCase> {
 protected:
  // What every case finds in its folder: a simulator log (sim.log), the points file the daemon
  // made of it (P.txt), a config file (a.conf), an angle pattern (a.txt), notes (notes.txt), a
  // folder (sub), and device nodes of its own: a full device (full), a null device (null) and a
  // block device (disk), never those of /dev.
  static void SetUpTestSuite() {
    base_ = MakeTempDir("can_matrix_base");
    std::vector<std::string> sim = {SPH_CANSIM, "-o", "sim.log"};
    sim.insert(sim.end(), kSmall.begin(), kSmall.end());
    ProgramResult r = RunProgram(sim, base_);
    ASSERT_EQ(r.code, 0) << r.err;
    r = RunProgram({SPH_ACQUIRED, "--replay", "sim.log", "--sync-period-ms", "10", "-o", "P.txt", "--sphere-radius-mm",
                    "20", "--log-level", "error"},
                   base_);
    ASSERT_EQ(r.code, 0) << r.err;
    std::ofstream(base_ + "/a.conf") << "# a configuration\nmode = \"points\"\nsync-period-ms = 10\n";
    std::ofstream(base_ + "/a.txt") << "0 45\n90 45\n";
    std::ofstream(base_ + "/notes.txt") << kNotes;
    nodes_ = MakeDeviceNodes(base_);
  }

  std::string Folder(const MatrixCase& c) {
    const std::string dir = MakeTempDir("can_matrix_" + c.name);
    for (const char* f : {"sim.log", "P.txt", "a.conf", "a.txt", "notes.txt"}) {
      std::ofstream(dir + "/" + f, std::ios::binary) << ReadWholeFile(base_ + "/" + f);
    }
    ::mkdir((dir + "/sub").c_str(), 0755);
    if (nodes_) MakeDeviceNodes(dir);
    for (const auto& [name, text] : c.files) std::ofstream(dir + "/" + name, std::ios::binary) << text;
    return dir;
  }

  void Check(const char* program) {
    const MatrixCase& c = GetParam();
    if (UsesDeviceNodes(c) && !nodes_) GTEST_SKIP() << "device nodes cannot be made here (needs CAP_MKNOD)";
    RunMatrixCase(program, c, Folder(c));
  }

  static inline std::string base_;
  static inline bool nodes_ = false;
};

std::vector<std::string> With(std::vector<std::string> args, const std::vector<std::string>& more) {
  args.insert(args.end(), more.begin(), more.end());
  return args;
}

// ---- sph_acquired ---------------------------------------------------------------------------------

class AcquiredMatrix : public CanMatrix {};
TEST_P(AcquiredMatrix, Case) { Check(SPH_ACQUIRED); }

std::vector<MatrixCase> AcquiredCases() {
  const std::string e = "sph_acquired: error: ";
  const std::vector<std::string> replay = {"--replay", "sim.log", "--sync-period-ms", "10", "--log-level", "error"};
  const auto r = [&](const std::vector<std::string>& more) { return With(replay, more); };
  return {
      // outputs that are inputs or each other
      {"output_is_the_replay", r({"-o", "sim.log"}), 2,
       e + "--output sim.log is also the input --replay sim.log: an output never replaces an input"},
      {"can_log_is_the_replay", r({"-o", "x.txt", "--can-log", "sim.log"}), 2,
       e + "--can-log sim.log is also the input --replay sim.log: an output never replaces an input"},
      {"can_log_is_the_replay_by_another_name", r({"-o", "x.txt", "--can-log", "./sub/../sim.log"}), 2,
       e + "--can-log ./sub/../sim.log is also the input --replay sim.log"},
      {"output_and_can_log_one_file", r({"-o", "x.txt", "--can-log", "x.txt"}), 2,
       e + "--output x.txt and --can-log x.txt are the same file: give each output a file of its own"},
      {"output_is_the_config", r({"--config", "a.conf", "-o", "a.conf"}), 2,
       e + "--output a.conf is also the input --config a.conf"},
      // existing files that are not this run's to continue: refused untouched
      {"output_is_not_a_points_file", r({"-o", "notes.txt"}), 3,
       e + "notes.txt: is not a points file (its first line is not '# sph-points 1'): refusing to append to it"},
      {"can_log_is_not_a_candump_log", r({"-o", "x.txt", "--can-log", "notes.txt"}), 3,
       e + "notes.txt: is not a candump log (line 1: expected '(seconds.microseconds)' at the start)"},
      {"output_has_other_columns",
       r({"-o", "x.txt"}),
       3,
       e + "x.txt: has columns 'theta_deg phi_deg r_mm' but this run writes 'theta_deg phi_deg r_mm t_s setup'",
       {{"x.txt", "# sph-points 1\n# columns: theta_deg phi_deg r_mm\n0 7.5 4.9\n0 22.5 4.9"}}},
      {"output_has_another_radius", r({"-o", "P.txt", "--sphere-radius-mm", "21"}), 3,
       e + "P.txt: has sphere_radius_mm 20 but this run writes 21: use another file"},
      {"output_continued", r({"-o", "P.txt", "--sphere-radius-mm", "20"}), 0, "", {}, {"P.txt"}},
      // a setup's rows keep the orientation and sphere they were recorded with (P.txt: setup 0 from line 8)
      {"rotation_for_a_setup_with_rows",
       r({"-o", "P.txt", "--sphere-radius-mm", "20", "--mount-rotation-deg", "0,90,0"}), 3,
       e + "P.txt: setup 0 has rows (the first at line 8) in the reference orientation (no mount_rotation_deg@0 before "
           "them): this run's mount_rotation_deg@0 0 90 0 would apply to them too: give this placement a setup of its "
           "own"},
      {"other_sphere_for_a_setup_with_rows", r({"-o", "P.txt", "--other-sphere-radius-mm", "10"}), 3,
       e + "P.txt: setup 0 has rows (the first at line 8) of the reference sphere (no sphere_radius_mm@0 before "
           "them): this run's sphere_radius_mm@0 10 would apply to them too"},
      {"rotation_for_a_new_setup",
       r({"-o", "P.txt", "--setup", "1", "--mount-rotation-deg", "0,90,0"}),
       0,
       "",
       {},
       {"P.txt"}},
      {"reference_orientation_for_a_setup_with_rows",
       r({"-o", "P.txt", "--mount-rotation-deg", "0,0,360"}),
       0,
       "",
       {},
       {"P.txt"}},
      {"same_orientation_written_otherwise",
       r({"-o", "x.txt", "--setup", "1", "--mount-rotation-deg", "0,-270,0"}),
       0,
       "",
       {{"x.txt",
         "# sph-points 1\n# mount_rotation_deg@1: 0 90 0\n# columns: theta_deg phi_deg r_mm t_s setup\n"
         "0.0000000000 90.0000000000 2.9399890000 1699999999.000000 1\n"}},
       {"x.txt"}},
      {"another_orientation_of_a_setup",
       r({"-o", "x.txt", "--setup", "1", "--mount-rotation-deg", "0,-90,0"}),
       3,
       e + "x.txt: has mount_rotation_deg@1 0 90 0 but this run writes 0 -90 0: use another file",
       {{"x.txt",
         "# sph-points 1\n# mount_rotation_deg@1: 0 90 0\n# columns: theta_deg phi_deg r_mm t_s setup\n"
         "0.0000000000 90.0000000000 2.9399890000 1699999999.000000 1\n"}}},
      // outputs that are no regular files
      {"output_onto_block_device", r({"-o", "disk"}), 3, e + "disk: is a block device: refusing to write onto it"},
      {"output_onto_full_device", r({"-o", "full"}), 3, e + "full: cannot write: No space left on device"},
      {"output_onto_null_device", r({"-o", "null", "--can-log", "null"}), 0, ""},
      {"output_onto_directory", r({"-o", "sub"}), 3, e + "sub: cannot open for appending: Is a directory"},
      {"output_into_missing_folder", r({"-o", "no/x.txt"}), 3,
       e + "no/x.txt: cannot open for appending: No such file or directory"},
      {"can_log_onto_block_device", r({"-o", "x.txt", "--can-log", "disk"}), 3,
       e + "disk: is a block device: refusing to write onto it"},
      {"outputs_written", r({"-o", "x.txt", "--can-log", "f.log"}), 0, "", {}, {"x.txt", "f.log"}},
      // the interface
      {"live_start_fails_and_makes_no_file",
       {"-i", "nosuchcan0", "-o", "live.txt", "--can-log", "live.log"},
       4,
       e + "nosuchcan0"},
      {"iface_with_a_space",
       {"-i", "can 0", "-o", "x.txt"},
       2,
       "--iface: an interface name has no space, '/' or ':' and is not '.' or '..', got 'can 0'"},
      {"iface_too_long",
       {"-i", "can0123456789abc", "-o", "x.txt"},
       2,
       "--iface: an interface name has 1 to 15 characters, got 16"},
      {"iface_with_a_slash", {"-i", "../can0", "-o", "x.txt"}, 2, "--iface: an interface name has no space, '/'"},
      {"iface_and_replay", r({"-i", "can0", "-o", "x.txt"}), 2, "--iface excludes --replay"},
      // the replay log
      {"replay_missing",
       {"--replay", "nope.log", "-o", "x.txt"},
       2,
       e + "nope.log: cannot open for reading: No such file or directory"},
      {"replay_time_goes_back",
       {"--replay", "x.log", "-o", "x.txt"},
       2,
       e + "x.log:3: the time 1700000000.500000 s is before the 1700000001.000000 s of line 2: a candump log is in "
           "time order",
       {{"x.log", "(1700000000.000000) can0 080#\n(1700000001.000000) can0 080#\n(1700000000.500000) can0 080#\n"}}},
      {"replay_of_zeros",
       {"--replay", "full", "-o", "x.txt"},
       2,
       e + "full:1: the line is longer than 1048576 bytes: this is not a candump log"},
      {"replay_binary",
       {"--replay", "x.log", "-o", "x.txt"},
       2,
       e + "x.log: no CAN frame in its 1 line",
       {{"x.log", std::string("\x7f"
                              "ELF\0\0\0",
                              7)}}},
      {"replay_two_interfaces",
       {"--replay", "x.log", "-o", "x.txt"},
       2,
       e + "x.log: frames of 2 interfaces, can0 (from line 1) and can1 (from line 2): choose one with "
           "--replay-iface",
       {{"x.log", "(1700000000.000000) can0 080#\n(1700000000.000050) can1 080#\n"}}},
      {"replay_interface_not_in_the_log",
       {"--replay", "sim.log", "--replay-iface", "can1", "-o", "x.txt"},
       2,
       e + "sim.log: no frame of interface can1 (the log holds can0 (from line 1))"},
      {"replay_interface_without_replay",
       {"-i", "nosuchcan0", "--replay-iface", "can1", "-o", "x.txt"},
       2,
       e + "--replay-iface can1: names the interface of a replay (--replay)"},
      {"replay_interface_named_badly",
       {"--replay", "sim.log", "--replay-iface", "can 1", "-o", "x.txt"},
       2,
       "--replay-iface: an interface name has no space, '/' or ':' and is not '.' or '..', got 'can 1'"},
      {"replay_one_interface_of_two",
       {"--replay", "x.log", "--replay-iface", "can1", "-o", "x.txt"},
       0,
       "",
       {{"x.log", "(1700000000.000000) can0 080#\n(1700000000.000050) can1 080#\n"}},
       {"x.txt"}},
      // the config file
      {"config_unknown_key",
       r({"--config", "x.conf", "-o", "x.txt"}),
       2,
       e + "x.conf:2: unknown option 'sphere-radius': not an option of sph_acquired",
       {{"x.conf", "mode = \"points\"\nsphere-radius = 20\n"}}},
      {"config_verbose_beyond_64_bits",
       r({"--config", "x.conf", "-o", "x.txt"}),
       2,
       "--verbose: '44444444444444444444444444' is not a count of 0 to 3 levels",
       {{"x.conf", "v = 44444444444444444444444444\n"}}},
      {"verbose_negative", r({"-o", "x.txt", "--verbose=-5"}), 2, "--verbose: '-5' is not a count of 0 to 3 levels"},
      {"config_key_given_twice",
       r({"--config", "x.conf", "-o", "x.txt"}),
       2,
       e + "x.conf:3: 'mode' is given twice (first at line 1): give each option once",
       {{"x.conf", "mode = \"points\"\n# the mode\nmode = \"stream\"\n"}}},
      {"config_option_by_two_names",
       r({"--config", "x.conf", "-o", "x.txt"}),
       2,
       e + "x.conf:2: 'output' is given twice (first at line 1)",
       {{"x.conf", "o = \"x.txt\"\noutput = \"y.txt\"\n"}}},
      {"config_binary",
       r({"--config", "x.conf", "-o", "x.txt"}),
       2,
       e + "x.conf:2: binary data (NUL byte): this is not a configuration file",
       {{"x.conf", std::string("mode = \"points\"\nsetup = 1\0\n", 27)}}},
      {"config_of_zeros", r({"--config", "full", "-o", "x.txt"}), 2,
       e + "full:1: binary data (NUL byte): this is not a configuration file"},
      {"config_section",
       r({"--config", "x.conf", "-o", "x.txt"}),
       2,
       e + "x.conf:1: a section '[daemon]': sph_acquired reads 'name = value' lines without sections",
       {{"x.conf", "[daemon]\nmode = \"points\"\n"}}},
      {"config_missing", r({"--config", "nope.conf", "-o", "x.txt"}), 2,
       e + "nope.conf: cannot open the configuration file (--config) for reading: No such file or directory"},
      {"config_directory", r({"--config", "sub", "-o", "x.txt"}), 2,
       e + "sub: is a directory, not a configuration file (--config)"},
      {"config_value_out_of_range",
       r({"--config", "x.conf", "-o", "x.txt"}),
       2,
       e + "x.conf:2: --heartbeat-timeout-s: must be -1 (three of the nodes' heartbeat times) or >= 0 and <= 86400 s, "
           "got -2",
       {{"x.conf", "mode = \"points\"\nheartbeat-timeout-s = -2\n"}}},
      {"bitrate_too_high", r({"-o", "x.txt", "--bitrate-kbit-s", "2000"}), 2,
       e + "--bitrate-kbit-s: must be 0 (the interface's) or >= 10 and <= 1000 kbit/s, got 2000"},
      {"config_bare_name",
       r({"--config", "x.conf", "-o", "x.txt"}),
       2,
       e + "x.conf:2: 'setup' needs a value: 'setup = VALUE'",
       {{"x.conf", "# the setup\nsetup\n"}}},
      {"config_empty_value",
       r({"--config", "x.conf", "-o", "x.txt"}),
       2,
       e + "x.conf:1: 'sync-period-ms' needs a value: 'sync-period-ms = VALUE'",
       {{"x.conf", "sync-period-ms =   # to be measured\n"}}},
      {"config_not_an_integer",
       r({"--config", "x.conf", "-o", "x.txt"}),
       2,
       e + "x.conf:1: --setup: 'one' is not an integer",
       {{"x.conf", "setup = one\n"}}},
      {"config_bare_flag_read",
       r({"--config", "x.conf", "-o", "x.txt"}),
       0,
       "",
       {{"x.conf", "trust-config\n"}},
       {"x.txt"}},
      {"config_read", r({"--config", "a.conf", "-o", "x.txt"}), 0, "", {}, {"x.txt"}},
      // numbers
      {"sync_period_tiny", r({"-o", "x.txt", "--sync-period-ms", "1e-300"}), 2,
       "--sync-period-ms: must be 0 (unknown) or >= 0.1 and <= 60000 ms, got 1e-300"},
      {"sync_period_nan", r({"-o", "x.txt", "--sync-period-ms", "nan"}), 2,
       "--sync-period-ms: must be 0 (unknown) or >= 0.1 and <= 60000 ms, got nan"},
      {"radius_too_large", r({"-o", "x.txt", "--sphere-radius-mm", "1e308"}), 2,
       "--sphere-radius-mm: must be > 0 and <= 1000 mm, got 1e308"},
      {"fsync_interval_negative", r({"-o", "x.txt", "--fsync-interval-s", "-2"}), 2,
       "--fsync-interval-s: must be -1 (only at the end) or >= 0 and <= 86400 s, got -2"},
      {"heartbeat_timeout_infinite", r({"-o", "x.txt", "--heartbeat-timeout-s", "inf"}), 2,
       "--heartbeat-timeout-s: must be -1 (three of the nodes' heartbeat times) or >= 0 and <= 86400 s, got inf"},
      {"standstill_tolerance_zero", r({"-o", "x.txt", "--standstill-tol-deg", "0"}), 2,
       "--standstill-tol-deg: must be > 0 and <= 360 deg, got 0"},
      {"node_heartbeat_negative", r({"-o", "x.txt", "--node-heartbeat-ms", "-1"}), 2,
       "--node-heartbeat-ms: Value -1 not in range 0 to 65535"},
      {"sdo_timeout_nan", r({"-o", "x.txt", "--sdo-timeout-ms", "nan"}), 2,
       "--sdo-timeout-ms: must be >= 1 and <= 60000 ms, got nan"},
      {"duration_too_long", r({"-o", "x.txt", "--duration-s", "1e300"}), 2,
       "--duration-s: must be >= 0 and <= 1e+08 s, got 1e300"},
      {"counts_per_rev_zero", r({"-o", "x.txt", "--theta-counts-per-rev", "0"}), 2,
       "--theta-counts-per-rev: must be >= 1 and <= 4.29497e+09 counts, got 0"},
      {"position_width_too_small", r({"-o", "x.txt", "--theta-width-bytes", "2"}), 2,
       e + "--theta-width-bytes 2: a position of 16 bits cannot count the 16777216 steps of one revolution "
           "(--theta-counts-per-rev); give at least 3 bytes"},
      {"probe_scale_zero", r({"-o", "x.txt", "--probe-scale-nm-per-count", "0"}), 2,
       e + "--probe-scale-nm-per-count: must not be 0 nm"},
      {"probe_cob_id_beyond_11_bits", r({"-o", "x.txt", "--probe-cob-id", "0x800"}), 2,
       e + "--probe-cob-id 0x800: an 11-bit id is at most 0x7FF (--probe-extended-id for a 29-bit id)"},
      {"probe_pdo_object_without_sub", r({"-o", "x.txt", "--probe-pdo-object", "2000:"}), 2,
       e + "--probe-pdo-object '2000:': expected INDEX:SUB in hex, e.g. 0x2000:00"},
      {"fsync_interval_in_hex", r({"-o", "x.txt", "--fsync-interval-s", "0x10"}), 2,
       "--fsync-interval-s: must be -1 (only at the end) or >= 0 and <= 86400 s, got 0x10"},
      {"mount_rotation_not_a_rotation", r({"-o", "x.txt", "--mount-rotation-deg", "0,90"}), 2,
       e + "--mount-rotation-deg '0,90': expected rx,ry,rz (a rotation vector in deg, axis times angle) or unknown"},
      {"no_output", replay, 2, "--output is required"},
  };
}
INSTANTIATE_TEST_SUITE_P(Acquired, AcquiredMatrix, ::testing::ValuesIn(AcquiredCases()), CaseName);

// ---- sph_cansim -----------------------------------------------------------------------------------

class CansimMatrix : public CanMatrix {};
TEST_P(CansimMatrix, Case) { Check(SPH_CANSIM); }

std::vector<MatrixCase> CansimCases() {
  const std::string e = "sph_cansim: error: ";
  const auto q = [&](const std::vector<std::string>& more) { return With(kSmall, more); };
  const auto log = [&](const std::vector<std::string>& more) { return With(q({"-o", "x.log"}), more); };
  return {
      // outputs that are inputs or each other
      {"output_is_the_angles", q({"-o", "a.txt", "--angles", "a.txt"}), 2,
       e + "--output a.txt is also the input --angles a.txt: an output never replaces an input"},
      {"record_is_the_angles", log({"--record", "a.txt", "--angles", "a.txt"}), 2,
       e + "--record a.txt is also the input --angles a.txt"},
      {"output_and_record_one_file", q({"-o", "s", "--record", "./s"}), 2,
       e + "--output s and --record ./s are the same file: give each output a file of its own"},
      {"output_is_the_config", q({"--config", "a.conf", "-o", "a.conf"}), 2,
       e + "--output a.conf is also the input --config a.conf"},
      {"output_and_record_both_stdout", q({"-o", "-", "--record", "-"}), 2,
       e + "--output and --record both write to standard output"},
      // outputs that are no regular files, or cannot be made
      {"output_onto_block_device", q({"-o", "disk"}), 3, e + "disk: is a block device: refusing to write onto it"},
      {"output_onto_full_device", q({"-o", "full"}), 3, e + "full: cannot write: No space left on device"},
      {"output_onto_null_device", q({"-o", "null", "--record", "null"}), 0, ""},
      {"output_onto_directory", q({"-o", "sub"}), 3, e + "sub: is a directory; give the name of a file"},
      {"output_into_missing_folder", q({"-o", "no/x.log"}), 3,
       e + "no/x.log: cannot create a file in 'no': No such file or directory"},
      {"record_onto_full_device_puts_no_log_in_place", log({"--record", "full"}), 3,
       e + "full: cannot write: No space left on device"},
      {"stdout_full",
       q({"-o", "-"}),
       3,
       e + "cannot write to standard output: No space left on device",
       {},
       {},
       "full"},
      {"stdout_closed_keeps_the_record",
       q({"-o", "-", "--record", "r.txt"}),
       3,
       e + "cannot write to standard output: Broken pipe",
       {{"r.txt", "yesterday\n"}},
       {},
       kClosedPipe},
      {"seed_negative", log({"--seed", "-1"}), 2,
       "--seed: must be an integer from 0 to 18446744073709551615, got '-1'"},
      {"output_and_record_written", log({"--record", "r.txt"}), 0, "", {}, {"x.log", "r.txt"}},
      {"output_replaced_whole", q({"-o", "notes.txt"}), 0, "", {}, {"notes.txt"}},
      // faults
      {"silence_ends_before_it_begins", log({"--silence", "probe:14:10"}), 2,
       e + "--silence 'probe:14:10': the window must end after it begins (from_s < to_s)"},
      {"silence_nan", log({"--silence", "probe:nan:3"}), 2,
       e + "--silence 'probe:nan:3': from_s: 'nan' is not a finite number"},
      {"silence_negative", log({"--silence", "probe:1:-3"}), 2,
       e + "--silence 'probe:1:-3': to_s: must be >= 0 and <= 1e+08 s, got -3"},
      {"silence_unknown_device", log({"--silence", "laser:1:2"}), 2,
       e + "--silence: device 'laser' is not theta, phi or probe"},
      {"emcy_time_infinite", log({"--emcy", "theta:inf:8130"}), 2,
       e + "--emcy 'theta:inf:8130': at_s: 'inf' is not a finite number"},
      {"emcy_code_not_hex", log({"--emcy", "theta:1:xyz"}), 2, e + "--emcy 'theta:1:xyz': code must be 16-bit hex"},
      {"emcy_code_with_a_sign", log({"--emcy", "theta:1:+8130"}), 2,
       e + "--emcy 'theta:1:+8130': code must be 16-bit hex"},
      {"fault_time_negative", log({"--fault", "reboot:1@-1"}), 2,
       e + "--fault 'reboot:1@-1': T: must be >= 0 and <= 1e+08 s, got -1"},
      {"fault_time_nan", log({"--fault", "reboot:theta@nan"}), 2,
       e + "--fault 'reboot:theta@nan': T: 'nan' is not a finite number"},
      {"fault_unknown_kind", log({"--fault", "unplug:1@1"}), 2,
       e + "--fault 'unplug:1@1': expected reboot:NODE@T, settings-lost:NODE@T, preop:NODE@T or error:NODE@T"},
      {"fault_settings_lost_of_absent_node", log({"--fault", "settings-lost:9@1"}), 2,
       e + "device simulator: reboot of node 9, which no device is"},
      {"nodes_sync_counter_max_one", log({"--nodes-sync-counter-max", "1"}), 2,
       e + "--nodes-sync-counter-max: 1 is not allowed (-1, 0 or 2..240)"},
      {"nodes_sync_counter_max_too_high", log({"--nodes-sync-counter-max", "241"}), 2,
       "--nodes-sync-counter-max: Value 241 not in range -1 to 240"},
      {"fault_node_absent", log({"--fault", "reboot:9@1"}), 2,
       e + "device simulator: reboot of node 9, which no device is"},
      {"bus_off_negative", log({"--bus-off-at-s", "-1"}), 2, "--bus-off-at-s: must be >= 0 and <= 1e+08 s, got -1"},
      {"drop_probability_nan", log({"--drop-probability", "nan"}), 2,
       "--drop-probability: must be >= 0 and <= 1, got nan"},
      {"jitter_infinite", log({"--jitter-us", "inf"}), 2, "--jitter-us: must be >= 0 and <= 1e+06 us, got inf"},
      // times and periods
      {"start_time_negative", log({"--start-time-s", "-1"}), 2, "--start-time-s: must be >= 0 and < 9.2e+09 s, got -1"},
      {"start_time_beyond_2261", log({"--start-time-s", "9.2e9"}), 2,
       "--start-time-s: must be >= 0 and < 9.2e+09 s, got 9.2e9"},
      {"simulation_ends_beyond_2261", log({"--start-time-s", "9199999900", "--stop-s", "3600", "--move-s", "0"}), 2,
       e + "--start-time-s 9199999900: the simulation would end at 9200007100 s since the epoch, beyond the 9.2e+09 s "
           "that a frame time in ns holds"},
      {"sync_period_tiny", With(log({}), {"--sync-period-ms", "1e-300"}), 2,
       "--sync-period-ms: must be >= 0.1 and <= 60000 ms, got 1e-300"},
      {"sync_period_zero", With(log({}), {"--sync-period-ms", "0"}), 2,
       "--sync-period-ms: must be >= 0.1 and <= 60000 ms, got 0"},
      {"heartbeat_period_tiny", log({"--heartbeat-period-s", "1e-300"}), 2,
       "--heartbeat-period-s: must be 0 (none) or >= 0.001 and <= 65.535 s, got 1e-300"},
      {"move_time_huge", log({"--move-s", "1e308"}), 2, "--move-s: must be >= 0 and <= 3600 s, got 1e308"},
      // names and layouts
      {"log_iface_with_a_space", log({"--log-iface", "can 0"}), 2,
       "--log-iface: an interface name has no space, '/' or ':' and is not '.' or '..', got 'can 0'"},
      {"log_iface_too_long", log({"--log-iface", "can0123456789abc"}), 2,
       "--log-iface: an interface name has 1 to 15 characters, got 16"},
      {"iface_with_a_colon", q({"-i", "vcan0:1"}), 2, "--iface: an interface name has no space, '/' or ':'"},
      {"position_width_too_small", log({"--phi-width-bytes", "1", "--phi-counts-per-rev", "4096"}), 2,
       e + "--phi-width-bytes 1: a position of 8 bits cannot count the 4096 steps of one revolution "
           "(--phi-counts-per-rev); give at least 2 bytes"},
      {"center_missing_part", log({"--center-mm", "2,0"}), 2, e + "--center-mm '2,0': expected x,y,z in mm"},
      // set-ups sph_simulate refuses
      {"sphere_missed_by_the_beam",
       {"--theta-steps", "4", "--phi-steps", "2", "--sync-period-ms", "10", "-o", "x.log", "--sphere-radius-mm", "0.5",
        "--probe-offset-mm", "5"},
       2,
       e + "simulation: the probe ray misses the sphere at theta 0.000000 deg, phi 45.000000 deg (setup 0)"},
      {"form_deeper_than_the_sphere",
       log({"--sphere-radius-mm", "0.5", "--center-mm", "0,0,0", "--form-um", "2,0,1000"}), 2,
       e + "simulation: the form error (up to 1000 um into the sphere) must be smaller than the sphere's radius (0.5 "
           "mm)"},
      {"angles_missing", log({"--angles", "nope.txt"}), 2, e + "nope.txt: cannot open for reading"},
      {"neither_log_nor_interface", kSmall, 2, e + "give either --output (a candump log) or --iface (live)"},
      // the config file: sph_acquired's options are accepted (one file describes both)
      {"config_of_the_daemon_read", log({"--config", "a.conf"}), 0, "", {}, {"x.log"}},
      {"config_unknown_key",
       log({"--config", "x.conf"}),
       2,
       e + "x.conf:1: unknown option 'theta-stepz': not an option of sph_cansim",
       {{"x.conf", "theta-stepz = 4\n"}}},
      {"config_key_given_twice",
       log({"--config", "x.conf"}),
       2,
       e + "x.conf:2: 'seed' is given twice (first at line 1)",
       {{"x.conf", "seed = 1\nseed = 2\n"}}},
      {"config_binary",
       log({"--config", "x.conf"}),
       2,
       e + "x.conf:1: binary data (NUL byte): this is not a configuration file",
       {{"x.conf", std::string("\0\1", 2)}}},
  };
}
INSTANTIATE_TEST_SUITE_P(Cansim, CansimMatrix, ::testing::ValuesIn(CansimCases()), CaseName);

// sph_cansim writing a long log, stopped by a signal: the log begun is removed, nothing else
// is left, and the exit code is 128 + the signal's number.
class CansimSignal : public ::testing::TestWithParam<int> {};

TEST_P(CansimSignal, RemovesTheLogBegunAndExits128PlusTheSignal) {
  const int sig = GetParam();
  const std::string dir = MakeTempDir("cansim_signal_" + std::to_string(sig));
  std::ofstream(dir + "/sim.log") << "(1700000000.000000) can0 080#\n";  // a log of an earlier run
  const auto before = FolderState(dir);
  const pid_t pid = ::fork();
  if (pid == 0) {
    if (::chdir(dir.c_str()) != 0) ::_exit(125);
    const int null = ::open("/dev/null", O_WRONLY);
    ::dup2(null, 2);
    // The paper's grid at 10 kHz: 4 million SYNC cycles, minutes of writing.
    ::execl(SPH_CANSIM, SPH_CANSIM, "-o", "sim.log", "--sync-period-ms", "0.1", static_cast<char*>(nullptr));
    ::_exit(126);
  }
  ASSERT_GT(pid, 0);
  // Until the temporary file beside sim.log has grown (at most 20 s).
  for (int i = 0; i < 400; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    bool writing = false;
    for (const auto& [name, what] : FolderState(dir))
      writing |= name.rfind(".sim.log.tmp.", 0) == 0 && what.size() > 1000;
    if (writing) break;
  }
  ::kill(pid, sig);
  int status = 0;
  ASSERT_EQ(::waitpid(pid, &status, 0), pid);
  const int code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  EXPECT_EQ(code, 128 + sig);
  EXPECT_EQ(FolderState(dir), before) << "the log of the earlier run must stay, and no temporary file";
}

INSTANTIATE_TEST_SUITE_P(Signals, CansimSignal, ::testing::Values(SIGINT, SIGTERM));

}  // namespace
}  // namespace sph::testing
