// Error frames (Linux SocketCAN, <linux/can/error.h>): the driver reports bus and controller
// problems as frames with kErrFlag set, the error classes in the id and details in the data.
//
//   id bit  class               details
//   0x001   TX timeout
//   0x002   lost arbitration    data[0] bit number
//   0x004   controller problem  data[1]: 0x01 RX overflow, 0x02 TX overflow, 0x04 RX warning,
//                               0x08 TX warning, 0x10 RX passive, 0x20 TX passive, 0x40 back to active
//   0x008   protocol violation  data[2] type (0x01 bit, 0x02 form, 0x04 stuff, 0x08 dominant bit,
//                               0x10 recessive bit, 0x20 overload, 0x40 active error, 0x80 on TX),
//                               data[3] location
//   0x010   transceiver status  data[4]
//   0x020   no ACK on transmission
//   0x040   bus off
//   0x080   bus error (may flood)
//   0x100   controller restarted
//   0x200   error counters      data[6] TX error counter, data[7] RX error counter
#ifndef SPH_CAN_ERROR_FRAME_HPP_
#define SPH_CAN_ERROR_FRAME_HPP_

#include <cstdint>
#include <optional>
#include <string>

#include "sph/can/frame.hpp"

namespace sph::can {

enum ErrorClass : std::uint32_t {
  kErrTxTimeout = 0x001,
  kErrLostArbitration = 0x002,
  kErrController = 0x004,
  kErrProtocol = 0x008,
  kErrTransceiver = 0x010,
  kErrNoAck = 0x020,
  kErrBusOff = 0x040,
  kErrBusError = 0x080,
  kErrRestarted = 0x100,
  kErrCounters = 0x200,
};

/// The error classes a daemon subscribes to (CAN_RAW_ERR_FILTER): everything but the
/// lost-arbitration and bus-error classes, which can flood a busy bus.
inline constexpr std::uint32_t kDefaultErrorMask = kErrTxTimeout | kErrController | kErrProtocol | kErrTransceiver |
                                                   kErrNoAck | kErrBusOff | kErrRestarted | kErrCounters;

/// What an error frame says.
struct ErrorFrameInfo {
  std::uint32_t classes = 0;  ///< ErrorClass bits
  bool bus_off = false;
  bool error_passive = false;                    ///< controller: RX or TX passive
  bool controller_overflow = false;              ///< controller: RX or TX buffer overflow
  std::optional<std::uint8_t> tx_error_counter;  ///< with kErrCounters
  std::optional<std::uint8_t> rx_error_counter;
  std::string text;  ///< "bus-off", "controller-problem{rx-error-warning}", ... joined by ", "
};

/// Decodes an error frame; nothing when `frame` is not one (kErrFlag clear).
std::optional<ErrorFrameInfo> DecodeErrorFrame(const CanFrame& frame);

/// An error frame with the given classes and data (for the simulator and the tests).
CanFrame MakeErrorFrame(std::uint32_t classes, std::initializer_list<std::uint8_t> data = {});

}  // namespace sph::can

#endif  // SPH_CAN_ERROR_FRAME_HPP_
