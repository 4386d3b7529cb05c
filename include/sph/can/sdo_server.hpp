// The server side of CiA 301 SDO, for simulated devices: an object dictionary and a server that
// answers uploads (expedited up to 4 bytes, segmented beyond) and downloads (expedited, and
// segmented of any length), with the aborts a real device gives (unknown object or sub-index,
// read-only entry, wrong length, a toggle bit that did not alternate, a write the device refuses
// in its present state), as CANopenNode's server (CO_SDOserver.c) gives them. While a segmented
// transfer is in progress, only its next segment or an abort is taken; any other request ends it
// with abort 0x05040001. Pure: request frame in, answer frame out.
#ifndef SPH_CAN_SDO_SERVER_HPP_
#define SPH_CAN_SDO_SERVER_HPP_

#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "sph/can/frame.hpp"
#include "sph/can/sdo.hpp"

namespace sph::can {

/// Entries by (index, sub-index), each with its value bytes (little endian) and access.
class ObjectDictionary {
 public:
  enum class Access { kReadOnly, kReadWrite };
  struct Entry {
    std::vector<std::uint8_t> value;
    Access access = Access::kReadOnly;
    bool mappable = false;  ///< may be mapped into a PDO
  };

  void Set(ObjectAddress object, std::vector<std::uint8_t> value, Access access = Access::kReadOnly,
           bool mappable = false);
  /// Sets an unsigned value of `bytes` bytes.
  void SetUnsigned(ObjectAddress object, std::uint64_t value, int bytes, Access access = Access::kReadOnly,
                   bool mappable = false);
  const Entry* Find(ObjectAddress object) const;
  Entry* Find(ObjectAddress object);
  /// The unsigned value of an entry (0 when it does not exist).
  std::uint64_t Unsigned(ObjectAddress object) const;
  bool HasIndex(std::uint16_t index) const;

 private:
  std::map<std::uint32_t, Entry> entries_;
};

/// Answers SDO requests to node `node_id` from an object dictionary.
class SdoServer {
 public:
  /// Decides a download the dictionary would accept: 0 to write it, else the abort code.
  using WriteCheck = std::function<std::uint32_t(ObjectAddress, const std::vector<std::uint8_t>&)>;
  /// Told of each entry written (after the write), for the device's side effects.
  using Written = std::function<void(ObjectAddress)>;

  SdoServer(int node_id, ObjectDictionary* od, WriteCheck check = nullptr, Written written = nullptr);

  /// A frame on 0x600 + node_id: the answer on 0x580 + node_id, or nothing (a client's abort).
  /// Frames on other ids give nothing.
  std::optional<CanFrame> OnRequest(const CanFrame& frame);
  /// Drops a transfer in progress (the node was reset).
  void Reset() {
    transfer_ = Transfer::kNone;
    buffer_.clear();
  }

 private:
  enum class Transfer { kNone, kUpload, kDownload };
  CanFrame Abort(ObjectAddress object, std::uint32_t code);
  std::optional<CanFrame> InitiateDownload(const SdoClientMessage& m);
  std::optional<CanFrame> DownloadSegment(const SdoClientMessage& m);
  /// Writes `value` to the entry of `object` (its length already checked): the answer `done`,
  /// or the abort of the device's check.
  CanFrame Write(ObjectAddress object, const std::vector<std::uint8_t>& value, const CanFrame& done);

  int node_id_;
  ObjectDictionary* od_;
  WriteCheck check_;
  Written written_;
  Transfer transfer_ = Transfer::kNone;
  ObjectAddress object_;              ///< of the transfer in progress, or of the last one
  std::vector<std::uint8_t> buffer_;  ///< upload: the value; download: the bytes received
  std::size_t upload_offset_ = 0;
  std::uint32_t download_size_ = 0;  ///< the size the client indicated; 0: none
  bool toggle_ = false;
};

}  // namespace sph::can

#endif  // SPH_CAN_SDO_SERVER_HPP_
