#pragma once
// What the two Modbus plant ports share (modbus_port.cpp: the fixed register map;
// modbus_profile_port.cpp: a device profile's tables): the endpoint (TCP "HOST:PORT" or an RTU
// pseudo-terminal behind a symlink) and its server thread, the lock, the lockstep flag, the
// "a command block arrived" wake-up and the counters. The derived port answers the requests
// (ModbusServer::Bank::Answer) and calls Close() in its own destructor, before its members go:
// the server's thread calls Answer until then.
#include <unistd.h>

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <string>

#include "modbus_server.hpp"
#include "mrd/hil/ports/plant_port.hpp"

namespace mrd::hil {

class ModbusServedPort : public PlantPort, protected ModbusServer::Bank {
 public:
  const char* name() const override { return rtu_ ? "modbus-rtu" : "modbus-tcp"; }

  bool Open(std::string* error) override {
    if (!OpenModbusEndpoint(server_, rtu_, endpoint_, &master_fd_, &slave_fd_, error)) {
      return false;
    }
    server_.Start();
    std::lock_guard<std::mutex> lock(mu_);
    open_ = true;
    return true;
  }

  void SetLockstep(bool on) override {
    std::lock_guard<std::mutex> lock(mu_);
    lockstep_ = on;
  }

  void Wait(std::int64_t timeout_ns) override {
    std::unique_lock<std::mutex> lock(mu_);
    if (pending_) return;
    written_.wait_for(lock, std::chrono::nanoseconds(timeout_ns), [this] { return pending_; });
  }

  void Close() override {
    server_.Stop();
    if (master_fd_ >= 0) close(master_fd_);
    if (slave_fd_ >= 0) close(slave_fd_);
    if (rtu_ && master_fd_ >= 0) unlink(endpoint_.c_str());
    master_fd_ = slave_fd_ = -1;
    std::lock_guard<std::mutex> lock(mu_);
    open_ = false;
  }

  PortCounters counters() const override {
    std::lock_guard<std::mutex> lock(mu_);
    return counters_;
  }

 protected:
  ModbusServedPort(bool rtu, std::string endpoint)
      : rtu_(rtu), endpoint_(std::move(endpoint)), server_(*this) {}
  ~ModbusServedPort() override = default;

  // ModbusServer::Bank's refusals, counted.
  void CountRejected() override {
    std::lock_guard<std::mutex> lock(mu_);
    ++counters_.rejected;
  }
  void CountRefused() override {
    std::lock_guard<std::mutex> lock(mu_);
    ++counters_.refused;
  }

  mutable std::mutex mu_;  // guards what follows and the derived port's registers
  bool open_ = false;
  bool lockstep_ = false;
  bool pending_ = false;             // a command block arrived, not yet polled
  std::condition_variable written_;  // pending_ became true
  PortCounters counters_;

 private:
  const bool rtu_;
  const std::string endpoint_;
  int master_fd_ = -1, slave_fd_ = -1;
  ModbusServer server_;
};

}  // namespace mrd::hil
