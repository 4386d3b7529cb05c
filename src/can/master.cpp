// The CANopen master of the acquisition: NMT, identification and checks over SDO, restarts.
#include "sph/can/master.hpp"

#include <algorithm>
#include <cstdio>
#include <limits>
#include <set>

#include "sph/core/error.hpp"

namespace sph::can {
namespace {

constexpr std::int64_t kNever = std::numeric_limits<std::int64_t>::max();

std::string Hex32(std::uint32_t v) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "0x%08X", v);
  return buf;
}

std::string HexId(std::uint32_t v) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "0x%X", v);
  return buf;
}

std::string Seconds(std::int64_t ns) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f s", static_cast<double>(ns) * 1e-9);
  return buf;
}

std::uint32_t Key(ObjectAddress o) { return (static_cast<std::uint32_t>(o.index) << 8) | o.subindex; }

ObjectAddress TpdoComm(int tpdo, std::uint8_t sub) { return {static_cast<std::uint16_t>(0x1800 + tpdo - 1), sub}; }
ObjectAddress TpdoMap(int tpdo, std::uint8_t sub) { return {static_cast<std::uint16_t>(0x1A00 + tpdo - 1), sub}; }

std::string TransmissionTypeName(std::uint64_t t) {
  if (t == 0) return "synchronous, acyclic";
  if (t == 1) return "synchronous, every SYNC";
  if (t <= 240) return "synchronous, every " + std::to_string(t) + "th SYNC";
  if (t <= 251) return "reserved";
  if (t == 252) return "RTR-only, synchronous";
  if (t == 253) return "RTR-only, event-driven";
  if (t == 254) return "event-driven, manufacturer-specific";
  return "event-driven, device profile";
}

// What an object is, for messages.
std::string ObjectName(ObjectAddress o) {
  switch (o.index) {
    case 0x1008:
      return "manufacturer device name";
    case 0x1017:
      return "producer heartbeat time";
    case 0x1019:
      return "synchronous counter overflow value";
    case 0x1018:
      switch (o.subindex) {
        case 1:
          return "identity: vendor-id";
        case 2:
          return "identity: product code";
        case 3:
          return "identity: revision number";
        case 4:
          return "identity: serial number";
        default:
          return "identity";
      }
    case 0x6001:
      return "measuring units per revolution";
    case 0x6002:
      return "total measuring range";
    default:
      break;
  }
  if (o.index >= 0x1800 && o.index < 0x1A00) {
    const std::string pdo = "TPDO" + std::to_string(o.index - 0x1800 + 1);
    return pdo + (o.subindex == 1 ? " COB-ID" : o.subindex == 2 ? " transmission type" : " communication");
  }
  if (o.index >= 0x1A00 && o.index < 0x1C00) {
    const std::string pdo = "TPDO" + std::to_string(o.index - 0x1A00 + 1);
    return pdo + (o.subindex == 0 ? " mapping: number of entries" : " mapping entry " + std::to_string(o.subindex));
  }
  return "object";
}

std::string Describe(ObjectAddress o) { return ToString(o) + " (" + ObjectName(o) + ")"; }

// A VISIBLE_STRING without trailing NULs, quotes and control characters made harmless.
std::string CleanString(const std::vector<std::uint8_t>& bytes) {
  std::string s;
  for (std::uint8_t b : bytes) s += static_cast<char>(b);
  while (!s.empty() && s.back() == '\0') s.pop_back();
  for (char& c : s) {
    if (c == '"' || static_cast<unsigned char>(c) < 0x20 || static_cast<unsigned char>(c) > 0x7E) c = '?';
  }
  return s;
}

}  // namespace

std::vector<MasterNode> MasterNodesFor(const PipelineConfig& c) {
  std::vector<MasterNode> nodes;
  const int ids[] = {c.theta.node_id, c.phi.node_id, c.probe.node_id};
  const FieldLayout* fields[] = {&c.theta.field, &c.phi.field, &c.probe.field};
  const char* keys[] = {"device_theta_encoder", "device_phi_encoder", "device_probe"};
  for (int d = 0; d < kNumDevices; ++d) {
    if (ids[d] == 0) continue;
    MasterDevice dev;
    dev.role = DeviceName(d);
    dev.header_key = keys[d];
    dev.field = *fields[d];
    const int tpdos[] = {c.theta.tpdo, c.phi.tpdo, c.probe.tpdo};
    dev.tpdo = TpdoNumber(tpdos[d], fields[d]->can_id, ids[d]);
    if (d != kProbe) {
      const EncoderConfig& e = d == kTheta ? c.theta : c.phi;
      dev.encoder = true;
      dev.mapped_object = ObjectAddress{0x6004, 0};
      dev.counts_per_rev = e.counts_per_rev;
      dev.multi_turn = e.multi_turn;
    }
    auto it = std::find_if(nodes.begin(), nodes.end(), [&](const MasterNode& n) { return n.node_id == ids[d]; });
    if (it == nodes.end()) {
      nodes.push_back(MasterNode{ids[d], dev.role, {}});
      it = nodes.end() - 1;
    } else {
      it->name += "+" + dev.role;
    }
    it->devices.push_back(dev);
  }
  return nodes;
}

void MasterConfig::Validate() const {
  if (configure_pdo && !nmt) throw Error("writing the PDO settings needs NMT (the nodes must be pre-operational)");
  std::set<int> ids;
  for (const MasterNode& n : nodes) {
    if (n.node_id < 1 || n.node_id > 127) throw Error(n.name + ": node id must be 1..127");
    if (!ids.insert(n.node_id).second) throw Error("node " + std::to_string(n.node_id) + " is configured twice");
    std::set<int> tpdos;
    for (const MasterDevice& d : n.devices) {
      if (d.tpdo < 1 || d.tpdo > 512) throw Error(d.role + ": TPDO number must be 1..512");
      if (!tpdos.insert(d.tpdo).second) {
        throw Error("node " + std::to_string(n.node_id) + ": two devices use TPDO" + std::to_string(d.tpdo));
      }
    }
  }
  if (sync_counter_max < -1 || sync_counter_max == 1 || sync_counter_max > 240) {
    throw Error("the SYNC counter overflow value to check must be 0 or 2..240 (-1: not checked)");
  }
  if (sdo_timeout_ns <= 0 || boot_timeout_ns <= 0 || operational_timeout_ns < 0 || return_timeout_ns <= 0) {
    throw Error("the master's timeouts must be positive");
  }
}

struct CanopenMaster::NodeState {
  enum class Step { kAwaitBoot, kSdo, kReadyToStart, kAwaitOperational, kRunning, kFailed };
  struct Job {
    bool write = false;
    ObjectAddress object;
    std::vector<std::uint8_t> data;
    bool optional = false;  ///< an abort "no such object / sub-index" leaves it absent
    bool may_fail = false;  ///< any abort is kept in write_error and the next job runs
  };

  NodeState(const MasterNode& c, std::int64_t timeout_ns) : config(c), sdo(c.node_id, timeout_ns) {}
  std::string Name() const { return "node " + std::to_string(config.node_id) + " (" + config.name + ")"; }
  const std::vector<std::uint8_t>* Value(ObjectAddress o) const {
    const auto it = values.find(Key(o));
    return it == values.end() ? nullptr : &it->second;
  }
  std::optional<std::uint32_t> U32(ObjectAddress o) const {
    const auto* v = Value(o);
    if (v == nullptr) return std::nullopt;
    return static_cast<std::uint32_t>(LittleEndianValue(*v));
  }

  const MasterNode& config;
  Step step = Step::kReadyToStart;
  std::int64_t deadline = kNever;
  std::int64_t wait_ns = 0;  ///< how long kAwaitBoot / kAwaitOperational waits
  SdoClient sdo;
  std::vector<Job> jobs;
  std::size_t next_job = 0;
  std::map<std::uint32_t, std::vector<std::uint8_t>> values;
  NodeIdentity identity;
  std::optional<NodeIdentity> first;  ///< identified at the start
  bool restarting = false;
  std::optional<std::uint8_t> last_state;
  bool heartbeat_since_start = false;              ///< a heartbeat came after the NMT Start
  std::string error;                               ///< why the start failed
  std::optional<std::uint16_t> hb_found;           ///< 1017h as this identification found it
  std::uint16_t hb_target = 0;                     ///< the heartbeat the master wants of it (set at the start)
  std::uint16_t hb_ms = 0;                         ///< the heartbeat it sends now
  std::string write_error;                         ///< a may_fail write the device refused
  bool confirmed = false;                          ///< its heartbeat said operational
  bool rebooted = false;                           ///< restarting after a boot-up (else: it left operational)
  std::int64_t left_ns = 0;                        ///< mid-run: when it left operational
  int starts = 0;                                  ///< Start commands sent since it left
  bool started = false;                            ///< the master sent it Start
  std::optional<std::uint8_t> state_before_start;  ///< its heartbeat's state when first started
  std::optional<std::uint16_t> hb_written_over;    ///< 1017h as found, when the master changed it
  bool heard = false;                              ///< a frame of it came since Begin()
};

CanopenMaster::CanopenMaster(MasterConfig config, Callbacks callbacks)
    : config_(std::move(config)), cb_(std::move(callbacks)) {
  config_.Validate();
  for (const MasterNode& n : config_.nodes) nodes_.push_back(std::make_unique<NodeState>(n, config_.sdo_timeout_ns));
}

CanopenMaster::~CanopenMaster() = default;

void CanopenMaster::Log(LogLevel level, const std::string& text) const {
  if (cb_.log) cb_.log(level, text);
}

void CanopenMaster::Send(const CanFrame& frame) {
  if (frame.id == kNmtCobId) ++counts_.nmt_commands;
  if (cb_.send) cb_.send(frame);
}

void CanopenMaster::Begin(std::int64_t now_ns) {
  if (nodes_.empty() || (!config_.nmt && !config_.sdo)) {
    for (auto& n : nodes_) n->step = NodeState::Step::kRunning;
    phase_ = Phase::kRunning;
    return;
  }
  if (config_.nmt && config_.reset_communication) {
    if (config_.nmt_broadcast) Send(EncodeNmt(NmtCommand::kResetCommunication, 0));
    for (auto& n : nodes_) {
      if (!config_.nmt_broadcast) Send(EncodeNmt(NmtCommand::kResetCommunication, n->config.node_id));
      n->step = NodeState::Step::kAwaitBoot;
      n->deadline = now_ns + config_.boot_timeout_ns;
    }
    Log(LogLevel::kInfo, "NMT Reset communication sent; waiting for the boot-up messages");
    return;
  }
  for (auto& n : nodes_) Advance(*n, now_ns);
  UpdatePhase(now_ns);
}

// Steps 2 to 6 of the start (sph/can/master.hpp), from a pre-operational (or unknown) node.
void CanopenMaster::Advance(NodeState& n, std::int64_t now_ns) {
  n.sdo.Cancel();
  n.deadline = kNever;
  if (config_.nmt && config_.configure_pdo) Send(EncodeNmt(NmtCommand::kEnterPreOperational, n.config.node_id));
  if (config_.sdo) {
    StartSdo(n, now_ns);
    return;
  }
  n.step = NodeState::Step::kReadyToStart;
  if (!config_.nmt) {
    NodeRunning(n, true);
  } else if (phase_ != Phase::kStarting) {
    SendStart(n, now_ns);
  }
}

void CanopenMaster::StartSdo(NodeState& n, std::int64_t now_ns) {
  using Job = NodeState::Job;
  n.step = NodeState::Step::kSdo;
  n.values.clear();
  n.jobs.clear();
  n.next_job = 0;
  n.hb_found.reset();
  n.write_error.clear();
  n.jobs.push_back(Job{false, {0x1018, 1}, {}, false});
  for (std::uint8_t sub = 2; sub <= 4; ++sub) n.jobs.push_back(Job{false, {0x1018, sub}, {}, true});
  n.jobs.push_back(Job{false, {0x1008, 0}, {}, true});
  n.jobs.push_back(Job{false, {0x1017, 0}, {}, true});  // a write may follow: ConfigureHeartbeat
  if (config_.configure_pdo && config_.sync_counter_max >= 0) {
    n.jobs.push_back(Job{true, {0x1019, 0}, {static_cast<std::uint8_t>(config_.sync_counter_max)}, true});
  }
  n.jobs.push_back(Job{false, {0x1019, 0}, {}, true});
  for (const MasterDevice& d : n.config.devices) {
    if (d.encoder) {
      n.jobs.push_back(Job{false, {0x6001, 0}, {}, true});
      n.jobs.push_back(Job{false, {0x6002, 0}, {}, true});
    }
    const std::uint32_t cob = (d.field.can_id & kEffMask) | ((d.field.can_id & kEffFlag) ? 0x20000000U : 0U);
    if (config_.configure_pdo) {
      n.jobs.push_back(Job{true, TpdoComm(d.tpdo, 1), LittleEndianBytes(cob | 0x80000000U, 4), false});
      n.jobs.push_back(Job{true, TpdoComm(d.tpdo, 2), {1}, false});
      if (d.mapped_object) {
        const std::uint32_t entry = (static_cast<std::uint32_t>(d.mapped_object->index) << 16) |
                                    (static_cast<std::uint32_t>(d.mapped_object->subindex) << 8) |
                                    static_cast<std::uint32_t>(8 * d.field.width_bytes);
        n.jobs.push_back(Job{true, TpdoMap(d.tpdo, 0), {0}, false});
        n.jobs.push_back(Job{true, TpdoMap(d.tpdo, 1), LittleEndianBytes(entry, 4), false});
        n.jobs.push_back(Job{true, TpdoMap(d.tpdo, 0), {1}, false});
      }
      n.jobs.push_back(Job{true, TpdoComm(d.tpdo, 1), LittleEndianBytes(cob, 4), false});
    }
    n.jobs.push_back(Job{false, TpdoComm(d.tpdo, 1), {}, false});
    n.jobs.push_back(Job{false, TpdoComm(d.tpdo, 2), {}, false});
    if (d.mapped_object && d.value_bytes > 0) n.jobs.push_back(Job{false, *d.mapped_object, {}, true});
    if (d.mapped_object) n.jobs.push_back(Job{false, TpdoMap(d.tpdo, 0), {}, false});
  }
  NextJob(n, now_ns);
}

void CanopenMaster::NextJob(NodeState& n, std::int64_t now_ns) {
  if (n.next_job >= n.jobs.size()) {
    FinishSdo(n, now_ns);
    return;
  }
  const NodeState::Job& job = n.jobs[n.next_job];
  ++counts_.sdo_transfers;
  Send(job.write ? n.sdo.StartDownload(job.object, job.data, now_ns) : n.sdo.StartUpload(job.object, now_ns));
}

void CanopenMaster::OnSdoStep(NodeState& n, const SdoClient::Step& step, std::int64_t now_ns) {
  using Status = SdoClient::Status;
  if (step.has_frame) Send(step.frame);
  if (step.status != Status::kDone && step.status != Status::kFailed) return;
  const NodeState::Job job = n.jobs[n.next_job];
  if (step.status == Status::kFailed) {
    const SdoError& e = n.sdo.error();
    const bool absent = e.kind == SdoError::Kind::kAborted && (e.code == kAbortNoObject || e.code == kAbortNoSubindex);
    if (job.may_fail && e.kind == SdoError::Kind::kAborted) {
      n.write_error = "writing " + Describe(job.object) + ": " + e.text;
      Log(LogLevel::kWarning, n.Name() + ": " + n.write_error);
    } else if (!(job.optional && absent)) {
      NodeFailed(n, std::string(job.write ? "writing " : "reading ") + Describe(job.object) + ": " + e.text);
      return;
    }
  } else if (job.write && job.object == ObjectAddress{0x1017, 0} && n.hb_found && !n.hb_written_over) {
    n.hb_written_over = n.hb_found;
  } else if (!job.write) {
    n.values[Key(job.object)] = n.sdo.data();
    if (job.object == ObjectAddress{0x1017, 0}) {
      ConfigureHeartbeat(n, static_cast<std::uint16_t>(LittleEndianValue(n.sdo.data())));
    }
    // The mapping's count says how many entries follow.
    if (job.object.index >= 0x1A00 && job.object.index < 0x1C00 && job.object.subindex == 0) {
      const std::uint64_t count = LittleEndianValue(n.sdo.data());
      for (std::uint64_t sub = 1; sub <= count && sub <= 64; ++sub) {
        n.jobs.insert(n.jobs.begin() + static_cast<std::ptrdiff_t>(n.next_job + sub),
                      NodeState::Job{false, {job.object.index, static_cast<std::uint8_t>(sub)}, {}, false});
      }
    }
  }
  ++n.next_job;
  NextJob(n, now_ns);
}

void CanopenMaster::ConfigureHeartbeat(NodeState& n, std::uint16_t found) {
  if (n.hb_found) return;  // the read back after the master's write
  n.hb_found = found;
  if (!config_.nmt) return;  // another master configures the heartbeats it consumes
  if (!n.first) n.hb_target = found != 0 ? found : config_.heartbeat_ms;
  if (n.hb_target == 0 || found == n.hb_target) return;
  using Job = NodeState::Job;
  const auto at = n.jobs.begin() + static_cast<std::ptrdiff_t>(n.next_job + 1);
  n.jobs.insert(
      at, {Job{true, {0x1017, 0}, LittleEndianBytes(n.hb_target, 2), false, true}, Job{false, {0x1017, 0}, {}, true}});
}

std::vector<std::string> CanopenMaster::Check(const NodeState& n, std::vector<std::string>* warnings) const {
  std::vector<std::string> problems;
  for (const MasterDevice& d : n.config.devices) {
    const std::string dev = n.config.devices.size() > 1 ? d.role + ": " : "";
    if (d.encoder) {
      const auto cpr = n.U32({0x6001, 0});
      if (!cpr) {
        problems.push_back(dev + "the device has no object 0x6001:00 (measuring units per revolution) to check " +
                           d.cpr_name + " " + std::to_string(d.counts_per_rev) + " against");
      } else if (*cpr != d.counts_per_rev) {
        problems.push_back(dev + "object 0x6001:00 (measuring units per revolution): the device has " +
                           std::to_string(*cpr) + ", " + d.cpr_name + " " + std::to_string(d.counts_per_rev));
      }
      const auto range = n.U32({0x6002, 0});
      if (cpr && range && !d.multi_turn && *range != *cpr) {
        problems.push_back(dev + "object 0x6002:00 (total measuring range): the device has " + std::to_string(*range) +
                           " (" + std::to_string(*range / (*cpr == 0 ? 1 : *cpr)) +
                           " revolutions), a single-turn encoder needs " + std::to_string(*cpr) +
                           ": configure it as multi-turn");
      }
    }
    const std::uint32_t want_id = d.field.can_id & kEffMask;
    const bool want_eff = (d.field.can_id & kEffFlag) != 0;
    if (const auto cob = n.U32(TpdoComm(d.tpdo, 1))) {
      const bool valid = (*cob & 0x80000000U) == 0;
      const bool eff = (*cob & 0x20000000U) != 0;
      const std::uint32_t id = *cob & (eff ? 0x1FFFFFFFU : 0x7FFU);
      if (!valid || eff != want_eff || id != want_id) {
        problems.push_back(dev + "object " + Describe(TpdoComm(d.tpdo, 1)) + ": the device has " + Hex32(*cob) +
                           (valid ? "" : " (the PDO is not valid)") + ", " + d.cob_name + " " + HexId(want_id) +
                           (want_eff ? " (29 bit)" : ""));
      }
    }
    if (const auto tt = n.U32(TpdoComm(d.tpdo, 2)); tt && *tt != 1) {
      problems.push_back(dev + "object " + Describe(TpdoComm(d.tpdo, 2)) + ": the device has " + std::to_string(*tt) +
                         " (" + TransmissionTypeName(*tt) + "), the daemon needs 1 (synchronous, every SYNC)");
    }
    if (d.mapped_object && d.value_bytes > 0) {
      const auto* value = n.Value(*d.mapped_object);
      if (value != nullptr && static_cast<int>(value->size()) != d.value_bytes) {
        problems.push_back(dev + "object " + ToString(*d.mapped_object) + " (the mapped value) holds " +
                           std::to_string(value->size()) + " bytes, " + d.type_name + " has " +
                           std::to_string(d.value_bytes));
      }
    }
    if (d.mapped_object) {
      const auto count = n.U32(TpdoMap(d.tpdo, 0));
      std::string mapped;
      bool found = false, right_place = false;
      int bit = 0;
      for (std::uint32_t sub = 1; count && sub <= *count && sub <= 64; ++sub) {
        const auto e = n.U32(TpdoMap(d.tpdo, static_cast<std::uint8_t>(sub)));
        if (!e) break;
        const ObjectAddress o{static_cast<std::uint16_t>(*e >> 16), static_cast<std::uint8_t>((*e >> 8) & 0xFF)};
        const int bits = static_cast<int>(*e & 0xFF);
        mapped += (mapped.empty() ? "" : ", ") + ToString(o) + " " + std::to_string(bits) + " bits at bit " +
                  std::to_string(bit);
        if (o == *d.mapped_object) {
          found = true;
          right_place = bits == 8 * d.field.width_bytes && bit == 8 * d.field.offset_byte;
        }
        bit += bits;
      }
      if (!found || !right_place) {
        problems.push_back(dev + "object " + ToString(TpdoMap(d.tpdo, 0)).substr(0, 6) + " (TPDO" +
                           std::to_string(d.tpdo) + " mapping) " + (found ? "maps " : "does not map ") +
                           ToString(*d.mapped_object) + " where " + d.layout_name + " reads " +
                           std::to_string(8 * d.field.width_bytes) + " bits at bit " +
                           std::to_string(8 * d.field.offset_byte) + " (the device maps " +
                           (mapped.empty() ? std::string("nothing") : mapped) + ")");
      }
    }
  }
  if (config_.sync_counter_max >= 0) {
    const auto v = n.U32({0x1019, 0});
    if (v && *v != static_cast<std::uint32_t>(config_.sync_counter_max)) {
      problems.push_back("object 0x1019:00 (synchronous counter overflow value): the device has " + std::to_string(*v) +
                         ", " + config_.sync_counter_name + " " + std::to_string(config_.sync_counter_max) +
                         " (a node that expects another SYNC refuses every SYNC: EMCY 0x8240, pre-operational)");
    }
  }
  if (config_.nmt && n.U32({0x1017, 0}).value_or(0) == 0) {
    std::string why =
        "its NMT state cannot be confirmed: object 0x1017:00 (producer heartbeat time) is 0, it sends no "
        "heartbeat";
    if (!n.write_error.empty()) {
      why += " (" + n.write_error + ")";
    } else if (n.hb_target == 0) {
      why += " (" + config_.heartbeat_name + " is 0: none written)";
    }
    problems.push_back(why);
  }
  if (config_.trust_config && !problems.empty()) {
    if (warnings != nullptr) {
      for (const std::string& p : problems) warnings->push_back(n.Name() + ": " + p + " (trusted: acquiring anyway)");
    }
    problems.clear();
  }
  return problems;
}

void CanopenMaster::FinishSdo(NodeState& n, std::int64_t now_ns) {
  NodeIdentity id;
  id.vendor_id = n.U32({0x1018, 1});
  id.product_code = n.U32({0x1018, 2});
  id.revision = n.U32({0x1018, 3});
  id.serial = n.U32({0x1018, 4});
  if (const auto* name = n.Value({0x1008, 0})) id.name = CleanString(*name);
  id.heartbeat_ms = n.hb_found;
  if (const auto v = n.U32({0x1019, 0})) id.sync_counter_max = static_cast<std::uint8_t>(*v);
  n.hb_ms = static_cast<std::uint16_t>(n.U32({0x1017, 0}).value_or(0));
  for (const MasterDevice& d : n.config.devices) {
    if (d.encoder) id.resolution[d.role] = {n.U32({0x6001, 0}), n.U32({0x6002, 0})};
  }
  std::vector<std::string> warnings;
  std::vector<std::string> problems = Check(n, &warnings);
  for (const std::string& w : warnings) Log(LogLevel::kWarning, w);
  if (config_.sync_counter_max > 0 && !n.U32({0x1019, 0})) {
    Log(LogLevel::kWarning, n.Name() +
                                ": the device has no object 0x1019:00 (synchronous counter overflow value): "
                                "whether it takes SYNC with a counter is not known");
  }
  if (n.first) {  // a restart: it must be the same device
    const auto differs = [](const std::optional<std::uint32_t>& a, const std::optional<std::uint32_t>& b) {
      return a && b && *a != *b;
    };
    const NodeIdentity& f = *n.first;
    if (f.heartbeat_ms && id.heartbeat_ms && *f.heartbeat_ms != *id.heartbeat_ms) {
      const std::string text = n.Name() + ": object 0x1017:00 (producer heartbeat time) is " +
                               std::to_string(*id.heartbeat_ms) + " ms after its reboot, " +
                               std::to_string(*f.heartbeat_ms) +
                               " ms at the start: it may have lost its stored settings";
      Log(LogLevel::kWarning, text);
      if (cb_.note) cb_.note(text);
    }
    if (differs(f.vendor_id, id.vendor_id) || differs(f.product_code, id.product_code) ||
        differs(f.serial, id.serial)) {
      problems.push_back("it came back as another device: vendor-id " + Hex32(id.vendor_id.value_or(0)) +
                         ", product code " + Hex32(id.product_code.value_or(0)) + ", serial " +
                         Hex32(id.serial.value_or(0)) + " (at the start: " + Hex32(f.vendor_id.value_or(0)) + ", " +
                         Hex32(f.product_code.value_or(0)) + ", " + Hex32(f.serial.value_or(0)) + ")");
    }
  }
  n.identity = id;
  if (!problems.empty()) {
    std::string all;
    for (const std::string& p : problems) all += (all.empty() ? "" : "; ") + p;
    NodeFailed(n, all, true);
    return;
  }
  n.step = NodeState::Step::kReadyToStart;
  if (!config_.nmt) {
    NodeRunning(n, true);
  } else if (phase_ != Phase::kStarting) {
    SendStart(n, now_ns);  // a restart mid-run; at the start every node waits for the others
  }
  UpdatePhase(now_ns);
}

void CanopenMaster::SendStart(NodeState& n, std::int64_t now_ns) {
  if (!n.started) n.state_before_start = n.last_state;
  n.started = true;
  Send(EncodeNmt(NmtCommand::kStart, n.config.node_id));
  ++n.starts;
  AwaitOperational(n, now_ns);
}

void CanopenMaster::AwaitOperational(NodeState& n, std::int64_t now_ns) {
  // Without SDO its heartbeat is not known: the heartbeats of the operational timeout are waited for.
  const std::uint16_t hb = config_.sdo ? n.hb_ms : 0;
  if (config_.sdo && hb == 0) {  // trusted without a heartbeat: started, not confirmed
    NodeRunning(n, false);
    return;
  }
  n.step = NodeState::Step::kAwaitOperational;
  n.heartbeat_since_start = false;
  n.wait_ns = config_.operational_timeout_ns + 3 * std::int64_t{hb} * 1000000;
  n.deadline = now_ns + n.wait_ns;
  if (n.restarting) n.deadline = std::min(n.deadline, n.left_ns + config_.return_timeout_ns);
}

void CanopenMaster::NodeFailed(NodeState& n, const std::string& why, bool permanent) {
  n.step = NodeState::Step::kFailed;
  n.deadline = kNever;
  n.sdo.Cancel();
  if (phase_ == Phase::kStarting) {
    n.error = n.Name() + ": " + why;
    return;
  }
  if (permanent || now_ns_ >= n.left_ns + config_.return_timeout_ns) {
    NodeLost(n, why);
    return;
  }
  // Not answering now: a boot-up may still bring it back (Advance) before the return timeout.
  n.error = why;
  n.deadline = n.left_ns + config_.return_timeout_ns;
  Log(LogLevel::kWarning, n.Name() + ": " + why + " (waiting for it until " + Seconds(config_.return_timeout_ns) +
                              " after it left operational)");
}

void CanopenMaster::NodeLost(NodeState& n, const std::string& why) {
  n.step = NodeState::Step::kFailed;
  n.deadline = kNever;
  n.sdo.Cancel();
  ++counts_.restart_failures;
  n.restarting = false;
  const std::string text =
      n.Name() + " was not restarted after " + (n.rebooted ? "its reboot" : "it left operational") + ": " + why;
  Log(LogLevel::kError, text);
  if (cb_.note) cb_.note(text + ": the acquisition ends");
  if (phase_ == Phase::kRunning) phase_ = Phase::kNodeLost;
  errors_.push_back(text);
}

void CanopenMaster::LeftOperational(NodeState& n, std::uint8_t state, std::int64_t now_ns) {
  ++counts_.left_operational;
  n.restarting = true;
  n.rebooted = false;
  n.left_ns = now_ns;
  n.starts = 0;
  Log(LogLevel::kWarning,
      n.Name() + ": heartbeat says " + NmtStateName(state) + ": it left operational; sending Start remote node");
  SendStart(n, now_ns);
}

void CanopenMaster::NodeRunning(NodeState& n, bool confirmed) {
  n.step = NodeState::Step::kRunning;
  n.deadline = kNever;
  n.confirmed = confirmed;
  if (!n.first && config_.sdo) n.first = n.identity;
  if (!confirmed) {
    ++counts_.unconfirmed;
    Log(LogLevel::kWarning, n.Name() + ": started by NMT; no heartbeat confirms that it is operational");
  }
  if (n.restarting) {
    n.restarting = false;
    ++counts_.restarts;
    Log(LogLevel::kInfo, n.Name() + (confirmed ? ": restarted, operational again" : ": restarted (not confirmed)"));
  }
}

void CanopenMaster::UpdatePhase(std::int64_t now_ns) {
  if (phase_ != Phase::kStarting) return;
  bool all_ready = true, all_running = true, any_failed = false, any_busy = false;
  for (const auto& n : nodes_) {
    using Step = NodeState::Step;
    any_failed |= n->step == Step::kFailed;
    any_busy |= n->step == Step::kAwaitBoot || n->step == Step::kSdo || n->step == Step::kAwaitOperational;
    all_ready &= n->step == Step::kReadyToStart;
    all_running &= n->step == Step::kRunning;
  }
  if (any_failed && !any_busy) {
    phase_ = Phase::kFailed;
    for (const auto& n : nodes_) {  // in configuration order
      if (!n->error.empty()) errors_.push_back(n->error);
    }
    return;
  }
  // No node is started before every node passed its checks: a refused start starts nothing.
  if (config_.nmt && all_ready && !start_sent_) {
    start_sent_ = true;
    if (config_.nmt_broadcast) Send(EncodeNmt(NmtCommand::kStart, 0));
    for (auto& n : nodes_) {
      n->state_before_start = n->last_state;
      n->started = true;
      if (!config_.nmt_broadcast) Send(EncodeNmt(NmtCommand::kStart, n->config.node_id));
      AwaitOperational(*n, now_ns);
    }
    UpdatePhase(now_ns);
    return;
  }
  if (all_running) {
    phase_ = Phase::kRunning;
    std::string unconfirmed;
    for (const auto& n : nodes_) {
      if (!n->confirmed) unconfirmed += (unconfirmed.empty() ? "" : ", ") + n->Name();
    }
    if (!config_.nmt) {
      Log(LogLevel::kInfo, "every node is identified");
    } else if (unconfirmed.empty()) {
      Log(LogLevel::kInfo, "every node is operational (each heartbeat says so)");
    } else {
      Log(LogLevel::kWarning, "every node is started; not confirmed operational (no heartbeat): " + unconfirmed);
    }
  }
}

void CanopenMaster::OnFrame(const CanFrame& frame) {
  const std::int64_t now = frame.t_ns;
  now_ns_ = now;
  if (frame.IsError() || frame.IsExtended() || frame.IsRemote()) return;
  for (auto& np : nodes_) {
    NodeState& n = *np;
    const auto id = static_cast<std::uint32_t>(n.config.node_id);
    if (frame.id == kHeartbeatBase + id || frame.id == kEmcyBase + id || frame.id == kSdoResponseBase + id) {
      n.heard = true;
    }
    for (const MasterDevice& d : n.config.devices) n.heard |= frame.id == d.field.can_id;
  }
  for (auto& np : nodes_) {
    NodeState& n = *np;
    // An EMCY of a running node that no heartbeat watches: it may have left operational (CiA
    // 301 error behaviour, 1029h) without a word: Start is sent (no harm to an operational node).
    if (frame.id == kEmcyBase + static_cast<std::uint32_t>(n.config.node_id)) {
      const auto e = DecodeEmergency(frame);
      if (e && e->error_register != 0 && e->error_code != 0 && config_.nmt && phase_ == Phase::kRunning &&
          n.step == NodeState::Step::kRunning && !n.confirmed) {
        Log(LogLevel::kWarning, n.Name() + ": EMCY, and no heartbeat tells its state: sending Start remote node");
        Send(EncodeNmt(NmtCommand::kStart, n.config.node_id));
      }
      return;
    }
    if (frame.id == kHeartbeatBase + static_cast<std::uint32_t>(n.config.node_id)) {
      const auto hb = DecodeHeartbeat(frame);
      if (!hb) return;
      n.last_state = hb->state;
      using Step = NodeState::Step;
      if (hb->state == static_cast<std::uint8_t>(NmtState::kBootUp)) {
        if (n.step == Step::kAwaitBoot) {
          Log(LogLevel::kInfo, n.Name() + ": boot-up");
          Advance(n, now);
        } else if (phase_ == Phase::kStarting) {
          Log(LogLevel::kWarning, n.Name() + ": boot-up message during the start: starting it over");
          Advance(n, now);
        } else {
          ++counts_.boot_ups;
          if (!config_.nmt) {
            Log(LogLevel::kWarning, n.Name() + ": boot-up message: the node rebooted (its NMT master restarts it)");
          } else {
            Log(LogLevel::kWarning, n.Name() + ": boot-up message: the node rebooted; restarting it");
            if (!n.restarting) {
              n.left_ns = now;
              n.starts = 0;
            }
            n.restarting = true;
            n.rebooted = true;
            Advance(n, now);
          }
        }
      } else if (n.step == Step::kAwaitOperational) {
        n.heartbeat_since_start = true;
        if (hb->state == static_cast<std::uint8_t>(NmtState::kOperational)) NodeRunning(n, true);
      } else if (n.step == Step::kRunning && phase_ == Phase::kRunning && config_.nmt &&
                 hb->state != static_cast<std::uint8_t>(NmtState::kOperational)) {
        LeftOperational(n, hb->state, now);
      }
      UpdatePhase(now);
      return;
    }
    if (frame.id == kSdoResponseBase + static_cast<std::uint32_t>(n.config.node_id)) {
      const SdoClient::Step step = n.sdo.OnFrame(frame);
      if (step.status != SdoClient::Status::kIgnored) OnSdoStep(n, step, now);
      UpdatePhase(now);
      return;
    }
  }
}

void CanopenMaster::OnTime(std::int64_t now_ns) {
  now_ns_ = now_ns;
  for (auto& np : nodes_) {
    NodeState& n = *np;
    using Step = NodeState::Step;
    if (n.sdo.busy()) {
      const SdoClient::Step step = n.sdo.OnTime(now_ns);
      if (step.status == SdoClient::Status::kFailed) OnSdoStep(n, step, now_ns);
    }
    if (now_ns < n.deadline) continue;
    if (n.step == Step::kAwaitBoot) {
      NodeFailed(n, "no boot-up message within " + Seconds(config_.boot_timeout_ns) + " after Reset communication");
    } else if (n.step == Step::kAwaitOperational && !config_.sdo && !n.heartbeat_since_start) {
      NodeRunning(n, false);  // no heartbeat at all: one it may not send at all
    } else if (n.step == Step::kAwaitOperational && phase_ != Phase::kStarting) {
      const std::string last = n.last_state ? NmtStateName(*n.last_state) : std::string("no heartbeat");
      if (now_ns < n.left_ns + config_.return_timeout_ns) {
        ++counts_.start_retries;
        Log(LogLevel::kWarning,
            n.Name() + ": not operational yet (last state: " + last + "): sending Start remote node again");
        SendStart(n, now_ns);
      } else {
        NodeLost(n, "no heartbeat saying operational within " + Seconds(config_.return_timeout_ns) +
                        " (Start remote node sent " + std::to_string(n.starts) + " time" + (n.starts == 1 ? "" : "s") +
                        "; last state: " + last + ")");
      }
    } else if (n.step == Step::kAwaitOperational) {
      NodeFailed(n, "no heartbeat saying operational within " + Seconds(n.wait_ns) +
                        " after Start remote node (last state: " +
                        (n.last_state ? NmtStateName(*n.last_state) : std::string("no heartbeat")) + ")");
    } else if (n.step == Step::kFailed && phase_ != Phase::kStarting) {
      NodeLost(n, n.error + " (and no boot-up within " + Seconds(config_.return_timeout_ns) + ")");
    }
  }
  UpdatePhase(now_ns);
}

std::int64_t CanopenMaster::NextDeadline() const {
  std::int64_t next = kNever;
  for (const auto& n : nodes_) {
    if (n->sdo.busy() && n->sdo.deadline_ns() < next) next = n->sdo.deadline_ns();
    if (n->deadline < next) next = n->deadline;
  }
  return next;
}

const NodeIdentity* CanopenMaster::identity(int node_id) const {
  for (const auto& n : nodes_) {
    if (n->config.node_id == node_id && n->first) return &*n->first;
  }
  return nullptr;
}

std::vector<std::pair<std::string, std::string>> CanopenMaster::HeaderFields() const {
  std::vector<std::pair<std::string, std::string>> out;
  for (const auto& n : nodes_) {
    if (!n->first) continue;
    const NodeIdentity& id = *n->first;
    for (const MasterDevice& d : n->config.devices) {
      std::string v = "node " + std::to_string(n->config.node_id);
      if (id.name) v += "; name \"" + *id.name + "\"";
      if (id.vendor_id) v += "; vendor_id " + Hex32(*id.vendor_id);
      if (id.product_code) v += "; product_code " + Hex32(*id.product_code);
      if (id.revision) v += "; revision " + Hex32(*id.revision);
      if (id.serial) v += "; serial " + Hex32(*id.serial);
      const auto r = id.resolution.find(d.role);
      if (r != id.resolution.end()) {
        if (r->second.first) v += "; measuring_units_per_revolution " + std::to_string(*r->second.first);
        if (r->second.second) v += "; total_measuring_range " + std::to_string(*r->second.second);
      }
      v += "; tpdo " + std::to_string(d.tpdo) + " cob_id " + HexId(d.field.can_id & kEffMask);
      out.emplace_back(d.header_key, v);
    }
  }
  return out;
}

std::vector<CanFrame> CanopenMaster::UndoStart() const {
  std::vector<CanFrame> out;
  if (!config_.nmt) return out;
  for (const auto& n : nodes_) {
    if (!n->started) continue;
    const std::uint8_t before = n->state_before_start.value_or(static_cast<std::uint8_t>(NmtState::kPreOperational));
    if (before == static_cast<std::uint8_t>(NmtState::kOperational)) continue;
    const auto command =
        before == static_cast<std::uint8_t>(NmtState::kStopped) ? NmtCommand::kStop : NmtCommand::kEnterPreOperational;
    out.push_back(EncodeNmt(command, n->config.node_id));
  }
  for (const auto& n : nodes_) {
    if (n->hb_written_over) {
      out.push_back(EncodeDownloadRequest(n->config.node_id, {0x1017, 0}, LittleEndianBytes(*n->hb_written_over, 2)));
    }
  }
  return out;
}

std::uint16_t CanopenMaster::LongestHeartbeatMs() const {
  std::uint16_t longest = 0;
  if (!config_.sdo) return longest;
  for (const auto& n : nodes_) longest = std::max(longest, n->hb_ms);
  return longest;
}

std::vector<std::string> CanopenMaster::NeverHeard() const {
  std::vector<std::string> out;
  for (const auto& n : nodes_) {
    if (!n->heard) out.push_back(n->Name());
  }
  return out;
}

std::vector<CanFrame> CanopenMaster::CommandAll(NmtCommand command) const {
  std::vector<CanFrame> out;
  if (!config_.nmt) return out;
  if (config_.nmt_broadcast) {
    out.push_back(EncodeNmt(command, 0));
    return out;
  }
  for (const auto& n : nodes_) out.push_back(EncodeNmt(command, n->config.node_id));
  return out;
}

}  // namespace sph::can
