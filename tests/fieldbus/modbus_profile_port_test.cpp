// The harness's Modbus server on a device profile (hil/src/modbus_profile_port.cpp), driven by
// libmodbus as the client: the modbus-float32 map at units 1 and 2 (swapped float32 words
// decoded here by hand), a unit the profile does not name refused with 0x0B, the Modbus
// exception codes, and a write of the command block heard as the driver's input.
#include <gtest/gtest.h>
#include <modbus.h>

#include <cerrno>
#include <cstring>
#include <memory>
#include <string>

#include "modbus_test_peers.hpp"
#include "mrd/hil/ports/plant_port.hpp"
#include "mrd/profile/modbus_profile.hpp"

namespace mrd::test {
namespace {

const std::string kProfile = std::string(MRD_SOURCE_DIR) + "/firmware/profiles/modbus-float32.toml";

float FromSwapped(std::uint16_t lo, std::uint16_t hi) {
  const std::uint32_t u = (std::uint32_t{hi} << 16) | lo;
  float f = 0.0F;
  std::memcpy(&f, &u, sizeof f);
  return f;
}

TEST(ModbusProfilePortTest, ServesTheProfilesUnitsAndHearsTheCommand) {
  auto p = std::make_shared<profile::ModbusProfile>();
  std::string error;
  ASSERT_TRUE(profile::LoadModbusProfile(kProfile, p.get(), &error)) << error;
  const int port = FreeTcpPort();
  auto hil = hil::MakeModbusProfilePort(false, "127.0.0.1:" + std::to_string(port), p);
  ASSERT_TRUE(hil->Open(&error)) << error;
  hil::SensorOutput out;
  out.seq = 70000;  // beyond 16 bits: a uint32 register pair
  out.sample.v = -12.5;
  out.sample.x = 0.25;
  out.sample.demand = 456.0;
  hil->Publish(out);

  modbus_t* ctx = modbus_new_tcp("127.0.0.1", port);
  ASSERT_NE(ctx, nullptr);
  ASSERT_EQ(modbus_connect(ctx), 0) << modbus_strerror(errno);
  modbus_set_slave(ctx, 1);
  std::uint16_t regs[16] = {};
  ASSERT_EQ(modbus_read_input_registers(ctx, 0, 16, regs), 16) << modbus_strerror(errno);
  EXPECT_EQ((std::uint32_t{regs[1]} << 16) | regs[0], 70000U);  // low word first
  EXPECT_FLOAT_EQ(FromSwapped(regs[2], regs[3]), -12.5F);
  EXPECT_FLOAT_EQ(FromSwapped(regs[4], regs[5]), 0.25F);
  EXPECT_FLOAT_EQ(FromSwapped(regs[6], regs[7]), 456.0F);

  // Exceptions: a quantity beyond 125 (0x03), beyond the table (0x02), an unknown function
  // (0x01), a unit the profile does not name (0x0B over TCP).
  // Raw requests (libmodbus refuses a quantity beyond 125 itself); the reply's function is
  // at byte 7 of the TCP frame, the exception code at byte 8.
  const auto exception_of = [&](std::initializer_list<std::uint8_t> pdu) {
    std::uint8_t raw[16] = {1};  // unit, then the PDU
    std::size_t n = 1;
    for (std::uint8_t b : pdu) raw[n++] = b;
    std::uint8_t rsp[MODBUS_TCP_MAX_ADU_LENGTH] = {};
    if (modbus_send_raw_request(ctx, raw, static_cast<int>(n)) <= 0) return -1;
    if (modbus_receive_confirmation(ctx, rsp) != 9 || rsp[7] != (*pdu.begin() | 0x80)) return -2;
    return static_cast<int>(rsp[8]);
  };
  EXPECT_EQ(exception_of({0x04, 0x00, 0x00, 0x00, 126}), 0x03);  // quantity
  EXPECT_EQ(exception_of({0x03, 0xFF, 0xFF, 0x00, 2}), 0x02);    // beyond the table
  EXPECT_EQ(exception_of({0x2B, 0x0E, 0x01, 0x00}), 0x01);       // unknown function
  modbus_set_slave(ctx, 3);
  EXPECT_EQ(modbus_read_input_registers(ctx, 0, 1, regs), -1);
  EXPECT_EQ(errno, EMBXGTAR);

  // The driver at unit 2: enable coil, then the command block (set-point 3.25 V, swapped).
  modbus_set_slave(ctx, 2);
  ASSERT_EQ(modbus_write_bit(ctx, 0, 1), 1) << modbus_strerror(errno);
  float sp = 3.25F;
  std::uint32_t u = 0;
  std::memcpy(&u, &sp, sizeof u);
  const std::uint16_t block[7] = {
      static_cast<std::uint16_t>(u & 0xFFFF), static_cast<std::uint16_t>(u >> 16), 42, 0, 7, 0, 0};
  ASSERT_EQ(modbus_write_registers(ctx, 0, 7, block), 7) << modbus_strerror(errno);
  hil::DriverInput in;
  hil->Poll(&in);
  EXPECT_TRUE(in.has_command);
  EXPECT_DOUBLE_EQ(in.volts, 3.25);
  EXPECT_TRUE(in.has_enable);
  EXPECT_TRUE(in.enable);
  EXPECT_TRUE(in.has_echo);
  EXPECT_EQ(in.echo, 42U);
  EXPECT_EQ(in.heartbeats, 1U);
  modbus_close(ctx);
  modbus_free(ctx);
  hil->Close();
  const hil::PortCounters c = hil->counters();
  EXPECT_EQ(c.received, 1U);
  EXPECT_EQ(c.rejected, 4U);  // the four refused requests
}

}  // namespace
}  // namespace mrd::test
