// Helpers shared by the tests.
#ifndef SPH_TESTS_TEST_UTIL_HPP_
#define SPH_TESTS_TEST_UTIL_HPP_

#include <dirent.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <streambuf>
#include <vector>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <Eigen/Core>

namespace sph::testing {

/// EXPECT_PRED_FORMAT3(MatrixNear, actual, expected, tol): element-wise |a - e| <= tol, printing
/// both matrices and the difference on failure.
template <typename A, typename B>
::testing::AssertionResult MatrixNear(const char* a_expr, const char* b_expr, const char* /*tol_expr*/,
                                      const Eigen::MatrixBase<A>& a, const Eigen::MatrixBase<B>& b, double tol) {
  if (a.rows() != b.rows() || a.cols() != b.cols()) {
    return ::testing::AssertionFailure() << a_expr << " and " << b_expr << " differ in size";
  }
  const double err = (a.template cast<double>() - b.template cast<double>()).cwiseAbs().maxCoeff();
  if (err <= tol) return ::testing::AssertionSuccess();
  std::ostringstream os;
  os.precision(17);
  os << a_expr << " and " << b_expr << " differ by " << err << " > " << tol << "\n"
     << a_expr << " =\n"
     << a << "\n"
     << b_expr << " =\n"
     << b << "\ndifference =\n"
     << (a.template cast<double>() - b.template cast<double>());
  return ::testing::AssertionFailure() << os.str();
}

/// The Kolmogorov-Smirnov distance sup |F_n(x) - F(x)| of a sample from the distribution whose
/// CDF is `cdf` (the sample is sorted here). sqrt(n) D exceeds x with probability about
/// 2 exp(-2 x^2) for a sample of that distribution (1.63 at 0.01, 1.95 at 0.001).
template <typename Cdf>
double KolmogorovSmirnovDistance(std::vector<double> sample, Cdf cdf) {
  std::sort(sample.begin(), sample.end());
  const auto n = static_cast<double>(sample.size());
  double distance = 0.0;
  for (std::size_t i = 0; i < sample.size(); ++i) {
    const double f = cdf(sample[i]);
    distance = std::max({distance, f - static_cast<double>(i) / n, static_cast<double>(i + 1) / n - f});
  }
  return distance;
}

/// The whole content of a file ("" when it cannot be read).
inline std::string ReadWholeFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// The names in a folder (without "." and ".."), sorted.
inline std::vector<std::string> ListFolder(const std::string& dir) {
  std::vector<std::string> names;
  if (DIR* d = opendir(dir.c_str())) {
    while (dirent* e = readdir(d)) {
      const std::string n = e->d_name;
      if (n != "." && n != "..") names.push_back(n);
    }
    closedir(d);
  }
  std::sort(names.begin(), names.end());
  return names;
}

/// A fresh empty directory under the test's temporary directory.
inline std::string MakeTempDir(const std::string& name) {
  const std::string dir = ::testing::TempDir() + "sph_" + name + "_" + std::to_string(::getpid());
  std::string cmd = "rm -rf '" + dir + "' && mkdir -p '" + dir + "'";
  if (std::system(cmd.c_str()) != 0) ADD_FAILURE() << "cannot create " << dir;
  return dir;
}

/// A stream of `size` copies of one byte, made as it is read: what /dev/zero, or a file without
/// line breaks, gives a reader, without holding it. consumed() says how much a reader took.
class RepeatedBytes : public std::streambuf {
 public:
  RepeatedBytes(char byte, std::size_t size) : size_(size) { piece_.fill(byte); }
  std::size_t consumed() const { return handed_ - static_cast<std::size_t>(egptr() - gptr()); }

 protected:
  int_type underflow() override {
    if (gptr() < egptr()) return traits_type::to_int_type(*gptr());
    if (handed_ >= size_) return traits_type::eof();
    const std::size_t n = std::min(piece_.size(), size_ - handed_);
    setg(piece_.data(), piece_.data(), piece_.data() + n);
    handed_ += n;
    return traits_type::to_int_type(piece_[0]);
  }

 private:
  std::array<char, 4096> piece_{};
  std::size_t size_;
  std::size_t handed_ = 0;
};

}  // namespace sph::testing

#endif  // SPH_TESTS_TEST_UTIL_HPP_
