// RAII raw CAN socket (Linux SocketCAN, CAN_RAW) for the acquisition daemon and the simulator.
//
// Receive timestamps come with each frame from recvmsg() control messages: SO_TIMESTAMPING
// (hardware time when the driver gives one, else the kernel's software receive time), or
// SO_TIMESTAMP where SO_TIMESTAMPING is refused. SO_RXQ_OVFL reports how many frames the kernel
// dropped because the receive queue was full, with the next frame queued after the drops; drops
// that no frame followed are read from the socket's counter (SO_MEMINFO) by TakeDrops(). Every
// setsockopt is checked.
//
// Not exceptional, returned as status: nothing to read, the interface going down (ENETDOWN) or
// away (ENODEV, ENXIO), a TX queue that is full (ENOBUFS). Exceptional (sph::Error with the
// interface, the call and strerror(errno)): a socket that cannot be made at all.
#ifndef SPH_CAN_SOCKET_HPP_
#define SPH_CAN_SOCKET_HPP_

#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "sph/can/error_frame.hpp"
#include "sph/can/frame.hpp"

namespace sph::can {

struct CanSocketOptions {
  std::string iface;  ///< e.g. "can0", "vcan0"; at most IFNAMSIZ - 1 characters
  /// Accepted frames as (id, mask) pairs with the kEffFlag/kRtrFlag bits of <linux/can.h>
  /// (CAN_RAW_FILTER); empty: every frame.
  std::vector<std::pair<std::uint32_t, std::uint32_t>> filters;
  std::uint32_t error_mask = kDefaultErrorMask;  ///< CAN_RAW_ERR_FILTER classes; 0: no error frames
  bool receive_own = false;                      ///< CAN_RAW_RECV_OWN_MSGS: our own frames come back (with their time)
  int rcvbuf_bytes = 0;                          ///< SO_RCVBUF; 0: the kernel's default
};

/// Where a frame's time came from.
enum class TimestampSource { kHardware, kKernel, kUser };
const char* ToString(TimestampSource source);

enum class RxStatus {
  kFrame,      ///< `frame` is valid
  kNone,       ///< nothing to read now (EAGAIN) or the wait timed out
  kDown,       ///< the interface is down (ENETDOWN) or gone (ENODEV, ENXIO): wait and reopen
  kMalformed,  ///< a read of unexpected size (not CAN_MTU): counted, not a frame
};

struct RxResult {
  RxStatus status = RxStatus::kNone;
  CanFrame frame;
  int error = 0;                ///< errno for kDown
  bool own = false;             ///< a frame this socket sent (MSG_CONFIRM)
  std::uint64_t new_drops = 0;  ///< frames the kernel dropped since the last report (SO_RXQ_OVFL)
  TimestampSource source = TimestampSource::kUser;
};

enum class TxStatus { kOk, kBusy, kDown };

/// Class invariant: fd() is an open CAN_RAW socket bound to the interface.
class CanSocket {
 public:
  /// socket(PF_CAN, SOCK_RAW, CAN_RAW), the options, bind. Throws sph::Error, e.g.
  /// "vcan0: socket(PF_CAN, SOCK_RAW, CAN_RAW): Address family not supported by protocol".
  explicit CanSocket(const CanSocketOptions& options);
  ~CanSocket();
  CanSocket(CanSocket&& other) noexcept;
  CanSocket& operator=(CanSocket&& other) noexcept;
  CanSocket(const CanSocket&) = delete;
  CanSocket& operator=(const CanSocket&) = delete;

  int fd() const { return fd_; }
  const std::string& iface() const { return iface_; }
  /// kKernel when SO_TIMESTAMPING or SO_TIMESTAMP was accepted (hardware time is used per frame
  /// where present), kUser otherwise.
  TimestampSource timestamp_mode() const { return ts_mode_; }

  /// One recvmsg() without waiting.
  RxResult Receive();
  /// poll() up to `timeout_ms` (negative: forever), then Receive(). EINTR gives kNone.
  RxResult Receive(int timeout_ms);
  /// One write(); `error` gets errno when not kOk.
  TxStatus Send(const CanFrame& frame, int* error = nullptr);
  /// Frames the kernel dropped that no received frame has reported yet: the socket's drop counter
  /// (getsockopt SO_MEMINFO, SK_MEMINFO_DROPS; Linux 4.12 and later, else always 0). Call it when
  /// the queue is empty and before closing, so that drops after the last queued frame are counted.
  std::uint64_t TakeDrops();

 private:
  int fd_ = -1;
  std::string iface_;
  TimestampSource ts_mode_ = TimestampSource::kUser;
  bool timestamping_ = false;  // SO_TIMESTAMPING (else SO_TIMESTAMP)
  std::uint32_t last_drops_ = 0;
};

/// Frames newly dropped when the kernel's drop counter (32 bits, wrapping) reads `counter` after
/// `*last`, which becomes `counter`. A reading older than `*last` (a frame queued before the drops
/// that TakeDrops() already counted) gives 0 and leaves `*last`: every drop is counted once.
std::uint64_t AdvanceDropCounter(std::uint32_t* last, std::uint32_t counter);

/// Whether the interface exists and is administratively up (SIOCGIFFLAGS IFF_UP); false when
/// there is no such interface or no CAN support to ask with.
bool InterfaceIsUp(const std::string& iface);

/// The interface's bitrate [bit/s] as the kernel reports it (rtnetlink: IFLA_CAN_BITTIMING of a
/// CAN controller's driver); none for an interface without one (vcan) or that cannot be asked.
std::optional<std::uint32_t> InterfaceBitrate(const std::string& iface);

/// Whether this kernel can make CAN_RAW sockets; `why` gets strerror otherwise.
bool CanSupported(std::string* why);

}  // namespace sph::can

#endif  // SPH_CAN_SOCKET_HPP_
