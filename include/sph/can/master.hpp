// The CANopen master of the acquisition: brings the SCMS devices from pre-operational to
// operational, identifies and checks them over SDO, and restarts a node that rebooted mid-run.
// Pure: frames in (with their receive time), frames out through a callback, time passed in, so
// the daemon drives it live and the replay of a frame log drives it the same way (its outputs
// then go nowhere: the log holds what was sent).
//
// The start, per node and all nodes at once (CiA 301, CiA 406): 1. [reset communication, wait for
// the boot-up], 2. [enter pre-operational], 3. SDO uploads of the identity, heartbeat (1017h, given
// one when 0), SYNC counter (1019h) and resolution objects, 4. [write the TPDO settings and 1019h],
// 5. read and check each TPDO, 1019h and the resolution (a mismatch refuses the start unless the
// configuration is trusted), 6. once every node passed, NMT Start; a node is operational only when
// its heartbeat says so. A node that reboots mid-run runs steps 2 to 6 again, if it is the same
// device; a node whose heartbeat leaves operational mid-run is sent Start again (and again, each
// time the wait for its heartbeat runs out). A node not operational again within the return
// timeout ends the acquisition (Phase::kNodeLost). Each step, with the objects and the checks:
// docs/method/acquisition.md.
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
  /// The size of the mapped object's value [bytes] by its configured data type, checked by
  /// reading the object over SDO (0: not checked); named in messages as `type_name`.
  int value_bytes = 0;
  std::string type_name;
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
  /// Mid-run: a node that left operational (rebooted, or its heartbeat says another state) must be
  /// operational again within this, else the acquisition ends (Phase::kNodeLost).
  std::int64_t return_timeout_ns = 10'000'000'000;

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
  /// kNodeLost: a node did not come back mid-run (errors() says which and why).
  enum class Phase { kStarting, kRunning, kFailed, kNodeLost };
  struct Callbacks {
    std::function<void(const CanFrame&)> send;
    std::function<void(LogLevel, const std::string&)> log;
    std::function<void(const std::string&)> note;  ///< mid-run events for the points file
  };
  struct Counts {
    std::uint64_t boot_ups = 0;          ///< mid-run boot-up messages of running nodes
    std::uint64_t restarts = 0;          ///< nodes brought back to operational after one
    std::uint64_t restart_failures = 0;  ///< nodes that could not be restarted
    std::uint64_t left_operational = 0;  ///< running nodes whose heartbeat left operational (sent Start)
    std::uint64_t start_retries = 0;     ///< Start sent again to a node not yet operational
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
  /// Why the start failed (phase() == kFailed) or which node was lost (kNodeLost): one line per
  /// problem.
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
  /// The frames that leave the bus as the start found it, after a refused or aborted start: each
  /// node the master started back to the state its heartbeat showed before (pre-operational
  /// unless it was operational or stopped), and each producer heartbeat time 1017h it wrote
  /// written back (SDO download, its answer not awaited). None without nmt.
  std::vector<CanFrame> UndoStart() const;
  /// The longest producer heartbeat time [ms] of the identified nodes, as found or set (0: none
  /// known: without SDO, or no node sends heartbeats).
  std::uint16_t LongestHeartbeatMs() const;
  /// The nodes no frame came from (heartbeat, EMCY, SDO answer, a PDO of its devices) since
  /// Begin(): "node 3 (probe)".
  std::vector<std::string> NeverHeard() const;

 private:
  struct NodeState;
  void Send(const CanFrame& frame);
  void Advance(NodeState& n, std::int64_t now_ns);
  void StartSdo(NodeState& n, std::int64_t now_ns);
  void NextJob(NodeState& n, std::int64_t now_ns);
  void FinishSdo(NodeState& n, std::int64_t now_ns);
  void SendStart(NodeState& n, std::int64_t now_ns);
  void AwaitOperational(NodeState& n, std::int64_t now_ns);
  /// Mid-run, a failure that retrying cannot mend (`permanent`) or past the return timeout ends
  /// the acquisition; another waits for a boot-up until then.
  void NodeFailed(NodeState& n, const std::string& why, bool permanent = false);
  void NodeLost(NodeState& n, const std::string& why);
  /// A running node's heartbeat says `state` (not operational, not boot-up): Start again.
  void LeftOperational(NodeState& n, std::uint8_t state, std::int64_t now_ns);
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
  std::int64_t now_ns_ = 0;  ///< the time of the frame or timeout being handled
  std::vector<std::string> errors_;
  Counts counts_;
};

}  // namespace sph::can

#endif  // SPH_CAN_MASTER_HPP_
