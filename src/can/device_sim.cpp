#include "sph/can/device_sim.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>

#include "sph/can/error_frame.hpp"
#include "sph/can/sdo_server.hpp"
#include "sph/core/error.hpp"
#include "sph/model/units.hpp"

namespace sph::can {
namespace {

constexpr std::int64_t kNever = std::numeric_limits<std::int64_t>::max();

std::int64_t ToNs(double s) { return static_cast<std::int64_t>(std::llround(s * 1e9)); }

// The simulated devices' identity (1018h): a vendor-id of no real vendor.
constexpr std::uint32_t kVendorId = 0x00535048;  // "SPH"
constexpr std::uint32_t kRevision = 0x00010000;

bool IsDummy(std::uint16_t index) { return index >= 0x0002 && index <= 0x0007; }
int DummyBits(std::uint16_t index) {
  switch (index) {
    case 0x0002:
    case 0x0005:
      return 8;
    case 0x0003:
    case 0x0006:
      return 16;
    default:
      return 32;
  }
}

// COB-IDs CiA 301 reserves (§7.3.5): no SYNC or EMCY may be sent on them.
bool Restricted(std::uint64_t id) {
  return id <= 0x07F || (id >= 0x101 && id <= 0x180) || (id >= 0x581 && id <= 0x5FF) || (id >= 0x601 && id <= 0x67F) ||
         (id >= 0x6E0 && id <= 0x6FF) || id >= 0x701;
}

std::uint32_t MapEntry(ObjectAddress o, int bits) {
  return (static_cast<std::uint32_t>(o.index) << 16) | (static_cast<std::uint32_t>(o.subindex) << 8) |
         static_cast<std::uint32_t>(bits);
}

// The default mapping of a device's TPDO: the value at its byte, the probe's status byte
// (`status`, -1: none), the SYNC counter byte (`counter`, -1: none), dummies (UNSIGNED8) before them.
std::vector<std::uint32_t> DefaultMapping(const FieldLayout& field, ObjectAddress value_obj, int status, int counter) {
  std::vector<std::uint32_t> entries;
  const int end = std::max({field.offset_byte + field.width_bytes, status + 1, counter + 1});
  for (int b = 0; b < end;) {
    if (b == field.offset_byte) {
      entries.push_back(MapEntry(value_obj, 8 * field.width_bytes));
      b += field.width_bytes;
    } else if (b == status) {
      entries.push_back(MapEntry({0x2001, 0}, 8));
      ++b;
    } else if (b == counter) {
      entries.push_back(MapEntry({0x2010, 0}, 8));
      ++b;
    } else {
      entries.push_back(MapEntry({0x0005, 0}, 8));
      ++b;
    }
  }
  return entries;
}

}  // namespace

struct DeviceSimulator::Node {
  int node_id = 0;  ///< 0: a sensor with its own frames, always sending
  int device = kProbe;
  int tpdo = 1;
  NmtState st = NmtState::kBootUp;  ///< kBootUp: off or booting
  std::int64_t boot_at = kNever;
  bool hb_on_grid = false;  ///< log mode: heartbeats on the internal SYNC grid
  std::int64_t hb_base = 0;
  std::uint64_t hb_index = 0;
  std::int64_t next_heartbeat = kNever;
  std::int64_t next_event_pdo = kNever;
  std::vector<RebootEvent> reboots;  ///< in time order
  std::size_t next_reboot = 0;
  bool settings_lost = false;              ///< the next boot is without the stored settings
  std::int64_t hardware_emcy_at = kNever;  ///< its EMCY 0x5000 after such a boot
  std::int64_t error_clear_at = kNever;    ///< a NodeFaultKind::kError clears then (EMCY 0x0000)
  std::uint8_t error_register = 0;         ///< 1001h: an error keeps the node from operational
  ObjectDictionary od;
  std::unique_ptr<SdoServer> server;
  std::uint64_t syncs_seen = 0;
  std::int64_t raw = 0;  ///< the latest reading [counts]
  std::optional<std::int64_t> last_sent_raw;

  std::uint16_t Comm() const { return static_cast<std::uint16_t>(0x1800 + tpdo - 1); }
  std::uint16_t Map() const { return static_cast<std::uint16_t>(0x1A00 + tpdo - 1); }
  std::uint8_t StateByte() const { return static_cast<std::uint8_t>(st); }
  bool On() const { return st != NmtState::kBootUp; }
  /// The heartbeat period of its 1017h [ns]; 0: none.
  std::int64_t HeartbeatNs() const { return static_cast<std::int64_t>(od.Unsigned({0x1017, 0})) * 1000000; }
};

void DeviceSimConfig::Validate() const {
  const int nodes[] = {devices.theta.node_id, devices.phi.node_id, devices.probe.node_id};
  std::set<int> seen;
  for (int d = 0; d < kNumDevices; ++d) {
    if (nodes[d] != 0 && !seen.insert(nodes[d]).second) {
      throw Error("device simulator: " + std::string(DeviceName(d)) + " shares node " + std::to_string(nodes[d]) +
                  " with another device: the simulated devices need a node each");
    }
  }
  for (const RebootEvent& r : faults.reboots) {
    if (r.node_id == 0 || seen.count(r.node_id) == 0) {
      throw Error("device simulator: reboot of node " + std::to_string(r.node_id) + ", which no device is");
    }
  }
  if (!(transmission_type >= 0 && transmission_type <= 240) &&
      !(transmission_type >= 252 && transmission_type <= 255)) {
    throw Error("device simulator: transmission type must be 0..240 or 252..255");
  }
  if (boot_s < 0.0 || sdo_latency_s < 0.0 || heartbeat_period_s < 0.0) {
    throw Error("device simulator: boot, SDO and heartbeat times must not be negative");
  }
  if (heartbeat_period_s > 65.535) throw Error("device simulator: 1017h holds a heartbeat period of at most 65.535 s");
  if (sync_counter_overflow < -1 || sync_counter_overflow == 1 || sync_counter_overflow > 240) {
    throw Error(
        "device simulator: the nodes' SYNC counter overflow value (1019h) must be 0 or 2..240 (-1: the "
        "SYNC's)");
  }
}

DeviceSimulator::DeviceSimulator(const DeviceSimConfig& config) : config_(config), rng_(config.spec.seed) {
  config_.devices.Validate();
  config_.Validate();
  if (config_.spec.pattern.empty()) throw Error("device simulator: the pattern is empty");
  if (config_.spec.centers_mm.empty()) throw Error("device simulator: no sphere centre");
  CheckSimulationSetup(config_.spec);  // what sph_simulate refuses: a beam that misses, a form too deep
  const auto mount = config_.spec.mount_rotations_deg.find(0);
  if (mount != config_.spec.mount_rotations_deg.end()) body_to_theta_ = RotationOfVectorDeg(mount->second);
  if (!(config_.sync_period_s > 0.0)) throw Error("device simulator: the SYNC period must be positive");
  if (config_.stop_s < 0.0 || config_.move_s < 0.0 || config_.stop_s + config_.move_s <= 0.0) {
    throw Error("device simulator: stop and move times must not be negative, and not both zero");
  }
  total_cycles_ = static_cast<std::uint64_t>(std::floor(duration_s() / config_.sync_period_s + 1e-9));
  bus_off_done_.assign(config_.faults.bus_off_at_s.size(), false);
  emcy_done_.assign(config_.faults.emergencies.size(), false);
  start_ns_ = ToNs(config_.start_time_s);
  next_error_frame_ns_ =
      config_.faults.error_frame_period_s > 0.0 ? GridNs(config_.faults.error_frame_period_s, 700.0) : kNever;
  const int ids[] = {config_.devices.theta.node_id, config_.devices.phi.node_id, config_.devices.probe.node_id};
  for (int d = 0; d < kNumDevices; ++d) {
    auto n = std::make_unique<Node>();
    n->node_id = ids[d];
    n->device = d;
    const PipelineConfig& dc = config_.devices;
    const std::uint32_t cob = d == kTheta ? dc.theta.field.can_id
                              : d == kPhi ? dc.phi.field.can_id
                                          : dc.probe.field.can_id;
    n->tpdo = TpdoNumber(d == kTheta ? dc.theta.tpdo : d == kPhi ? dc.phi.tpdo : dc.probe.tpdo, cob, n->node_id);
    for (const RebootEvent& r : config_.faults.reboots) {
      if (r.node_id == n->node_id) n->reboots.push_back(r);
    }
    std::stable_sort(n->reboots.begin(), n->reboots.end(),
                     [](const RebootEvent& a, const RebootEvent& b) { return a.at_s < b.at_s; });
    nodes_.push_back(std::move(n));
  }
  for (auto& n : nodes_) {
    if (n->node_id == 0 || config_.start_operational) {
      Boot(*n, start_ns_);
      n->st = NmtState::kOperational;
      n->hb_on_grid = true;
      n->hb_index = 0;
      n->next_heartbeat = n->node_id != 0 && n->HeartbeatNs() > 0 ? GridNs(0.0, 600.0 + 20.0 * n->device) : kNever;
    } else {
      n->boot_at = start_ns_ + ToNs(config_.boot_s);  // power-on
    }
  }
}

DeviceSimulator::~DeviceSimulator() = default;

double DeviceSimulator::duration_s() const {
  const auto n = static_cast<double>(config_.spec.pattern.size());
  return n * config_.stop_s + (n - 1.0) * config_.move_s;
}

double DeviceSimulator::RelS(std::int64_t t_ns) const { return static_cast<double>(t_ns - start_ns_) * 1e-9; }

// The time `offset_us` after the first internal SYNC at or after `at_s`.
std::int64_t DeviceSimulator::GridNs(double at_s, double offset_us) const {
  const double T = config_.sync_period_s;
  const double k = std::max(0.0, std::ceil(at_s / T - 1e-9));
  return ToNs(config_.start_time_s + k * T) + std::min<std::int64_t>(ToNs(offset_us * 1e-6), ToNs(T) * 9 / 10);
}

AnglePair DeviceSimulator::AxesAt(double t_s) const {
  const auto& pat = config_.spec.pattern;
  const double seg = config_.stop_s + config_.move_s;
  const auto n = pat.size();
  double i_d = std::floor(t_s / seg);
  if (i_d < 0.0) i_d = 0.0;
  auto i = static_cast<std::size_t>(i_d);
  if (i >= n) return pat.back();
  const double u = t_s - static_cast<double>(i) * seg;
  if (u < config_.stop_s || i + 1 >= n) return pat[i];
  const double frac = (u - config_.stop_s) / config_.move_s;
  const double s = 0.5 * (1.0 - std::cos(kPi * frac));
  return {pat[i].theta_deg + s * (pat[i + 1].theta_deg - pat[i].theta_deg),
          pat[i].phi_deg + s * (pat[i + 1].phi_deg - pat[i].phi_deg)};
}

bool DeviceSimulator::Silent(int device, double t_rel_s) const {
  for (const Silence& s : config_.faults.silences) {
    if (s.device == device && t_rel_s >= s.from_s && t_rel_s < s.to_s) return true;
  }
  return false;
}

std::int64_t DeviceSimulator::RebootNs(const Node& n) const { return start_ns_ + ToNs(n.reboots[n.next_reboot].at_s); }

std::uint8_t DeviceSimulator::NodeState(int node_id) const {
  for (const auto& n : nodes_) {
    if (n->node_id == node_id) return n->StateByte();
  }
  return 0xFF;
}

std::uint32_t DeviceSimulator::CheckWrite(const Node& n, ObjectAddress o, const std::vector<std::uint8_t>& v) {
  const std::uint64_t value = LittleEndianValue(v);
  switch (o.index) {
    case 0x1005:  // a SYNC consumer: an 11-bit id, no producer bit (CANopenNode's OD_write_1005)
      return (value & 0xFFFFF800U) != 0 || Restricted(value & 0x7FFU) ? kAbortInvalidValue : 0U;
    case 0x1014: {  // bit 31: no EMCY; the id may change only while EMCY is off (OD_write_1014)
      const std::uint64_t old = n.od.Unsigned(o);
      const bool on = (old & 0x80000000U) == 0, new_on = (value & 0x80000000U) == 0;
      if ((value & 0x7FFFF800U) != 0 || Restricted(value & 0x7FFU)) return kAbortInvalidValue;
      return on && new_on && (value & 0x7FFU) != (old & 0x7FFU) ? kAbortInvalidValue : 0U;
    }
    case 0x1019:  // OD_write_1019
      return value == 1 || value > 240 ? kAbortInvalidValue : 0U;
    default:
      break;
  }
  const bool comm = o.index == n.Comm(), map = o.index == n.Map();
  if (!comm && !map) return std::uint32_t{0};
  // CiA 301: while operational only the COB-ID may be written (to make the PDO invalid first);
  // an invalid PDO's parameters may be changed in any state, as CANopenNode allows.
  const bool pdo_valid = (n.od.Unsigned({n.Comm(), 1}) & 0x80000000U) == 0;
  if (n.st == NmtState::kOperational && pdo_valid && !(comm && o.subindex == 1)) return kAbortDeviceState;
  if (comm && o.subindex == 1) {
    const std::uint64_t old = n.od.Unsigned(o);
    const bool old_valid = (old & 0x80000000U) == 0, new_valid = (value & 0x80000000U) == 0;
    if (old_valid && new_valid && (old & 0x3FFFFFFFU) != (value & 0x3FFFFFFFU)) return kAbortInvalidValue;
  } else if (comm && o.subindex == 2) {
    if (value >= 241 && value <= 251) return kAbortInvalidValue;
  } else if (map && o.subindex == 0) {
    if (value > 8) return kAbortPdoLength;
    int bits = 0;
    for (std::uint64_t sub = 1; sub <= value; ++sub)
      bits += static_cast<int>(n.od.Unsigned({o.index, static_cast<std::uint8_t>(sub)}) & 0xFF);
    if (bits > 64) return kAbortPdoLength;
  } else if (map) {
    if (n.od.Unsigned({o.index, 0}) != 0) return kAbortUnsupportedAccess;
    const ObjectAddress target{static_cast<std::uint16_t>(value >> 16), static_cast<std::uint8_t>((value >> 8) & 0xFF)};
    const int bits = static_cast<int>(value & 0xFF);
    if (IsDummy(target.index)) return bits == DummyBits(target.index) ? std::uint32_t{0} : kAbortNotMappable;
    const ObjectDictionary::Entry* e = n.od.Find(target);
    if (e == nullptr) return kAbortNoObject;
    if (!e->mappable || static_cast<int>(8 * e->value.size()) != bits) return kAbortNotMappable;
  }
  return std::uint32_t{0};
}

// A node (re)starts: the object dictionary at its defaults (or without its stored settings),
// pre-operational.
void DeviceSimulator::Boot(Node& n, std::int64_t t_ns) {
  using A = ObjectDictionary::Access;
  ObjectDictionary& od = n.od;
  od = ObjectDictionary{};
  const int d = n.device;
  const bool encoder = d != kProbe;
  const FieldLayout& field = d == kTheta ? config_.devices.theta.field
                             : d == kPhi ? config_.devices.phi.field
                                         : config_.devices.probe.field;
  // The stored communication settings, or without them the defaults of CANopenNode's object
  // dictionary: no heartbeat, no SYNC counter.
  const bool stored = !n.settings_lost;
  const int overflow =
      config_.sync_counter_overflow >= 0 ? config_.sync_counter_overflow : config_.devices.sync_counter_max;
  od.SetUnsigned({0x1000, 0}, encoder ? 0x00010196 : 0x00000000, 4);  // CiA 406 (0x196), single-turn
  od.SetUnsigned({0x1001, 0}, 0, 1);
  od.SetUnsigned({0x1005, 0}, config_.devices.sync_cob_id, 4, A::kReadWrite);
  const std::string name = std::string("sph_cansim ") + DeviceName(d) + (encoder ? " encoder" : "");
  od.Set({0x1008, 0}, std::vector<std::uint8_t>(name.begin(), name.end()));
  // A writable object longer than 4 bytes (a segmented download): a 16-byte location text.
  const std::string location = "not set";
  std::vector<std::uint8_t> text(location.begin(), location.end());
  text.resize(16, ' ');
  od.Set({0x2100, 0}, text, A::kReadWrite);
  od.SetUnsigned({0x1014, 0}, kEmcyBase + static_cast<std::uint32_t>(n.node_id), 4, A::kReadWrite);
  od.SetUnsigned({0x1017, 0},
                 stored ? static_cast<std::uint64_t>(std::llround(config_.heartbeat_period_s * 1000.0)) : 0, 2,
                 A::kReadWrite);
  od.SetUnsigned({0x1019, 0}, stored ? static_cast<std::uint64_t>(overflow) : 0, 1, A::kReadWrite);
  od.SetUnsigned({0x1018, 0}, 4, 1);
  od.SetUnsigned({0x1018, 1}, kVendorId, 4);
  od.SetUnsigned({0x1018, 2}, encoder ? 0x00004060U + static_cast<std::uint32_t>(d) : 0x00002000U, 4);
  od.SetUnsigned({0x1018, 3}, kRevision, 4);
  od.SetUnsigned({0x1018, 4}, 0x00010000U + static_cast<std::uint32_t>(n.node_id), 4);
  const std::uint32_t id = field.can_id & kEffMask;
  const std::uint32_t cob = (field.can_id & kEffFlag) ? (id | 0x20000000U) : id;
  od.SetUnsigned({n.Comm(), 0}, 5, 1);
  od.SetUnsigned({n.Comm(), 1}, cob, 4, A::kReadWrite);
  od.SetUnsigned({n.Comm(), 2}, static_cast<std::uint64_t>(config_.transmission_type), 1, A::kReadWrite);
  od.SetUnsigned({n.Comm(), 3}, 0, 2, A::kReadWrite);
  od.SetUnsigned({n.Comm(), 5}, config_.event_timer_ms, 2, A::kReadWrite);
  // The value object, sized as configured.
  const ObjectAddress value_obj = encoder ? ObjectAddress{0x6004, 0} : ObjectAddress{0x2000, 0};
  od.SetUnsigned(value_obj, 0, field.width_bytes, A::kReadOnly, true);
  od.SetUnsigned({0x2001, 0}, 0, 1, A::kReadOnly, true);
  od.SetUnsigned({0x2010, 0}, 0, 1, A::kReadOnly, true);
  if (encoder) {
    const EncoderConfig& e = d == kTheta ? config_.devices.theta : config_.devices.phi;
    od.SetUnsigned({0x6000, 0}, 0, 2, A::kReadWrite);
    od.SetUnsigned({0x6001, 0}, e.counts_per_rev, 4);
    const std::uint64_t total =
        e.multi_turn ? std::min<std::uint64_t>(e.counts_per_rev * 4096, 0xFFFFFFFFU) : e.counts_per_rev;
    od.SetUnsigned({0x6002, 0}, total, 4);
  }
  const int status = d == kProbe ? config_.devices.probe.status_offset_byte : -1;
  const std::vector<std::uint32_t> entries =
      DefaultMapping(field, value_obj, status, config_.devices.sync_counter_byte[static_cast<std::size_t>(d)]);
  od.SetUnsigned({n.Map(), 0}, entries.size(), 1, A::kReadWrite);
  for (std::size_t i = 0; i < 8; ++i) {
    od.SetUnsigned({n.Map(), static_cast<std::uint8_t>(i + 1)}, i < entries.size() ? entries[i] : 0, 4, A::kReadWrite);
  }
  n.server = std::make_unique<SdoServer>(
      n.node_id, &n.od, [&n](ObjectAddress o, const std::vector<std::uint8_t>& v) { return CheckWrite(n, o, v); },
      [this, &n](ObjectAddress o) { OnWritten(n, o); });
  n.st = NmtState::kPreOperational;
  n.boot_at = kNever;
  n.syncs_seen = 0;
  n.last_sent_raw.reset();
  n.error_register = 0;
  n.hardware_emcy_at = kNever;
  n.error_clear_at = kNever;
  if (!stored) {  // the device finds its settings gone: a hardware error, reported after its boot-up
    n.error_register = 0x01;
    n.hardware_emcy_at = t_ns + ToNs(config_.sdo_latency_s);
    n.settings_lost = false;
  }
  od.SetUnsigned({0x1001, 0}, n.error_register, 1);
  n.hb_on_grid = false;
  n.hb_base = t_ns;
  n.hb_index = 1;
  n.next_heartbeat = n.node_id != 0 && n.HeartbeatNs() > 0 ? t_ns + n.HeartbeatNs() : kNever;
  n.next_event_pdo = kNever;
}

void DeviceSimulator::OnWritten(Node& n, ObjectAddress o) {
  if (o.index != 0x1017) return;
  // CANopenNode's OD_write_1017: the new period runs from a heartbeat sent at once.
  n.hb_on_grid = false;
  n.hb_base = now_ns_ + ToNs(config_.sdo_latency_s);
  n.hb_index = 0;
  n.next_heartbeat = n.HeartbeatNs() > 0 ? n.hb_base : kNever;
}

void DeviceSimulator::Enter(Node& n, NmtState state, std::int64_t t_ns) {
  // An error in the register keeps the node from operational (CANopenNode: CO_NMT_ERR_ON_ERR_REG
  // with the generic and communication bits).
  if (state == NmtState::kOperational && (n.error_register & 0x11) != 0) state = NmtState::kPreOperational;
  if (state == NmtState::kOperational) {
    if (n.st != NmtState::kOperational) n.syncs_seen = 0;
    const std::uint64_t timer_ms = n.od.Unsigned({n.Comm(), 5});
    n.next_event_pdo = timer_ms > 0 ? t_ns + static_cast<std::int64_t>(timer_ms) * 1000000 : kNever;
  }
  const bool changed = state != n.st;
  n.st = state;
  if (changed && n.node_id != 0 && n.HeartbeatNs() > 0) {  // a heartbeat at once, then every period
    n.hb_on_grid = false;
    n.hb_base = t_ns + ToNs(config_.sdo_latency_s);
    n.hb_index = 0;
    n.next_heartbeat = n.hb_base;
  }
}

std::optional<CanFrame> DeviceSimulator::Emcy(const Node& n, std::uint16_t code, std::uint8_t manufacturer_bit,
                                              std::uint32_t info) const {
  const std::uint64_t cob = n.od.Unsigned({0x1014, 0});
  if (n.node_id == 0 || (cob & 0x80000000U) != 0) return std::nullopt;
  Emergency em;
  em.node_id = n.node_id;
  em.error_code = code;
  em.error_register = n.error_register;
  em.manufacturer = {manufacturer_bit, static_cast<std::uint8_t>(info), static_cast<std::uint8_t>(info >> 8),
                     static_cast<std::uint8_t>(info >> 16), static_cast<std::uint8_t>(info >> 24)};
  CanFrame f = EncodeEmergency(em);
  f.id = static_cast<std::uint32_t>(cob & 0x7FFU);
  return f;
}

// CANopenNode's CO_SYNC_receive: with 1019h 0 a SYNC has no data, else one byte (the counter);
// another length is an error (EMCY 0x8240 once, the communication bit set, pre-operational).
bool DeviceSimulator::TakesSync(Node& n, std::int64_t t_ns, std::optional<std::uint8_t> counter,
                                std::vector<CanFrame>& out) {
  if (n.node_id == 0) return true;  // a sensor with its own frames: no object dictionary to follow
  const bool counted = n.od.Unsigned({0x1019, 0}) != 0;
  if (counted == counter.has_value()) return true;
  ++injected_.sync_length_errors;
  if ((n.error_register & 0x10) == 0) {
    n.error_register |= 0x11;  // communication, and the generic bit CiA 301 sets with any error
    if (auto* e = n.od.Find({0x1001, 0})) e->value = {n.error_register};
    const std::uint32_t info = (counter ? 1U : 0U) | (counted ? 0x80U : 0x40U);
    if (auto f = Emcy(n, 0x8240, 0x18, info)) {
      f->t_ns = t_ns + ToNs(config_.sdo_latency_s);
      out.push_back(*f);
    }
  }
  if (n.st == NmtState::kOperational) Enter(n, NmtState::kPreOperational, t_ns);
  return false;
}

bool DeviceSimulator::NextCycle(std::vector<CanFrame>& frames) {
  if (finished()) return false;
  const std::size_t first = frames.size();
  const double t_rel = static_cast<double>(internal_syncs_) * config_.sync_period_s;
  const std::int64_t t_ns = ToNs(config_.start_time_s + t_rel);
  AdvanceTo(t_ns, frames);
  ++internal_syncs_;
  std::optional<std::uint8_t> counter;
  if (config_.devices.sync_counter_max != 0) {
    sync_counter_ = NextSyncCounter(sync_counter_, config_.devices.sync_counter_max);
    counter = sync_counter_;
  }
  if (config_.faults.sync_drop_probability > 0.0 && rng_.Uniform() < config_.faults.sync_drop_probability) {
    ++injected_.syncs_dropped;
  } else {
    CanFrame sync = EncodeSync(counter, config_.devices.sync_cob_id);
    sync.t_ns = t_ns;
    frames.push_back(sync);
  }
  OnSync(t_ns, config_.devices.sync_cob_id, counter, frames);
  AdvanceTo(t_ns + ToNs(config_.sync_period_s), frames);
  std::stable_sort(frames.begin() + static_cast<std::ptrdiff_t>(first), frames.end(),
                   [](const CanFrame& a, const CanFrame& b) { return a.t_ns < b.t_ns; });
  return true;
}

// Whether node n's TPDO goes out at this SYNC by its transmission type: synchronous (every
// type-th SYNC; counted here) or acyclic (only a changed value), and valid.
bool DeviceSimulator::TransmitsAtSync(Node& n) {
  if (n.st != NmtState::kOperational) return false;
  const std::uint64_t tt = n.od.Unsigned({n.Comm(), 2});
  const std::uint64_t cob = n.od.Unsigned({n.Comm(), 1});
  if (tt > 240 || (cob & 0x80000000U) != 0) return false;  // not synchronous, or the PDO is not valid
  if (tt >= 1) return n.syncs_seen++ % tt == 0;
  return !(n.last_sent_raw && *n.last_sent_raw == n.raw);  // acyclic: only a changed value
}

// Node n's TPDO with COB-ID `cob`, as its mapping lays it out.
CanFrame DeviceSimulator::MappedPdo(const Node& n, std::uint64_t cob) const {
  CanFrame pdo;
  pdo.id = (cob & 0x20000000U) ? ((cob & kEffMask) | kEffFlag) : (cob & kSffMask);
  int bit = 0;
  const std::uint64_t count = n.od.Unsigned({n.Map(), 0});
  for (std::uint64_t sub = 1; sub <= count && bit < 64; ++sub) {
    const std::uint64_t e = n.od.Unsigned({n.Map(), static_cast<std::uint8_t>(sub)});
    const ObjectAddress o{static_cast<std::uint16_t>(e >> 16), static_cast<std::uint8_t>((e >> 8) & 0xFF)};
    const int bytes = static_cast<int>(e & 0xFF) / 8;
    if (bytes < 1 || bit / 8 + bytes > kMaxDataBytes) break;
    FieldLayout l{pdo.id, bit / 8, bytes, false, false};
    std::int64_t v = 0;
    if (o == ObjectAddress{0x2000, 0}) {
      l.is_signed = config_.devices.probe.field.is_signed;
      l.big_endian = config_.devices.probe.field.big_endian;
      v = n.raw;
    } else if (o == ObjectAddress{0x6004, 0}) {
      v = n.raw;
    } else if (!IsDummy(o.index)) {
      v = static_cast<std::int64_t>(n.od.Unsigned(o));
    }
    InsertField(pdo, l, v);
    bit += 8 * bytes;
  }
  return pdo;
}

void DeviceSimulator::OnSync(std::int64_t t_ns, std::uint32_t cob_id, std::optional<std::uint8_t> counter,
                             std::vector<CanFrame>& out) {
  if (finished()) return;
  const SimFaults& f = config_.faults;
  const std::size_t first = out.size();
  const auto period_ns = ToNs(config_.sync_period_s);
  auto at = [&](double offset_us) {  // a time inside this cycle
    return t_ns + std::min<std::int64_t>(ToNs(offset_us * 1e-6), period_ns * 9 / 10);
  };
  ++injected_.cycles;
  if (!moving_) {
    moving_ = std::all_of(nodes_.begin(), nodes_.end(), [](const auto& n) { return n->st == NmtState::kOperational; });
  }
  // The fault times count from the start; the pattern from its own start.
  const double t_rel = RelS(t_ns);
  const double t_pattern = moving_ ? static_cast<double>(cycle_) * config_.sync_period_s : 0.0;
  // Draw every random number in a fixed order, whatever faults are on, so a seed gives the same
  // readings with and without faults.
  const AnglePair axes = AxesAt(t_pattern);
  const double n_theta = rng_.Normal(), n_phi = rng_.Normal(), n_r = rng_.Normal();
  const double theta_deg = axes.theta_deg + config_.spec.noise_theta_arcsec / 3600.0 * n_theta;
  const double phi_deg = axes.phi_deg + config_.spec.noise_phi_arcsec / 3600.0 * n_phi;
  const auto r = TrueProbeDistance(config_.spec.truth, config_.spec.effects, axes.theta_deg * kRadPerDeg,
                                   axes.phi_deg * kRadPerDeg, config_.spec.probe_offset_mm,
                                   config_.spec.centers_mm.front(), config_.spec.sphere_radius_mm, body_to_theta_);
  SimCycleRecord rec;
  rec.sync_ns = t_ns;
  rec.counter = counter;
  for (int dev = 0; dev < kNumDevices; ++dev) {
    const double u_drop = rng_.Uniform(), u_short = rng_.Uniform(), u_range = rng_.Uniform(), u_jit = rng_.Uniform();
    const auto d = static_cast<std::size_t>(dev);
    Node& n = *nodes_[d];
    bool out_of_range = false;
    if (dev == kProbe) {
      const ProbeConfig& p = config_.devices.probe;
      out_of_range = !r || (f.probe_out_of_range_probability > 0.0 && u_range < f.probe_out_of_range_probability);
      n.raw = out_of_range ? (p.real32 ? 0x7F800000 : p.over_range_raw.value_or(0x7FFFFFFF))
                           : EncodeProbeRaw(p, *r + config_.spec.noise_r_um * kMmPerUm * n_r);
    } else {
      const EncoderConfig& e = dev == kTheta ? config_.devices.theta : config_.devices.phi;
      n.raw = EncodePositionRaw(e, dev == kTheta ? theta_deg : phi_deg);
    }
    if (auto* e = n.od.Find(dev == kProbe ? ObjectAddress{0x2000, 0} : ObjectAddress{0x6004, 0})) {
      e->value = LittleEndianBytes(static_cast<std::uint64_t>(n.raw), static_cast<int>(e->value.size()));
    }
    if (auto* e = n.od.Find({0x2010, 0})) e->value = {counter.value_or(0)};
    // A node takes SYNC on the id of its 1005h, pre-operational or operational, of the length of its 1019h.
    const bool listens = n.node_id == 0 ? cob_id == config_.devices.sync_cob_id
                                        : (n.st == NmtState::kPreOperational || n.st == NmtState::kOperational) &&
                                              (n.od.Unsigned({0x1005, 0}) & 0x7FFU) == cob_id;
    if (!listens || !TakesSync(n, t_ns, counter, out) || !TransmitsAtSync(n)) continue;
    const std::uint64_t cob = n.od.Unsigned({n.Comm(), 1});
    if (Silent(dev, t_rel)) {
      ++injected_.silent_cycles[d];
      continue;
    }
    if (f.drop_probability > 0.0 && u_drop < f.drop_probability) {
      ++injected_.dropped[d];
      continue;
    }
    CanFrame pdo = MappedPdo(n, cob);
    if (dev == kProbe && out_of_range) ++injected_.probe_out_of_range;
    if (f.short_probability > 0.0 && u_short < f.short_probability && pdo.len > 0) {
      pdo.len = static_cast<std::uint8_t>(pdo.len - 1);
      ++injected_.shortened[d];
    }
    pdo.t_ns = at(100.0 + 130.0 * dev + f.jitter_us * u_jit);
    n.last_sent_raw = n.raw;
    ++injected_.pdos[d];
    const DecodedValue dv = dev == kProbe
                                ? DecodeProbe(config_.devices.probe, pdo)
                                : DecodePosition(dev == kTheta ? config_.devices.theta : config_.devices.phi, pdo);
    rec.sent[d] = dv.status == DecodeStatus::kOk;
    rec.value[d] = dv.value;
    out.push_back(pdo);
  }
  if (recording_) records_.push_back(rec);
  if (moving_) ++cycle_;
  std::stable_sort(out.begin() + static_cast<std::ptrdiff_t>(first), out.end(),
                   [](const CanFrame& a, const CanFrame& b) { return a.t_ns < b.t_ns; });
}

void DeviceSimulator::OnFrame(const CanFrame& frame, std::vector<CanFrame>& out) {
  if (frame.IsError() || frame.IsRemote()) return;
  const std::int64_t t = frame.t_ns;
  now_ns_ = t;
  // A SYNC: on the configured id (the sensors') or on the 1005h of a node.
  const bool sync_id =
      !frame.IsExtended() &&
      (frame.id == config_.devices.sync_cob_id || std::any_of(nodes_.begin(), nodes_.end(), [&](const auto& n) {
         return n->node_id != 0 && n->On() && (n->od.Unsigned({0x1005, 0}) & 0x7FFU) == frame.id;
       }));
  if (sync_id) {
    if (const auto sync = DecodeSync(frame, frame.id)) OnSync(t, frame.id, sync->counter, out);
    return;
  }
  if (frame.id == kNmtCobId) {
    const auto nmt = DecodeNmt(frame);
    if (!nmt) return;
    ++injected_.nmt_commands;
    for (auto& np : nodes_) {
      Node& n = *np;
      if (n.node_id == 0 || (nmt->node_id != 0 && nmt->node_id != n.node_id) || n.st == NmtState::kBootUp) continue;
      switch (static_cast<NmtCommand>(nmt->command)) {
        case NmtCommand::kStart:
          Enter(n, NmtState::kOperational, t);
          break;
        case NmtCommand::kStop:
          Enter(n, NmtState::kStopped, t);
          break;
        case NmtCommand::kEnterPreOperational:
          Enter(n, NmtState::kPreOperational, t);
          break;
        case NmtCommand::kResetNode:
        case NmtCommand::kResetCommunication:
          n.st = NmtState::kBootUp;
          n.boot_at = t + ToNs(config_.boot_s);
          n.next_heartbeat = kNever;
          n.server->Reset();
          break;
      }
    }
    return;
  }
  for (auto& np : nodes_) {
    Node& n = *np;
    if (n.node_id == 0 || frame.id != kSdoRequestBase + static_cast<std::uint32_t>(n.node_id)) continue;
    if (n.st != NmtState::kPreOperational && n.st != NmtState::kOperational) return;  // no SDO when stopped or off
    if (auto answer = n.server->OnRequest(frame)) {
      ++injected_.sdo_requests;
      if ((answer->data[0] >> 5) == 4) ++injected_.sdo_aborts;
      answer->t_ns = t + ToNs(config_.sdo_latency_s);
      out.push_back(*answer);
    }
    return;
  }
}

std::int64_t DeviceSimulator::NextEventNs() const {
  std::int64_t next = next_error_frame_ns_;
  for (std::size_t i = 0; i < config_.faults.bus_off_at_s.size(); ++i) {
    if (!bus_off_done_[i]) next = std::min(next, GridNs(config_.faults.bus_off_at_s[i], 710.0));
  }
  for (std::size_t i = 0; i < config_.faults.emergencies.size(); ++i) {
    if (!emcy_done_[i]) next = std::min(next, GridNs(config_.faults.emergencies[i].at_s, 720.0));
  }
  for (const auto& n : nodes_) {
    if (n->st == NmtState::kBootUp) next = std::min(next, n->boot_at);
    if (n->st != NmtState::kBootUp) next = std::min(next, n->next_heartbeat);
    if (n->next_reboot < n->reboots.size()) next = std::min(next, RebootNs(*n));
    if (n->On()) next = std::min({next, n->hardware_emcy_at, n->error_clear_at});
    if (n->st == NmtState::kOperational && n->od.Unsigned({n->Comm(), 2}) >= 254) {
      next = std::min(next, n->next_event_pdo);
    }
  }
  return next;
}

void DeviceSimulator::AdvanceTo(std::int64_t t_end, std::vector<CanFrame>& out) {
  for (;;) {
    const std::int64_t t = NextEventNs();
    if (t >= t_end) return;
    // Bus events first, then the nodes, each in a fixed order.
    if (t == next_error_frame_ns_) {
      CanFrame e = MakeErrorFrame(kErrController, {0, 0x04});  // RX error warning
      e.t_ns = t;
      out.push_back(e);
      ++injected_.error_frames;
      ++error_frame_index_;
      next_error_frame_ns_ =
          GridNs(static_cast<double>(error_frame_index_) * config_.faults.error_frame_period_s, 700.0);
      continue;
    }
    bool done = false;
    for (std::size_t i = 0; i < config_.faults.bus_off_at_s.size() && !done; ++i) {
      if (bus_off_done_[i] || GridNs(config_.faults.bus_off_at_s[i], 710.0) != t) continue;
      bus_off_done_[i] = true;
      CanFrame e = MakeErrorFrame(kErrBusOff);
      e.t_ns = t;
      out.push_back(e);
      ++injected_.error_frames;
      ++injected_.bus_off;
      done = true;
    }
    for (std::size_t i = 0; i < config_.faults.emergencies.size() && !done; ++i) {
      if (emcy_done_[i] || GridNs(config_.faults.emergencies[i].at_s, 720.0) != t) continue;
      emcy_done_[i] = true;
      const Node& n = *nodes_[static_cast<std::size_t>(config_.faults.emergencies[i].device)];
      if (auto e = Emcy(n, config_.faults.emergencies[i].code, 0, 0)) {
        e->data[2] |= 0x01;  // generic error
        e->t_ns = t;
        out.push_back(*e);
        ++injected_.emergencies;
      }
      done = true;
    }
    for (auto& np : nodes_) {
      if (done) break;
      Node& n = *np;
      if (n.next_reboot < n.reboots.size() && RebootNs(n) == t &&
          n.reboots[n.next_reboot].kind != NodeFaultKind::kReboot) {
        const RebootEvent& fault = n.reboots[n.next_reboot++];
        if (n.On() && fault.kind == NodeFaultKind::kError) {
          n.error_register |= 0x11;  // communication, and the generic bit
          if (auto* e = n.od.Find({0x1001, 0})) e->value = {n.error_register};
          if (auto e = Emcy(n, 0x8100, 0, 0)) {  // communication, generic
            e->t_ns = t;
            out.push_back(*e);
            ++injected_.emergencies;
          }
          n.error_clear_at = fault.clears_after_s > 0.0 ? t + ToNs(fault.clears_after_s) : kNever;
        }
        if (n.On()) Enter(n, NmtState::kPreOperational, t);
        ++injected_.state_faults;
        done = true;
      } else if (n.On() && n.error_clear_at == t) {
        n.error_clear_at = kNever;
        n.error_register = 0;
        if (auto* e = n.od.Find({0x1001, 0})) e->value = {n.error_register};
        if (auto e = Emcy(n, 0x0000, 0, 0)) {  // error reset
          e->t_ns = t;
          out.push_back(*e);
          ++injected_.emergencies;
        }
        done = true;
      } else if (n.next_reboot < n.reboots.size() && RebootNs(n) == t) {
        n.settings_lost = n.reboots[n.next_reboot].settings_lost;
        ++n.next_reboot;
        ++injected_.reboots;
        n.st = NmtState::kBootUp;
        n.boot_at = t + ToNs(config_.boot_s);
        n.next_heartbeat = kNever;
        if (n.server) n.server->Reset();
        done = true;
      } else if (n.st == NmtState::kBootUp && n.boot_at == t) {
        Boot(n, t);
        CanFrame b = EncodeHeartbeat(n.node_id, NmtState::kBootUp);
        b.t_ns = t;
        out.push_back(b);
        ++injected_.boot_ups;
        done = true;
      } else if (n.On() && n.hardware_emcy_at == t) {
        n.hardware_emcy_at = kNever;
        if (auto e = Emcy(n, 0x5000, 0, 0)) {  // device hardware
          e->t_ns = t;
          out.push_back(*e);
        }
        done = true;
      } else if (n.st != NmtState::kBootUp && n.next_heartbeat == t) {
        if (!Silent(n.device, RelS(t))) {
          CanFrame hb = MakeFrame(kHeartbeatBase + static_cast<std::uint32_t>(n.node_id), {n.StateByte()});
          hb.t_ns = t;
          out.push_back(hb);
          ++injected_.heartbeats;
        }
        ++n.hb_index;
        const std::int64_t p = n.HeartbeatNs();
        n.next_heartbeat = p == 0         ? kNever
                           : n.hb_on_grid ? GridNs(static_cast<double>(n.hb_index) * static_cast<double>(p) * 1e-9,
                                                   600.0 + 20.0 * n.device)
                                          : n.hb_base + static_cast<std::int64_t>(n.hb_index) * p;
        done = true;
      } else if (n.st == NmtState::kOperational && n.od.Unsigned({n.Comm(), 2}) >= 254 && n.next_event_pdo == t) {
        const std::uint64_t timer_ms = n.od.Unsigned({n.Comm(), 5});
        n.next_event_pdo = timer_ms == 0 ? kNever : t + static_cast<std::int64_t>(timer_ms) * 1000000;
        CanFrame pdo;
        const FieldLayout& l = n.device == kTheta ? config_.devices.theta.field
                               : n.device == kPhi ? config_.devices.phi.field
                                                  : config_.devices.probe.field;
        pdo.id = l.can_id;
        InsertField(pdo, l, n.raw);
        pdo.t_ns = t;
        out.push_back(pdo);
        ++injected_.pdos[static_cast<std::size_t>(n.device)];
        done = true;
      }
    }
    if (!done) return;  // cannot happen: NextEventNs() named an event
  }
}

}  // namespace sph::can
