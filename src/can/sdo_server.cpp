// The SDO server of the simulated devices (CiA 301 §7.2.4.3).
#include "sph/can/sdo_server.hpp"

#include <algorithm>

namespace sph::can {
namespace {

std::uint32_t Key(ObjectAddress o) { return (static_cast<std::uint32_t>(o.index) << 8) | o.subindex; }

}  // namespace

void ObjectDictionary::Set(ObjectAddress object, std::vector<std::uint8_t> value, Access access, bool mappable) {
  entries_[Key(object)] = Entry{std::move(value), access, mappable};
}

void ObjectDictionary::SetUnsigned(ObjectAddress object, std::uint64_t value, int bytes, Access access, bool mappable) {
  Set(object, LittleEndianBytes(value, bytes), access, mappable);
}

const ObjectDictionary::Entry* ObjectDictionary::Find(ObjectAddress object) const {
  const auto it = entries_.find(Key(object));
  return it == entries_.end() ? nullptr : &it->second;
}

ObjectDictionary::Entry* ObjectDictionary::Find(ObjectAddress object) {
  const auto it = entries_.find(Key(object));
  return it == entries_.end() ? nullptr : &it->second;
}

std::uint64_t ObjectDictionary::Unsigned(ObjectAddress object) const {
  const Entry* e = Find(object);
  return e == nullptr ? 0 : LittleEndianValue(e->value);
}

bool ObjectDictionary::HasIndex(std::uint16_t index) const {
  const auto it = entries_.lower_bound(static_cast<std::uint32_t>(index) << 8);
  return it != entries_.end() && (it->first >> 8) == index;
}

SdoServer::SdoServer(int node_id, ObjectDictionary* od, WriteCheck check, Written written)
    : node_id_(node_id), od_(od), check_(std::move(check)), written_(std::move(written)) {}

CanFrame SdoServer::Abort(ObjectAddress object, std::uint32_t code) {
  transfer_ = Transfer::kNone;
  return EncodeAbort(kSdoResponseBase + static_cast<std::uint32_t>(node_id_), object, code);
}

CanFrame SdoServer::Write(ObjectAddress object, const std::vector<std::uint8_t>& value, const CanFrame& done) {
  transfer_ = Transfer::kNone;
  if (check_) {
    if (const std::uint32_t code = check_(object, value); code != 0) return Abort(object, code);
  }
  od_->Find(object)->value = value;  // the check may have changed the dictionary
  if (written_) written_(object);
  return done;
}

// Initiate download (CiA 301 §7.2.4.3.3): the entry must exist and be writable; expedited data
// is written at once, a segmented transfer announces its size (checked against the entry's) or not.
std::optional<CanFrame> SdoServer::InitiateDownload(const SdoClientMessage& m) {
  object_ = m.object;
  ObjectDictionary::Entry* e = od_->Find(m.object);
  if (e == nullptr) return Abort(m.object, od_->HasIndex(m.object.index) ? kAbortNoSubindex : kAbortNoObject);
  if (e->access == ObjectDictionary::Access::kReadOnly) return Abort(m.object, kAbortReadOnly);
  const std::size_t size = e->value.size();
  if (m.expedited) {
    if (m.size_indicated && m.data.size() != size) {
      return Abort(m.object, m.data.size() > size ? kAbortLengthHigh : kAbortLengthLow);
    }
    std::vector<std::uint8_t> value = m.data;
    value.resize(size);  // without a size: the entry's own length
    return Write(m.object, value, EncodeDownloadResponse(node_id_, m.object));
  }
  download_size_ = m.size_indicated ? m.size : 0;
  if (m.size_indicated && m.size != size) return Abort(m.object, m.size > size ? kAbortLengthHigh : kAbortLengthLow);
  transfer_ = Transfer::kDownload;
  buffer_.clear();
  toggle_ = false;
  return EncodeDownloadResponse(node_id_, m.object);
}

// Download segment (§7.2.4.3.5): the toggle bit alternates from 0; the answer repeats it. The
// last segment completes the value, which must be the entry's length (and the size announced).
std::optional<CanFrame> SdoServer::DownloadSegment(const SdoClientMessage& m) {
  if (m.toggle != toggle_) return Abort(object_, kAbortToggleBit);
  buffer_.insert(buffer_.end(), m.data.begin(), m.data.end());
  const std::size_t size = od_->Find(object_)->value.size();
  if (buffer_.size() > size) return Abort(object_, kAbortLengthHigh);
  CanFrame answer;
  answer.id = kSdoResponseBase + static_cast<std::uint32_t>(node_id_);
  answer.len = 8;
  answer.data[0] = static_cast<std::uint8_t>(0x20 | (toggle_ ? 0x10 : 0x00));
  toggle_ = !toggle_;
  if (!m.last) return answer;
  if (download_size_ != 0 && buffer_.size() != download_size_) {
    return Abort(object_, buffer_.size() > download_size_ ? kAbortLengthHigh : kAbortLengthLow);
  }
  if (buffer_.size() != size) return Abort(object_, kAbortLengthLow);
  return Write(object_, buffer_, answer);
}

std::optional<CanFrame> SdoServer::OnRequest(const CanFrame& frame) {
  if (frame.id != kSdoRequestBase + static_cast<std::uint32_t>(node_id_)) return std::nullopt;
  const auto m = DecodeSdoClient(frame);
  if (!m) {  // not an SDO frame the server knows: abort with the object bytes as sent
    ObjectAddress o;
    if (frame.len >= 4) o = {static_cast<std::uint16_t>(frame.data[1] | (frame.data[2] << 8)), frame.data[3]};
    return Abort(o, kAbortCommand);
  }
  using Kind = SdoClientMessage::Kind;
  if (m->kind == Kind::kAbort) {  // the client ends the transfer: no answer
    transfer_ = Transfer::kNone;
    return std::nullopt;
  }
  // A transfer in progress takes its own next segment only.
  if ((transfer_ == Transfer::kUpload && m->kind != Kind::kUploadSegment) ||
      (transfer_ == Transfer::kDownload && m->kind != Kind::kDownloadSegment) ||
      (transfer_ == Transfer::kNone && (m->kind == Kind::kUploadSegment || m->kind == Kind::kDownloadSegment))) {
    return Abort(object_, kAbortCommand);
  }
  switch (m->kind) {
    case Kind::kInitiateUpload: {
      object_ = m->object;
      const ObjectDictionary::Entry* e = od_->Find(m->object);
      if (e == nullptr) return Abort(m->object, od_->HasIndex(m->object.index) ? kAbortNoSubindex : kAbortNoObject);
      if (e->value.size() <= 4) return EncodeUploadExpedited(node_id_, m->object, e->value);
      transfer_ = Transfer::kUpload;
      buffer_ = e->value;
      upload_offset_ = 0;
      toggle_ = false;
      return EncodeUploadSegmentedInitiate(node_id_, m->object, static_cast<std::uint32_t>(buffer_.size()));
    }
    case Kind::kUploadSegment: {
      if (m->toggle != toggle_) return Abort(object_, kAbortToggleBit);
      const std::size_t n = std::min<std::size_t>(7, buffer_.size() - upload_offset_);
      const bool last = upload_offset_ + n >= buffer_.size();
      const CanFrame out =
          EncodeUploadSegment(node_id_, toggle_, buffer_.data() + upload_offset_, static_cast<int>(n), last);
      upload_offset_ += n;
      toggle_ = !toggle_;
      if (last) transfer_ = Transfer::kNone;
      return out;
    }
    case Kind::kInitiateDownload:
      return InitiateDownload(*m);
    case Kind::kDownloadSegment:
      return DownloadSegment(*m);
    case Kind::kAbort:
      break;
  }
  return std::nullopt;
}

}  // namespace sph::can
