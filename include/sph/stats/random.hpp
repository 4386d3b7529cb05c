// The project's random generator: the 64-bit Mersenne Twister, specified by the C++ standard,
// turned into uniform and normal variates here rather than by the standard library's
// distributions (whose algorithms differ between implementations), so that a seed gives the same
// numbers with every compiler. The simulator, the Monte Carlo methods and the CAN device
// simulator draw from it.
#ifndef SPH_STATS_RANDOM_HPP_
#define SPH_STATS_RANDOM_HPP_

#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

namespace sph {

/// The 64-bit Mersenne Twister of the C++ standard ([rand.predef] mt19937_64): the same numbers
/// as std::mt19937_64 for the same seed (tested), with a state refill written so that the compiler
/// vectorises it. The Monte Carlo studies draw about four numbers per reading, and with the
/// standard library's refill that was a fifth of a study's time.
class MersenneTwister64 {
 public:
  static constexpr int kStateWords = 312;
  explicit MersenneTwister64(std::uint64_t seed);
  std::uint64_t operator()() {
    if (next_ == kStateWords) Refill();
    std::uint64_t z = state_[next_++];
    z ^= (z >> 29) & 0x5555555555555555ULL;
    z ^= (z << 17) & 0x71d67fffeda60000ULL;
    z ^= (z << 37) & 0xfff7eee000000000ULL;
    return z ^ (z >> 43);
  }

 private:
  void Refill();
  std::uint64_t state_[kStateWords];
  int next_ = kStateWords;
};

/// Uniform and normal variates from the 64-bit Mersenne Twister (see the file comment).
class Random {
 public:
  explicit Random(std::uint64_t seed) : engine_(seed) {}
  /// Uniform on the open interval (0, 1): (2k + 1) / 2^53 for 52 random bits k, symmetric about 1/2.
  double Uniform();
  /// Standard normal (the polar method of Marsaglia).
  double Normal();
  /// Advances the stream past one Normal() without computing it: the draws that follow are those
  /// that follow a Normal(). (The polar method draws normals in pairs; a pair whose values are both
  /// skipped costs its uniforms only, not its logarithm and square root.)
  void SkipNormal();
  /// `items` in an order drawn by Fisher-Yates from the engine's outputs (j = output mod (i + 1),
  /// a bias below 1e-13 for any size that fits in memory). std::shuffle's algorithm is the
  /// standard library's choice, and its orders differ between libraries.
  template <typename T>
  void Shuffle(std::vector<T>& items) {
    for (std::size_t i = items.size(); i > 1; --i) {
      std::swap(items[i - 1], items[static_cast<std::size_t>(engine_() % i)]);
    }
  }

 private:
  MersenneTwister64 engine_;
  // The point (u, v) of the unit disc the polar method accepted, s = u^2 + v^2.
  struct DiscPoint {
    double u, v, s;
  };
  DiscPoint DrawDiscPoint();
  static double PolarFactor(double s) { return std::sqrt(-2.0 * std::log(s) / s); }
  // The second normal of the last pair: v * PolarFactor(s) of spare_point_, computed (spare_) when
  // the first was.
  bool have_spare_ = false;
  bool spare_computed_ = false;
  double spare_ = 0.0;
  DiscPoint spare_point_{0.0, 0.0, 0.0};
};

}  // namespace sph

#endif  // SPH_STATS_RANDOM_HPP_
