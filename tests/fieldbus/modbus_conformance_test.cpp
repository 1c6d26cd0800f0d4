// Conformance of the Modbus transport with peers the project did not write, checked from the
// documents (docs/modbus_registers.md and the Modbus specifications), over TCP and RTU:
// Debian's pymodbus 3.0 client (pymodbus_conformance.py) and mbpoll against `mrd-hil serve`;
// a pymodbus 3.0 server playing the sensor module / driver (pymodbus_driver.py) against
// `mrd-firmware`: its requests (function codes, addresses, counts, unit id, MBAP fields),
// its command blocks, and its refusal of replies from another unit or protocol.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>
#include <string>
#include <thread>
#include <vector>

#include "modbus_test_peers.hpp"
#include "support/process.hpp"

namespace mrd::test {
namespace {

using nlohmann::json;

const std::string kPython = "/usr/bin/python3";
const std::string kBin = MRD_BIN_DIR;
const std::string kTests = std::string(MRD_SOURCE_DIR) + "/tests/fieldbus/";

class ModbusConformanceTest : public ::testing::TestWithParam<bool> {  // true: RTU
 protected:
  void SetUp() override {
    if (system((kPython + " -c 'import pymodbus, serial' 2>/dev/null").c_str()) != 0) {
      GTEST_FAIL() << "Debian's python3-pymodbus and python3-serial are needed: "
                      "toolchain/setup.sh installs them";
    }
    port_ = FreeTcpPort();
    dir_ = "/tmp/mrd-modbus-conf-" + std::to_string(getpid());
    ASSERT_EQ(system(("mkdir -p " + dir_).c_str()), 0);
    link_ = dir_ + "/pty";
  }
  void TearDown() override { (void)system(("rm -rf " + dir_).c_str()); }
  bool rtu() const { return GetParam(); }
  bool Ready() { return rtu() ? WaitForPath(link_, 10.0) : TcpReady(port_, 10.0); }
  std::string Where() const { return rtu() ? link_ : "127.0.0.1:" + std::to_string(port_); }

  std::unique_ptr<ChildProcess> StartHil(double duration_s) {
    auto hil = std::make_unique<ChildProcess>(std::vector<std::string>{
        kBin + "/mrd-hil", "serve", "--port", (rtu() ? "modbus-rtu=" : "modbus-tcp=") + Where(),
        "--duration", std::to_string(duration_s), "--json"});
    EXPECT_TRUE(Ready()) << hil->Stderr();
    return hil;
  }
  // A pymodbus server playing the driver (pymodbus_driver.py) with extra options.
  std::unique_ptr<ChildProcess> StartDriver(std::vector<std::string> options) {
    std::vector<std::string> argv = {kPython,
                                     kTests + "pymodbus_driver.py",
                                     rtu() ? "rtu" : "tcp",
                                     rtu() ? link_ : std::to_string(port_),
                                     "--seconds",
                                     "30"};
    argv.insert(argv.end(), options.begin(), options.end());
    auto driver = std::make_unique<ChildProcess>(argv);
    EXPECT_TRUE(Ready()) << driver->Stderr();
    return driver;
  }
  // mrd-firmware as the client of unit 7 for duration_s.
  std::unique_ptr<ChildProcess> StartFirmware(double duration_s) {
    std::ofstream cfg(dir_ + "/fw.toml");
    cfg << "[control]\nlaw = \"force\"\n\n[safety]\nmax_age_ms = 50\n\n[modbus]\n";
    if (rtu()) {
      cfg << "mode = \"rtu\"\ndevice = \"" << link_ << "\"\nbaud = 115200\n";
    } else {
      cfg << "mode = \"tcp\"\nhost = \"127.0.0.1\"\nport = " << port_ << "\n";
    }
    cfg << "slave = 7\nresponse_timeout_ms = 200\nretries = 1\npoll_period_us = 2000\n"
           "inputs = [\"velocity\", \"displacement\", \"demand\"]\n"
           "outputs = [\"command\", \"enable\", \"heartbeat\", \"status\"]\n";
    cfg.close();
    return std::make_unique<ChildProcess>(
        std::vector<std::string>{kBin + "/mrd-firmware", "--config", dir_ + "/fw.toml",
                                 "--duration", std::to_string(duration_s), "--json"});
  }
  static json Parse(ChildProcess& p) {
    const json j = json::parse(p.Stdout(), nullptr, false);
    EXPECT_FALSE(j.is_discarded()) << p.Stdout().substr(0, 2000) << p.Stderr();
    return j;
  }
  // mrd-firmware for 1 s against the driver started with `options`, whose replies it must
  // refuse: it took none and ended safe. Its JSON summary in *f.
  void RunFirmwareRefusing(const std::vector<std::string>& options, json* f) {
    auto driver = StartDriver(options);
    auto fw = StartFirmware(1.0);
    ASSERT_EQ(fw->Wait(30.0), 0) << fw->Stdout() << fw->Stderr();
    driver->Signal(SIGTERM);
    driver->Wait(20.0);
    *f = Parse(*fw);
    const json& summary = *f;
    const json& d = summary["devices"]["modbus"];
    EXPECT_EQ(d["rx_ok"].get<std::uint64_t>(), 0U) << d.dump();
    EXPECT_TRUE(summary["final_safe_state"].get<bool>());
  }

  int port_ = 0;
  std::string dir_, link_;
};

// Every check of pymodbus_conformance.py: each documented register readable and writable as
// documented, and the specification's exception code (or silence) for every wrong request.
TEST_P(ModbusConformanceTest, PymodbusClientGetsTheDocumentedAnswersFromTheHarness) {
  auto hil = StartHil(30.0);
  ChildProcess client(
      {kPython, kTests + "pymodbus_conformance.py", rtu() ? "rtu" : "tcp", Where()});
  ASSERT_EQ(client.Wait(60.0), 0) << client.Stdout() << client.Stderr();
  hil->Signal(SIGTERM);
  ASSERT_EQ(hil->Wait(20.0), 0) << hil->Stderr();
  const json checks = Parse(client);
  ASSERT_TRUE(checks.is_array());
  EXPECT_GT(checks.size(), 35U);
  for (const json& c : checks) {
    EXPECT_TRUE(c["ok"].get<bool>()) << c["check"].get<std::string>() << ": want "
                                     << c["want"].dump() << ", got " << c["got"].dump();
  }
  // The refused requests are counted.
  const json h = Parse(*hil);
  EXPECT_GE(h["ports"][rtu() ? "modbus-rtu" : "modbus-tcp"]["rejected"].get<std::uint64_t>(), 20U)
      << h.dump(2);
}

// mbpoll reads the sensor block as 32-bit values in big-endian word order ("ABCD", as the
// map says) and the values are the reference plant's at step seq; a write to the sensor
// block is refused with ILLEGAL DATA ADDRESS.
TEST_P(ModbusConformanceTest, MbpollReadsTheSensorBlockInTheDocumentedWordOrder) {
  auto hil = StartHil(30.0);
  std::vector<std::string> common = {
      "/usr/bin/mbpoll", "-m", rtu() ? "rtu" : "tcp", "-a", "1", "-1", "-o", "2"};
  if (rtu()) {
    common.insert(common.end(), {"-b", "115200", "-P", "none"});
  } else {
    common.insert(common.end(), {"-p", std::to_string(port_)});
  }
  const std::string target = rtu() ? link_ : "127.0.0.1";
  std::vector<std::string> read = common;
  read.insert(read.end(), {"-t", "4:int", "-B", "-r", "1", "-c", "6", target});
  ChildProcess poll(read);
  ASSERT_EQ(poll.Wait(20.0), 0) << poll.Stdout() << poll.Stderr();
  // "[1]: \t26565" ... one line per 32-bit value, at references 1, 3, 5, ...
  std::vector<long long> v;
  const std::regex line(R"(\[(\d+)\]:\s+(-?\d+))");
  const std::string out = poll.Stdout();
  for (std::sregex_iterator it(out.begin(), out.end(), line), end; it != end; ++it) {
    v.push_back(std::stoll((*it)[2]));
  }
  ASSERT_EQ(v.size(), 6U) << out;
  // seq, velocity (1e-4 cm/s), displacement (1e-5 cm), ...: x = sin(4 pi t), v = 4 pi cos(4 pi t)
  // at t = seq x 1 ms (the reference plant: A = 1 cm, f = 2 Hz).
  const double t = static_cast<double>(v[0]) * 1e-3;
  EXPECT_GT(v[0], 0);
  EXPECT_NEAR(static_cast<double>(v[2]) * 1e-5, std::sin(4.0 * M_PI * t), 1e-3) << out;
  EXPECT_NEAR(static_cast<double>(v[1]) * 1e-4, 4.0 * M_PI * std::cos(4.0 * M_PI * t), 1e-2) << out;
  std::vector<std::string> write = common;
  write.insert(write.end(), {"-t", "4", "-r", "1", target, "5", "6"});  // registers 0..1
  ChildProcess refused(write);
  EXPECT_NE(refused.Wait(20.0), 0) << refused.Stdout();
  EXPECT_NE((refused.Stdout() + refused.Stderr()).find("Illegal data address"), std::string::npos)
      << refused.Stdout() << refused.Stderr();
  hil->Signal(SIGTERM);
  EXPECT_EQ(hil->Wait(20.0), 0) << hil->Stderr();
}

// The firmware's requests, as pymodbus saw them: only the documented ones (0x03 of 13 at 0,
// 0x10 of 9 at 32), to its configured unit id, MBAP protocol 0 with increasing transaction
// ids; command blocks within the map's codes; the shutdown's block safe, 0 V, enable off.
TEST_P(ModbusConformanceTest, FirmwareSendsTheDocumentedRequests) {
  auto driver = StartDriver({});
  auto fw = StartFirmware(2.0);
  ASSERT_EQ(fw->Wait(30.0), 0) << fw->Stdout() << fw->Stderr();
  driver->Signal(SIGTERM);
  ASSERT_EQ(driver->Wait(20.0), 0) << driver->Stderr();
  const json log = Parse(*driver);
  const json f = Parse(*fw);
  const json& requests = log["requests"];  // [t, function, address, count, unit, tid, pid]
  ASSERT_GT(requests.size(), 100U);
  std::size_t reads = 0, writes = 0;
  long long last_tid = -1;
  for (const json& r : requests) {
    const int function = r[1].get<int>();
    if (function == 0x03) {
      ++reads;
      EXPECT_EQ(r[2].get<int>(), 0) << r.dump();
      EXPECT_EQ(r[3].get<int>(), 13) << r.dump();
    } else {
      ++writes;
      EXPECT_EQ(function, 0x10) << r.dump();
      EXPECT_EQ(r[2].get<int>(), 32) << r.dump();
      EXPECT_EQ(r[3].get<int>(), 9) << r.dump();
    }
    EXPECT_EQ(r[4].get<int>(), 7) << "unit id " << r.dump();
    if (!rtu()) {
      EXPECT_EQ(r[6].get<int>(), 0) << "MBAP protocol id " << r.dump();
      const long long tid = r[5].get<long long>();
      EXPECT_TRUE(last_tid < 0 || tid == (last_tid + 1) % 65536) << "transaction " << r.dump();
      last_tid = tid;
    }
  }
  EXPECT_GT(reads, 50U);
  EXPECT_GT(writes, 50U);
  // [t, echo, set_point, enable, heartbeat, state, causes, ticks]
  const json& blocks = log["blocks"];
  ASSERT_GT(blocks.size(), 50U);
  long long last_ticks = -1, last_heartbeat = -1;
  std::uint64_t repeated = 0;  // a block sent again (a retry after a timeout)
  for (const json& b : blocks) {
    const int set_point = b[2].get<int>() >= 0x8000 ? b[2].get<int>() - 0x10000 : b[2].get<int>();
    const int enable = b[3].get<int>(), state = b[5].get<int>();
    EXPECT_GE(set_point, 0) << b.dump();
    EXPECT_LE(set_point, 2250) << b.dump();  // e_max 2.25 V
    EXPECT_TRUE(enable == 0 || enable == 1) << b.dump();
    EXPECT_EQ(state & ~3, 0) << b.dump();
    EXPECT_NE(state & 2, 0) << "status routed here: bit 1 " << b.dump();
    if ((state & 1) != 0) {
      EXPECT_EQ(enable, 0) << "safe with enable on " << b.dump();
    }
    EXPECT_LT(b[6].get<int>(), 1 << 9) << "causes beyond the documented bits " << b.dump();
    if (b[4].get<long long>() == last_heartbeat) ++repeated;
    EXPECT_GE(b[7].get<long long>(), last_ticks) << b.dump();
    last_heartbeat = b[4].get<long long>();
    last_ticks = b[7].get<long long>();
  }
  const json& last = blocks.back();
  EXPECT_EQ(last[2].get<int>(), 0) << "shutdown block: 0 V " << last.dump();
  EXPECT_EQ(last[3].get<int>(), 0) << "shutdown block: enable off " << last.dump();
  EXPECT_EQ(last[5].get<int>() & 1, 1) << "shutdown block: safe " << last.dump();
  const json& d = f["devices"]["modbus"];
  // The heartbeat changes from block to block; only a retry sends one again.
  EXPECT_LE(repeated, d["errors"]["timeout"].get<std::uint64_t>()) << d.dump();
  EXPECT_GT(d["rx_ok"].get<std::uint64_t>(), 50U) << d.dump();
  EXPECT_EQ(d["rx_rejected"].get<std::uint64_t>(), 0U) << d.dump();
}

// Replies from another unit are not the addressed server's: refused (rejected_frame), the
// loop stays safe, and the link is kept (well-formed frames).
TEST_P(ModbusConformanceTest, FirmwareRefusesRepliesFromAnotherUnit) {
  json f;
  ASSERT_NO_FATAL_FAILURE(RunFirmwareRefusing({"--reply-unit", "8"}, &f));
  const json& d = f["devices"]["modbus"];
  // Each refusal costs RTU a quiet-line wait (up to 4 x 200 ms here): a few per second.
  EXPECT_GE(d["errors"]["rejected_frame"].get<std::uint64_t>(), 3U) << d.dump();
  EXPECT_GE(d["rx_rejected"].get<std::uint64_t>(), 2U) << d.dump();
  EXPECT_EQ(f["safe_periods"].get<std::uint64_t>(), f["ticks"].get<std::uint64_t>());
}

INSTANTIATE_TEST_SUITE_P(Transports, ModbusConformanceTest, ::testing::Values(false, true),
                         [](const auto& p) { return std::string(p.param ? "rtu" : "tcp"); });

class ModbusTcpConformanceTest : public ModbusConformanceTest {};

// Modbus TCP: a reply whose MBAP protocol id is not 0 is not a Modbus reply.
TEST_P(ModbusTcpConformanceTest, FirmwareRefusesRepliesWithAnotherProtocolId) {
  json f;
  ASSERT_NO_FATAL_FAILURE(RunFirmwareRefusing({"--reply-protocol", "7"}, &f));
  const json& d = f["devices"]["modbus"];
  EXPECT_GT(d["errors"]["rejected_frame"].get<std::uint64_t>(), 10U) << d.dump();
}

INSTANTIATE_TEST_SUITE_P(Transports, ModbusTcpConformanceTest, ::testing::Values(false),
                         [](const auto&) { return std::string("tcp"); });

}  // namespace
}  // namespace mrd::test
