// The server side of CiA 301 SDO, for simulated devices: an object dictionary and a server that
// answers uploads (expedited up to 4 bytes, segmented beyond) and expedited downloads, with the
// aborts a real device gives (unknown object or sub-index, read-only entry, wrong length, a write
// the device refuses in its present state). Pure: request frame in, answer frame out.
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

  SdoServer(int node_id, ObjectDictionary* od, WriteCheck check = nullptr);

  /// A frame on 0x600 + node_id: the answer on 0x580 + node_id, or nothing (a client's abort).
  /// Frames on other ids give nothing.
  std::optional<CanFrame> OnRequest(const CanFrame& frame);
  /// Drops a transfer in progress (the node was reset).
  void Reset() {
    upload_.clear();
    in_upload_ = false;
  }

 private:
  CanFrame Abort(ObjectAddress object, std::uint32_t code);

  int node_id_;
  ObjectDictionary* od_;
  WriteCheck check_;
  bool in_upload_ = false;
  ObjectAddress upload_object_;
  std::vector<std::uint8_t> upload_;
  std::size_t upload_offset_ = 0;
  bool toggle_ = false;
};

}  // namespace sph::can

#endif  // SPH_CAN_SDO_SERVER_HPP_
