// libFuzzer target: CAN frame decoding (sph/can/canopen.hpp, error_frame.hpp) and the acquisition
// pipeline that uses it. The first bytes choose a device configuration (field layouts, direction,
// multi-turn, SYNC counter, stream or points mode); the rest are frames of 12 bytes each:
//   [0] which id: SYNC, theta, phi, probe, heartbeat, EMCY, error frame or a raw 11/29-bit id
//   [1] length (mod 9) and the RTR flag   [2..9] data   [10..11] time step [0.1 ms]
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "sph/can/canopen.hpp"
#include "sph/can/error_frame.hpp"
#include "sph/can/frame.hpp"
#include "sph/can/pipeline.hpp"
#include "sph/core/error.hpp"

namespace {

using namespace sph::can;

class Bytes {
 public:
  Bytes(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}
  std::uint8_t Next() { return pos_ < size_ ? data_[pos_++] : 0; }
  std::uint32_t Next32() {
    std::uint32_t v = 0;
    for (int i = 0; i < 4; ++i) v = (v << 8) | Next();
    return v;
  }
  std::uint64_t Next64() { return (std::uint64_t{Next32()} << 32) | Next32(); }
  std::size_t Left() const { return size_ - pos_; }

 private:
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t pos_ = 0;
};

FieldLayout Layout(Bytes& in, std::uint32_t can_id) {
  const std::uint8_t b = in.Next();
  FieldLayout l;
  l.can_id = can_id;
  l.width_bytes = 1 + (b & 7);
  l.offset_byte = (b >> 3) & 7;
  l.is_signed = (b & 0x40) != 0;
  l.big_endian = (b & 0x80) != 0;
  return l;
}

void Encoder(Bytes& in, EncoderConfig& c) {
  c.field = Layout(in, c.field.can_id);
  const std::uint8_t b = in.Next();
  c.direction = (b & 1) ? -1 : 1;
  c.multi_turn = (b & 2) != 0;
  c.counts_per_rev = (b & 4) ? in.Next64() : (std::uint64_t{1} << (b >> 3));
  c.zero_offset_counts = static_cast<std::int64_t>(in.Next64());
}

// The stateless decoders on one frame: whatever they return, they must not fault.
void DecodeAll(const PipelineConfig& c, const CanFrame& f) {
  (void)DecodeSync(f, c.sync_cob_id);
  if (const auto hb = DecodeHeartbeat(f)) (void)NmtStateName(hb->state);
  if (const auto emcy = DecodeEmergency(f)) (void)DescribeEmergency(*emcy);
  (void)IsEmergencyId(f);
  if (const auto err = DecodeErrorFrame(f)) {
    if (err->text.empty()) std::abort();  // an error frame is always described
  }
  (void)DecodePosition(c.theta, f);
  (void)DecodePosition(c.phi, f);
  (void)DecodeProbe(c.probe, f);
  (void)ToString(f);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  Bytes in(data, size);
  PipelineConfig c;
  Encoder(in, c.theta);
  Encoder(in, c.phi);
  c.probe.field = Layout(in, c.probe.field.can_id);
  const std::uint8_t p = in.Next();
  if (p & 1) c.probe.status_offset_byte = in.Next() & 7;
  if (p & 2) c.probe.over_range_raw.reset();
  if (p & 4) c.probe.error_raw.push_back(static_cast<std::int64_t>(in.Next64()));
  c.probe.scale_mm_per_count = (p & 8) ? -1e-6 : 1e-6;
  const std::uint8_t s = in.Next();
  c.sync_counter_max = (s & 1) ? static_cast<std::uint8_t>(2 + in.Next() % 239) : 0;
  c.mode = (s & 2) ? Mode::kPoints : Mode::kStream;
  c.sync_period_s = (s & 4) ? 0.001 * (1 + (s >> 3)) : 0.0;
  c.heartbeat_timeout_s = (s & 8) ? 0.5 : 0.0;
  if ((s & 0x80) && c.sync_counter_max != 0) c.sync_counter_byte = {7, 7, 7};  // PDOs carry the counter

  for (std::uint8_t m : {in.Next(), in.Next()}) (void)MissedSyncs(m, static_cast<std::uint8_t>(m * 7), 240);

  std::uint64_t samples = 0;
  PipelineCounts counts;
  try {
    AcquisitionPipeline pipeline(
        c, {[&](const sph::Sample&) { ++samples; }, [](const std::string&) {}, [](LogLevel, const std::string&) {}});
    std::int64_t t_ns = 1700000000LL * 1000000000LL;
    while (in.Left() > 0) {
      const std::uint8_t which = in.Next();
      CanFrame f;
      switch (which & 7) {
        case 0:
          f.id = c.sync_cob_id;
          break;
        case 1:
          f.id = c.theta.field.can_id;
          break;
        case 2:
          f.id = c.phi.field.can_id;
          break;
        case 3:
          f.id = c.probe.field.can_id;
          break;
        case 4:
          f.id = kHeartbeatBase + (which >> 3);
          break;
        case 5:
          f.id = kEmcyBase + (which >> 3);
          break;
        case 6:
          f.id = kErrFlag | (in.Next32() & kErrMask);
          break;
        default:
          f.id = in.Next32();
          break;
      }
      const std::uint8_t len = in.Next();
      f.len = static_cast<std::uint8_t>(len % 9);
      if (len & 0x80) f.id |= kRtrFlag;
      for (auto& b : f.data) b = in.Next();
      t_ns += (std::int64_t{in.Next()} << 8 | in.Next()) * 100000;
      f.t_ns = t_ns;
      DecodeAll(c, f);
      pipeline.OnFrame(f);
      if (which == 0xFF) pipeline.OnTime(t_ns + 1000000000);
    }
    pipeline.Finish();
    counts = pipeline.counts();
  } catch (const sph::Error&) {
    return 0;  // a configuration the pipeline refuses
  }
  if (c.mode == Mode::kStream && counts.samples != samples) std::abort();
  // Every sample is a SYNC cycle, received or recovered of a SYNC that never arrived.
  if (counts.samples > counts.cycles || counts.recovered > counts.missed_syncs) std::abort();
  return 0;
}
