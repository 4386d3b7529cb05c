// One classic CAN frame as sph sees it: identifier with the Linux flag bits, up to 8 data bytes
// and the receive time. Pure data, no socket: everything in sph/can/ that decodes or encodes
// frames works on this type, so it is tested without a CAN stack.
//
// can_id layout (the same bits as struct can_frame in <linux/can.h>):
//
//   bit 31       bit 30      bit 29      bits 28..0
//   EFF (29 bit) RTR         ERR (error) identifier (11 bit in 10..0 unless EFF)
#ifndef SPH_CAN_FRAME_HPP_
#define SPH_CAN_FRAME_HPP_

#include <array>
#include <cstdint>
#include <initializer_list>
#include <string>

namespace sph::can {

inline constexpr std::uint32_t kEffFlag = 0x80000000U;  ///< extended (29 bit) identifier
inline constexpr std::uint32_t kRtrFlag = 0x40000000U;  ///< remote transmission request
inline constexpr std::uint32_t kErrFlag = 0x20000000U;  ///< error frame (class bits in the id)
inline constexpr std::uint32_t kSffMask = 0x000007FFU;  ///< standard identifier bits
inline constexpr std::uint32_t kEffMask = 0x1FFFFFFFU;  ///< extended identifier bits
inline constexpr std::uint32_t kErrMask = 0x1FFFFFFFU;  ///< error class bits
inline constexpr int kMaxDataBytes = 8;                 ///< classic CAN

/// A classic CAN frame with its receive time.
/// Class invariant (of frames made by the decoders and the socket): len <= kMaxDataBytes.
struct CanFrame {
  std::uint32_t id = 0;  ///< identifier plus kEffFlag/kRtrFlag/kErrFlag
  std::uint8_t len = 0;  ///< data length [bytes], 0..8
  std::array<std::uint8_t, kMaxDataBytes> data{};
  std::int64_t t_ns = 0;  ///< receive time since the Unix epoch [ns]; 0 when unknown

  bool IsExtended() const { return (id & kEffFlag) != 0; }
  bool IsRemote() const { return (id & kRtrFlag) != 0; }
  bool IsError() const { return (id & kErrFlag) != 0; }
  /// The bare identifier: 11 or 29 bits, flags removed.
  std::uint32_t Identifier() const { return id & (IsExtended() ? kEffMask : kSffMask); }
  /// Receive time [s] since the Unix epoch.
  double TimeS() const { return static_cast<double>(t_ns) * 1e-9; }
};

/// A data frame with a standard (11 bit) identifier; `len` bytes from `bytes` (len <= 8).
CanFrame MakeFrame(std::uint32_t id, std::initializer_list<std::uint8_t> bytes, std::int64_t t_ns = 0);

/// "181#0A0B0C" (can-utils' compact notation, as cansend takes it); see sph/can/candump_log.hpp.
std::string ToString(const CanFrame& frame);

}  // namespace sph::can

#endif  // SPH_CAN_FRAME_HPP_
