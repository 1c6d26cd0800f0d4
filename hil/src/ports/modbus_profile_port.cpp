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
// Several channels (MakeModbusProfilePorts): each channel's map is served on the same tables
// (units several maps name are one unit); each channel's faults land in its own registers,
// each channel's command write ends its own cycle, channel 0's grant stores every channel's
// staged step.
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
#include "mrd/profile/modbus_channels.hpp"
#include "mrd/profile/modbus_profile.hpp"

namespace mrd::hil {
namespace {

namespace pf = mrd::profile;
namespace mb = mrd::protocol::modbus;

constexpr std::size_t kTableSize = 65536;

// Serves one or several channel maps on one server: channel k's sensor block, driver block and
// faults are its own; the units' tables are shared (a unit several maps name holds all of
// their registers). As a PlantPort it is channel 0 (the one-channel port); ChannelPort is
// channel k of a shared server (MakeModbusProfilePorts).
class ModbusProfilePort final : public ModbusServedPort {
 public:
  ModbusProfilePort(bool rtu, std::string endpoint,
                    std::vector<std::shared_ptr<const pf::ModbusProfile>> profiles)
      : ModbusServedPort(rtu, std::move(endpoint)), ch_(profiles.size()) {
    const auto add = [&](const pf::ModbusPoint& pt) {
      if (!pt.mapped || units_.count(pt.unit) != 0) return;
      Unit& u = units_[pt.unit];
      for (auto& t : u.tables) t.assign(kTableSize, 0);
    };
    const auto add_fixed = [&](const pf::ModbusFixedWrite& w) {
      pf::ModbusPoint pt;
      pt.mapped = true;
      pt.unit = w.unit;
      add(pt);
    };
    for (std::size_t k = 0; k < ch_.size(); ++k) {
      Ch& c = ch_[k];
      c.profile = std::move(profiles[k]);
      for (const auto& pt : c.profile->inputs) add(pt);
      for (const auto& pt : c.profile->outputs) add(pt);
      for (const auto& w : c.profile->startup) add_fixed(w);
      for (const auto& w : c.profile->periodic) add_fixed(w);
      c.keepalive_ns.assign(c.profile->periodic.size(), 0);
      // The cycle's end: the command's write (without one, the enable's).
      const pf::ModbusPoint& cmd = c.profile->Out(pf::ModbusOut::kCommand);
      c.enable_point = c.profile->Out(pf::ModbusOut::kEnable);
      c.trigger = cmd.mapped ? &cmd : &c.profile->Out(pf::ModbusOut::kEnable);
    }
  }
  ~ModbusProfilePort() override { Close(); }

  std::size_t channels() const { return ch_.size(); }

  // Channel 0 (the one-channel port).
  void Publish(const SensorOutput& out) override { PublishChannel(0, out); }
  bool SendGrant(std::int64_t t_ns) override { return SendGrantChannel(0, t_ns); }
  bool CarriesStatus() const override { return CarriesStatusChannel(0); }
  bool CarriesHeartbeat() const override { return CarriesHeartbeatChannel(0); }
  void Poll(DriverInput* in) override { PollChannel(0, in); }
  void Wait(std::int64_t timeout_ns) override { WaitChannel(0, timeout_ns); }

  // Channel k's side (ChannelPort). Open and Close of the shared server: the first opens, the
  // last closes.
  bool OpenShared(std::string* error) {
    std::lock_guard<std::mutex> lock(share_mu_);
    if (opens_ == 0 && !Open(error)) return false;
    ++opens_;
    return true;
  }
  void CloseShared() {
    std::lock_guard<std::mutex> lock(share_mu_);
    if (opens_ > 0 && --opens_ == 0) Close();
  }
  PortCounters ChannelCounters(std::size_t k) const {
    std::lock_guard<std::mutex> lock(mu_);
    PortCounters c = counters_;
    c.published = ch_[k].published;
    c.received = ch_[k].received;
    return c;
  }

  void PublishChannel(std::size_t k, const SensorOutput& out) {
    Ch& c = ch_[k];
    {
      // The driver's side holds whatever the sensor module does: its fault report (stored
      // with the grant in lockstep, as the sensor values) and its refusal of enable writes.
      std::lock_guard<std::mutex> lock(mu_);
      c.enable_refused = out.enable_refused;
      c.driver_fault = out.driver_fault || out.fault_line;
      if (!lockstep_) StoreDriverFault(c);
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
    ++c.published;
    if (lockstep_) {  // stored with the grant
      c.staged = s;
      return;
    }
    Store(c, s);
  }

  // Channel 0 sends the grant: every channel's staged step goes into the tables with it,
  // under one lock (publish every channel's step first). Another channel's grant is a no-op
  // (its step goes out with channel 0's).
  bool SendGrantChannel(std::size_t k, std::int64_t t_ns) {
    const pf::ModbusProfile& p0 = *ch_[0].profile;
    const pf::ModbusPoint& g = p0.In(pf::CanIn::kGrant);
    std::lock_guard<std::mutex> lock(mu_);
    if (!open_ || !g.mapped) return false;
    if (k != 0) return true;
    for (Ch& c : ch_) {
      if (c.staged.valid) {
        Store(c, c.staged);
        c.staged.valid = false;
      }
      StoreDriverFault(c);
    }
    (void)pf::StoreModbusPoint(p0, g, static_cast<double>(t_ns / 1000), Table(g));
    return true;
  }

  bool CarriesStatusChannel(std::size_t k) const {
    const pf::ModbusProfile& p = *ch_[k].profile;
    return p.Out(pf::ModbusOut::kStatusSafe).mapped || p.Out(pf::ModbusOut::kStatusCauses).mapped;
  }

  bool CarriesHeartbeatChannel(std::size_t k) const {
    return ch_[k].profile->Out(pf::ModbusOut::kHeartbeat).mapped;
  }

  void WaitChannel(std::size_t k, std::int64_t timeout_ns) {
    std::unique_lock<std::mutex> lock(mu_);
    if (ch_[k].pending) return;
    written_.wait_for(lock, std::chrono::nanoseconds(timeout_ns), [&] { return ch_[k].pending; });
  }

  void PollChannel(std::size_t k, DriverInput* in) {
    Ch& c = ch_[k];
    const pf::ModbusProfile& p = *c.profile;
    std::lock_guard<std::mutex> lock(mu_);
    if (c.heartbeat_ns != 0) in->heartbeat_ns = c.heartbeat_ns;
    in->heartbeats = c.heartbeats;
    if (!lockstep_ && WatchdogArmedAny(c)) {
      in->has_watchdog = true;
      in->watchdog_ok = WatchdogOk(c, common::MonotonicNs());
    }
    if (!c.pending) return;
    c.pending = false;
    const auto mapped = [&](pf::ModbusOut r) { return p.Out(r).mapped; };
    if (mapped(pf::ModbusOut::kCommand)) {
      in->has_command = true;
      in->volts = c.volts;
      in->command_ns = c.command_ns;
    }
    if (mapped(pf::ModbusOut::kEcho)) {
      in->has_echo = true;
      in->echo = c.echo;
    }
    if (mapped(pf::ModbusOut::kEnable)) {
      in->has_enable = true;
      in->enable = c.enable;
    }
    if (mapped(pf::ModbusOut::kSafe) || mapped(pf::ModbusOut::kStatusSafe)) {
      in->has_safe = true;
      in->safe = c.safe;
    }
    if (CarriesStatusChannel(k)) {
      in->has_status = true;
      in->status_causes = c.causes;
      in->status_safe = c.safe;
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
  // One channel's map and state (guarded by mu_ after construction).
  struct Ch {
    std::shared_ptr<const pf::ModbusProfile> profile;
    const pf::ModbusPoint* trigger = nullptr;
    pf::ModbusPoint enable_point;
    Staged staged;
    double volts = 0.0;
    std::uint32_t echo = 0;
    bool enable = false, safe = false;
    bool enable_refused = false;  // the step's enable_refused fault
    bool driver_fault = false;    // the step's driver_fault (or fault_line) fault
    std::uint16_t causes = 0;
    double heartbeat = 0.0;
    bool have_heartbeat = false;
    std::int64_t command_ns = 0, heartbeat_ns = 0;
    std::uint64_t heartbeats = 0;
    std::vector<std::int64_t> keepalive_ns;  // per periodic write: its latest arrival (0: none)
    bool pending = false;                    // a command block arrived, not yet polled
    std::uint64_t published = 0, received = 0;
  };

  std::uint16_t* Table(const pf::ModbusPoint& pt) {
    return units_.at(pt.unit).tables[static_cast<std::size_t>(pt.table)].data();
  }

  // The communication watchdog (mu_ held): some keep-alive with watchdog_ms has arrived.
  static bool WatchdogArmedAny(const Ch& c) {
    for (std::size_t i = 0; i < c.keepalive_ns.size(); ++i) {
      if (c.profile->periodic[i].watchdog_ms > 0 && c.keepalive_ns[i] != 0) return true;
    }
    return false;
  }
  // Every armed keep-alive came within its watchdog_ms of now.
  static bool WatchdogOk(const Ch& c, std::int64_t now) {
    for (std::size_t i = 0; i < c.keepalive_ns.size(); ++i) {
      const int ms = c.profile->periodic[i].watchdog_ms;
      if (ms > 0 && c.keepalive_ns[i] != 0 &&
          now - c.keepalive_ns[i] > static_cast<std::int64_t>(ms) * 1'000'000) {
        return false;
      }
    }
    return true;
  }

  // The driver's fault report into its driver_faults register (mu_ held): 1 or 0.
  void StoreDriverFault(const Ch& c) {
    const pf::ModbusPoint& pt = c.profile->In(pf::CanIn::kDriverFaults);
    if (pt.mapped) {
      (void)pf::StoreModbusPoint(*c.profile, pt, c.driver_fault ? 1.0 : 0.0, Table(pt));
    }
  }

  // The sensor roles into their registers (mu_ held). A value its register cannot hold
  // leaves the register as it was; a NaN velocity in a float32 register is stored as such.
  void Store(const Ch& c, const Staged& s) {
    const pf::ModbusProfile& p = *c.profile;
    for (std::size_t i = 0; i < pf::kNumCanIn; ++i) {
      const pf::ModbusPoint& pt = p.inputs[i];
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
      (void)pf::StoreModbusPoint(p, pt, v, Table(pt));
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
    if (!read) {
      bool refused = false;
      {
        std::lock_guard<std::mutex> lock(mu_);
        for (const Ch& c : ch_) {
          refused =
              refused || (c.enable_refused && Touches(c.enable_point, unit, table, address, count));
        }
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
    for (Ch& c : ch_) {  // the watchdog's keep-alives
      for (std::size_t i = 0; i < c.keepalive_ns.size(); ++i) {
        const pf::ModbusFixedWrite& w = c.profile->periodic[i];
        if (w.unit == unit && static_cast<int>(w.table) == table && w.address >= address &&
            w.address < address + count) {
          c.keepalive_ns[i] = common::MonotonicNs();
        }
      }
    }
    std::memcpy(reply, pdu, 5);  // the echo: address and count (0x0F 0x10) or value
    a.reply_len = 5;
    a.wrote = true;
    for (Ch& c : ch_) {  // each channel's cycle ends with its own command write
      if (Touches(*c.trigger, unit, table, address, count)) {
        a.command = true;
        Decode(c);
      }
    }
    return a;
  }

  // A channel's cycle, decoded from the tables (mu_ held).
  void Decode(Ch& c) {
    const pf::ModbusProfile& p = *c.profile;
    const auto get = [&](pf::ModbusOut r) {
      const pf::ModbusPoint& pt = p.Out(r);
      return pt.mapped ? pf::LoadModbusPoint(p, pt, Table(pt)) : 0.0;
    };
    const std::int64_t now = common::MonotonicNs();
    ++counters_.received;
    ++c.received;
    c.volts = p.command.Invert(get(pf::ModbusOut::kCommand));
    c.echo = static_cast<std::uint32_t>(std::max(0.0, get(pf::ModbusOut::kEcho)));
    c.enable = get(pf::ModbusOut::kEnable) != 0.0;
    c.safe = get(pf::ModbusOut::kSafe) != 0.0 || get(pf::ModbusOut::kStatusSafe) != 0.0;
    c.causes = static_cast<std::uint16_t>(std::max(0.0, get(pf::ModbusOut::kStatusCauses)));
    const double hb = get(pf::ModbusOut::kHeartbeat);
    if (p.Out(pf::ModbusOut::kHeartbeat).mapped && (!c.have_heartbeat || hb != c.heartbeat)) {
      c.heartbeat = hb;
      c.have_heartbeat = true;
      c.heartbeat_ns = now;
      ++c.heartbeats;
    }
    c.command_ns = now;
    c.pending = true;
    pending_ = true;
    written_.notify_all();
  }

  std::vector<Ch> ch_;                  // fixed in number after construction
  std::map<std::uint8_t, Unit> units_;  // fixed after construction (Serves reads it unlocked)
  std::mutex share_mu_;                 // guards opens_
  int opens_ = 0;                       // channel ports that opened the shared server
};

// Channel k of a shared server (MakeModbusProfilePorts).
class ChannelPort final : public PlantPort {
 public:
  ChannelPort(std::shared_ptr<ModbusProfilePort> server, std::size_t k)
      : server_(std::move(server)), k_(k) {}
  ~ChannelPort() override { Close(); }
  const char* name() const override { return server_->name(); }
  bool Open(std::string* error) override {
    if (open_) return true;
    open_ = server_->OpenShared(error);
    return open_;
  }
  void Close() override {
    if (!open_) return;
    open_ = false;
    server_->CloseShared();
  }
  void Publish(const SensorOutput& out) override { server_->PublishChannel(k_, out); }
  void Poll(DriverInput* in) override { server_->PollChannel(k_, in); }
  PortCounters counters() const override { return server_->ChannelCounters(k_); }
  bool SendGrant(std::int64_t t_ns) override { return server_->SendGrantChannel(k_, t_ns); }
  void SetLockstep(bool on) override { server_->SetLockstep(on); }
  bool CarriesStatus() const override { return server_->CarriesStatusChannel(k_); }
  bool CarriesHeartbeat() const override { return server_->CarriesHeartbeatChannel(k_); }
  void Wait(std::int64_t timeout_ns) override { server_->WaitChannel(k_, timeout_ns); }

 private:
  std::shared_ptr<ModbusProfilePort> server_;
  const std::size_t k_;
  bool open_ = false;
};

}  // namespace

std::unique_ptr<PlantPort> MakeModbusProfilePort(bool rtu, const std::string& endpoint,
                                                 std::shared_ptr<const profile::ModbusProfile> p) {
  return std::make_unique<ModbusProfilePort>(
      rtu, endpoint, std::vector<std::shared_ptr<const profile::ModbusProfile>>{std::move(p)});
}

std::vector<std::unique_ptr<PlantPort>> MakeModbusProfilePorts(
    bool rtu, const std::string& endpoint,
    std::vector<std::shared_ptr<const profile::ModbusProfile>> profiles, std::string* error) {
  std::vector<const profile::ModbusProfile*> maps;
  for (const auto& p : profiles) {
    if (p == nullptr) {
      *error = "modbus channels: a channel without a map";
      return {};
    }
    maps.push_back(p.get());
  }
  profile::ModbusChannelPlan plan;
  if (!profile::PlanModbusChannels(maps, &plan, error)) return {};
  const std::size_t n = profiles.size();
  auto server = std::make_shared<ModbusProfilePort>(rtu, endpoint, std::move(profiles));
  std::vector<std::unique_ptr<PlantPort>> ports;
  for (std::size_t k = 0; k < n; ++k) ports.push_back(std::make_unique<ChannelPort>(server, k));
  return ports;
}

}  // namespace mrd::hil
