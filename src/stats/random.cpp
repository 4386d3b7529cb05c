#include "sph/stats/random.hpp"

namespace sph {

double Random::Uniform() {
  // The top 52 bits k, shifted off zero by half a unit: (k + 0.5) / 2^52 = (2k + 1) / 2^53, exact in a
  // double, lies in [2^-53, 1 - 2^-53]. (With 53 bits, k + 0.5 is not representable above 2^52 and
  // rounds to even: the largest k gave exactly 1.)
  return (static_cast<double>(engine_() >> 12) + 0.5) * 0x1.0p-52;
}

MersenneTwister64::MersenneTwister64(std::uint64_t seed) {
  state_[0] = seed;
  for (int i = 1; i < kStateWords; ++i) {
    const std::uint64_t prev = state_[i - 1];
    state_[i] = 6364136223846793005ULL * (prev ^ (prev >> 62)) + static_cast<std::uint64_t>(i);
  }
}

void MersenneTwister64::Refill() {
  // x_{i+n} = x_{i+m} ^ ((upper bit of x_i | lower 31 bits of x_{i+1}) A), n = 312, m = 156, with A
  // the multiplication by the twist matrix: a shift, and the constant when the low bit is set.
  // The first half reads words not yet replaced, the second half words the first half replaced;
  // within each, no word depends on one written in the same pass, so each loop vectorises.
  constexpr int n = kStateWords, m = 156;
  constexpr std::uint64_t kUpper = ~0ULL << 31, kLower = ~kUpper, kTwist = 0xb5026f5aa96619e9ULL;
  auto twisted = [&](std::uint64_t upper_of, std::uint64_t lower_of) {
    const std::uint64_t y = (upper_of & kUpper) | (lower_of & kLower);
    return (y >> 1) ^ (kTwist & (0ULL - (y & 1ULL)));
  };
  for (int i = 0; i < n - m; ++i) state_[i] = state_[i + m] ^ twisted(state_[i], state_[i + 1]);
  for (int i = n - m; i < n - 1; ++i) state_[i] = state_[i + m - n] ^ twisted(state_[i], state_[i + 1]);
  state_[n - 1] = state_[m - 1] ^ twisted(state_[n - 1], state_[0]);
  next_ = 0;
}

Random::DiscPoint Random::DrawDiscPoint() {
  DiscPoint p;
  do {
    p.u = 2.0 * Uniform() - 1.0;
    p.v = 2.0 * Uniform() - 1.0;
    p.s = p.u * p.u + p.v * p.v;
  } while (p.s >= 1.0 || p.s == 0.0);
  return p;
}

double Random::Normal() {
  if (have_spare_) {
    have_spare_ = false;
    return spare_computed_ ? spare_ : spare_point_.v * PolarFactor(spare_point_.s);
  }
  const DiscPoint p = DrawDiscPoint();
  const double f = PolarFactor(p.s);
  spare_ = p.v * f;
  spare_computed_ = have_spare_ = true;
  return p.u * f;
}

void Random::SkipNormal() {
  if (have_spare_) {
    have_spare_ = false;
    return;
  }
  spare_point_ = DrawDiscPoint();
  spare_computed_ = false;
  have_spare_ = true;
}

}  // namespace sph
