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

SdoServer::SdoServer(int node_id, ObjectDictionary* od, WriteCheck check)
    : node_id_(node_id), od_(od), check_(std::move(check)) {}

CanFrame SdoServer::Abort(ObjectAddress object, std::uint32_t code) {
  in_upload_ = false;
  return EncodeAbort(kSdoResponseBase + static_cast<std::uint32_t>(node_id_), object, code);
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
  switch (m->kind) {
    case Kind::kAbort:
      in_upload_ = false;
      return std::nullopt;
    case Kind::kInitiateUpload: {
      in_upload_ = false;
      const ObjectDictionary::Entry* e = od_->Find(m->object);
      if (e == nullptr) return Abort(m->object, od_->HasIndex(m->object.index) ? kAbortNoSubindex : kAbortNoObject);
      if (e->value.size() <= 4) return EncodeUploadExpedited(node_id_, m->object, e->value);
      in_upload_ = true;
      upload_object_ = m->object;
      upload_ = e->value;
      upload_offset_ = 0;
      toggle_ = false;
      return EncodeUploadSegmentedInitiate(node_id_, m->object, static_cast<std::uint32_t>(upload_.size()));
    }
    case Kind::kUploadSegment: {
      if (!in_upload_) return Abort(upload_object_, kAbortCommand);
      if (m->toggle != toggle_) return Abort(upload_object_, kAbortToggleBit);
      const std::size_t n = std::min<std::size_t>(7, upload_.size() - upload_offset_);
      const bool last = upload_offset_ + n >= upload_.size();
      const CanFrame out =
          EncodeUploadSegment(node_id_, toggle_, upload_.data() + upload_offset_, static_cast<int>(n), last);
      upload_offset_ += n;
      toggle_ = !toggle_;
      if (last) in_upload_ = false;
      return out;
    }
    case Kind::kInitiateDownload: {
      in_upload_ = false;
      if (!m->expedited) return Abort(m->object, kAbortUnsupportedAccess);  // segmented download: not offered
      ObjectDictionary::Entry* e = od_->Find(m->object);
      if (e == nullptr) return Abort(m->object, od_->HasIndex(m->object.index) ? kAbortNoSubindex : kAbortNoObject);
      if (e->access == ObjectDictionary::Access::kReadOnly) return Abort(m->object, kAbortReadOnly);
      if (m->size_indicated && m->data.size() != e->value.size()) {
        return Abort(m->object, m->data.size() > e->value.size() ? kAbortLengthHigh : kAbortLengthLow);
      }
      std::vector<std::uint8_t> value = m->data;
      value.resize(e->value.size());  // without a size: the entry's own length
      if (check_) {
        if (const std::uint32_t code = check_(m->object, value); code != 0) return Abort(m->object, code);
      }
      od_->Find(m->object)->value = value;  // the check may have changed the dictionary
      return EncodeDownloadResponse(node_id_, m->object);
    }
    case Kind::kDownloadSegment:
      return Abort(upload_object_, kAbortCommand);
  }
  return std::nullopt;
}

}  // namespace sph::can
