// CiA 301 service data objects (SDO): the frames of the default SDO channel, the abort codes, and
// a client that reads (uploads) and writes (downloads) one object at a time. Pure: frames in,
// frames out, time passed in; nothing here touches a socket, so every transfer is tested against
// scripted byte sequences.
//
// Frames (CiA 301 §7.2.4.3; predefined connection set, node id n = 1..127). Every SDO frame has
// 8 data bytes; the command specifier is in bits 7..5 of byte 0.
//
//   client -> server on 0x600 + n                 server -> client on 0x580 + n
//   ccs 2 initiate upload   40 ii ii ss 00000000  scs 2 initiate upload  4[n e s] ii ii ss dd dd dd dd
//   ccs 3 upload segment    6t 00 ...             scs 0 upload segment   [t nnn c] d1 .. d7
//   ccs 1 initiate download 2[n e s] ii ii ss dd  scs 3 initiate download 60 ii ii ss 00000000
//   ccs 4 abort             80 ii ii ss cc cc cc cc (either side; abort code little endian)
//
//   ii ii: object index, little endian; ss: sub-index.
//   Initiate, byte 0 bits 3..2 n: bytes of d that hold no data (valid when e = s = 1),
//   bit 1 e: expedited (the data is in bytes 4..7), bit 0 s: size indicated (expedited: by n;
//   segmented: bytes 4..7 are the size in bytes, little endian). §7.2.4.3.3, §7.2.4.3.6.
//   Segment (§7.2.4.3.7): t toggle bit, 0 in the first segment, alternating; nnn bytes of the 7
//   that hold no data; c = 1 in the last segment. The client's segment request carries the toggle
//   bit the server must answer with.
//   Abort (§7.2.4.3.17): code in bytes 4..7, names in SdoAbortName() (CiA 301 Table 22).
//
// Block transfer (ccs/scs 5 and 6) is not used; a server that answers with it gets an abort.
#ifndef SPH_CAN_SDO_HPP_
#define SPH_CAN_SDO_HPP_

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "sph/can/frame.hpp"

namespace sph::can {

inline constexpr std::uint32_t kSdoRequestBase = 0x600;   ///< client -> server, + node id
inline constexpr std::uint32_t kSdoResponseBase = 0x580;  ///< server -> client, + node id

/// An entry of an object dictionary: index and sub-index.
struct ObjectAddress {
  std::uint16_t index = 0;
  std::uint8_t subindex = 0;
  bool operator==(const ObjectAddress& o) const { return index == o.index && subindex == o.subindex; }
  bool operator!=(const ObjectAddress& o) const { return !(*this == o); }
};
/// "0x1018:04".
std::string ToString(const ObjectAddress& object);
/// "INDEX:SUB" in hex, with or without "0x" ("0x2000:00", "1A00:1"): index 1..0xFFFF, sub-index
/// 0..0xFF. Throws sph::Error "<what>: expected INDEX:SUB in hex, e.g. 0x2000:00" otherwise.
ObjectAddress ParseObjectAddress(const std::string& text, const std::string& what);

// CiA 301 Table 22: the abort codes this code sends or names.
inline constexpr std::uint32_t kAbortToggleBit = 0x05030000;
inline constexpr std::uint32_t kAbortTimeout = 0x05040000;
inline constexpr std::uint32_t kAbortCommand = 0x05040001;
inline constexpr std::uint32_t kAbortOutOfMemory = 0x05040005;
inline constexpr std::uint32_t kAbortUnsupportedAccess = 0x06010000;
inline constexpr std::uint32_t kAbortWriteOnly = 0x06010001;
inline constexpr std::uint32_t kAbortReadOnly = 0x06010002;
inline constexpr std::uint32_t kAbortNoObject = 0x06020000;
inline constexpr std::uint32_t kAbortNotMappable = 0x06040041;
inline constexpr std::uint32_t kAbortPdoLength = 0x06040042;
inline constexpr std::uint32_t kAbortParameterIncompatible = 0x06040043;
inline constexpr std::uint32_t kAbortLengthMismatch = 0x06070010;
inline constexpr std::uint32_t kAbortLengthHigh = 0x06070012;
inline constexpr std::uint32_t kAbortLengthLow = 0x06070013;
inline constexpr std::uint32_t kAbortNoSubindex = 0x06090011;
inline constexpr std::uint32_t kAbortInvalidValue = 0x06090030;
inline constexpr std::uint32_t kAbortGeneral = 0x08000000;
inline constexpr std::uint32_t kAbortDeviceState = 0x08000022;

/// "object does not exist in the object dictionary" for 0x06020000; "unknown abort code" else.
const char* SdoAbortName(std::uint32_t code);
/// "0x06020000 (object does not exist in the object dictionary)".
std::string DescribeAbort(std::uint32_t code);

// ------------------------------------------------------------------------------------ frames
/// What a frame on 0x580 + n says (the client's view of the server). See the file comment.
struct SdoServerMessage {
  enum class Kind { kInitiateUpload, kUploadSegment, kInitiateDownload, kDownloadSegment, kAbort };
  Kind kind = Kind::kAbort;
  ObjectAddress object;            ///< initiate and abort
  bool expedited = false;          ///< initiate upload: the data is in the frame
  bool size_indicated = false;     ///< initiate upload
  std::uint32_t size = 0;          ///< initiate upload with size indicated: the object's size [bytes]
  std::vector<std::uint8_t> data;  ///< expedited data or the segment's data
  bool toggle = false;             ///< segments
  bool last = false;               ///< upload segment: no more segments follow
  std::uint32_t abort_code = 0;
};

/// What a frame on 0x600 + n says (the server's view of the client).
struct SdoClientMessage {
  enum class Kind { kInitiateUpload, kUploadSegment, kInitiateDownload, kDownloadSegment, kAbort };
  Kind kind = Kind::kAbort;
  ObjectAddress object;
  bool expedited = false;
  bool size_indicated = false;
  std::uint32_t size = 0;
  std::vector<std::uint8_t> data;  ///< expedited download data or a download segment's data
  bool toggle = false;
  bool last = false;
  std::uint32_t abort_code = 0;
};

/// Decodes a server's SDO frame; nothing, with the reason in `error` ("3 data bytes, an SDO frame
/// has 8", "server command specifier 6 (block transfer) is not supported", ...), for any other.
/// The frame's id is not checked.
std::optional<SdoServerMessage> DecodeSdoServer(const CanFrame& frame, std::string* error = nullptr);
/// Decodes a client's SDO frame, likewise.
std::optional<SdoClientMessage> DecodeSdoClient(const CanFrame& frame, std::string* error = nullptr);

/// The client's frames to node `node_id` (on 0x600 + node_id).
CanFrame EncodeUploadRequest(int node_id, ObjectAddress object);
CanFrame EncodeUploadSegmentRequest(int node_id, bool toggle);
/// Expedited download of 1..4 bytes (`data` is truncated to 4).
CanFrame EncodeDownloadRequest(int node_id, ObjectAddress object, const std::vector<std::uint8_t>& data);
/// An abort frame on `cob_id` (0x600 + n from the client, 0x580 + n from a server).
CanFrame EncodeAbort(std::uint32_t cob_id, ObjectAddress object, std::uint32_t code);

/// The server's frames from node `node_id` (on 0x580 + node_id), for the device simulator.
CanFrame EncodeUploadExpedited(int node_id, ObjectAddress object, const std::vector<std::uint8_t>& data);
CanFrame EncodeUploadSegmentedInitiate(int node_id, ObjectAddress object, std::uint32_t size);
CanFrame EncodeUploadSegment(int node_id, bool toggle, const std::uint8_t* data, int n, bool last);
CanFrame EncodeDownloadResponse(int node_id, ObjectAddress object);

/// Little-endian unsigned value of up to 8 bytes (CiA 301 UNSIGNEDn).
std::uint64_t LittleEndianValue(const std::vector<std::uint8_t>& bytes);
/// The `n` low bytes of `value`, little endian.
std::vector<std::uint8_t> LittleEndianBytes(std::uint64_t value, int n);

// ------------------------------------------------------------------------------------ client
/// How an SDO transfer failed.
struct SdoError {
  enum class Kind {
    kNone,
    kAborted,   ///< the server sent an abort: `code` is its reason
    kProtocol,  ///< the server's answer broke the protocol: we sent abort `code`
    kTimeout,   ///< no answer in time: we sent abort 0x05040000
  };
  Kind kind = Kind::kNone;
  std::uint32_t code = 0;
  std::string text;  ///< "the device aborted: 0x06020000 (object does not exist ...)", ...
};

/// An SDO client for one node: one transfer at a time, expedited and segmented upload, expedited
/// download (CiA 301 §7.2.4.3). Each request arms a timer; an answer that breaks the protocol (a
/// frame that is no SDO frame, another command than the one expected, another object, a toggle
/// bit that did not alternate, more or less data than announced) or no answer within the timeout
/// ends the transfer with an abort sent to the server and an SdoError. Nothing of a failed upload
/// is returned. Frames on other ids are ignored.
///
/// Class invariant: at most one transfer is in progress; busy() tells.
class SdoClient {
 public:
  /// `max_upload_bytes`: a longer object is refused (abort 0x05040005).
  SdoClient(int node_id, std::int64_t timeout_ns, std::size_t max_upload_bytes = 1024);

  enum class Status {
    kIgnored,   ///< the frame is not this transfer's (other id, or no transfer in progress)
    kContinue,  ///< the transfer goes on; send `frame`
    kWaiting,   ///< nothing to do yet
    kDone,      ///< upload: data() holds the value; download: the server confirmed the write
    kFailed,    ///< error(); send `frame` when has_frame (our abort)
  };
  struct Step {
    Status status = Status::kIgnored;
    bool has_frame = false;
    CanFrame frame;
  };

  /// Starts reading `object`: returns the request to send. The timer runs from `now_ns`.
  /// Precondition: !busy().
  CanFrame StartUpload(ObjectAddress object, std::int64_t now_ns);
  /// Starts writing 1..4 bytes (expedited download). Precondition: !busy().
  CanFrame StartDownload(ObjectAddress object, const std::vector<std::uint8_t>& data, std::int64_t now_ns);

  /// A received frame; its t_ns is the time the next timer runs from.
  Step OnFrame(const CanFrame& frame);
  /// Time passes: kFailed with an abort frame once the answer is overdue, else kWaiting
  /// (kIgnored when idle).
  Step OnTime(std::int64_t now_ns);

  /// Drops the transfer without a frame (the node rebooted: it forgot it anyway).
  void Cancel() { state_ = State::kIdle; }
  bool busy() const { return state_ != State::kIdle; }
  int node_id() const { return node_id_; }
  /// The time the pending answer is due (meaningful when busy()).
  std::int64_t deadline_ns() const { return deadline_ns_; }
  ObjectAddress object() const { return object_; }
  /// The uploaded value of the last kDone upload.
  const std::vector<std::uint8_t>& data() const { return data_; }
  /// Why the last transfer failed.
  const SdoError& error() const { return error_; }

 private:
  enum class State { kIdle, kUploadInitiate, kUploadSegment, kDownload };
  Step Fail(SdoError::Kind kind, std::uint32_t code, const std::string& why);
  Step Protocol(std::uint32_t code, const std::string& why) { return Fail(SdoError::Kind::kProtocol, code, why); }

  int node_id_;
  std::int64_t timeout_ns_;
  std::size_t max_upload_bytes_;
  State state_ = State::kIdle;
  ObjectAddress object_;
  std::int64_t deadline_ns_ = 0;
  bool toggle_ = false;
  bool size_known_ = false;
  std::uint32_t size_ = 0;
  std::vector<std::uint8_t> data_;
  SdoError error_;
};

}  // namespace sph::can

#endif  // SPH_CAN_SDO_HPP_
