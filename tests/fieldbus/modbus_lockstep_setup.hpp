#pragma once
// The lockstep Modbus TCP set-up the device tests share: the firmware's device configuration
// and the shipped modbus-float32 profile.
#include <gtest/gtest.h>

#include <cstdint>
#include <memory>
#include <string>

#include "mrd/firmware/io/modbus/modbus_device.hpp"
#include "mrd/profile/modbus_profile.hpp"

namespace mrd::firmware {

// The device in lockstep on 127.0.0.1:port: velocity, displacement and demand in; command,
// enable, heartbeat and status out; response_timeout_ns per request.
inline ModbusConfig LockstepTcp(int port, std::int64_t response_timeout_ns) {
  ModbusConfig c;
  c.enabled = true;
  c.mode = ModbusMode::kTcp;
  c.host = "127.0.0.1";
  c.port = port;
  c.lockstep = true;
  c.inputs = Bit(Input::kVelocity) | Bit(Input::kDisplacement) | Bit(Input::kDemand);
  c.outputs =
      Bit(Output::kCommand) | Bit(Output::kEnable) | Bit(Output::kHeartbeat) | Bit(Output::kStatus);
  c.response_timeout_ns = response_timeout_ns;
  return c;
}

// firmware/profiles/modbus-float32.toml, loaded (a gtest failure and an empty profile if not).
inline std::shared_ptr<profile::ModbusProfile> Float32Profile() {
  auto mp = std::make_shared<profile::ModbusProfile>();
  std::string error;
  EXPECT_TRUE(profile::LoadModbusProfile(MRD_SOURCE_DIR "/firmware/profiles/modbus-float32.toml",
                                         mp.get(), &error))
      << error;
  return mp;
}

}  // namespace mrd::firmware
