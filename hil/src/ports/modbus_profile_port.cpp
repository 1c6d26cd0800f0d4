// The harness's Modbus side on a device profile (modbus_profile.hpp): the sensor module and
// the current driver of the profile's map, served over TCP or RTU by the harness's own
// server (modbus_server.hpp) at every unit id the profile names. Each unit holds the four
// tables (coils, discrete inputs, holding and input registers; 65536 entries each) and
// answers 0x01 0x02 0x03 0x04 reads and 0x05 0x06 0x0F 0x10 writes, Modbus Application
// Protocol checks in order (function 0x01, quantity 0x03, address 0x02, value 0x03).
// Publish stores the step's sensor roles (lockstep: staged, and stored with the grant role
// under one lock, so no read sees a step's values without its grant). A write that touches
// the command role's registers (without one: the enable's) is the firmware's cycle: the
// output roles are decoded from the tables then, the set-point through the profile's
// calibration inverted to volts, and Wait wakes.
// Faults: drop and stall leave the values as they were; nan stores a float32 NaN in the
// velocity register (an integer register cannot hold one: left as it was); out_of_range
// stores 1e30 cm/s where the type can hold it. The driver's side: driver_fault (and
// fault_line, as on CAN) sets its driver_faults register to 1; enable_refused answers every
// write touching the enable's registers (coils) with exception 0x04, the others as usual.
// Start-up and periodic writes land in the tables like any write. A periodic write with
// watchdog_ms arms the driver's communication watchdog on its first arrival; in real time,
// once it has not come for watchdog_ms the driver drops its coil (DriverInput::watchdog_ok)
// until it comes again (lockstep: plant time is not wall time, not supervised).
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstring>
#include <map>
#include <mutex>
#include <vector>

#include "modbus_served_port.hpp"
#include "mrd/common/clock.hpp"
#include "mrd/hil/ports/plant_port.hpp"
#include "mrd/profile/modbus_profile.hpp"

namespace mrd::hil {
namespace {

namespace pf = mrd::profile;
namespace mb = mrd::protocol::modbus;

constexpr std::size_t kTableSize = 65536;

class ModbusProfilePort final : public ModbusServedPort {
 public:
  ModbusProfilePort(bool rtu, std::string endpoint, std::shared_ptr<const pf::ModbusProfile> p)
      : ModbusServedPort(rtu, std::move(endpoint)), profile_(std::move(p)) {
    const auto add = [&](const pf::ModbusPoint& pt) {
      if (!pt.mapped || units_.count(pt.unit) != 0) return;
      Unit& u = units_[pt.unit];
      for (auto& t : u.tables) t.assign(kTableSize, 0);
    };
    for (const auto& pt : profile_->inputs) add(pt);
    for (const auto& pt : profile_->outputs) add(pt);
    const auto add_fixed = [&](const pf::ModbusFixedWrite& w) {
      pf::ModbusPoint pt;
      pt.mapped = true;
      pt.unit = w.unit;
      add(pt);
    };
    for (const auto& w : profile_->startup) add_fixed(w);
    for (const auto& w : profile_->periodic) add_fixed(w);
    keepalive_ns_.assign(profile_->periodic.size(), 0);
    // The cycle's end: the command's write (without one, the enable's).
    const pf::ModbusPoint& cmd = profile_->Out(pf::ModbusOut::kCommand);
    enable_point_ = profile_->Out(pf::ModbusOut::kEnable);
    trigger_ = cmd.mapped ? &cmd : &profile_->Out(pf::ModbusOut::kEnable);
  }
  ~ModbusProfilePort() override { Close(); }

  void Publish(const SensorOutput& out) override {
    {
      // The driver's side holds whatever the sensor module does: its fault report (stored
      // with the grant in lockstep, as the sensor values) and its refusal of enable writes.
      std::lock_guard<std::mutex> lock(mu_);
      enable_refused_ = out.enable_refused;
      driver_fault_ = out.driver_fault || out.fault_line;
      if (!lockstep_) StoreDriverFault();
    }
    if (out.fault == SensorFault::kDrop || out.fault == SensorFault::kStall) return;
    Staged s;
    s.valid = true;
    const auto set = [&](pf::CanIn r, double v) { s.v[static_cast<std::size_t>(r)] = v; };
    set(pf::CanIn::kVelocity, out.fault == SensorFault::kNan          ? std::nan("")
                              : out.fault == SensorFault::kOutOfRange ? 1e30
                                                                      : out.sample.v);
    set(pf::CanIn::kDisplacement, out.sample.x);
    set(pf::CanIn::kDemand, out.sample.demand);
    set(pf::CanIn::kBodyVelocity, out.sample.body_velocity);
    set(pf::CanIn::kForce, out.sample.force);
    set(pf::CanIn::kBodyAcceleration, out.sample.body_acceleration);
    set(pf::CanIn::kWheelVelocity, out.sample.wheel_velocity);
    set(pf::CanIn::kFloorAcceleration1, out.sample.floor_acceleration[0]);
    set(pf::CanIn::kFloorAcceleration2, out.sample.floor_acceleration[1]);
    set(pf::CanIn::kFloorAcceleration3, out.sample.floor_acceleration[2]);
    set(pf::CanIn::kFaultLine, out.fault_line ? 1.0 : 0.0);
    set(pf::CanIn::kSensorSeq, static_cast<double>(out.seq));
    std::lock_guard<std::mutex> lock(mu_);
    ++counters_.published;
    if (lockstep_) {  // stored with the grant
      staged_ = s;
      return;
    }
    Store(s);
  }

  bool SendGrant(std::int64_t t_ns) override {
    const pf::ModbusPoint& g = profile_->In(pf::CanIn::kGrant);
    std::lock_guard<std::mutex> lock(mu_);
    if (!open_ || !g.mapped) return false;
    if (staged_.valid) {
      Store(staged_);
      staged_.valid = false;
    }
    StoreDriverFault();
    (void)pf::StoreModbusPoint(*profile_, g, static_cast<double>(t_ns / 1000), Table(g));
    return true;
  }

  bool CarriesStatus() const override {
    return profile_->Out(pf::ModbusOut::kStatusSafe).mapped ||
           profile_->Out(pf::ModbusOut::kStatusCauses).mapped;
  }

  bool CarriesHeartbeat() const override { return profile_->Out(pf::ModbusOut::kHeartbeat).mapped; }

  void Poll(DriverInput* in) override {
    std::lock_guard<std::mutex> lock(mu_);
    if (heartbeat_ns_ != 0) in->heartbeat_ns = heartbeat_ns_;
    in->heartbeats = heartbeats_;
    if (!lockstep_ && WatchdogArmedAny()) {
      in->has_watchdog = true;
      in->watchdog_ok = WatchdogOk(common::MonotonicNs());
    }
    if (!pending_) return;
    pending_ = false;
    const auto mapped = [&](pf::ModbusOut r) { return profile_->Out(r).mapped; };
    if (mapped(pf::ModbusOut::kCommand)) {
      in->has_command = true;
      in->volts = volts_;
      in->command_ns = command_ns_;
    }
    if (mapped(pf::ModbusOut::kEcho)) {
      in->has_echo = true;
      in->echo = echo_;
    }
    if (mapped(pf::ModbusOut::kEnable)) {
      in->has_enable = true;
      in->enable = enable_;
    }
    if (mapped(pf::ModbusOut::kSafe) || mapped(pf::ModbusOut::kStatusSafe)) {
      in->has_safe = true;
      in->safe = safe_;
    }
    if (CarriesStatus()) {
      in->has_status = true;
      in->status_causes = causes_;
      in->status_safe = safe_;
    }
  }

 private:
  struct Unit {
    std::vector<std::uint16_t> tables[4];  // by ModbusTable: coils, discrete, holding, input
  };
  struct Staged {
    bool valid = false;
    double v[pf::kNumCanIn] = {};
  };

  std::uint16_t* Table(const pf::ModbusPoint& pt) {
    return units_.at(pt.unit).tables[static_cast<std::size_t>(pt.table)].data();
  }

  // The communication watchdog (mu_ held): some keep-alive with watchdog_ms has arrived.
  bool WatchdogArmedAny() const {
    for (std::size_t i = 0; i < keepalive_ns_.size(); ++i) {
      if (profile_->periodic[i].watchdog_ms > 0 && keepalive_ns_[i] != 0) return true;
    }
    return false;
  }
  // Every armed keep-alive came within its watchdog_ms of now.
  bool WatchdogOk(std::int64_t now) const {
    for (std::size_t i = 0; i < keepalive_ns_.size(); ++i) {
      const int ms = profile_->periodic[i].watchdog_ms;
      if (ms > 0 && keepalive_ns_[i] != 0 &&
          now - keepalive_ns_[i] > static_cast<std::int64_t>(ms) * 1'000'000) {
        return false;
      }
    }
    return true;
  }

  // The driver's fault report into its driver_faults register (mu_ held): 1 or 0.
  void StoreDriverFault() {
    const pf::ModbusPoint& pt = profile_->In(pf::CanIn::kDriverFaults);
    if (pt.mapped) (void)pf::StoreModbusPoint(*profile_, pt, driver_fault_ ? 1.0 : 0.0, Table(pt));
  }

  // The sensor roles into their registers (mu_ held). A value its register cannot hold
  // leaves the register as it was; a NaN velocity in a float32 register is stored as such.
  void Store(const Staged& s) {
    for (std::size_t i = 0; i < pf::kNumCanIn; ++i) {
      const pf::ModbusPoint& pt = profile_->inputs[i];
      const auto role = static_cast<pf::CanIn>(i);
      if (!pt.mapped || role == pf::CanIn::kGrant || role == pf::CanIn::kDriverFaults) continue;
      double v = s.v[i];
      if (static_cast<pf::CanIn>(i) == pf::CanIn::kSensorSeq) {
        const double span = pt.count() == 2 ? 4294967296.0 : 65536.0;  // the counter wraps
        v = std::fmod(v, span) * pt.scale + pt.offset;
      }
      if (std::isnan(v) && pt.type == pf::ModbusType::kFloat32) {
        std::uint16_t* w = Table(pt) + pt.address;
        const std::uint16_t hi = 0x7FC0, lo = 0x0000;  // quiet NaN
        w[0] = pt.swapped ? lo : hi;
        w[1] = pt.swapped ? hi : lo;
        continue;
      }
      (void)pf::StoreModbusPoint(*profile_, pt, v, Table(pt));
    }
  }

  bool Serves(std::uint8_t unit) const override { return units_.count(unit) != 0; }

  // A request of unit / table / address / count covers (part of) the point.
  static bool Touches(const pf::ModbusPoint& pt, std::uint8_t unit, int table, int address,
                      int count) {
    return pt.mapped && pt.unit == unit && static_cast<int>(pt.table) == table &&
           pt.address < address + count && pt.address + pt.count() > address;
  }

  static int Exception(const std::uint8_t* pdu, std::uint8_t code, std::uint8_t* reply) {
    reply[0] = static_cast<std::uint8_t>(pdu[0] | mb::kExceptionFlag);
    reply[1] = code;
    return 2;
  }

  // ModbusServer::Bank: one request against the unit's tables, under the lock (no waiting).
  mb::ServerAnswer Answer(std::uint8_t unit, const std::uint8_t* pdu, int len,
                          std::uint8_t* reply) override {
    mb::ServerAnswer a;
    const std::uint8_t fc = len > 0 ? pdu[0] : 0;
    const auto fail = [&](std::uint8_t code) {
      a.reply_len = Exception(pdu, code, reply);
      a.exception = true;
      std::lock_guard<std::mutex> lock(mu_);
      ++counters_.rejected;
      return a;
    };
    if (units_.empty()) return fail(mb::kExGatewayNoResponse);  // a profile mapping nothing
    if (units_.count(unit) == 0) unit = units_.begin()->first;  // 0 or 0xFF: the first unit
    const auto u16 = [&](int at) { return (pdu[at] << 8) | pdu[at + 1]; };
    int table = -1, max = 0;
    switch (fc) {
      case 0x01:
        table = 0;
        max = 2000;
        break;
      case 0x02:
        table = 1;
        max = 2000;
        break;
      case 0x03:
        table = 2;
        max = 125;
        break;
      case 0x04:
        table = 3;
        max = 125;
        break;
      case 0x05:
        table = 0;
        max = 1;
        break;
      case 0x06:
        table = 2;
        max = 1;
        break;
      case 0x0F:
        table = 0;
        max = 1968;
        break;
      case 0x10:
        table = 2;
        max = 123;
        break;
      default:
        return fail(mb::kExIllegalFunction);
    }
    if (len < 5) return fail(mb::kExIllegalValue);
    const int address = u16(1);
    const bool single = fc == 0x05 || fc == 0x06;
    const int count = single ? 1 : u16(3);
    const bool read = fc <= 0x04;
    const bool bits = table <= 1;
    if (count < 1 || count > max) return fail(mb::kExIllegalValue);
    if (read && len != 5) return fail(mb::kExIllegalValue);
    if (single && (len != 5 || (fc == 0x05 && u16(3) != 0xFF00 && u16(3) != 0x0000))) {
      return fail(mb::kExIllegalValue);
    }
    const int bytes = bits ? (count + 7) / 8 : 2 * count;
    if (!read && !single && (len < 6 || pdu[5] != bytes || len != 6 + bytes)) {
      return fail(mb::kExIllegalValue);
    }
    if (address + count > static_cast<int>(kTableSize)) return fail(mb::kExIllegalAddress);
    if (!read && Touches(enable_point_, unit, table, address, count)) {
      bool refused = false;
      {
        std::lock_guard<std::mutex> lock(mu_);
        refused = enable_refused_;
      }
      if (refused) {  // the scenario's enable_refused fault (not the firmware's error)
        a.reply_len = Exception(pdu, mb::kExServerFailure, reply);
        a.exception = true;
        return a;
      }
    }
    std::unique_lock<std::mutex> lock(mu_);
    std::uint16_t* t = units_[unit].tables[table].data() + address;
    if (read) {
      reply[0] = fc;
      reply[1] = static_cast<std::uint8_t>(bytes);
      std::memset(reply + 2, 0, static_cast<std::size_t>(bytes));
      for (int i = 0; i < count; ++i) {
        if (bits) {
          if (t[i] != 0)
            reply[2 + i / 8] = static_cast<std::uint8_t>(reply[2 + i / 8] | (1U << (i % 8)));
        } else {
          reply[2 + 2 * i] = static_cast<std::uint8_t>(t[i] >> 8);
          reply[3 + 2 * i] = static_cast<std::uint8_t>(t[i] & 0xFF);
        }
      }
      a.reply_len = 2 + bytes;
      return a;
    }
    if (fc == 0x05) {
      t[0] = u16(3) == 0xFF00 ? 1 : 0;
    } else if (fc == 0x06) {
      t[0] = static_cast<std::uint16_t>(u16(3));
    } else {
      for (int i = 0; i < count; ++i) {
        t[i] = bits ? static_cast<std::uint16_t>((pdu[6 + i / 8] >> (i % 8)) & 1U)
                    : static_cast<std::uint16_t>(u16(6 + 2 * i));
      }
    }
    for (std::size_t i = 0; i < keepalive_ns_.size(); ++i) {  // the watchdog's keep-alives
      const pf::ModbusFixedWrite& w = profile_->periodic[i];
      if (w.unit == unit && static_cast<int>(w.table) == table && w.address >= address &&
          w.address < address + count) {
        keepalive_ns_[i] = common::MonotonicNs();
      }
    }
    std::memcpy(reply, pdu, 5);  // the echo: address and count (0x0F 0x10) or value
    a.reply_len = 5;
    a.wrote = true;
    if (Touches(*trigger_, unit, table, address, count)) {
      a.command = true;
      Decode();
    }
    return a;
  }

  // The firmware's cycle, decoded from the tables (mu_ held).
  void Decode() {
    const pf::ModbusProfile& p = *profile_;
    const auto get = [&](pf::ModbusOut r) {
      const pf::ModbusPoint& pt = p.Out(r);
      return pt.mapped ? pf::LoadModbusPoint(p, pt, Table(pt)) : 0.0;
    };
    const std::int64_t now = common::MonotonicNs();
    ++counters_.received;
    volts_ = p.command.Invert(get(pf::ModbusOut::kCommand));
    echo_ = static_cast<std::uint32_t>(std::max(0.0, get(pf::ModbusOut::kEcho)));
    enable_ = get(pf::ModbusOut::kEnable) != 0.0;
    safe_ = get(pf::ModbusOut::kSafe) != 0.0 || get(pf::ModbusOut::kStatusSafe) != 0.0;
    causes_ = static_cast<std::uint16_t>(std::max(0.0, get(pf::ModbusOut::kStatusCauses)));
    const double hb = get(pf::ModbusOut::kHeartbeat);
    if (p.Out(pf::ModbusOut::kHeartbeat).mapped && (!have_heartbeat_ || hb != heartbeat_)) {
      heartbeat_ = hb;
      have_heartbeat_ = true;
      heartbeat_ns_ = now;
      ++heartbeats_;
    }
    command_ns_ = now;
    pending_ = true;
    written_.notify_all();
  }

  const std::shared_ptr<const pf::ModbusProfile> profile_;
  const pf::ModbusPoint* trigger_ = nullptr;
  pf::ModbusPoint enable_point_;
  std::map<std::uint8_t, Unit> units_;  // fixed after construction (Serves reads it unlocked)

  // Guarded by mu_ (the tables too):
  Staged staged_;
  double volts_ = 0.0;
  std::uint32_t echo_ = 0;
  bool enable_ = false, safe_ = false;
  bool enable_refused_ = false;  // the step's enable_refused fault
  bool driver_fault_ = false;    // the step's driver_fault (or fault_line) fault
  std::uint16_t causes_ = 0;
  double heartbeat_ = 0.0;
  bool have_heartbeat_ = false;
  std::int64_t command_ns_ = 0, heartbeat_ns_ = 0;
  std::uint64_t heartbeats_ = 0;
  std::vector<std::int64_t> keepalive_ns_;  // per periodic write: its latest arrival (0: none)
};

}  // namespace

std::unique_ptr<PlantPort> MakeModbusProfilePort(bool rtu, const std::string& endpoint,
                                                 std::shared_ptr<const profile::ModbusProfile> p) {
  return std::make_unique<ModbusProfilePort>(rtu, endpoint, std::move(p));
}

}  // namespace mrd::hil
