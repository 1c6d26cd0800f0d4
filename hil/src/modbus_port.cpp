// The harness's Modbus side: a libmodbus server holding the register map of
// docs/modbus_registers.md, over TCP ("HOST:PORT", several clients at once) or RTU on a
// pseudo-terminal (the endpoint becomes a symlink to the pty's slave, which the firmware
// opens as its serial device; the server talks on the master). A server thread answers the
// requests; Publish and Poll exchange the registers with it under a mutex held only for a
// register copy (the plant loop never waits on the wire). The sensor block is read-only:
// a write to it gets the exception ILLEGAL DATA ADDRESS and counts as rejected.
// Lockstep: Publish stages the step's sensor block and SendGrant writes it together with the
// grant register (13-15) under one lock, so the firmware never reads a step's values without
// its grant (their stamp is the grant); the firmware's tick answers with one command block carrying its status, which wakes Wait.
#include <arpa/inet.h>
#include <fcntl.h>
#include <modbus/modbus.h>
#include <pty.h>
#include <sys/select.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cerrno>
#include <cstring>
#include <ctime>
#include <mutex>
#include <thread>
#include <vector>

#include "mrd/hil/plant_port.hpp"
#include "mrd/protocol/modbus_map.hpp"

namespace mrd::hil {
namespace {

namespace map = mrd::protocol::modbus;

std::int64_t NowNs() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

class ModbusPort final : public PlantPort {
 public:
  ModbusPort(bool rtu, std::string endpoint) : rtu_(rtu), endpoint_(std::move(endpoint)) {}
  ~ModbusPort() override { Close(); }

  const char* name() const override { return rtu_ ? "modbus-rtu" : "modbus-tcp"; }

  bool Open(std::string* error) override {
    if (rtu_ ? !OpenRtu(error) : !OpenTcp(error)) return false;
    mapping_ = modbus_mapping_new(0, 0, map::kMapSize, 0);
    if (mapping_ == nullptr) {
      *error = std::string(name()) + ": cannot allocate the register map";
      return false;
    }
    // Until the firmware writes: no set-point, enable not driven, no heartbeat.
    mapping_->tab_registers[map::kCommandBase + map::kSetPoint] = map::kNoSetPoint;
    mapping_->tab_registers[map::kCommandBase + map::kEnable] = map::kEnableNotDriven;
    running_.store(true);
    thread_ = std::thread([this] { Serve(); });
    return true;
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
    std::uint16_t regs[map::kSensorCount] = {};
    if (map::EncodeSensors(b, regs) != map::MapError::kOk) return;  // not representable
    if (out.fault == SensorFault::kOutOfRange) regs[map::kFaults] |= 0x8000U;  // reserved bit
    std::lock_guard<std::mutex> lock(mu_);
    if (mapping_ == nullptr) return;
    ++counters_.published;
    if (lockstep_) {  // written with the grant, so no read sees the block without it
      std::copy(regs, regs + map::kSensorCount, staged_);
      staged_valid_ = true;
      return;
    }
    std::copy(regs, regs + map::kSensorCount, mapping_->tab_registers + map::kSensorBase);
  }

  void SetLockstep(bool on) override {
    std::lock_guard<std::mutex> lock(mu_);
    lockstep_ = on;
  }

  bool SendGrant(std::int64_t t_ns) override {
    std::uint16_t regs[3];
    map::PutU48(static_cast<std::uint64_t>(t_ns / 1000), regs);
    std::lock_guard<std::mutex> lock(mu_);
    if (mapping_ == nullptr) return false;
    if (staged_valid_) {
      std::copy(staged_, staged_ + map::kSensorCount, mapping_->tab_registers + map::kSensorBase);
      staged_valid_ = false;
    }
    std::copy(regs, regs + 3, mapping_->tab_registers + map::kSensorBase + map::kGrant);
    return true;
  }

  void Wait(std::int64_t timeout_ns) override {
    std::unique_lock<std::mutex> lock(mu_);
    if (pending_) return;
    written_.wait_for(lock, std::chrono::nanoseconds(timeout_ns), [this] { return pending_; });
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

  void Close() override {
    if (thread_.joinable()) {
      running_.store(false);
      thread_.join();
    }
    for (int fd : clients_) close(fd);
    clients_.clear();
    if (listen_fd_ >= 0) close(listen_fd_);
    listen_fd_ = -1;
    if (master_fd_ >= 0) close(master_fd_);
    if (slave_fd_ >= 0) close(slave_fd_);
    if (rtu_ && master_fd_ >= 0) unlink(endpoint_.c_str());
    master_fd_ = slave_fd_ = -1;
    if (ctx_ != nullptr) modbus_free(ctx_);
    ctx_ = nullptr;
    std::lock_guard<std::mutex> lock(mu_);
    if (mapping_ != nullptr) modbus_mapping_free(mapping_);
    mapping_ = nullptr;
  }

  PortCounters counters() const override {
    std::lock_guard<std::mutex> lock(mu_);
    return counters_;
  }

 private:
  bool OpenTcp(std::string* error) {
    const auto colon = endpoint_.rfind(':');
    int port = 0;
    if (colon == std::string::npos || colon == 0) {
      *error = "modbus-tcp '" + endpoint_ + "': expected HOST:PORT";
      return false;
    }
    const std::string host = endpoint_.substr(0, colon), digits = endpoint_.substr(colon + 1);
    if (digits.empty() || digits.size() > 5 ||
        !std::all_of(digits.begin(), digits.end(), [](char c) { return c >= '0' && c <= '9'; }) ||
        (port = std::stoi(digits)) < 1 || port > 65535) {
      *error = "modbus-tcp '" + endpoint_ + "': port must be 1-65535";
      return false;
    }
    in_addr addr{};
    if (inet_pton(AF_INET, host.c_str(), &addr) != 1) {
      *error = "modbus-tcp '" + endpoint_ + "': host must be an IPv4 address";
      return false;
    }
    ctx_ = modbus_new_tcp(host.c_str(), port);
    if (ctx_ == nullptr) {
      *error = "modbus-tcp '" + endpoint_ + "': " + modbus_strerror(errno);
      return false;
    }
    listen_fd_ = modbus_tcp_listen(ctx_, 4);
    if (listen_fd_ < 0) {
      *error = "modbus-tcp '" + endpoint_ + "': cannot listen: " + modbus_strerror(errno);
      return false;
    }
    return true;
  }

  bool OpenRtu(std::string* error) {
    char slave_name[128] = {};
    if (openpty(&master_fd_, &slave_fd_, slave_name, nullptr, nullptr) != 0) {
      *error = "modbus-rtu: openpty: " + std::string(std::strerror(errno));
      return false;
    }
    termios t{};
    if (tcgetattr(slave_fd_, &t) == 0) {
      cfmakeraw(&t);
      cfsetspeed(&t, B115200);
      tcsetattr(slave_fd_, TCSANOW, &t);
    }
    unlink(endpoint_.c_str());  // a link left by an earlier run
    if (symlink(slave_name, endpoint_.c_str()) != 0) {
      *error = "modbus-rtu: cannot create the link '" + endpoint_ + "' -> " + slave_name + ": " +
               std::strerror(errno);
      return false;
    }
    // The context only frames RTU over the master fd: never connected (no device to open).
    ctx_ = modbus_new_rtu(slave_name, 115200, 'N', 8, 1);
    if (ctx_ == nullptr || modbus_set_slave(ctx_, 1) != 0 ||
        modbus_set_socket(ctx_, master_fd_) != 0) {
      *error = "modbus-rtu: " + std::string(modbus_strerror(errno));
      return false;
    }
    modbus_set_byte_timeout(ctx_, 0, 20'000);
    return true;
  }

  void Serve() {
    std::uint8_t query[MODBUS_RTU_MAX_ADU_LENGTH > MODBUS_TCP_MAX_ADU_LENGTH
                           ? MODBUS_RTU_MAX_ADU_LENGTH
                           : MODBUS_TCP_MAX_ADU_LENGTH];
    while (running_.load()) {
      fd_set fds;
      FD_ZERO(&fds);
      int max_fd = -1;
      const auto add = [&](int fd) {
        FD_SET(fd, &fds);
        max_fd = std::max(max_fd, fd);
      };
      if (rtu_) {
        add(master_fd_);
      } else {
        add(listen_fd_);
        for (int fd : clients_) add(fd);
      }
      timeval tv{0, 20'000};
      if (select(max_fd + 1, &fds, nullptr, nullptr, &tv) <= 0) continue;
      if (!rtu_ && FD_ISSET(listen_fd_, &fds)) {
        int listen_fd = listen_fd_;
        const int fd = modbus_tcp_accept(ctx_, &listen_fd);
        if (fd >= 0) clients_.push_back(fd);
      }
      if (rtu_) {
        if (FD_ISSET(master_fd_, &fds)) HandleOne(master_fd_, query);
        continue;
      }
      for (std::size_t i = 0; i < clients_.size();) {
        const int fd = clients_[i];
        if (FD_ISSET(fd, &fds) && !HandleOne(fd, query)) {
          close(fd);
          clients_.erase(clients_.begin() + static_cast<std::ptrdiff_t>(i));
          continue;
        }
        ++i;
      }
    }
  }

  // Receives and answers one request on fd; false when a TCP client has gone.
  bool HandleOne(int fd, std::uint8_t* query) {
    modbus_set_socket(ctx_, fd);
    const int n = modbus_receive(ctx_, query);
    if (n == 0) return true;  // addressed to another slave (RTU)
    if (n < 0) {
      if (rtu_) {
        // CRC error, truncated frame or the line hung up: drop what is buffered.
        if (errno == EMBBADCRC || errno == ETIMEDOUT) {
          std::lock_guard<std::mutex> lock(mu_);
          ++counters_.rejected;
        }
        tcflush(master_fd_, TCIFLUSH);
        if (errno == EIO) {
          timespec pause{0, 5'000'000};  // slave side closed: no busy loop on EIO
          nanosleep(&pause, nullptr);
        }
        return true;
      }
      return false;
    }
    const int h = modbus_get_header_length(ctx_);
    const int function = query[h];
    const int addr = (query[h + 1] << 8) | query[h + 2];
    int count = 0;
    bool write = false;
    if (function == MODBUS_FC_WRITE_SINGLE_REGISTER) {
      write = true;
      count = 1;
    } else if (function == MODBUS_FC_WRITE_MULTIPLE_REGISTERS ||
               function == MODBUS_FC_WRITE_AND_READ_REGISTERS) {
      write = true;
      count = function == MODBUS_FC_WRITE_MULTIPLE_REGISTERS ? (query[h + 3] << 8) | query[h + 4]
                                                             : (query[h + 7] << 8) | query[h + 8];
    }
    const int write_addr =
        function == MODBUS_FC_WRITE_AND_READ_REGISTERS ? (query[h + 5] << 8) | query[h + 6] : addr;
    if (write && write_addr < map::kCommandBase) {  // the sensor block is read-only
      modbus_reply_exception(ctx_, query, MODBUS_EXCEPTION_ILLEGAL_DATA_ADDRESS);
      std::lock_guard<std::mutex> lock(mu_);
      ++counters_.rejected;
      return true;
    }
    std::lock_guard<std::mutex> lock(mu_);
    std::uint16_t before[map::kCommandCount];
    std::copy(mapping_->tab_registers + map::kCommandBase,
              mapping_->tab_registers + map::kCommandBase + map::kCommandCount, before);
    if (modbus_reply(ctx_, query, n, mapping_) < 0) return rtu_;
    if (!write || write_addr + count <= map::kCommandBase ||
        write_addr >= map::kCommandBase + map::kCommandCount) {
      return true;
    }
    map::CommandBlock c;
    if (map::DecodeCommand(mapping_->tab_registers + map::kCommandBase, &c) != map::MapError::kOk) {
      // Undefined codes: keep the last valid block.
      std::copy(before, before + map::kCommandCount, mapping_->tab_registers + map::kCommandBase);
      ++counters_.rejected;
      return true;
    }
    const std::int64_t now = NowNs();
    ++counters_.received;
    if (c.heartbeat != last_.heartbeat) {
      heartbeat_ns_ = now;
      ++heartbeats_;
    }
    last_ = c;
    command_ns_ = now;
    pending_ = true;
    written_.notify_all();
    return true;
  }

  const bool rtu_;
  const std::string endpoint_;
  modbus_t* ctx_ = nullptr;
  int listen_fd_ = -1, master_fd_ = -1, slave_fd_ = -1;
  std::vector<int> clients_;  // server thread only
  std::thread thread_;
  std::atomic<bool> running_{false};

  mutable std::mutex mu_;  // guards everything below
  modbus_mapping_t* mapping_ = nullptr;
  map::CommandBlock last_;
  bool pending_ = false;
  std::int64_t command_ns_ = 0;
  std::int64_t heartbeat_ns_ = 0;
  std::uint64_t heartbeats_ = 0;  // heartbeat changes heard
  bool lockstep_ = false;
  std::uint16_t staged_[map::kSensorCount] = {};  // lockstep: the step's block, until its grant
  bool staged_valid_ = false;
  std::condition_variable written_;  // a command block arrived (pending_)
  PortCounters counters_;
};

}  // namespace

std::unique_ptr<PlantPort> MakeModbusTcpPort(const std::string& endpoint) {
  return std::make_unique<ModbusPort>(false, endpoint);
}

std::unique_ptr<PlantPort> MakeModbusRtuPort(const std::string& endpoint) {
  return std::make_unique<ModbusPort>(true, endpoint);
}

}  // namespace mrd::hil
