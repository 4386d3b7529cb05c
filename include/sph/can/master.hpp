// The CANopen master of the acquisition: brings the SCMS devices from pre-operational to
// operational, identifies and checks them over SDO, and restarts a node that rebooted mid-run.
// Pure: frames in (with their receive time), frames out through a callback, time passed in, so
// the daemon drives it live and the replay of a frame log drives it the same way (its outputs
// then go nowhere: the log holds what was sent).
//
// Start, per node (all nodes at once, each on its own SDO channel):
//   1. [--nmt-reset-comm] NMT Reset communication, then wait for the node's boot-up message
//      (CiA 301 §7.2.8.3.1, §7.2.8.3.3).
//   2. [--configure-pdo] NMT Enter pre-operational: PDO parameters can only be written there.
//   3. SDO uploads: identity 1018h (sub 1 vendor-id, 2 product code, 3 revision, 4 serial number;
//      CiA 301 §7.5.2.21), device name 1008h, producer heartbeat time 1017h, synchronous counter
//      overflow value 1019h; for each encoder the measuring units per revolution 6001h and the
//      total measuring range 6002h (CiA 406). A node whose 1017h is 0 sends no heartbeat, so
//      nothing could confirm its NMT state: the master writes heartbeat_ms into it (and reads it
//      back), as a CiA 302 master configures the heartbeats it consumes.
//   4. [--configure-pdo] for each device's TPDO k the CiA 301 sequence: COB-ID (1800h + k - 1,
//      sub 1) with bit 31 set (PDO invalid), transmission type (sub 2) = 1, mapping count
//      (1A00h + k - 1, sub 0) = 0, the mapping entry (sub 1: index << 16 | sub-index << 8 | bits),
//      count = 1, COB-ID valid (§7.5.2.37, §7.5.2.38); 1019h = the SYNC's counter overflow value.
//   5. SDO uploads of each TPDO's COB-ID, transmission type and mapping, and the checks: the
//      COB-ID valid and the configured one; transmission type 1 (synchronous, every SYNC); the
//      configured object (0x6004:00 for an encoder) mapped with the configured width at the
//      configured byte; 6001h equal to the configured counts per revolution; a single-turn
//      encoder's 6002h equal to its 6001h; 1019h equal to the SYNC's counter overflow value (a
//      node expecting another SYNC length refuses every SYNC: EMCY 0x8240, pre-operational); a
//      heartbeat to confirm its state. A mismatch refuses the start, naming node, object and both
//      values, unless the configuration is trusted (then it is a warning).
//   6. Once every node passed (a refused start starts no node): NMT Start remote node, one
//      broadcast to node 0 or one per node, then wait for the heartbeat that says operational.
//      A node is operational only when its heartbeat says so; one that cannot tell (no SDO to
//      learn its heartbeat, or a trusted node without one) is "started", not confirmed.
//
// Mid-run, a boot-up message (heartbeat state 0x00) of a running node means it rebooted and is
// pre-operational again: steps 2 to 6 run again (its PDO settings may be back at the defaults),
// its identity must be the one read at the start (else it is not restarted: another device), a
// heartbeat time other than at the start is flagged (the node may have lost its stored settings)
// and the start's one written back; it is running again only when its heartbeat says operational.
#ifndef SPH_CAN_MASTER_HPP_
#define SPH_CAN_MASTER_HPP_

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "sph/can/canopen.hpp"
#include "sph/can/frame.hpp"
#include "sph/can/pipeline.hpp"
#include "sph/can/sdo.hpp"

namespace sph::can {

/// One device of a node as the master checks it: its TPDO and, for an encoder, its resolution.
struct MasterDevice {
  std::string role;        ///< "theta", "phi", "probe"
  std::string header_key;  ///< "device_theta_encoder": the points-file header field
  int tpdo = 1;            ///< TPDO number 1..512: objects 1800h + tpdo - 1, 1A00h + tpdo - 1
  FieldLayout field;       ///< the value's place in the TPDO (can_id with kEffFlag for 29 bit)
  /// The object mapped at `field` (0x6004:00 for an encoder); empty: the mapping is not checked.
  std::optional<ObjectAddress> mapped_object;
  bool encoder = false;
  std::uint64_t counts_per_rev = 0;
  bool multi_turn = false;
  /// Where the configured values came from, for messages: "--theta-counts-per-rev" etc.
  std::string cpr_name = "the configured counts per revolution";
  std::string cob_name = "the configured COB-ID";
  std::string layout_name = "the configured layout";
};

struct MasterNode {
  int node_id = 1;
  std::string name;  ///< "theta", or "theta+phi" for a node with two devices
  std::vector<MasterDevice> devices;
};

struct MasterConfig {
  std::vector<MasterNode> nodes;
  bool nmt = true;                   ///< send NMT commands (false: another master does)
  bool nmt_broadcast = false;        ///< start all nodes with one command to node 0
  bool reset_communication = false;  ///< Reset communication first, wait for the boot-ups
  bool sdo = true;                   ///< identify and check the devices
  bool trust_config = false;         ///< mismatches are warnings, not a refused start
  bool configure_pdo = false;        ///< write the TPDO settings (needs nmt), then verify them
  /// The SYNC counter overflow value of the bus (0: SYNC without counter), which each node's
  /// 1019h must equal; -1: not checked.
  int sync_counter_max = -1;
  std::string sync_counter_name = "the SYNC counter overflow value";  ///< for messages
  /// Producer heartbeat time [ms] written into a node whose 1017h is 0; 0: none written.
  std::uint16_t heartbeat_ms = 100;
  std::string heartbeat_name = "the master's heartbeat time";  ///< for messages
  std::int64_t sdo_timeout_ns = 500'000'000;
  std::int64_t boot_timeout_ns = 5'000'000'000;  ///< a boot-up after Reset communication
  /// After Start remote node: a node that produces heartbeats must report operational within
  /// this plus three of its heartbeat periods.
  std::int64_t operational_timeout_ns = 500'000'000;

  /// Throws sph::Error (configure_pdo without nmt, node ids, TPDO numbers, ...).
  void Validate() const;
};

/// The nodes of the SCMS devices of `devices` (theta, phi, probe; nodes with id 0 are no
/// CANopen nodes and left out; two devices on one node share it): each TPDO from the predefined
/// connection set (TPDO1 where the COB-ID is none of it), the encoders' 0x6004:00 mapped at
/// their field, the probe's mapping not checked.
std::vector<MasterNode> MasterNodesFor(const PipelineConfig& devices);

/// What a node told about itself (each value only when the device has the object).
struct NodeIdentity {
  std::optional<std::uint32_t> vendor_id, product_code, revision, serial;
  std::optional<std::string> name;
  std::optional<std::uint16_t> heartbeat_ms;     ///< 1017h as found, before the master wrote it
  std::optional<std::uint8_t> sync_counter_max;  ///< 1019h as found
  /// Per device (by role): 6001h and 6002h of encoders.
  std::map<std::string, std::pair<std::optional<std::uint32_t>, std::optional<std::uint32_t>>> resolution;
};

class CanopenMaster {
 public:
  enum class Phase { kStarting, kRunning, kFailed };
  struct Callbacks {
    std::function<void(const CanFrame&)> send;
    std::function<void(LogLevel, const std::string&)> log;
    std::function<void(const std::string&)> note;  ///< mid-run events for the points file
  };
  struct Counts {
    std::uint64_t boot_ups = 0;          ///< mid-run boot-up messages of running nodes
    std::uint64_t restarts = 0;          ///< nodes brought back to operational after one
    std::uint64_t restart_failures = 0;  ///< nodes that could not be restarted
    std::uint64_t unconfirmed = 0;       ///< nodes started without a heartbeat to confirm it
    std::uint64_t sdo_transfers = 0;
    std::uint64_t nmt_commands = 0;
  };

  /// Validates `config` (throws sph::Error).
  CanopenMaster(MasterConfig config, Callbacks callbacks);
  ~CanopenMaster();
  CanopenMaster(const CanopenMaster&) = delete;
  CanopenMaster& operator=(const CanopenMaster&) = delete;

  /// Starts every node at `now_ns` (sends the first commands).
  void Begin(std::int64_t now_ns);
  /// A received frame (also the master's own, echoed: they are ignored); its time is `now`.
  void OnFrame(const CanFrame& frame);
  /// Timeouts at `now_ns`.
  void OnTime(std::int64_t now_ns);
  /// The earliest time something is due (a timeout), or INT64_MAX.
  std::int64_t NextDeadline() const;

  Phase phase() const { return phase_; }
  /// Why the start failed (phase() == kFailed): one line per problem.
  const std::vector<std::string>& errors() const { return errors_; }
  const Counts& counts() const { return counts_; }
  const MasterConfig& config() const { return config_; }
  /// The identity read at the start, by node id.
  const NodeIdentity* identity(int node_id) const;
  /// Header fields "device_theta_encoder" -> "node 1; name \"...\"; vendor_id 0x...; ..." of the
  /// identified devices, in configuration order.
  std::vector<std::pair<std::string, std::string>> HeaderFields() const;
  /// The NMT frames that bring every node to `command` (at exit); none without nmt.
  std::vector<CanFrame> CommandAll(NmtCommand command) const;

 private:
  struct NodeState;
  void Send(const CanFrame& frame);
  void Advance(NodeState& n, std::int64_t now_ns);
  void StartSdo(NodeState& n, std::int64_t now_ns);
  void NextJob(NodeState& n, std::int64_t now_ns);
  void FinishSdo(NodeState& n, std::int64_t now_ns);
  void SendStart(NodeState& n, std::int64_t now_ns);
  void AwaitOperational(NodeState& n, std::int64_t now_ns);
  void NodeFailed(NodeState& n, const std::string& why);
  /// The node runs: `confirmed` by its heartbeat saying operational (or without NMT, identified).
  void NodeRunning(NodeState& n, bool confirmed);
  /// After a read of 1017h: the write (and read back) of the heartbeat the master wants of the node.
  void ConfigureHeartbeat(NodeState& n, std::uint16_t found);
  void OnSdoStep(NodeState& n, const SdoClient::Step& step, std::int64_t now_ns);
  void UpdatePhase(std::int64_t now_ns);
  std::vector<std::string> Check(const NodeState& n, std::vector<std::string>* warnings) const;
  void Log(LogLevel level, const std::string& text) const;

  MasterConfig config_;
  Callbacks cb_;
  std::vector<std::unique_ptr<NodeState>> nodes_;
  Phase phase_ = Phase::kStarting;
  bool start_sent_ = false;
  std::vector<std::string> errors_;
  Counts counts_;
};

}  // namespace sph::can

#endif  // SPH_CAN_MASTER_HPP_
