// SDO frames, abort codes and the client's transfer state machine (CiA 301 §7.2.4).
#include "sph/can/sdo.hpp"

#include "sph/core/error.hpp"
#include "sph/core/text_input.hpp"
#include "sph/internal/format.hpp"

namespace sph::can {
namespace {

CanFrame Frame8(std::uint32_t id, std::uint8_t command, ObjectAddress object) {
  CanFrame f;
  f.id = id;
  f.len = 8;
  f.data[0] = command;
  f.data[1] = static_cast<std::uint8_t>(object.index & 0xFF);
  f.data[2] = static_cast<std::uint8_t>(object.index >> 8);
  f.data[3] = object.subindex;
  return f;
}

ObjectAddress AddressOf(const CanFrame& f) {
  return {static_cast<std::uint16_t>(f.data[1] | (f.data[2] << 8)), f.data[3]};
}

std::uint32_t Bytes4(const CanFrame& f) {
  return static_cast<std::uint32_t>(f.data[4]) | (static_cast<std::uint32_t>(f.data[5]) << 8) |
         (static_cast<std::uint32_t>(f.data[6]) << 16) | (static_cast<std::uint32_t>(f.data[7]) << 24);
}

void Put4(CanFrame& f, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) f.data[static_cast<std::size_t>(4 + i)] = static_cast<std::uint8_t>(v >> (8 * i));
}

bool CheckShape(const CanFrame& f, std::string* error) {
  if (f.IsRemote() || f.IsError()) {
    if (error != nullptr) *error = "a remote or error frame is no SDO frame";
    return false;
  }
  if (f.len != 8) {
    if (error != nullptr) *error = std::to_string(f.len) + " data bytes, an SDO frame has 8";
    return false;
  }
  return true;
}

// Initiate with bits n, e, s (byte 0 bits 3..0): the expedited data or the announced size.
template <typename Message>
void DecodeInitiate(const CanFrame& f, Message& m) {
  m.object = AddressOf(f);
  m.expedited = (f.data[0] & 0x02) != 0;
  m.size_indicated = (f.data[0] & 0x01) != 0;
  if (m.expedited) {
    const int n = m.size_indicated ? 4 - ((f.data[0] >> 2) & 0x03) : 4;
    m.data.assign(f.data.begin() + 4, f.data.begin() + 4 + n);
    m.size = static_cast<std::uint32_t>(n);
  } else if (m.size_indicated) {
    m.size = Bytes4(f);
  }
}

// Segment: t in bit 4, nnn in bits 3..1, c in bit 0; the data in bytes 1..7.
template <typename Message>
void DecodeSegment(const CanFrame& f, Message& m) {
  m.toggle = (f.data[0] & 0x10) != 0;
  m.last = (f.data[0] & 0x01) != 0;
  const int n = 7 - ((f.data[0] >> 1) & 0x07);
  m.data.assign(f.data.begin() + 1, f.data.begin() + 1 + n);
}

std::string FrameText(const CanFrame& f) { return ToString(f); }

}  // namespace

std::string ToString(const ObjectAddress& o) { return internal::Format("0x%04X:%02X", o.index, o.subindex); }

ObjectAddress ParseObjectAddress(const std::string& text, const std::string& what) {
  const auto colon = text.find(':');
  unsigned long long index = 0, sub = 0;
  if (colon == std::string::npos || !ParseHex(text.substr(0, colon), 0xFFFF, &index) || index == 0 ||
      !ParseHex(text.substr(colon + 1), 0xFF, &sub)) {
    throw Error(what + ": expected INDEX:SUB in hex, e.g. 0x2000:00");
  }
  return {static_cast<std::uint16_t>(index), static_cast<std::uint8_t>(sub)};
}

const char* SdoAbortName(std::uint32_t code) {
  switch (code) {  // CiA 301 §7.2.4.3.17, Table 22
    case 0x05030000:
      return "toggle bit not alternated";
    case 0x05040000:
      return "SDO protocol timed out";
    case 0x05040001:
      return "client/server command specifier not valid or unknown";
    case 0x05040002:
      return "invalid block size";
    case 0x05040003:
      return "invalid sequence number";
    case 0x05040004:
      return "CRC error";
    case 0x05040005:
      return "out of memory";
    case 0x06010000:
      return "unsupported access to an object";
    case 0x06010001:
      return "attempt to read a write only object";
    case 0x06010002:
      return "attempt to write a read only object";
    case 0x06020000:
      return "object does not exist in the object dictionary";
    case 0x06040041:
      return "object cannot be mapped to the PDO";
    case 0x06040042:
      return "the number and length of the objects to be mapped would exceed the PDO length";
    case 0x06040043:
      return "general parameter incompatibility";
    case 0x06040047:
      return "general internal incompatibility in the device";
    case 0x06060000:
      return "access failed due to a hardware error";
    case 0x06070010:
      return "data type does not match, length of service parameter does not match";
    case 0x06070012:
      return "data type does not match, length of service parameter too high";
    case 0x06070013:
      return "data type does not match, length of service parameter too low";
    case 0x06090011:
      return "sub-index does not exist";
    case 0x06090030:
      return "invalid value for parameter";
    case 0x06090031:
      return "value of parameter written too high";
    case 0x06090032:
      return "value of parameter written too low";
    case 0x06090036:
      return "maximum value is less than minimum value";
    case 0x060A0023:
      return "resource not available: SDO connection";
    case 0x08000000:
      return "general error";
    case 0x08000020:
      return "data cannot be transferred or stored to the application";
    case 0x08000021:
      return "data cannot be transferred or stored to the application because of local control";
    case 0x08000022:
      return "data cannot be transferred or stored to the application because of the present device state";
    case 0x08000023:
      return "object dictionary dynamic generation fails or no object dictionary is present";
    case 0x08000024:
      return "no data available";
    default:
      return "unknown abort code";
  }
}

std::string DescribeAbort(std::uint32_t code) {
  return internal::Format("0x%08X", code) + " (" + SdoAbortName(code) + ")";
}

std::optional<SdoServerMessage> DecodeSdoServer(const CanFrame& f, std::string* error) {
  if (!CheckShape(f, error)) return std::nullopt;
  SdoServerMessage m;
  const int scs = f.data[0] >> 5;
  switch (scs) {
    case 0:
      m.kind = SdoServerMessage::Kind::kUploadSegment;
      DecodeSegment(f, m);
      return m;
    case 1:
      m.kind = SdoServerMessage::Kind::kDownloadSegment;
      m.toggle = (f.data[0] & 0x10) != 0;
      return m;
    case 2:
      m.kind = SdoServerMessage::Kind::kInitiateUpload;
      DecodeInitiate(f, m);
      return m;
    case 3:
      m.kind = SdoServerMessage::Kind::kInitiateDownload;
      m.object = AddressOf(f);
      return m;
    case 4:
      m.kind = SdoServerMessage::Kind::kAbort;
      m.object = AddressOf(f);
      m.abort_code = Bytes4(f);
      return m;
    default:
      if (error != nullptr) {
        *error = "server command specifier " + std::to_string(scs) +
                 (scs == 7 ? " does not exist" : " (block transfer) is not supported");
      }
      return std::nullopt;
  }
}

std::optional<SdoClientMessage> DecodeSdoClient(const CanFrame& f, std::string* error) {
  if (!CheckShape(f, error)) return std::nullopt;
  SdoClientMessage m;
  const int ccs = f.data[0] >> 5;
  switch (ccs) {
    case 0:
      m.kind = SdoClientMessage::Kind::kDownloadSegment;
      DecodeSegment(f, m);
      return m;
    case 1:
      m.kind = SdoClientMessage::Kind::kInitiateDownload;
      DecodeInitiate(f, m);
      return m;
    case 2:
      m.kind = SdoClientMessage::Kind::kInitiateUpload;
      m.object = AddressOf(f);
      return m;
    case 3:
      m.kind = SdoClientMessage::Kind::kUploadSegment;
      m.toggle = (f.data[0] & 0x10) != 0;
      return m;
    case 4:
      m.kind = SdoClientMessage::Kind::kAbort;
      m.object = AddressOf(f);
      m.abort_code = Bytes4(f);
      return m;
    default:
      if (error != nullptr) {
        *error = "client command specifier " + std::to_string(ccs) +
                 (ccs == 7 ? " does not exist" : " (block transfer) is not supported");
      }
      return std::nullopt;
  }
}

CanFrame EncodeUploadRequest(int node_id, ObjectAddress object) {
  return Frame8(kSdoRequestBase + static_cast<std::uint32_t>(node_id), 0x40, object);
}

CanFrame EncodeUploadSegmentRequest(int node_id, bool toggle) {
  CanFrame f;
  f.id = kSdoRequestBase + static_cast<std::uint32_t>(node_id);
  f.len = 8;
  f.data[0] = static_cast<std::uint8_t>(0x60 | (toggle ? 0x10 : 0x00));
  return f;
}

CanFrame EncodeDownloadRequest(int node_id, ObjectAddress object, const std::vector<std::uint8_t>& data) {
  const int n = data.size() > 4 ? 4 : static_cast<int>(data.size());
  CanFrame f = Frame8(kSdoRequestBase + static_cast<std::uint32_t>(node_id),
                      static_cast<std::uint8_t>(0x20 | ((4 - n) << 2) | 0x03), object);
  for (int i = 0; i < n; ++i) f.data[static_cast<std::size_t>(4 + i)] = data[static_cast<std::size_t>(i)];
  return f;
}

CanFrame EncodeAbort(std::uint32_t cob_id, ObjectAddress object, std::uint32_t code) {
  CanFrame f = Frame8(cob_id, 0x80, object);
  Put4(f, code);
  return f;
}

CanFrame EncodeUploadExpedited(int node_id, ObjectAddress object, const std::vector<std::uint8_t>& data) {
  const int n = data.size() > 4 ? 4 : static_cast<int>(data.size());
  CanFrame f = Frame8(kSdoResponseBase + static_cast<std::uint32_t>(node_id),
                      static_cast<std::uint8_t>(0x40 | ((4 - n) << 2) | 0x03), object);
  for (int i = 0; i < n; ++i) f.data[static_cast<std::size_t>(4 + i)] = data[static_cast<std::size_t>(i)];
  return f;
}

CanFrame EncodeUploadSegmentedInitiate(int node_id, ObjectAddress object, std::uint32_t size) {
  CanFrame f = Frame8(kSdoResponseBase + static_cast<std::uint32_t>(node_id), 0x41, object);
  Put4(f, size);
  return f;
}

CanFrame EncodeUploadSegment(int node_id, bool toggle, const std::uint8_t* data, int n, bool last) {
  CanFrame f;
  f.id = kSdoResponseBase + static_cast<std::uint32_t>(node_id);
  f.len = 8;
  if (n > 7) n = 7;
  f.data[0] = static_cast<std::uint8_t>((toggle ? 0x10 : 0x00) | ((7 - n) << 1) | (last ? 0x01 : 0x00));
  for (int i = 0; i < n; ++i) f.data[static_cast<std::size_t>(1 + i)] = data[i];
  return f;
}

CanFrame EncodeDownloadResponse(int node_id, ObjectAddress object) {
  return Frame8(kSdoResponseBase + static_cast<std::uint32_t>(node_id), 0x60, object);
}

std::uint64_t LittleEndianValue(const std::vector<std::uint8_t>& bytes) {
  std::uint64_t v = 0;
  for (std::size_t i = 0; i < bytes.size() && i < 8; ++i) v |= static_cast<std::uint64_t>(bytes[i]) << (8 * i);
  return v;
}

std::vector<std::uint8_t> LittleEndianBytes(std::uint64_t value, int n) {
  std::vector<std::uint8_t> out(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) out[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(value >> (8 * i));
  return out;
}

// ------------------------------------------------------------------------------------ client
SdoClient::SdoClient(int node_id, std::int64_t timeout_ns, std::size_t max_upload_bytes)
    : node_id_(node_id), timeout_ns_(timeout_ns), max_upload_bytes_(max_upload_bytes) {}

CanFrame SdoClient::StartUpload(ObjectAddress object, std::int64_t now_ns) {
  state_ = State::kUploadInitiate;
  object_ = object;
  deadline_ns_ = now_ns + timeout_ns_;
  data_.clear();
  error_ = SdoError{};
  size_known_ = false;
  size_ = 0;
  return EncodeUploadRequest(node_id_, object);
}

CanFrame SdoClient::StartDownload(ObjectAddress object, const std::vector<std::uint8_t>& data, std::int64_t now_ns) {
  state_ = State::kDownload;
  object_ = object;
  deadline_ns_ = now_ns + timeout_ns_;
  data_.clear();
  error_ = SdoError{};
  return EncodeDownloadRequest(node_id_, object, data);
}

SdoClient::Step SdoClient::Fail(SdoError::Kind kind, std::uint32_t code, const std::string& why) {
  state_ = State::kIdle;
  data_.clear();
  error_.kind = kind;
  error_.code = code;
  Step s;
  s.status = Status::kFailed;
  if (kind == SdoError::Kind::kAborted) {
    error_.text = "the device aborted: " + DescribeAbort(code);
    return s;
  }
  error_.text = why + " (sent abort " + DescribeAbort(code) + ")";
  s.has_frame = true;
  s.frame = EncodeAbort(kSdoRequestBase + static_cast<std::uint32_t>(node_id_), object_, code);
  return s;
}

SdoClient::Step SdoClient::OnTime(std::int64_t now_ns) {
  if (state_ == State::kIdle) return {};
  if (now_ns < deadline_ns_) return {Status::kWaiting, false, {}};
  return Fail(SdoError::Kind::kTimeout, kAbortTimeout,
              internal::Format("no answer within %.0f ms", static_cast<double>(timeout_ns_) * 1e-6));
}

SdoClient::Step SdoClient::OnFrame(const CanFrame& frame) {
  if (state_ == State::kIdle || frame.id != kSdoResponseBase + static_cast<std::uint32_t>(node_id_)) return {};
  std::string why;
  const auto m = DecodeSdoServer(frame, &why);
  if (!m) return Protocol(kAbortGeneral, "malformed SDO answer " + FrameText(frame) + ": " + why);
  using Kind = SdoServerMessage::Kind;
  if (m->kind == Kind::kAbort) return Fail(SdoError::Kind::kAborted, m->abort_code, "");
  const std::int64_t next_deadline = frame.t_ns + timeout_ns_;
  switch (state_) {
    case State::kUploadInitiate: {
      if (m->kind != Kind::kInitiateUpload) {
        return Protocol(kAbortCommand, "answer " + FrameText(frame) + " is not an initiate-upload response");
      }
      if (m->object != object_) {
        return Protocol(kAbortParameterIncompatible,
                        "answer for " + ToString(m->object) + " while reading " + ToString(object_));
      }
      if (m->expedited) {
        data_ = m->data;
        state_ = State::kIdle;
        return {Status::kDone, false, {}};
      }
      size_known_ = m->size_indicated;
      size_ = m->size;
      if (size_known_ && size_ > max_upload_bytes_) {
        return Protocol(kAbortOutOfMemory, "the device announces " + std::to_string(size_) + " bytes, more than " +
                                               std::to_string(max_upload_bytes_));
      }
      state_ = State::kUploadSegment;
      toggle_ = false;
      deadline_ns_ = next_deadline;
      return {Status::kContinue, true, EncodeUploadSegmentRequest(node_id_, toggle_)};
    }
    case State::kUploadSegment: {
      if (m->kind != Kind::kUploadSegment) {
        return Protocol(kAbortCommand, "answer " + FrameText(frame) + " is not an upload segment");
      }
      if (m->toggle != toggle_) {
        return Protocol(kAbortToggleBit, "segment " + FrameText(frame) + " has toggle bit " +
                                             std::to_string(m->toggle ? 1 : 0) + ", expected " +
                                             std::to_string(toggle_ ? 1 : 0));
      }
      data_.insert(data_.end(), m->data.begin(), m->data.end());
      if (size_known_ && data_.size() > size_) {
        return Protocol(kAbortLengthHigh,
                        "the segments hold more than the announced " + std::to_string(size_) + " bytes");
      }
      if (data_.size() > max_upload_bytes_) {
        return Protocol(kAbortOutOfMemory, "the value is longer than " + std::to_string(max_upload_bytes_) + " bytes");
      }
      if (m->last) {
        if (size_known_ && data_.size() != size_) {
          return Protocol(kAbortLengthLow, "the segments hold " + std::to_string(data_.size()) +
                                               " bytes, the device announced " + std::to_string(size_));
        }
        state_ = State::kIdle;
        return {Status::kDone, false, {}};
      }
      toggle_ = !toggle_;
      deadline_ns_ = next_deadline;
      return {Status::kContinue, true, EncodeUploadSegmentRequest(node_id_, toggle_)};
    }
    case State::kDownload: {
      if (m->kind != Kind::kInitiateDownload) {
        return Protocol(kAbortCommand, "answer " + FrameText(frame) + " is not an initiate-download response");
      }
      if (m->object != object_) {
        return Protocol(kAbortParameterIncompatible,
                        "answer for " + ToString(m->object) + " while writing " + ToString(object_));
      }
      state_ = State::kIdle;
      return {Status::kDone, false, {}};
    }
    case State::kIdle:
      break;
  }
  return {};
}

}  // namespace sph::can
