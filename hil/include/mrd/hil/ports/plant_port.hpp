#pragma once
// The device side of one transport, as the harness plays it: the plant's sensors publish
// over it, and the simulated current driver hears the firmware's command, enable and
// heartbeat through it. One implementation per transport (local CAN bus / SocketCAN, Modbus
// TCP and RTU servers, simulated GPIO chip); the serve loop (serve.hpp) drives any set of them.

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "mrd/sim/damper_plant.hpp"

namespace mrd::canbus {
class LocalBusRelay;
}  // namespace mrd::canbus
namespace mrd::profile {
struct CanProfile;
struct ModbusProfile;
}  // namespace mrd::profile

namespace mrd::hil {

// A fault the harness injects into one step's sensor messages (scenario fault schedule).
enum class SensorFault : std::uint8_t {
  kNone = 0,
  kDrop,        // not sent
  kCorrupt,     // one data bit flipped after sealing (checksum / CRC mismatch)
  kStall,       // the previous step's messages again, unchanged (repeated counter)
  kOutOfRange,  // velocity beyond the transport's range (receiver refuses it)
  kNan,         // velocity the transport cannot represent (CAN: raw 0x8000)
};

// One plant step's sensor values as the transport carries them.
struct SensorOutput {
  SensorFault fault = SensorFault::kNone;
  PlantSample sample;
  std::uint32_t seq = 0;    // step number (CAN rolling counter / Modbus sequence register)
  std::int64_t t_ns = 0;    // CLOCK_MONOTONIC when published
  bool fault_line = false;  // fault input asserted (GPIO / status register)
  bool drive_heartbeat_loss = false;  // CANopen: the drive's heartbeat not sent this step
  bool driver_fault = false;          // the driver reports a fault (its driver_faults role)
  bool enable_refused = false;        // Modbus profile: writes of the enable get exception 0x04
};

// What arrived from the firmware since the last Poll; each port sets only what it carries.
struct DriverInput {
  bool has_command = false;
  double volts = 0.0;           // set-point [V] as received (may be anything: the invariant
                                // check is the harness's job)
  std::int64_t command_ns = 0;  // when the latest command arrived
  bool has_echo = false;
  std::uint32_t echo = 0;  // sensor seq the command was computed from (latency)
  bool has_enable = false;
  bool enable = false;
  std::int64_t heartbeat_ns = 0;  // latest heartbeat seen (0: none yet)
  std::uint64_t heartbeats = 0;   // heartbeats heard so far (lockstep: freshness per step)
  bool has_safe = false;          // the command carried the firmware's safe-state flag
  bool safe = false;
  bool has_status = false;          // a firmware status arrived since the last Poll
  std::uint16_t status_causes = 0;  // its active watchdog causes (bit i = cause i)
  bool status_safe = false;
  // Modbus profile with a periodic write under watchdog_ms: the driver's communication
  // watchdog (real time only): false once an armed keep-alive write stopped for watchdog_ms
  // (the driver drops its coil until the writes come again).
  bool has_watchdog = false;
  bool watchdog_ok = true;
};

struct PortCounters {
  std::uint64_t published = 0;  // sensor messages / register updates
  std::uint64_t received = 0;   // commands and heartbeats heard
  std::uint64_t rejected = 0;   // malformed messages from the firmware
  std::uint64_t refused = 0;    // Modbus TCP: clients refused (over the limit) or dropped
                                // (a request not complete in time, replies not read)
};

class PlantPort {
 public:
  virtual ~PlantPort() = default;
  virtual const char* name() const = 0;
  // Binds, listens or creates its endpoint; called before the firmware starts. false: *error.
  virtual bool Open(std::string* error) = 0;
  // Publishes one step's sensors. Must not block.
  virtual void Publish(const SensorOutput& out) = 0;
  // Merges what the firmware sent since the last call into *in. Must not block.
  virtual void Poll(DriverInput* in) = 0;
  virtual void Close() = 0;
  virtual PortCounters counters() const = 0;
  // Lockstep: grants the firmware time t_ns, after this step's sensors. false: this
  // transport carries no grants (the run then uses the real-time clock).
  virtual bool SendGrant(std::int64_t t_ns) {
    (void)t_ns;
    return false;
  }
  // Lockstep: Poll hands over one firmware tick at a time (CAN: up to its status frame).
  virtual void SetLockstep(bool on) { (void)on; }
  // Lockstep: the firmware's status travels on this port with every tick's command (the
  // harness then waits for both).
  virtual bool CarriesStatus() const { return true; }
  // The firmware's heartbeat travels on this port (the simulated driver then supervises it:
  // no fresh heartbeat, no current). A driver whose profile maps no heartbeat is not
  // supervised (it applies every command it hears).
  virtual bool CarriesHeartbeat() const { return true; }
  // Peers that have joined the transport so far (a count that only grows), or -1 when the
  // port cannot tell. Lockstep start-up: the harness offers its first step again only when a
  // peer joined since the last offer (else an offer reaches nobody, or the firmware twice).
  virtual std::int64_t Joined() const { return -1; }
  // A new firmware instance is starting (the harness restarted it): forget the previous
  // sender's rolling counters, so its first frames are not taken for repeated or stale ones.
  virtual void PeerRestarted() {}
  // CANopen drives (a profile with [canopen]), a test hook: the drive refuses SDO downloads to
  // index:subindex (subindex -1: any) with this abort code. false: this port plays no
  // CANopen drive.
  virtual bool RefuseSdo(int index, int subindex, std::uint32_t abort_code) {
    (void)index;
    (void)subindex;
    (void)abort_code;
    return false;
  }
  // Waits up to timeout_ns for something from the firmware (then Poll). Default: sleeps a
  // little (transports without a pollable fd).
  virtual void Wait(std::int64_t timeout_ns);
};

// Per transport (can_port.cpp, modbus_port.cpp, gpio_port.cpp). endpoint: the local bus
// socket path or CAN interface; "HOST:PORT" for Modbus TCP; the pty link path for Modbus
// RTU; the simulated chip path (with optional line settings, gpio_port.hpp) for GPIO. nullptr
// when the transport is not in this build (GPIO: or the endpoint does not parse).
// CAN: in the messages of a device profile (nullptr: the built-in mrd-native one).
std::unique_ptr<PlantPort> MakeCanPort(
    const std::string& endpoint, std::shared_ptr<const profile::CanProfile> profile = nullptr);
std::unique_ptr<PlantPort> MakeModbusTcpPort(const std::string& endpoint);
std::unique_ptr<PlantPort> MakeModbusRtuPort(const std::string& endpoint);
// Modbus TCP (rtu false) or RTU on a device profile's map, at every unit id it names
// (modbus_profile_port.cpp).
std::unique_ptr<PlantPort> MakeModbusProfilePort(
    bool rtu, const std::string& endpoint, std::shared_ptr<const profile::ModbusProfile> profile);
// Several damper channels' maps (profiles[k]: channel k's) served by one server on one
// endpoint, as one sensor module and one driver with a block per channel: one port per
// channel (its Publish, Poll and Wait are that channel's; Open and Close share the server: the
// first opens it, the last closes it). Lockstep: publish every channel's step, then send the
// grant through channel 0's port (its grant role; every channel's staged step goes into the
// tables with it); the other ports' SendGrant does nothing. Empty with *error when the maps
// cannot share one link (profile::PlanModbusChannels).
std::vector<std::unique_ptr<PlantPort>> MakeModbusProfilePorts(
    bool rtu, const std::string& endpoint,
    std::vector<std::shared_ptr<const profile::ModbusProfile>> profiles, std::string* error);
std::unique_ptr<PlantPort> MakeGpioPort(const std::string& endpoint);
// CAN as an in-process node of a local-bus relay this process runs (mrd-hil run owns the bus):
// frames go straight to the relay's socket nodes and come back through its tap; Wait steps the
// relay. The relay outlives the port.
std::unique_ptr<PlantPort> MakeCanPortOnRelay(
    canbus::LocalBusRelay& relay, std::shared_ptr<const profile::CanProfile> profile = nullptr);
// Several such ports on one relay, one per profile (the corners of a vehicle, each playing its
// corner's drive and sensors): the relay's one tap is handed to every port, each keeping the
// frames its profile listens to (its command, status, the firmware's heartbeat, its drive's
// NMT and SDO). Do not make another port on the relay while these live.
std::vector<std::unique_ptr<PlantPort>> MakeCanPortsOnRelay(
    canbus::LocalBusRelay& relay,
    const std::vector<std::shared_ptr<const profile::CanProfile>>& profiles);
// Lockstep, one tick of several ports on one relay: each port's sensors (outs[i] on ports[i];
// the relay holds them), then ONE grant of grant_ns through the first port (releasing the
// tick's frames in one batch).
void PublishTick(const std::vector<PlantPort*>& ports, const std::vector<SensorOutput>& outs,
                 std::int64_t grant_ns);

}  // namespace mrd::hil
