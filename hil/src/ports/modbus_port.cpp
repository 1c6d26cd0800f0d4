// The harness's Modbus side: the register map of docs/modbus_registers.md served over TCP
// ("HOST:PORT", several clients at once) or RTU on a pseudo-terminal (the endpoint becomes a
// symlink to the pty's slave, which the firmware opens as its serial device; the server talks
// on the master). The wire is modbus_server.hpp's (its own thread, non-blocking descriptors);
// the registers are here: each request is answered from a copy taken under the mutex, and a
// write puts the command block back under it, so the plant loop (Publish, Poll, SendGrant,
// Wait) never waits on a client. The server implements 0x03 and 0x10 (modbus_server.hpp in
// common/protocol: the exception codes); refused requests count as rejected.
// Lockstep: Publish stages the step's sensor block and SendGrant writes it together with the
// grant register (13-15) under one lock, so the firmware never reads a step's values without
// its grant (their stamp is the grant); the firmware's tick answers with one command block
// carrying its status, which wakes Wait.
#include <arpa/inet.h>
#include <fcntl.h>
#include <pty.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstring>
#include <mutex>
#include <thread>
#include <vector>

#include "modbus_served_port.hpp"
#include "mrd/common/clock.hpp"
#include "mrd/hil/ports/plant_port.hpp"
#include "mrd/protocol/modbus_map.hpp"
#include "mrd/protocol/modbus_server.hpp"

namespace mrd::hil {
namespace {

namespace map = mrd::protocol::modbus;

class ModbusPort final : public ModbusServedPort {
 public:
  ModbusPort(bool rtu, std::string endpoint) : ModbusServedPort(rtu, std::move(endpoint)) {}
  ~ModbusPort() override { Close(); }

  bool Open(std::string* error) override {
    {
      std::lock_guard<std::mutex> lock(mu_);
      std::fill(regs_, regs_ + map::kMapSize, std::uint16_t{0});
      // Until the firmware writes: no set-point, enable not driven, no heartbeat.
      regs_[map::kCommandBase + map::kSetPoint] = map::kNoSetPoint;
      regs_[map::kCommandBase + map::kEnable] = map::kEnableNotDriven;
    }
    return ModbusServedPort::Open(error);
  }

  // Faults on a register transport: drop and stall leave the block as it was (the firmware
  // reads the previous seq again: no new data); a NaN cannot be encoded, so the block is not
  // updated either (the map's rule for unrepresentable values); out_of_range writes a block
  // with a reserved fault bit set, which the firmware's decoder refuses (bad_value). Corrupt
  // frames are a CAN fault only (run.cpp refuses them here).
  void Publish(const SensorOutput& out) override {
    if (out.fault == SensorFault::kDrop || out.fault == SensorFault::kStall) return;
    map::SensorBlock b;
    b.seq = out.seq;
    b.velocity = out.fault == SensorFault::kNan ? std::nan("") : out.sample.v;
    b.displacement = out.sample.x;
    b.demand = out.sample.demand;
    b.body_velocity = out.sample.body_velocity;
    b.force = out.sample.force;
    b.fault_line = out.fault_line;
    b.driver_fault = out.driver_fault;
    std::uint16_t regs[map::kSensorCount] = {};
    if (map::EncodeSensors(b, regs) != map::MapError::kOk) return;             // not representable
    if (out.fault == SensorFault::kOutOfRange) regs[map::kFaults] |= 0x8000U;  // reserved bit
    std::lock_guard<std::mutex> lock(mu_);
    ++counters_.published;
    if (lockstep_) {  // written with the grant, so no read sees the block without it
      std::copy(regs, regs + map::kSensorCount, staged_);
      staged_valid_ = true;
      return;
    }
    std::copy(regs, regs + map::kSensorCount, regs_ + map::kSensorBase);
  }

  bool SendGrant(std::int64_t t_ns) override {
    std::uint16_t regs[3];
    map::PutU48(static_cast<std::uint64_t>(t_ns / 1000), regs);
    std::lock_guard<std::mutex> lock(mu_);
    if (!open_) return false;
    if (staged_valid_) {
      std::copy(staged_, staged_ + map::kSensorCount, regs_ + map::kSensorBase);
      staged_valid_ = false;
    }
    std::copy(regs, regs + 3, regs_ + map::kSensorBase + map::kGrant);
    return true;
  }

  void Poll(DriverInput* in) override {
    std::lock_guard<std::mutex> lock(mu_);
    if (heartbeat_ns_ != 0) in->heartbeat_ns = heartbeat_ns_;
    in->heartbeats = heartbeats_;
    if (!pending_) return;
    pending_ = false;
    if (last_.has_set_point) {
      in->has_command = true;
      in->volts = last_.set_point;
      in->command_ns = command_ns_;
      in->has_echo = true;
      in->echo = last_.echo;
    }
    if (last_.enable_driven) {
      in->has_enable = true;
      in->enable = last_.enable;
    }
    if (last_.has_status) {
      in->has_status = true;
      in->status_causes = last_.causes;
      in->status_safe = last_.safe;
      in->has_safe = true;
      in->safe = last_.safe;
    }
  }

 private:
  // ModbusServer::Bank: one request against a copy of the registers; a write goes back
  // under the lock (the command block and the unused 41..47: the plant never writes them).
  map::ServerAnswer Answer(std::uint8_t /*unit*/, const std::uint8_t* pdu, int len,
                           std::uint8_t* reply) override {
    std::uint16_t regs[map::kMapSize];
    {
      std::lock_guard<std::mutex> lock(mu_);
      std::copy(regs_, regs_ + map::kMapSize, regs);
    }
    const map::ServerAnswer a = map::AnswerRequest(pdu, len, regs, reply);
    std::lock_guard<std::mutex> lock(mu_);
    if (a.exception) ++counters_.rejected;
    if (!a.wrote) return a;
    std::copy(regs + map::kCommandBase, regs + map::kMapSize, regs_ + map::kCommandBase);
    map::CommandBlock c;
    if (!a.command || map::DecodeCommand(regs_ + map::kCommandBase, &c) != map::MapError::kOk) {
      return a;
    }
    // Lockstep: a block the firmware wrote again (its write timed out on a stalled harness
    // and was retried) is the same tick, not the next one: only a new tick count is a command.
    if (lockstep_ && have_last_ && c.has_status && last_.has_status && c.ticks == last_.ticks) {
      return a;
    }
    const std::int64_t now = common::MonotonicNs();
    ++counters_.received;
    have_last_ = true;
    if (c.heartbeat != last_.heartbeat) {
      heartbeat_ns_ = now;
      ++heartbeats_;
    }
    last_ = c;
    command_ns_ = now;
    pending_ = true;
    written_.notify_all();
    return a;
  }
  void PeerRestarted() override {
    std::lock_guard<std::mutex> lock(mu_);
    have_last_ = false;  // a new firmware counts its ticks from the start
  }

  // Guarded by mu_:
  std::uint16_t regs_[map::kMapSize] = {};  // holding registers 0..47
  map::CommandBlock last_;
  bool have_last_ = false;
  std::int64_t command_ns_ = 0;
  std::int64_t heartbeat_ns_ = 0;
  std::uint64_t heartbeats_ = 0;                  // heartbeat changes heard
  std::uint16_t staged_[map::kSensorCount] = {};  // lockstep: the step's block, until its grant
  bool staged_valid_ = false;
};

}  // namespace

std::unique_ptr<PlantPort> MakeModbusTcpPort(const std::string& endpoint) {
  return std::make_unique<ModbusPort>(false, endpoint);
}

std::unique_ptr<PlantPort> MakeModbusRtuPort(const std::string& endpoint) {
  return std::make_unique<ModbusPort>(true, endpoint);
}

}  // namespace mrd::hil
