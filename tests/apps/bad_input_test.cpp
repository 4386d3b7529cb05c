// The bad-input matrix of sph_calibrate, sph_simulate, sph_montecarlo and sph_measure: each case
// runs the real program in a folder of its own and checks the exit code, the message (naming
// the option, or the file and line), that no solver log reaches the user, and that the folder
// is byte for byte as before (device nodes still device nodes), apart from the outputs a
// successful case makes. A failed run replaces no file: a case whose standard output fails (a
// full device, a pipe nobody reads) or whose plot fails finds its old output unchanged.
#include <signal.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <unistd.h>

#include <cmath>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "program_run.hpp"
#include "sph/internal/format.hpp"
#include "test_util.hpp"

namespace sph::testing {
namespace {

std::string Example() { return ReadWholeFile(SPH_SOURCE_DIR "/data/example/points.txt"); }

// The example's header and its first `rows` rows with the column r_mm replaced in row `row`.
std::string ExampleWithR(int row, const std::string& r) {
  std::istringstream in(Example());
  std::string out, line;
  int n = 0;
  while (std::getline(in, line)) {
    if (!line.empty() && line[0] != '#' && n++ == row) {
      std::istringstream ls(line);
      std::string theta, phi, old, t;
      ls >> theta >> phi >> old >> t;
      line = theta + " " + phi + " " + r + " " + t;
    }
    out += line + "\n";
  }
  return out;
}

// The example's header and `rows` of its samples, every (288 / rows)-th.
std::string ExampleSamples(int rows) {
  std::istringstream in(Example());
  std::string out, line;
  int n = 0, kept = 0;
  while (std::getline(in, line)) {
    if (!line.empty() && line[0] != '#' && (n++ % (288 / rows) != 0 || kept++ >= rows)) continue;
    out += line + "\n";
  }
  return out;
}

// data/example/separation/points.txt (four orientations of the sphere) with every k-th sample.
std::string SeparationEvery(int k) {
  std::istringstream in(ReadWholeFile(SPH_SOURCE_DIR "/data/example/separation/points.txt"));
  std::string out, line;
  int n = 0;
  while (std::getline(in, line)) {
    if (!line.empty() && line[0] != '#' && n++ % k != 0) continue;
    out += line + "\n";
  }
  return out;
}

// The example with every t_s 5 s.
std::string ExampleAtOneTime() {
  std::istringstream in(Example());
  std::string out, line;
  while (std::getline(in, line)) {
    if (!line.empty() && line[0] != '#') line = line.substr(0, line.find_last_of(' ')) + " 5";
    out += line + "\n";
  }
  return out;
}

constexpr const char* kHeader = "# sph-points 1\n# sphere_radius_mm: 20\n# probe_offset_mm: 25\n";

// Stand-ins for gnuplot: one that never finishes (what it starts must go with it), one that
// ends well without drawing anything.
constexpr const char* kHangingGnuplot = "#!/bin/sh\nsleep 30\n";
constexpr const char* kIdleGnuplot = "#!/bin/sh\nexit 0\n";
constexpr const char* kSeedRange = "--seed: must be an integer from 0 to 18446744073709551615, got ";
// The example with `lines` added to its header (after its first three lines), or with its
// probe_offset_mm replaced when `offset` is given.
std::string ExampleWithHeader(const std::string& lines, const std::string& offset = "") {
  std::string text = Example();
  if (!offset.empty()) {
    const std::string key = "# probe_offset_mm: 25\n";
    text.replace(text.find(key), key.size(), "# probe_offset_mm: " + offset + "\n");
  }
  const std::size_t third = text.find('\n', text.find('\n', text.find('\n') + 1) + 1);
  return text.insert(third + 1, lines);
}

class Matrix : public ::testing::TestWithParam<MatrixCase> {
 protected:
  // The files every case finds in its folder: the example (P.txt), a calibration made from it
  // (cal.json), an angle pattern (a.txt), a folder (sub), and device nodes of its own: a full
  // device (full), a null device (null) and a block device (disk), never those of /dev.
  static void SetUpTestSuite() {
    base_ = MakeTempDir("matrix_base");
    std::ofstream(base_ + "/P.txt") << Example();
    const ProgramResult r = RunProgram({SPH_CALIBRATE, "P.txt", "--no-trace", "-q", "-o", "cal.json"}, base_);
    ASSERT_EQ(r.code, 0) << r.err;
    nodes_ = MakeDeviceNodes(base_);
  }

  // A copy of the base folder for one case, with its files.
  std::string Folder(const MatrixCase& c) {
    const std::string dir = MakeTempDir("matrix_" + c.name);
    for (const char* f : {"P.txt", "cal.json"}) std::ofstream(dir + "/" + f) << ReadWholeFile(base_ + "/" + f);
    std::ofstream(dir + "/a.txt") << "0 45\n90 45\n180 45\n270 45\n0 90\n90 90\n180 90\n270 90\n45 135\n135 135\n";
    ::mkdir((dir + "/sub").c_str(), 0755);
    if (nodes_) MakeDeviceNodes(dir);
    for (const auto& [name, text] : c.files) std::ofstream(dir + "/" + name, std::ios::binary) << text;
    return dir;
  }

  void Check(const char* program) {
    const MatrixCase& c = GetParam();
    if (UsesDeviceNodes(c) && !nodes_) GTEST_SKIP() << "device nodes cannot be made here (needs CAP_MKNOD)";
    if (UsesRealGnuplot(c) && !OnPath("gnuplot")) GTEST_SKIP() << "gnuplot is not installed";
    const ProgramResult r = RunMatrixCase(program, c, Folder(c));
    EXPECT_FALSE(HasSolverLog(r.out + r.err)) << r.err;
  }

  static inline std::string base_;
  static inline bool nodes_ = false;
};

// ---- sph_calibrate --------------------------------------------------------------------------------

class CalibrateMatrix : public Matrix {};
TEST_P(CalibrateMatrix, Case) { Check(SPH_CALIBRATE); }

// A calibration file by hand with the sphere's form (one term, its standard uncertainty) and R0
// `radius`; without a form when `form` is false.
std::string FormFile(const std::string& radius, bool form = true) {
  std::string j = R"({"format": "sph-calibration", "format_version": 1, "probe_offset_mm": 25, "sphere_radius_mm": )" +
                  radius + R"(, "geometry": {)";
  for (const char* p : {"a", "b", "c", "d_prime"})
    j += std::string("\"") + p + R"(": {"value": 0.001, "unit": "mm"}, )";
  for (const char* p : {"alpha", "beta", "epsilon"})
    j += std::string("\"") + p + R"(": {"value": 0.02, "unit": "deg"}, )";
  j.resize(j.size() - 2);
  j += R"(}, "effects": [])";
  if (form) {
    j += R"(, "sphere_form": {"normalisation": "schmidt_semi_normalised", "frame": "body", "unit": "um", )"
         R"("terms": [{"l": 2, "m": 0, "value_um": 0.05, "std_um": 0.002}]})";
  }
  return j + "}\n";
}

// The example as two setups, the second (its last 144 rows) on another sphere of radius `radius`
// mm (sphere_radius_mm@1): for the cases refused before any fit.
std::string TwoSpheres(const std::string& radius = "15") {
  std::istringstream in(Example());
  std::string out, line;
  int n = 0;
  while (std::getline(in, line)) {
    if (line.rfind("# columns:", 0) == 0) {
      out += "# sphere_radius_mm@1: " + radius + "\n" + line + " setup\n";
    } else {
      out += line + (!line.empty() && line[0] != '#' ? (n++ < 144 ? " 0" : " 1") : "") + "\n";
    }
  }
  return out;
}

// The example with each probe reading r replaced by 10 - r: a probe that reads the other way.
std::string ExampleReadingTheOtherWay() {
  std::istringstream in(Example());
  std::string out, line;
  while (std::getline(in, line)) {
    if (!line.empty() && line[0] != '#') {
      std::istringstream ls(line);
      double theta = 0.0, phi = 0.0, r = 0.0, t = 0.0;
      ls >> theta >> phi >> r >> t;
      line = internal::Format("%.10f %.10f %.10f %.2f", theta, phi, 10.0 - r, t);
    }
    out += line + "\n";
  }
  return out;
}

// The example's readings at theta 0, 45, ..., 315 deg only: a pattern of 8 angles, which resolves
// harmonics of theta up to order 3.
std::string ExampleAtEightThetas() {
  std::istringstream in(Example());
  std::string out, line;
  while (std::getline(in, line)) {
    if (!line.empty() && line[0] != '#' && std::fmod(std::stod(line), 45.0) != 0.0) continue;
    out += line + "\n";
  }
  return out;
}

std::vector<MatrixCase> CalibrateCases() {
  const std::string h = kHeader;
  const std::string e = "sph_calibrate: error: ";
  return {
      // The sphere's known form: the same sphere's, from a file that holds one, with the trace.
      {"sphere_form_of_another_sphere",
       {"P.txt", "--sphere-form", "f.json"},
       2,
       e + "P.txt: sphere_radius_mm 20 mm (u 0 um) is not the radius of the sphere whose form f.json holds, 20.01 mm "
           "(u 0 um): they differ by 10 um, more than their standard uncertainties together",
       {{"f.json", FormFile("20.01")}}},
      // Several spheres: each file matched to the one whose radius is its R0.
      {"sphere_form_of_no_sphere_of_the_points",
       {"T.txt", "--sphere-form", "f.json"},
       2,
       e + "f.json: its sphere, sphere_radius_mm 12 mm (u 0 um), is none of the spheres of T.txt (R0 20 mm (u 0 um), "
           "sphere_radius_mm@1 15 mm (u 0 um)) within their standard uncertainties",
       {{"T.txt", TwoSpheres()}, {"f.json", FormFile("12")}}},
      {"sphere_form_of_either_sphere",
       {"T.txt", "--sphere-form", "f.json", "--sphere-radius-u-um", "600"},
       2,
       e + "f.json: its sphere, sphere_radius_mm 20.5 mm (u 0 um), could be any of the spheres of T.txt R0 20 mm "
           "(u 600 um), sphere_radius_mm@1 20.5 mm (u 0 um) within their standard uncertainties: which sphere's "
           "form it holds is ambiguous",
       {{"T.txt", TwoSpheres("20.5")}, {"f.json", FormFile("20.5")}}},
      {"two_sphere_forms_of_one_sphere",
       {"T.txt", "--sphere-form", "f.json", "--sphere-form", "g.json"},
       2,
       e + "g.json and f.json both hold a form of the sphere sphere_radius_mm@1 of T.txt",
       {{"T.txt", TwoSpheres()}, {"f.json", FormFile("15")}, {"g.json", FormFile("15")}}},
      {"other_sphere_form_alone",
       {"T.txt", "--sphere-form", "g.json"},
       2,
       e + "T.txt: a known form of another sphere (g.json) needs the reference sphere's form known too",
       {{"T.txt", TwoSpheres()}, {"g.json", FormFile("15")}}},
      {"output_is_the_second_sphere_form_input",
       {"T.txt", "--sphere-form", "f.json", "--sphere-form", "g.json", "-o", "g.json"},
       2,
       e + "--output g.json is also the input --sphere-form g.json",
       {{"T.txt", TwoSpheres()}, {"f.json", FormFile("20")}, {"g.json", FormFile("15")}}},
      {"sphere_form_file_without_a_form",
       {"P.txt", "--sphere-form", "f.json"},
       2,
       e + "f.json: holds no \"sphere_form\"",
       {{"f.json", FormFile("20", false)}}},
      {"sphere_form_without_trace",
       {"P.txt", "--no-trace", "--sphere-form", "f.json"},
       2,
       "--no-trace excludes --sphere-form",
       {{"f.json", FormFile("20")}}},
      {"output_is_the_sphere_form_input",
       {"P.txt", "--sphere-form", "f.json", "-o", "f.json"},
       2,
       e + "--output f.json is also the input --sphere-form f.json",
       {{"f.json", FormFile("20")}}},
      {"sphere_form_rms_zero",
       {"P.txt", "--sphere-form-rms-um", "0"},
       2,
       "--sphere-form-rms-um: must be >= 1e-06 and <= 1000 um, got 0"},
      {"missing_file", {"nope.txt"}, 2, e + "nope.txt: cannot open for reading: No such file or directory"},
      {"directory", {"sub"}, 2, e + "sub: is a directory, not a file"},
      {"empty_file", {"x.txt"}, 2, e + "x.txt: no samples (the file has 0 lines", {{"x.txt", ""}}},
      {"header_only", {"x.txt"}, 2, e + "x.txt: no samples (the file has 3 lines", {{"x.txt", h}}},
      {"binary",
       {"x.txt"},
       2,
       e + "x.txt:1: binary data (NUL byte): this is not a points file",
       {{"x.txt", std::string("\x7f"
                              "ELF\x02\x01\x01\0\0\0",
                              10)}}},
      {"byte_order_mark", {"x.txt", "--no-trace", "-q"}, 0, "", {{"x.txt", "\xEF\xBB\xBF" + Example()}}},
      {"bad_columns_line_named_at_its_line",
       {"x.txt"},
       2,
       e + "x.txt:4: unknown column name 'temp_c'",
       {{"x.txt", h + "# columns: theta_deg phi_deg r_mm temp_c\n1 2 3 4\n"}}},
      {"duplicate_header_key",
       {"x.txt"},
       2,
       e + "x.txt:3: header key 'sphere_radius_mm' is given twice",
       {{"x.txt", "# sph-points 1\n# sphere_radius_mm: 20\n# sphere_radius_mm: 20\n1 2 3\n"}}},
      {"radius_in_header_too_large",
       {"x.txt"},
       2,
       e + "x.txt:2: sphere_radius_mm must be at most 1000 mm, got '1e308'",
       {{"x.txt", "# sph-points 1\n# sphere_radius_mm: 1e308\n1 2 3\n"}}},
      {"long_field_cut",
       {"x.txt"},
       2,
       e + "x.txt:4: column r_mm: '4x" + std::string(38, '9') + "...' (1000002 characters)",
       {{"x.txt", h + "0 7.5 4x" + std::string(1000000, '9') + "\n"}}},
      {"points_file_of_zeros", {"full"}, 2, e + "full:1: binary data (NUL byte): this is not a points file"},
      {"line_without_end",
       {"x.txt"},
       2,
       e + "x.txt:4: the line is longer than 1048576 bytes: this is not a points file",
       {{"x.txt", h + std::string(2 << 20, '9')}}},
      {"mount_rotation_beyond_a_turn",
       {"x.txt"},
       2,
       e + "x.txt:4: mount_rotation_deg@0 rz: must be within [-360, 360] deg, got '1e308'",
       {{"x.txt", h + "# mount_rotation_deg@0: 0 0 1e308\n0 7.5 4.8\n"}}},
      {"setup_field_naming_no_setup",
       {"x.txt"},
       2,
       e + "x.txt:4: mount_rotation_deg@ names no setup: write 'mount_rotation_deg@<setup>: rx ry rz'",
       {{"x.txt", h + "# mount_rotation_deg@: 0 0 90\n0 7.5 4.8\n"}}},
      {"setup_field_after_its_rows",
       {"x.txt"},
       2,
       e + "x.txt:295: mount_rotation_deg@0: setup 0 has rows before this line (the first at line 7): the mount "
           "rotation of a setup applies to all of its rows and stands before the first of them",
       {{"x.txt", Example() + "# mount_rotation_deg@0: 0 0 90\n"}}},
      {"columns_line_after_rows",
       {"x.txt"},
       2,
       e + "x.txt:5: a columns line after the first sample (line 4): the columns are named once, before the samples",
       {{"x.txt", h + "0 7.5 4.8\n# columns: theta_deg phi_deg r_mm t_s\n15 7.5 4.8 1\n"}}},
      {"time_beyond_bound",
       {"x.txt"},
       2,
       e + "x.txt:6: column t_s: '1e308' is beyond 1e+12 s from 0: not a time of a measurement",
       {{"x.txt", h + "# columns: theta_deg phi_deg r_mm t_s\n0 7.5 4.8 0\n15 7.5 4.8 1e308\n"}}},
      {"reading_beyond_any_machine",
       {"x.txt"},
       2,
       e + "x.txt:5: column r_mm: '1e150' is beyond 1e+06 mm from 0: not a probe reading in mm",
       {{"x.txt", h + "0 7.5 4.8\n15 7.5 1e150\n"}}},
      {"angle_beyond_any_encoder",
       {"x.txt"},
       2,
       e + "x.txt:4: column phi_deg: '-1e153' is beyond 1e+09 deg from 0: not an encoder's angle",
       {{"x.txt", h + "0 -1e153 4.8\n"}}},
      {"setup_id_out_of_range",
       {"x.txt"},
       2,
       e + "x.txt:5: column setup: '99999999999' is out of the range of an integer",
       {{"x.txt", h + "# columns: theta_deg phi_deg r_mm setup\n0 7.5 4.8 99999999999\n"}}},
      {"nan_reading",
       {"x.txt"},
       2,
       e + "x.txt:7: column r_mm: 'nan' is not a finite number",
       {{"x.txt", ExampleWithR(0, "nan")}}},
      {"wrong_column_count",
       {"x.txt"},
       2,
       e + "x.txt:4: expected 3 columns (theta_deg phi_deg r_mm), found 2",
       {{"x.txt", h + "1 2\n"}}},
      {"absurd_reading_named",
       {"x.txt", "--no-trace", "-q"},
       0,
       "x.txt:107: r_mm 100000",
       {{"x.txt", ExampleWithR(100, "1e5")}}},
      {"huge_constant_readings_no_solver_log",
       {"x.txt", "-q"},
       1,
       "",
       {{"x.txt",
         [] {
           std::string t = kHeader;
           for (int i = 0; i < 288; ++i)
             t += std::to_string(15 * (i % 24)) + " " + std::to_string(7.5 + 15 * (i / 24)) + " 1e6\n";
           return t;
         }()}}},
      {"radius_option_too_large",
       {"P.txt", "--sphere-radius-mm", "1e308"},
       2,
       "--sphere-radius-mm: must be > 0 and <= 1000 mm, got 1e308"},
      {"radius_option_negative",
       {"P.txt", "--sphere-radius-mm", "-3"},
       2,
       "--sphere-radius-mm: must be > 0 and <= 1000 mm, got -3"},
      {"radius_option_hex",  // a number is decimal: strtod read 0x10 as 16 mm
       {"P.txt", "--sphere-radius-mm", "0x10"},
       2,
       "--sphere-radius-mm: must be > 0 and <= 1000 mm, got 0x10"},
      {"offset_option_infinite",
       {"P.txt", "--probe-offset-mm", "inf"},
       2,
       "--probe-offset-mm: must be > 0 and <= 10000 mm, got inf"},
      {"max_std_zero", {"P.txt", "--max-std-um", "0"}, 2, "--max-std-um: must be > 0 and <= 1e+06 um, got 0"},
      {"max_iterations_zero", {"P.txt", "--max-iterations", "0"}, 2, "--max-iterations: Value 0 not in range"},
      {"unknown_effect", {"P.txt", "--effects", "probe_temperature"}, 2, "--effects: probe_temperature not in"},
      {"harmonics_too_high", {"P.txt", "--harmonics", "13"}, 2, "--harmonics: Value 13 not in range"},
      {"output_is_the_input",
       {"P.txt", "-o", "P.txt"},
       2,
       e + "--output P.txt is also the input points P.txt: an output never replaces an input"},
      {"output_is_the_input_by_another_name",
       {"P.txt", "-o", "./sub/../P.txt"},
       2,
       e + "--output ./sub/../P.txt is also the input points P.txt"},
      {"json_is_the_input", {"P.txt", "--json", "P.txt"}, 2, e + "--json P.txt is also the input points P.txt"},
      {"report_is_the_input", {"P.txt", "--report", "P.txt"}, 2, e + "--report P.txt is also the input points P.txt"},
      {"report_and_json_one_file",
       {"P.txt", "--json", "r", "--report", "r"},
       2,
       e + "--json r and --report r are the same file"},
      {"json_and_report_to_stdout",
       {"P.txt", "--json", "-", "--report", "-"},
       2,
       e + "--json and --report both write to standard output"},
      {"report_written", {"P.txt", "--no-trace", "-q", "--report", "r.html"}, 0, "", {}, {"r.html"}},
      {"two_outputs_one_file",
       {"P.txt", "-o", "c.json", "--json", "c.json"},
       2,
       e + "--json c.json and --output c.json are the same file: give each output a file of its own"},
      {"output_is_the_validation_input",
       {"P.txt", "--validate", "cal.json", "-o", "cal.json"},
       2,
       e + "--output cal.json is also the input --validate cal.json"},
      {"plot_dir_file_is_the_input",
       {"sub/residuals.dat", "--plot-dir", "sub"},
       2,
       e + "--plot-dir sub/residuals.dat is also the input points sub/residuals.dat",
       {{"sub/residuals.dat", Example()}}},
      {"json_to_stdout_twice",
       {"P.txt", "--json", "-", "-o", "-"},
       2,
       e + "--json and --output both write to standard output"},
      {"output_onto_block_device",
       {"P.txt", "-o", "disk"},
       2,
       e + "disk: is a block device: refusing to write onto it"},
      {"output_onto_full_device",
       {"P.txt", "--no-trace", "-q", "-o", "full"},
       2,
       e + "full: cannot write: No space left on device"},
      {"output_onto_null_device", {"P.txt", "--no-trace", "-q", "-o", "null", "--json", "null"}, 0, ""},
      {"output_onto_directory", {"P.txt", "-o", "sub"}, 2, e + "sub: is a directory; give the name of a file"},
      {"output_into_missing_folder",
       {"P.txt", "--no-trace", "-q", "-o", "no/c.json"},
       2,
       e + "no/c.json: cannot create a file in 'no': No such file or directory"},
      {"json_and_output_written",
       {"P.txt", "--no-trace", "-q", "-o", "c.json", "--json", "r.json"},
       0,
       "",
       {},
       {"c.json", "r.json"}},
      {"stdout_full",
       {"P.txt", "--no-trace"},
       2,
       e + "cannot write to standard output: No space left on device",
       {},
       {},
       "full"},
      {"json_stdout_full",
       {"P.txt", "--no-trace", "--json", "-"},
       2,
       e + "cannot write to standard output: No space left on device",
       {},
       {},
       "full"},
      {"validate_without_trace", {"P.txt", "--no-trace", "--validate", "P.txt"}, 2, "--no-trace excludes --validate"},
      {"stdout_full_keeps_the_calibration",
       {"P.txt", "--no-trace", "-o", "c.json"},
       2,
       e + "cannot write to standard output: No space left on device",
       {{"c.json", "yesterday\n"}},
       {},
       "full"},
      {"stdout_closed_keeps_the_calibration",
       {"P.txt", "--no-trace", "-o", "c.json"},
       2,
       e + "cannot write to standard output: Broken pipe",
       {{"c.json", "yesterday\n"}},
       {},
       kClosedPipe},
      {"plot_hangs",
       {"P.txt", "-q", "-o", "c.json", "--plot-dir", "plots", "--plot-timeout-s", "1"},
       2,
       e + "--plot-dir plots: gnuplot did not finish the residual plots within 1 s and was stopped; give it longer "
           "with --plot-timeout-s",
       {{"c.json", "yesterday\n"}},
       {},
       "",
       kHangingGnuplot},
      {"plot_timeout_zero",
       {"P.txt", "--plot-dir", "plots", "--plot-timeout-s", "0"},
       2,
       "--plot-timeout-s: must be > 0 and <= 86400 s, got 0"},
      {"plot_left_empty",
       {"P.txt", "-q", "--plot-dir", "sub"},
       2,
       e + "sub/residual_map.png: gnuplot ended without drawing the residual plots into it (the image is empty)",
       {},
       {},
       "",
       kIdleGnuplot},
      {"plot_through_a_link_drawn_into_its_target",
       {"P.txt", "-q", "--plot-dir", "sub"},
       0,
       "",
       {{"elsewhere.png", "old\n"}},
       {"elsewhere.png", "sub/residual_time.png", "sub/residuals.dat", "sub/residuals.gp"},
       "",
       "",
       {{"sub/residual_map.png", "../elsewhere.png"}}},
      {"seed_negative", {"P.txt", "--seed", "-1"}, 2, kSeedRange + std::string("'-1'")},
      {"seed_beyond_64_bits",
       {"P.txt", "--seed", "18446744073709551616"},
       2,
       kSeedRange + std::string("'18446744073709551616'")},
      {"readings_outside_the_probe_range",
       {"x.txt", "-q"},
       2,
       e + "x.txt:8: r_mm 4.77605065 lies outside the probe's measuring range, 0 to 0.002 mm (probe_range_mm): 288 "
           "of 288 readings do (they span 2.95877 to 6.92469 mm)",
       {{"x.txt", ExampleWithHeader("# probe_range_mm: 0.002\n")}}},
      {"probe_range_option_below_the_readings",
       {"P.txt", "--no-trace", "-q", "--probe-range-mm", "6"},
       2,
       e + "P.txt:65: r_mm 6.065184228 lies outside the probe's measuring range, 0 to 6 mm (--probe-range-mm): 56 of "
           "288 readings do"},
      {"radius_of_half_the_sphere",
       {"P.txt", "--sphere-radius-mm", "10", "-q", "-o", "c.json"},
       1,
       "sph_calibrate: not usable: d' = -10.0601 mm is more than a tenth of the sphere's radius (10 mm): with the "
       "nominal d the points lie on a sphere of radius about R0 - d' = 20.0601 mm"},
      {"temperature_leaves_d_prime_uncertain_by_a_millimetre",
       {"P.txt", "--no-trace", "-q", "--sphere-temperature-c", "100", "--sphere-cte-per-k", "1e-3",
        "--sphere-temperature-u-c", "50", "-o", "c.json"},
       1,
       "sph_calibrate: not usable: d_prime has a combined standard uncertainty of 1005 um as a displacement (U = 2010 "
       "um, k = 2.00), most of it from sphere temperature (1005 um)"},
      {"quiet_not_usable_says_why",
       {"P.txt", "--effects", "phi_wobble", "--phi-wobble-pivot-mm", "10000", "-q"},
       1,
       "sph_calibrate: not usable: the data do not determine a (std 17.5 um), beta (std 4.74e+03 um)"},
      {"drift_of_readings_all_at_one_time",
       {"x.txt", "--effects", "probe_drift", "-q"},
       1,
       "sph_calibrate: not usable: the data do not determine probe_drift.t1 (no information at all), "
       "probe_drift.t2 (no information at all)",
       {{"x.txt", ExampleAtOneTime()}}},
      {"too_few_samples_for_the_trace",
       {"x.txt", "-q"},
       2,
       e + "x.txt: 11 samples are too few to trace the residual: its 5-fold cross-validation fits the 7 errors and 3 "
           "centre coordinates for each of 1 setup(s) (10 parameters) to the samples outside each fold, here as few "
           "as 8 (a fold leaves out up to 3), and a fit needs more samples than parameters: at least 14 samples are "
           "needed; the seven errors alone (--no-trace) need more than 10",
       {{"x.txt", ExampleSamples(11)}}},
      {"too_few_samples_for_the_seven_errors", {"x.txt", "--no-trace", "-q"}, 1, "", {{"x.txt", ExampleSamples(11)}}},
      // What a few samples determine is usable against a requirement that says so; by default they fall
      // short of what the set-up can reach.
      {"few_samples_trace_what_they_can",
       {"x.txt", "-q", "--max-std-um", "10"},
       0,
       "",
       {{"x.txt", ExampleSamples(20)}}},
      {"few_samples_fall_short_of_the_default_requirement",
       {"x.txt", "-q"},
       1,
       "sph_calibrate: not usable: the readings determine alpha to ",
       {{"x.txt", ExampleSamples(20)}}},
      {"few_samples_of_four_orientations_trace_what_they_can",
       {"x.txt", "-q", "--max-std-um", "10"},
       0,
       "",
       {{"x.txt", SeparationEvery(20)}}},
      {"too_few_samples_for_the_effects_given",
       {"x.txt", "-q", "--effects", "theta_encoder"},
       2,
       e + "x.txt: 20 samples are too few to trace the residual: its 5-fold cross-validation fits the seven-error "
           "model and theta_encoder (18 parameters) to the samples outside each fold, here as few as 16 (a fold leaves "
           "out up to 4), and a fit needs more samples than parameters: at least 24 samples are needed",
       {{"x.txt", ExampleSamples(20)}}},
      {"validate_a_file_of_another_probe_offset",
       {"P.txt", "-q", "--validate", "v.txt"},
       2,
       e + "v.txt: probe_offset_mm 30 differs from the calibration's 25: the calibration belongs to another probe "
           "set-up",
       {{"v.txt", ExampleWithHeader("", "30")}}},
      // An earlier calibration to compare with: a calibration file of this set-up, else refused
      // before anything is written; the comparison itself never changes the exit code.
      {"compare_a_points_file",
       {"P.txt", "-q", "--no-trace", "--json", "r.json", "--compare", "P.txt"},
       2,
       e + "P.txt: not valid JSON"},
      {"compare_not_a_calibration_file",
       {"P.txt", "-q", "--no-trace", "--json", "r.json", "--compare", "x.json"},
       2,
       e + "x.json: not an sph calibration file (field \"format\" must be \"sph-calibration\")",
       {{"x.json", R"({"format": "sph-truth", "format_version": 1})"}}},
      {"compare_a_calibration_in_other_units",
       {"P.txt", "-q", "--no-trace", "--json", "r.json", "--compare", "c.json"},
       2,
       e + "c.json: field 'geometry.alpha.unit' must be \"deg\"",
       {{"c.json", R"({"format": "sph-calibration", "format_version": 1, "probe_offset_mm": 25, "effects": [],
          "geometry": {"alpha": {"value": 0.0003, "unit": "rad"}}})"}}},
      {"compare_a_calibration_of_another_probe_offset",
       {"v.txt", "-q", "--no-trace", "--json", "r.json", "--compare", "cal.json"},
       2,
       e + "cal.json: field 'probe_offset_mm' is 25 mm, this calibration's nominal d is 30 mm: the seven errors of "
           "another nominal d are not comparable",
       {{"v.txt", ExampleWithHeader("", "30")}}},
      {"compare_missing",
       {"P.txt", "-q", "--no-trace", "--compare", "none.json"},
       2,
       e + "none.json: cannot open for reading"},
      {"output_is_the_compare_input",
       {"P.txt", "--compare", "cal.json", "-o", "cal.json"},
       2,
       e + "--output cal.json is also the input --compare cal.json"},
      {"compare_written",
       {"P.txt", "--no-trace", "-q", "--compare", "cal.json", "--json", "r.json"},
       0,
       "",
       {},
       {"r.json"}},
      // What the calibration is told besides the readings: names and units checked, each named.
      {"fix_unknown_parameter",
       {"P.txt", "--fix", "d_primo"},
       2,
       e + "--fix d_primo: unknown parameter 'd_primo'; a parameter is one of the seven errors"},
      {"fix_value_without_unit",
       {"P.txt", "--fix", "d_prime=-0.062"},
       2,
       e + "--fix d_prime=-0.062: the value of d_prime needs its unit in the name: d_prime_mm or _um"},
      {"fix_angle_in_mm",
       {"P.txt", "--fix", "alpha_mm=0.001"},
       2,
       e + "--fix alpha_mm=0.001: alpha is an angle: give it in deg, arcsec or urad"},
      {"fix_beyond_the_parameters_range",
       {"P.txt", "--no-trace", "--fix", "alpha_deg=100"},
       2,
       e + "--fix alpha_deg=100: alpha: must be >= -10 and <= 10 deg, got 100"},
      {"prior_without_uncertainty",
       {"P.txt", "--prior", "alpha_deg=0.02"},
       2,
       e + "--prior alpha_deg=0.02: expected NAME_UNIT=VALUE,U"},
      {"prior_uncertainty_negative",
       {"P.txt", "--prior", "alpha_deg=0.02,-0.001"},
       2,
       e + "--prior alpha_deg=0.02,-0.001: the standard uncertainty of alpha: must be >= 5.72958e-11 and <= 10 deg, "
           "got -0.001"},
      // A prior's standard uncertainty in the range its parameter's values have, and above what any
      // reading resolves.
      {"prior_uncertainty_beyond_the_parameters_range",
       {"P.txt", "--no-trace", "--prior", "alpha_deg=0.02,1e200", "--sphere-radius-u-um", "1", "-o", "c.json"},
       2,
       e + "--prior alpha_deg=0.02,1e200: the standard uncertainty of alpha: must be >= 5.72958e-11 and <= 10 deg, "
           "got 1e200"},
      {"prior_uncertainty_below_any_resolution",
       {"P.txt", "--no-trace", "--prior", "alpha_deg=0.02,1e-300"},
       2,
       e + "--prior alpha_deg=0.02,1e-300: the standard uncertainty of alpha: must be >= 5.72958e-11 and <= 10 deg, "
           "got 1e-300"},
      // A prior the readings reject: not usable, no calibration file.
      {"prior_rejected_by_the_readings",
       {"P.txt", "--no-trace", "--prior", "alpha_deg=0.03,1e-6", "-o", "c.json"},
       1,
       "sph_calibrate: warning: the readings reject --prior alpha_deg=0.03,1e-06: without it they give "
       "alpha_deg=0.02022,0.00019, stated alpha_deg=0.03,1e-06"},
      // A fixed value or a prior of an effect's parameter states that the effect exists: refused
      // where the calibration's model cannot have it.
      {"effect_fix_without_trace",
       {"P.txt", "--no-trace", "--fix", "theta_encoder.c2_arcsec=5"},
       2,
       e + "--fix theta_encoder.c2_arcsec=5: theta_encoder.c2 is a parameter of the effect theta_encoder, which a "
           "calibration of the seven errors alone (--no-trace) does not have: the statement applies to nothing"},
      {"effect_prior_without_trace",
       {"P.txt", "--no-trace", "--prior", "theta_encoder.c2_arcsec=5,1"},
       2,
       e + "--prior theta_encoder.c2_arcsec=5,1: theta_encoder.c2 is a parameter of the effect theta_encoder"},
      {"effect_prior_outside_the_fixed_model",
       {"P.txt", "--effects", "probe_drift", "--prior", "theta_encoder.c2_arcsec=5,1"},
       2,
       e + "--prior theta_encoder.c2_arcsec=5,1: theta_encoder.c2 is a parameter of the effect theta_encoder, which "
           "the fixed model --effects probe_drift does not have: the statement applies to nothing; add "
           "theta_encoder to --effects"},
      {"header_effect_fix_without_trace",
       {"x.txt", "--no-trace"},
       2,
       e + "fix theta_encoder.c2_arcsec=5 (the header of x.txt): theta_encoder.c2 is a parameter of the effect "
           "theta_encoder",
       {{"x.txt", ExampleWithHeader("# fix: theta_encoder.c2_arcsec=5\n")}}},
      {"form_bound_without_trace",
       {"P.txt", "--no-trace", "--sphere-form-rms-um", "0.02"},
       2,
       "--no-trace excludes --sphere-form-rms-um"},
      {"sphere_form_of_a_setup_of_unknown_orientation",
       {"x.txt", "--sphere-form", "f.json"},
       2,
       e + "f.json: holds the form of the reference sphere of x.txt, but every setup of that sphere is of unknown "
           "orientation (mount_rotation_deg@<setup>: unknown): the known form applies to none of them",
       {{"x.txt", ExampleWithHeader("# mount_rotation_deg@0: unknown\n")}, {"f.json", FormFile("20")}}},
      {"form_bound_of_a_setup_of_unknown_orientation",
       {"x.txt", "--sphere-form-rms-um", "0.02"},
       2,
       e + "--sphere-form-rms-um 0.02: every setup of the reference sphere is of unknown orientation",
       {{"x.txt", ExampleWithHeader("# mount_rotation_deg@0: unknown\n")}}},
      // Header keys of the whole file with a setup's suffix, at their line.
      {"header_fix_with_a_setup_suffix",
       {"x.txt", "--no-trace"},
       2,
       e + "x.txt:4: header key 'fix@0': fix belongs to the whole file and takes no setup suffix (@0)",
       {{"x.txt", ExampleWithHeader("# fix@0: alpha\n")}}},
      {"header_form_bound_with_a_setup_suffix",
       {"x.txt"},
       2,
       e + "x.txt:4: header key 'sphere_form_rms_um@0': sphere_form_rms_um belongs to the whole file",
       {{"x.txt", ExampleWithHeader("# sphere_form_rms_um@0: 0.02\n")}}},
      // The options' own conflicts are the options', not the points file's.
      {"fixed_and_informed",
       {"P.txt", "--no-trace", "--fix", "alpha", "--prior", "alpha_deg=0.02,0.001"},
       2,
       e + "calibration options: alpha is both held and given a prior"},
      {"held_twice_by_the_options",
       {"P.txt", "--no-trace", "--fix", "alpha", "--fix", "alpha"},
       2,
       e + "calibration options: alpha is held twice"},
      {"two_priors_by_the_options",
       {"P.txt", "--no-trace", "--prior", "alpha_deg=0.02,0.001", "--prior", "alpha_deg=0.03,0.001"},
       2,
       e + "calibration options: alpha has two priors"},
      {"header_fix_held_twice_at_its_line",
       {"x.txt", "--no-trace"},
       2,
       e + "x.txt:4: fix: alpha is held twice",
       {{"x.txt", h + "# fix: alpha alpha\n0 7.5 4.8\n"}}},
      {"header_priors_twice_at_their_line",
       {"x.txt", "--no-trace"},
       2,
       e + "x.txt:4: prior: alpha has two priors",
       {{"x.txt", h + "# prior: alpha_deg=0.02,0.001 alpha_deg=0.03,0.001\n0 7.5 4.8\n"}}},
      {"header_fix_unknown_at_its_line",
       {"x.txt", "--no-trace"},
       2,
       e + "x.txt:4: fix: unknown parameter 'gamma'",
       {{"x.txt", h + "# fix: gamma\n0 7.5 4.8\n"}}},
      {"header_prior_without_unit_at_its_line",
       {"x.txt", "--no-trace"},
       2,
       e + "x.txt:4: prior: the value of alpha needs its unit in the name",
       {{"x.txt", h + "# prior: alpha=0.02,0.001\n0 7.5 4.8\n"}}},
      {"robust_loss_with_the_trace",
       {"P.txt", "--robust-loss", "huber"},
       2,
       e + "--robust-loss keeps every reading at a weight"},
      {"robust_loss_unknown", {"P.txt", "--no-trace", "--robust-loss", "tukey"}, 2, "--robust-loss: tukey not in"},
      {"robust_scale_without_loss",
       {"P.txt", "--no-trace", "--robust-scale-sigma", "2"},
       2,
       "--robust-scale-sigma requires --robust-loss"},
      {"robust_scale_not_a_number",
       {"P.txt", "--no-trace", "--robust-loss", "huber", "--robust-scale-sigma", "nan"},
       2,
       "--robust-scale-sigma: must be >= 0.01 and <= 100, got nan"},
      {"fix_prior_robust_accepted",
       {"P.txt", "--no-trace", "-q", "--fix", "d_prime_mm=-0.062", "--prior", "alpha_deg=0.02,0.0005", "--robust-loss",
        "cauchy", "--robust-scale-sigma", "3"},
       0,
       ""},
      // Header text is copied into every report: UTF-8 or refused at its line before any fit.
      {"latin1_header_value_refused_at_its_line",
       {"x.txt", "--no-trace", "-o", "c.json", "--json", "j.json", "--report", "r.html"},
       2,
       e + "x.txt:4: operator: 'caf\\xE9' is not UTF-8 text (the byte 0xE9 at character 4): save the file as "
           "UTF-8, for the reports copy the header's text",
       {{"x.txt", ExampleWithHeader("# operator: caf\xE9\n")}}},
      {"utf8_header_value_kept",
       {"x.txt", "--no-trace", "--json", "j.json"},
       0,
       "",
       {{"x.txt", ExampleWithHeader("# operator: caf\xC3\xA9\n")}},
       {"j.json"},
       "",
       "",
       {},
       {{"-", "operator: caf\xC3\xA9\n"}, {"j.json", "\"operator\": \"caf\xC3\xA9\""}}},
      // A file's escape sequences (retitle, clear the screen) are printed as text.
      {"escape_sequences_in_the_header_printed_escaped",
       {"x.txt", "--no-trace"},
       0,
       "",
       {{"x.txt", ExampleWithHeader("# operator: \x1b]0;pwned\x07\x1b[2J\xC2\x9B\n")}},
       {},
       "",
       "",
       {},
       {{"-", "operator: \\u001b]0;pwned\\u0007\\u001b[2J\\u009b\n"}}},
      {"escape_sequences_in_json_on_standard_output",
       {"x.txt", "--no-trace", "-q", "--json", "-"},
       0,
       "",
       {{"x.txt", ExampleWithHeader("# operator: \x1b]0;pwned\x07\x7F\n")}},
       {},
       "",
       "",
       {},
       {{"-", "\"operator\": \"\\u001b]0;pwned\\u0007\\u007f\""}}},
      // A key of 3000 characters: the report's first column holds at most 30em, a longer word breaks.
      {"long_metadata_key_wraps_in_html",
       {"x.txt", "--no-trace", "-q", "--report", "r.html"},
       0,
       "",
       {{"x.txt", ExampleWithHeader("# " + std::string(3000, 'k') + ": v\n")}},
       {"r.html"},
       "",
       "",
       {},
       {{"r.html", "td:first-child { max-width: 30em; overflow-wrap: break-word; }"}}},
      // An output the user may not write is not replaced, as cp refuses it.
      {"read_only_report_not_replaced",
       {"P.txt", "--no-trace", "-q", "--report", "r.html"},
       2,
       "(mode 0444): refusing to replace a file that may not be written; make it writable or give another name",
       {{"r.html", "an old report\n"}},
       {},
       "",
       "",
       {},
       {},
       {"r.html"}},
      {"read_only_calibration_file_not_replaced",
       {"P.txt", "--no-trace", "-q", "-o", "c.json"},
       2,
       e + "--output c.json: cannot write: ",
       {{"c.json", "{}\n"}},
       {},
       "",
       "",
       {},
       {},
       {"c.json"}},
      {"sphere_form_file_without_a_radius",
       {"P.txt", "--sphere-form", "f.json"},
       2,
       e + "f.json: states no sphere_radius_mm, so it cannot be told whether its form is that of the sphere of P.txt "
           "(sphere_radius_mm 20 mm): the known form belongs to its own sphere",
       {{"f.json", [] {
           std::string f = FormFile("20");
           const std::string radius = "\"sphere_radius_mm\": 20, ";
           return f.erase(f.find(radius), radius.size());
         }()}}},
      // Harmonics of theta that 8 angles cannot resolve (orders 4 to 8) are marked, not printed as numbers.
      {"harmonics_the_pattern_cannot_resolve_marked",
       {"x.txt"},
       0,
       "",
       {{"x.txt", ExampleAtEightThetas()}},
       {},
       "",
       "",
       {},
       {{"-", " 3: 0.0"}, {"-", " 4: unresolved 5: unresolved 6: unresolved 7: unresolved 8: unresolved\n"}}},
      // A probe that reads the other way: the cause named.
      {"probe_reading_the_other_way_named",
       {"x.txt", "--no-trace"},
       1,
       "",
       {{"x.txt", ExampleReadingTheOtherWay()}},
       {},
       "",
       "",
       {},
       {{"-", "why: likely cause: the probe's reading runs the other way (with r taken as 2 x median(r) - r"}}},
      // Commas: a CSV export, a decimal comma.
      {"comma_separated_values_named",
       {"x.txt"},
       2,
       e + "x.txt:4: expected 3 columns (theta_deg phi_deg r_mm), found 1 (the line holds commas: a points file "
           "separates its values by spaces or tabs, and a decimal point is '.')",
       {{"x.txt", h + "0,7.5,4.8\n"}}},
      {"decimal_comma_named",
       {"x.txt"},
       2,
       e + "x.txt:4: column phi_deg: '7,5' is not a number (the line holds commas",
       {{"x.txt", h + "0 7,5 4,8\n"}}},
  };
}
INSTANTIATE_TEST_SUITE_P(Calibrate, CalibrateMatrix, ::testing::ValuesIn(CalibrateCases()), CaseName);

// ---- sph_simulate ---------------------------------------------------------------------------------

class SimulateMatrix : public Matrix {};
TEST_P(SimulateMatrix, Case) { Check(SPH_SIMULATE); }

std::vector<MatrixCase> SimulateCases() {
  const std::string e = "sph_simulate: error: ";
  return {
      {"radius_too_large",
       {"--sphere-radius-mm", "1e308"},
       2,
       "--sphere-radius-mm: must be > 0 and <= 1000 mm, got 1e308"},
      {"alpha_too_large", {"--alpha-deg", "1e308"}, 2, "--alpha-deg: must be >= -10 and <= 10 deg, got 1e308"},
      {"a_too_large", {"--a-mm", "-11"}, 2, "--a-mm: must be >= -10 and <= 10 mm, got -11"},
      {"d_prime_beyond_d",
       {"--d-prime-mm", "30"},
       2,
       e + "--d-prime-mm 30: the error of the probe zero distance must be smaller than the distance itself"},
      {"noise_infinite", {"--noise-r-um", "inf"}, 2, "--noise-r-um: must be >= 0 and <= 1000 um, got inf"},
      {"noise_negative",
       {"--noise-theta-arcsec", "-1"},
       2,
       "--noise-theta-arcsec: must be >= 0 and <= 3600 arcsec, got -1"},
      {"sample_period_too_long",
       {"--sample-period-s", "1e308"},
       2,
       "--sample-period-s: must be >= 0 and <= 86400 s, got 1e308"},
      {"grid_too_large",
       {"--theta-steps", "1000000", "--phi-steps", "1000000"},
       2,
       e + "--theta-steps 1000000 x --phi-steps 1000000 is a grid of 1000000000000 points; at most 10000000 are "
           "simulated"},
      {"steps_zero", {"--theta-steps", "0"}, 2, "--theta-steps: Value 0 not in range"},
      {"effect_too_large",
       {"--effect-arcsec", "theta_encoder.c2=1e308"},
       2,
       e + "--effect-arcsec theta_encoder.c2=1e308: must be >= -3600 and <= 3600 arcsec, got 1e308"},
      {"effect_not_a_number",
       {"--effect-um", "probe_drift.t1=abc"},
       2,
       e + "--effect-um probe_drift.t1=abc: 'abc' is not a number"},
      {"effect_unknown",
       {"--effect-um", "probe_heat.t1=1"},
       2,
       e + "--effect-um probe_heat.t1=1: unknown effect 'probe_heat'"},
      {"effect_wrong_unit",
       {"--effect-um", "theta_encoder.c2=1"},
       2,
       "theta_encoder is an angle; give it with --effect-arcsec"},
      {"effect_given_twice",
       {"--effect-um", "probe_drift.t1=1", "--effect-um", "probe_drift.t1=2"},
       2,
       "is given twice"},
      {"effect_malformed", {"--effect-arcsec", "theta_encoder"}, 2, "expected id.param=value"},
      {"form_too_large", {"--form-um", "3,2,1e308"}, 2, e + "--form-um 3,2,1e308: must be >= -1000 and <= 1000 um"},
      {"form_bad_degree", {"--form-um", "30,2,0.1"}, 2, "expected l,m,amplitude_um with 0 <= l <= 20 and |m| <= l"},
      // sscanf read a hexadecimal amplitude (0x1p-3 um)
      {"form_hex_amplitude", {"--form-um", "2,0,0x1p-3"}, 2, "--form-um 2,0,0x1p-3: expected l,m,amplitude_um"},
      {"outlier_fraction_above_one",
       {"--outlier-fraction", "2"},
       2,
       "--outlier-fraction: must be >= 0 and <= 1, got 2"},
      {"mount_rotation_without_setup",
       {"--mount-rotation-deg", "0,0,90"},
       2,
       e + "--mount-rotation-deg '0,0,90': expected SETUP:rx,ry,rz (a setup id and a rotation vector in deg, axis "
           "times angle)"},
      {"mount_rotation_not_a_number",
       {"--mount-rotation-deg", "0:0,x,90"},
       2,
       e + "--mount-rotation-deg '0:0,x,90': ry: 'x' is not a number"},
      {"mount_rotation_too_large",
       {"--mount-rotation-deg", "0:0,0,1e308"},
       2,
       e + "--mount-rotation-deg '0:0,0,1e308': rz: must be >= -360 and <= 360 deg, got 1e308"},
      {"mount_rotation_two_values",
       {"--mount-rotation-deg", "0:0,90"},
       2,
       e + "--mount-rotation-deg '0:0,90': expected"},
      {"mount_rotation_setup_not_an_integer",
       {"--mount-rotation-deg", "a:0,0,90"},
       2,
       e + "--mount-rotation-deg 'a:0,0,90': setup: 'a' is not an integer"},
      {"mount_rotation_setup_missing",
       {"--center-mm", "2,0,0", "--center-mm", "0,2,0", "--mount-rotation-deg", "2:0,0,90"},
       2,
       e + "--mount-rotation-deg '2:0,0,90': setup 2 does not exist (the setups are 0 to 1, one per --center-mm)"},
      {"mount_rotation_given_twice",
       {"--mount-rotation-deg", "0:0,0,90", "--mount-rotation-deg", "0:0,0,90"},
       2,
       e + "--mount-rotation-deg '0:0,0,90': setup 0 is given twice"},
      {"other_sphere_without_setup",
       {"--other-sphere-radius-mm", "10"},
       2,
       e + "--other-sphere-radius-mm '10': expected SETUP:R (a setup id and a radius in mm)"},
      {"other_sphere_radius_not_a_number",
       {"--center-mm", "2,0,0", "--center-mm", "2,0,0", "--other-sphere-radius-mm", "1:ten"},
       2,
       e + "--other-sphere-radius-mm '1:ten': radius: 'ten' is not a number"},
      {"other_sphere_radius_negative",
       {"--center-mm", "2,0,0", "--center-mm", "2,0,0", "--other-sphere-radius-mm", "1:-10"},
       2,
       e + "--other-sphere-radius-mm '1:-10': radius: must be > 0 and <= 1000 mm, got -10"},
      {"other_sphere_setup_missing",
       {"--other-sphere-radius-mm", "1:10"},
       2,
       e + "--other-sphere-radius-mm '1:10': setup 1 does not exist (the setups are 0 to 0, one per --center-mm)"},
      {"other_sphere_given_twice",
       {"--center-mm", "2,0,0", "--center-mm", "2,0,0", "--other-sphere-radius-mm", "1:10", "--other-sphere-radius-mm",
        "1:12"},
       2,
       e + "--other-sphere-radius-mm '1:12': setup 1 is given twice"},
      {"mount_unknown_not_an_integer",
       {"--mount-unknown", "x"},
       2,
       e + "--mount-unknown 'x': setup: 'x' is not an integer"},
      {"mount_unknown_setup_missing",
       {"--mount-unknown", "-1"},
       2,
       e + "--mount-unknown '-1': setup -1 does not exist"},
      {"flat_depth_zero",
       {"--form-flat-um", "0,1,0,0"},
       2,
       e + "--form-flat-um '0,1,0,0': depth_um: must be > 0 and <= 1000 um, got 0"},
      {"flat_depth_infinite",
       {"--form-flat-um", "inf,1,0,0"},
       2,
       e + "--form-flat-um 'inf,1,0,0': depth_um: 'inf' is not a finite number"},
      {"flat_no_direction",
       {"--form-flat-um", "0.5,0,0,0"},
       2,
       e + "--form-flat-um '0.5,0,0,0': the direction nx,ny,nz has no length"},
      {"flat_three_values",
       {"--form-flat-um", "0.5,1,0"},
       2,
       e + "--form-flat-um '0.5,1,0': expected depth_um,nx,ny,nz"},
      {"flat_direction_too_long",
       {"--form-flat-um", "0.5,1e308,0,0"},
       2,
       e + "--form-flat-um '0.5,1e308,0,0': nx: must be >= -1e+06 and <= 1e+06, got 1e308"},
      {"bump_width_zero",
       {"--form-bump-um", "0.2,0,0,0,1"},
       2,
       e + "--form-bump-um '0.2,0,0,0,1': width_deg: must be > 0 and <= 180 deg, got 0"},
      {"bump_height_too_large",
       {"--form-bump-um", "1e308,5,0,0,1"},
       2,
       e + "--form-bump-um '1e308,5,0,0,1': height_um: must be >= -1000 and <= 1000 um, got 1e308"},
      {"bump_not_a_number",
       {"--form-bump-um", "0.2,5,0,z,1"},
       2,
       e + "--form-bump-um '0.2,5,0,z,1': ny: 'z' is not a number"},
      {"bump_trailing_comma",
       {"--form-bump-um", "0.2,5,0,0,1,"},
       2,
       e + "--form-bump-um '0.2,5,0,0,1,': expected height_um,width_deg,nx,ny,nz"},
      {"bump_larger_than_the_sphere",
       {"--sphere-radius-mm", "0.5", "--probe-offset-mm", "5", "--form-bump-um", "-600,5,0,0,1"},
       2,
       e + "simulation: the form error (up to 600 um into the sphere) must be smaller than the sphere's radius (0.5 "
           "mm)"},
      {"scan_order_unknown",
       {"--scan-order", "spiral"},
       2,
       e + "--scan-order 'spiral': unknown order 'spiral' (known: rings reversed serpentine columns serpentine-columns "
           "shuffled)"},
      {"scan_order_setup_missing",
       {"--scan-order", "3:columns"},
       2,
       e + "--scan-order '3:columns': setup 3 does not exist"},
      {"scan_order_setup_not_an_integer",
       {"--scan-order", "one:columns"},
       2,
       e + "--scan-order 'one:columns': setup: 'one' is not an integer"},
      {"separation_options_written",
       {"-o",           "x.txt",           "--truth",
        "t.json",       "--center-mm",     "2,0,0",
        "--center-mm",  "0,2,0",           "--mount-rotation-deg",
        "1:0,0,90",     "--mount-unknown", "1",
        "--form-um",    "2,1,0.05",        "--form-flat-um",
        "0.3,1,0,0",    "--form-bump-um",  "0.1,4,0,0,1",
        "--scan-order", "columns",         "--scan-order",
        "1:shuffled"},
       0,
       "",
       {},
       {"x.txt", "t.json"}},
      {"center_not_a_number", {"--center-mm", "2,x,0"}, 2, e + "--center-mm '2,x,0': 'x' is not a number"},
      {"center_too_far",
       {"--center-mm", "2,0,1e308"},
       2,
       e + "--center-mm '2,0,1e308': must be >= -1000 and <= 1000 mm"},
      {"center_missing_part", {"--center-mm", "2,0"}, 2, e + "--center-mm '2,0': expected x,y,z in mm"},
      {"ray_misses_the_sphere", {"--center-mm", "30,0,0"}, 2, e + "simulation: the probe ray misses the sphere"},
      {"angles_missing", {"--angles", "nope.txt"}, 2, e + "nope.txt: cannot open for reading"},
      {"angles_bad_line",
       {"--angles", "x.txt"},
       2,
       e + "x.txt:2: expected 'theta_deg phi_deg'",
       {{"x.txt", "0 45\n0 x\n"}}},
      {"angles_directory", {"--angles", "sub"}, 2, e + "sub: is a directory, not a file"},
      {"angles_of_zeros", {"--angles", "full"}, 2, e + "full:1: binary data (NUL byte): this is not a file of angles"},
      {"output_is_the_angles",
       {"-o", "a.txt", "--angles", "a.txt"},
       2,
       e + "--output a.txt is also the input --angles a.txt: an output never replaces an input"},
      {"output_and_truth_one_file", {"-o", "s", "--truth", "s"}, 2, e + "--output s and --truth s are the same file"},
      {"output_onto_block_device", {"-o", "disk"}, 2, e + "disk: is a block device: refusing to write onto it"},
      {"output_onto_full_device", {"-o", "full"}, 2, e + "full: cannot write: No space left on device"},
      {"truth_onto_full_device",
       {"-o", "x.txt", "--truth", "full"},
       2,
       e + "full: cannot write: No space left on device"},
      {"output_onto_null_device", {"-o", "null"}, 0, ""},
      {"stdout_full", {}, 2, e + "cannot write to standard output: No space left on device", {}, {}, "full"},
      {"stdout_closed_keeps_the_truth",
       {"--truth", "t.json"},
       2,
       e + "cannot write to standard output: Broken pipe",
       {{"t.json", "yesterday\n"}},
       {},
       kClosedPipe},
      {"seed_negative", {"--seed", "-1"}, 2, kSeedRange + std::string("'-1'")},
      {"seed_in_hex", {"--seed", "0x10"}, 2, kSeedRange + std::string("'0x10'")},
      {"output_and_truth_written", {"-o", "x.txt", "--truth", "t.json"}, 0, "", {}, {"x.txt", "t.json"}},
      {"probe_gain_beyond_the_range",
       {"--probe-range-mm", "1", "--effect-um", "probe_gain.u1=600", "-o", "x.txt"},
       2,
       e + "simulation: 288 of 288 distances (the first: 4.77605 mm at theta 0 deg, phi 7.5 deg, setup 0) lie beyond "
           "what the probe reads over its range 0 to 1 mm (probe_range_mm): its readings would lie outside it"},
      {"probe_gain_on_a_tiny_range",
       {"--probe-range-mm", "0.002", "--effect-um", "probe_gain.u1=1000", "-o", "x.txt"},
       2,
       e + "simulation: 288 of 288 distances"},
      {"probe_nonlinearity_on_a_small_range",
       {"--probe-range-mm", "0.1", "--effect-um", "probe_nonlinearity.u3=200", "-o", "x.txt"},
       2,
       e + "simulation: 288 of 288 distances"},
      {"probe_gain_of_half_the_range",
       {"--probe-range-mm", "2", "--effect-um", "probe_gain.u1=1000", "-o", "x.txt"},
       2,
       e + "simulation: 286 of 288 distances"},
      {"probe_gain_of_half_the_range_read",
       {"--probe-offset-mm", "21.5", "--center-mm", "0.5,0,0", "--probe-range-mm", "2", "--effect-um",
        "probe_gain.u1=1000", "-o", "x.txt"},
       0,
       "",
       {},
       {"x.txt"}},
      {"probe_response_falls",
       {"--probe-offset-mm", "20.7", "--center-mm", "0.2,0,0", "--probe-range-mm", "1", "--effect-um",
        "probe_gain.u1=-600", "-o", "x.txt"},
       2,
       e + "simulation: with probe_gain.u1 -600 um, the distance the probe reports does not rise with its reading "
           "over its range 0 to 1 mm (probe_range_mm): d(distance)/d(reading) is -0.2 at r = 0 mm"},
      {"probe_response_folds_the_own_range",
       {"--effect-um", "probe_nonlinearity.u2=1000", "-o", "x.txt"},
       2,
       e + "simulation: with probe_nonlinearity.u2 1000 um, the distance the probe reports does not rise with its "
           "reading over the readings' own range"},
      {"unknown_option", {"--sphere-radius", "20"}, 2, "The following arguments were not expected: 20 --sphere-radius"},
  };
}
INSTANTIATE_TEST_SUITE_P(Simulate, SimulateMatrix, ::testing::ValuesIn(SimulateCases()), CaseName);

// ---- sph_montecarlo -------------------------------------------------------------------------------

class MonteCarloMatrix : public Matrix {};
TEST_P(MonteCarloMatrix, Case) { Check(SPH_MONTECARLO); }

std::vector<MatrixCase> MonteCarloCases() {
  const std::string e = "sph_montecarlo: error: ";
  const std::vector<std::string> quick = {"--trials", "2", "--no-progress"};
  auto with = [&](std::vector<std::string> args) {
    args.insert(args.begin(), quick.begin(), quick.end());
    return args;
  };
  return {
      {"trials_one", {"--trials", "1"}, 2, "--trials: must be >= 2 and <= 1e+06, got 1"},
      {"trials_too_many", {"--trials", "100000000"}, 2, "--trials: must be >= 2 and <= 1e+06, got 100000000"},
      {"eccentricity_negative", with({"--eccentricities-mm", "-1"}), 2,
       e + "--eccentricities-mm: -1 is not in [0, R0)"},
      {"eccentricity_beyond_radius", with({"--eccentricities-mm", "25"}), 2,
       e + "--eccentricities-mm: 25 is not in [0, R0)"},
      {"eccentricity_not_a_number", with({"--eccentricities-mm", "x"}), 2, "--eccentricities-mm"},
      {"table3_calibration_not_studied", with({"--table3-calibration-e-mm", "-5"}), 2,
       e + "--table3-calibration-e-mm -5: Table 3 uses the study's calibrations at one of the eccentricities studied "
           "(--eccentricities-mm 0.5, 1, 1.5, 2)"},
      {"table3_calibration_between", with({"--table3-calibration-e-mm", "1.7"}), 2,
       e + "--table3-calibration-e-mm 1.7"},
      {"direction_zero", with({"--direction", "0,0,0"}), 2, e + "--direction must not be zero"},
      {"direction_bad", with({"--direction", "1,0"}), 2, e + "--direction '1,0': expected x,y,z in mm"},
      {"setups_zero", with({"--setups", "0"}), 2, "--setups: must be >= 1 and <= 100, got 0"},
      {"threads_too_many", with({"--threads", "5000"}), 2, "--threads: must be >= 0 and <= 1024, got 5000"},
      {"target_without_plan", with({"--target-std-um", "1"}), 2, e + "--target-std-um goes with --plan"},
      {"target_zero", {"--plan", "--target-std-um", "0"}, 2, "--target-std-um: must be > 0 and <= 1e+06 um, got 0"},
      {"max_std_zero", {"--plan", "--max-std-um", "0"}, 2, "--max-std-um: must be > 0 and <= 1e+06 um, got 0"},
      {"undetermined_study_reported",
       with({"--eccentricities-mm", "0", "--no-table3", "--json", "m.json", "--csv", "m.csv"}),
       0,
       "",
       {},
       {"m.json", "m.csv"}},
      {"candidate_rotation_short",
       {"--plan-orientations", "--candidate-rotation-deg", "1,2"},
       2,
       e + "--candidate-rotation-deg '1,2': expected rx,ry,rz (a rotation vector in deg, axis times angle)"},
      {"candidate_rotation_too_large",
       {"--plan-orientations", "--candidate-rotation-deg", "0,400,0"},
       2,
       e + "--candidate-rotation-deg '0,400,0': ry: must be >= -360 and <= 360 deg, got 400"},
      {"form_degree_without_plan", with({"--form-degree-max", "3"}), 2,
       "--form-degree-max requires --plan-orientations"},
      {"form_degree_one",
       {"--plan-orientations", "--form-degree-max", "1"},
       2,
       "--form-degree-max: Value 1 not in range"},
      {"plan_effect_unknown", {"--plan-orientations", "--effects", "spindle"}, 2, "--effects: spindle not in"},
      {"both_plans", {"--plan", "--plan-orientations"}, 2, "--plan excludes --plan-orientations"},
      {"alpha_too_large", with({"--alpha-deg", "1e308"}), 2, "--alpha-deg: must be >= -10 and <= 10 deg, got 1e308"},
      {"radius_zero", with({"--sphere-radius-mm", "0"}), 2, "--sphere-radius-mm: must be > 0 and <= 1000 mm, got 0"},
      {"noise_infinite", with({"--noise-r-um", "inf"}), 2, "--noise-r-um: must be >= 0 and <= 1000 um, got inf"},
      {"grid_too_large", with({"--theta-steps", "100000", "--phi-steps", "1000"}), 2,
       e + "--theta-steps 100000 x --phi-steps 1000 is a grid of 100000000 points"},
      {"angles_missing", with({"--angles", "nope.txt"}), 2, e + "nope.txt: cannot open for reading"},
      {"angles_binary",
       with({"--angles", "x.txt"}),
       2,
       e + "x.txt:1: expected 'theta_deg phi_deg'",
       {{"x.txt", std::string("\x01\x02\x03 \x04\n", 6)}}},
      {"json_is_the_angles", with({"--angles", "a.txt", "--json", "a.txt"}), 2,
       e + "--json a.txt is also the input --angles a.txt"},
      {"json_and_csv_one_file", with({"--json", "s", "--csv", "s"}), 2, e + "--json s and --csv s are the same file"},
      {"csv_onto_block_device", with({"--csv", "disk"}), 2, e + "disk: is a block device: refusing to write onto it"},
      {"csv_onto_full_device", with({"--no-table3", "--csv", "full"}), 2,
       e + "full: cannot write: No space left on device"},
      {"json_onto_directory", with({"--no-table3", "--json", "sub"}), 2,
       e + "sub: is a directory; give the name of a file"},
      {"json_into_missing_folder", with({"--no-table3", "--json", "no/m.json"}), 2,
       e + "no/m.json: cannot create a file in 'no'"},
      {"plan_json_onto_full_device",
       {"--plan", "--json", "full"},
       2,
       e + "full: cannot write: No space left on device"},
      {"plot_dir_is_a_file", with({"--no-table3", "--plot-dir", "P.txt"}), 2, e + "P.txt: cannot create the folder"},
      {"csv_onto_null_device", with({"--no-table3", "--csv", "null", "--json", "null"}), 0, ""},
      {"stdout_full",
       with({"--no-table3"}),
       2,
       e + "cannot write to standard output: No space left on device",
       {},
       {},
       "full"},
      {"stdout_full_keeps_the_csv",
       with({"--no-table3", "--csv", "m.csv"}),
       2,
       e + "cannot write to standard output: No space left on device",
       {{"m.csv", "yesterday\n"}},
       {},
       "full"},
      {"stdout_closed_keeps_the_csv",
       with({"--no-table3", "--csv", "m.csv"}),
       2,
       e + "cannot write to standard output: Broken pipe",
       {{"m.csv", "yesterday\n"}},
       {},
       kClosedPipe},
      {"plan_stdout_full_keeps_the_json",
       {"--plan", "--json", "m.json"},
       2,
       e + "cannot write to standard output: No space left on device",
       {{"m.json", "yesterday\n"}},
       {},
       "full"},
      {"plot_hangs",
       with({"--no-table3", "--plot-dir", "plots", "--plot-timeout-s", "1"}),
       2,
       e + "--plot-dir plots: gnuplot did not finish Figure 4 within 1 s and was stopped",
       {},
       {},
       "",
       kHangingGnuplot},
      {"plot_left_empty",
       with({"--no-table3", "--plot-dir", "plots"}),
       2,
       e + "plots/fig4_b_c_std.png: gnuplot ended without drawing Figure 4 into it (the image is empty)",
       {},
       {},
       "",
       kIdleGnuplot},
      {"seed_beyond_64_bits", with({"--seed", "18446744073709551616"}), 2,
       kSeedRange + std::string("'18446744073709551616'")},
      {"csv_and_json_written",
       with({"--no-table3", "--csv", "m.csv", "--json", "m.json"}),
       0,
       "",
       {},
       {"m.csv", "m.json"}},
      {"unknown_option", {"--trial", "5"}, 2, "The following arguments were not expected: 5 --trial"},
  };
}
INSTANTIATE_TEST_SUITE_P(MonteCarlo, MonteCarloMatrix, ::testing::ValuesIn(MonteCarloCases()), CaseName);

// ---- sph_measure ----------------------------------------------------------------------------------

class MeasureMatrix : public Matrix {};
TEST_P(MeasureMatrix, Case) { Check(SPH_MEASURE); }

std::vector<MatrixCase> MeasureCases() {
  const std::string e = "sph_measure: error: ";
  // A calibration file written out by hand: the seven errors (alpha in deg) and a covariance
  // in deg and mm whose (alpha, alpha), (alpha, a) and (a, alpha) entries are given.
  auto cal = [](const std::string& alpha, const std::string& var_alpha, const std::string& c01,
                const std::string& c10) {
    std::string j = R"({"format": "sph-calibration", "format_version": 1, "probe_offset_mm": 25,)"
                    R"( "geometry": {"alpha": {"value": )" +
                    alpha + R"(, "unit": "deg"},)";
    for (const char* p : {"a", "b", "c", "d_prime"})
      j += std::string(" \"") + p + R"(": {"value": 0.001, "unit": "mm"},)";
    for (const char* p : {"beta", "epsilon"}) j += std::string(" \"") + p + R"(": {"value": 0.02, "unit": "deg"},)";
    j.pop_back();
    j += R"(}, "covariance": {"parameters": ["alpha", "a", "beta", "b", "epsilon", "c", "d_prime"],)"
         R"( "units": ["deg", "mm", "deg", "mm", "deg", "mm", "mm"], "matrix": [)";
    for (int p = 0; p < 7; ++p) {
      j += p ? ", [" : "[";
      for (int q = 0; q < 7; ++q) {
        const std::string v = p == 0 && q == 0   ? var_alpha
                              : p == 0 && q == 1 ? c01
                              : p == 1 && q == 0 ? c10
                              : p == q           ? "1e-8"
                                                 : "0";
        j += (q ? ", " : "") + v;
      }
      j += "]";
    }
    return j + R"(]}, "effects": []})" + "\n";
  };
  const std::string good = cal("0.02", "1e-8", "0", "0");
  // A calibration with a form of the calibration sphere (one term, no covariance).
  std::string with_form = good.substr(0, good.find(R"(, "covariance")")) +
                          R"(, "effects": [], "sphere_form": {"normalisation": "schmidt_semi_normalised", )"
                          R"("frame": "body", "unit": "um", "terms": [{"l": 2, "m": 0, "value_um": 0.05}]}})" +
                          "\n";
  const std::string xyz = "1 0 0\n0 1 0\n0 0 1\n-1 0 0\n0 -1 0\n0 0 -1\n";
  const std::vector<std::string> quick = {"-c", "cal.json", "--uncertainty-samples", "0"};
  auto with = [&](std::vector<std::string> args) {
    args.insert(args.end(), quick.begin(), quick.end());
    return args;
  };
  return {
      {"readings_without_calibration", {"P.txt"}, 2, e + "P.txt: readings (theta, phi, r) need a calibration"},
      {"missing_file", with({"nope.txt"}), 2, e + "nope.txt: cannot open for reading"},
      {"directory", with({"sub"}), 2, e + "sub: is a directory, not a file"},
      {"calibration_by_hand_is_good", {"P.txt", "-c", "x.json", "-q"}, 0, "", {{"x.json", good}}},
      {"calibration_missing", {"P.txt", "-c", "nope.json"}, 2, e + "nope.json: cannot open for reading"},
      {"calibration_directory", {"P.txt", "-c", "sub"}, 2, e + "sub: is a directory, not a file"},
      {"calibration_not_json", {"P.txt", "-c", "x.json"}, 2, e + "x.json: not valid JSON", {{"x.json", "{[\n"}}},
      {"calibration_trailing_garbage",
       {"P.txt", "-c", "x.json"},
       2,
       e + "x.json: not valid JSON",
       {{"x.json", good + "garbage\n"}}},
      {"calibration_alpha_absurd",
       {"P.txt", "-c", "x.json"},
       2,
       e + "x.json: field 'geometry.alpha.value' is 1e+308 deg: a geometric error of the machine lies within 10 deg",
       {{"x.json", cal("1e308", "1e-8", "0", "0")}}},
      {"calibration_negative_variance",
       {"P.txt", "-c", "x.json"},
       2,
       e + "x.json: covariance.matrix: the variance of alpha is -1: a variance is finite and >= 0",
       {{"x.json", cal("0.02", "-1", "0", "0")}}},
      {"calibration_asymmetric_covariance",
       {"P.txt", "-c", "x.json"},
       2,
       e + "x.json: covariance.matrix is not symmetric: the entries of alpha and a differ",
       {{"x.json", cal("0.02", "1e-8", "5e-9", "0")}}},
      {"calibration_indefinite_covariance",
       {"P.txt", "-c", "x.json"},
       2,
       e + "x.json: covariance.matrix is not positive semi-definite",
       {{"x.json", cal("0.02", "1e-8", "2e-8", "2e-8")}}},
      {"calibration_of_zeros",
       {"P.txt", "-c", "full"},
       2,
       e + "full:1: binary data (NUL byte): this is not a calibration file"},
      {"calibration_nested_deep",
       {"P.txt", "-c", "x.json"},
       2,
       e + "x.json: arrays and objects nested deeper than 64 levels (at 'format_version[0][0][0][0][0][0][0][0][0...'",
       {{"x.json",
         [&] {
           std::string j = good;
           const std::string version = "\"format_version\": 1";
           j.replace(j.find(version), version.size(),
                     "\"format_version\": " + std::string(70000, '[') + "1" + std::string(70000, ']'));
           return j;
         }()}}},
      {"calibration_key_given_twice",
       {"P.txt", "-c", "x.json"},
       2,
       e + "x.json: key 'geometry.alpha' is given twice (JSON would keep one of them silently): give each key once",
       {{"x.json",
         [&] {
           std::string j = good;
           const std::string alpha = "\"alpha\": {\"value\": 0.02, \"unit\": \"deg\"},";
           j.replace(j.find(alpha), alpha.size(), alpha + " \"alpha\": {\"value\": 5, \"unit\": \"deg\"},");
           return j;
         }()}}},
      {"calibration_variance_beyond_the_range",
       {"P.txt", "-c", "x.json"},
       2,
       e + "x.json: covariance.matrix: the standard uncertainty of alpha is 14.1421 deg, more than any value of it "
           "(within 10 deg): not the covariance of a calibration",
       {{"x.json", cal("0.02", "200", "0", "0")}}},
      {"calibration_of_another_probe",
       with({"x.txt"}),
       2,
       e + "x.txt: probe_offset_mm 30 differs from the calibration's 25",
       {{"x.txt", "# sph-points 1\n# probe_offset_mm: 30\n0 45 4.9\n90 45 4.9\n180 45 4.9\n270 45 4.9\n"}}},
      {"xyz_empty_field",
       {"--xyz", "x.xyz"},
       2,
       e + "x.xyz:2: an empty field between commas",
       {{"x.xyz", "1,0,0\n1,2,,3\n"}}},
      {"xyz_trailing_comma", {"--xyz", "x.xyz"}, 2, e + "x.xyz:1: the line ends with a comma", {{"x.xyz", "1,0,0,\n"}}},
      {"xyz_count_mismatch",
       {"--xyz", "x.xyz"},
       2,
       e + "x.xyz:1: the count line announces 7 points, but the file holds 6",
       {{"x.xyz", "7\n" + xyz}}},
      {"xyz_binary",
       {"--xyz", "x.xyz"},
       2,
       e + "x.xyz:1: binary data (NUL byte): this is not a text file of points",
       {{"x.xyz", std::string("1\0 2 3\n", 7)}}},
      {"xyz_of_zeros", {"--xyz", "full"}, 2, e + "full:1: binary data (NUL byte): this is not a text file of points"},
      {"xyz_with_calibration",
       {"--xyz", "x.xyz", "-c", "cal.json"},
       2,
       e + "--calibration compensates readings",
       {{"x.xyz", xyz}}},
      {"xyz_too_few", {"--xyz", "x.xyz"}, 2, e, {{"x.xyz", "1 0 0\n0 1 0\n0 0 1\n"}}},
      {"xyz_beyond_any_machine",
       {"--xyz", "x.xyz"},
       2,
       e + "x.xyz: point 1 of 6 (1e+153 0 0 mm) lies beyond 1e+06 mm from the origin, which no measuring machine "
           "reaches: are the coordinates in mm?",
       {{"x.xyz", "1e153 0 0\n0 1e153 0\n0 0 1e153\n-1e153 0 0\n0 -1e153 0\n0 0 -1e153\n"}}},
      {"xyz_one_point",
       {"--xyz", "x.xyz"},
       2,
       e + "x.xyz: the 5 points are all one point (1 2 3 mm)",
       {{"x.xyz", "1 2 3\n1 2 3\n1 2 3\n1 2 3\n1 2 3\n"}}},
      {"readings_outside_the_probe_range",
       with({"x.txt"}),
       2,
       e + "x.txt:8: r_mm 4.77605065 lies outside the probe's measuring range, 0 to 0.002 mm (probe_range_mm)",
       {{"x.txt", ExampleWithHeader("# probe_range_mm: 0.002\n")}}},
      {"form_taken_off_another_sphere",
       {"x.txt", "-c", "f.json", "--subtract-sphere-form", "-q"},
       2,
       e + "x.txt: setup 0 measured another sphere (sphere_radius_mm@0: 10 mm), not the calibration sphere whose "
           "form the calibration file holds: its form cannot be taken off these points",
       {{"x.txt", ExampleWithHeader("# sphere_radius_mm@0: 10\n")}, {"f.json", with_form}}},
      {"form_taken_off_the_calibration_sphere",
       {"P.txt", "-c", "f.json", "--subtract-sphere-form", "-q", "--uncertainty-samples", "0"},
       0,
       "",
       {{"f.json", with_form}}},
      {"setup_missing", with({"P.txt", "--setup", "3"}), 2, e + "P.txt: there is no setup 3"},
      {"one_draw",
       {"P.txt", "-c", "cal.json", "--uncertainty-samples", "1"},
       2,
       e + "--uncertainty-samples: 1 draw gives no spread"},
      {"max_dilution_negative", with({"P.txt", "--max-dilution", "-1"}), 2, "--max-dilution: must be"},
      {"output_is_the_calibration", with({"P.txt", "-o", "cal.json"}), 2,
       e + "--output cal.json is also the input --calibration cal.json"},
      {"json_is_the_points", with({"P.txt", "--json", "P.txt"}), 2, e + "--json P.txt is also the input points P.txt"},
      {"report_is_the_calibration", with({"P.txt", "--report", "cal.json"}), 2,
       e + "--report cal.json is also the input --calibration cal.json"},
      {"report_and_output_one_file", with({"P.txt", "--report", "m", "-o", "m"}), 2,
       e + "--report m and --output m are the same file"},
      {"report_written", with({"P.txt", "-q", "--report", "m.html"}), 0, "", {}, {"m.html"}},
      {"plot_and_script_one_file", with({"P.txt", "--plot", "m", "--plot-script", "m"}), 2,
       e + "--plot m and --plot-script m are the same file"},
      {"output_to_stdout_beside_the_report", with({"P.txt", "-o", "-"}), 2,
       e + "the text report (-q leaves it out) and --output both write to standard output"},
      {"output_onto_block_device", with({"P.txt", "-o", "disk"}), 2,
       e + "disk: is a block device: refusing to write onto it"},
      {"output_onto_full_device", with({"P.txt", "-q", "-o", "full"}), 2,
       e + "full: cannot write: No space left on device"},
      {"plot_onto_full_device", with({"P.txt", "-q", "--plot", "full"}), 2,
       e + "full: is not a regular file: an image is written to a regular file only"},
      {"output_onto_null_device", with({"P.txt", "-q", "-o", "null", "--json", "null"}), 0, ""},
      {"output_onto_directory", with({"P.txt", "--json", "sub"}), 2,
       e + "sub: is a directory; give the name of a file"},
      {"stdout_full",
       with({"P.txt"}),
       2,
       e + "cannot write to standard output: No space left on device",
       {},
       {},
       "full"},
      {"stdout_full_keeps_the_points",
       with({"P.txt", "-o", "p.xyz"}),
       2,
       e + "cannot write to standard output: No space left on device",
       {{"p.xyz", "yesterday\n"}},
       {},
       "full"},
      {"stdout_closed_keeps_the_points",
       with({"P.txt", "-o", "p.xyz"}),
       2,
       e + "cannot write to standard output: Broken pipe",
       {{"p.xyz", "yesterday\n"}},
       {},
       kClosedPipe},
      {"plot_hangs",
       with({"P.txt", "-q", "--plot", "m.png", "--plot-timeout-s", "1"}),
       2,
       e + "m.png: gnuplot did not finish the form-error map within 1 s and was stopped",
       {},
       {},
       "",
       kHangingGnuplot},
      {"plot_left_empty",
       with({"P.txt", "-q", "--plot", "m.png", "--plot-script", "m.gp"}),
       2,
       e + "m.png: gnuplot ended without drawing the form-error map into it (the image is empty)",
       {},
       {},
       "",
       kIdleGnuplot},
      {"seed_negative", with({"P.txt", "--seed", "-1"}), 2, kSeedRange + std::string("'-1'")},
      {"outputs_written",
       with({"P.txt", "-q", "-o", "p.xyz", "--json", "m.json", "--plot-script", "m.gp"}),
       0,
       "",
       {},
       {"p.xyz", "m.json", "m.gp"}},
  };
}
INSTANTIATE_TEST_SUITE_P(Measure, MeasureMatrix, ::testing::ValuesIn(MeasureCases()), CaseName);

// A signal while gnuplot draws: the program kills gnuplot before it removes the image begun, so
// that nothing draws into it afterwards.
TEST(PlotSignal, EndsGnuplotAndLeavesNothingBehind) {
  const std::string dir = MakeTempDir("plot_signal");
  std::ofstream(dir + "/P.txt") << Example();
  ASSERT_EQ(RunProgram({SPH_CALIBRATE, "P.txt", "--no-trace", "-q", "-o", "cal.json"}, dir).code, 0);
  // Says that it started, then draws into its image (-e "png = '<name>'; ") half a second later.
  const std::string started = dir + ".started";
  const std::string gnuplot =
      "#!/bin/sh\npng=${2#*\\'}; png=${png%%\\'*}\ntouch '" + started + "'\nsleep 0.5\necho drawn > \"$png\"\n";
  const std::vector<std::string> env = {FakeGnuplot(dir, gnuplot)};
  const auto before = FolderState(dir);
  const pid_t pid = StartProgram({SPH_MEASURE, "P.txt", "-c", "cal.json", "-q", "--uncertainty-samples", "0",
                                  "--mc-max-trials", "0", "--plot", "m.png"},
                                 dir, "", env);
  ASSERT_GT(pid, 0);
  for (int i = 0; i < 2000 && ::access(started.c_str(), F_OK) != 0; ++i) ::usleep(10000);
  ASSERT_EQ(::access(started.c_str(), F_OK), 0) << "gnuplot did not start";
  ::kill(pid, SIGTERM);
  const ProgramResult r = FinishProgram(pid, dir);
  EXPECT_EQ(r.code, 128 + SIGTERM) << r.err;
  ::usleep(1000000);  // a gnuplot left running would have drawn by now
  EXPECT_EQ(FolderState(dir), before);
}

}  // namespace
}  // namespace sph::testing
