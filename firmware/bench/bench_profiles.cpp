// Google Benchmark: one control period's wire work through each device profile, the CPU the
// 1 kHz loop spends packing and unpacking (goal: <= 2 us per period). Registered for every
// profile in firmware/profiles/ and the test driver (tests/data/profiles/), plus
// MRD_BENCH_PROFILE=FILE:
//   BM_ProfileCanPeriod/NAME     the sensor messages found, checked (length, checksum,
//                                counter) and decoded; the command message (when the profile
//                                carries the set-point on CAN) built and sealed
//   BM_ProfileModbusPeriod/NAME  every grouped read reply checked and its points decoded; every
//                                write request's points encoded and its PDU built
#include <benchmark/benchmark.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "mrd/profile/can_profile.hpp"
#include "mrd/profile/frame_codec.hpp"
#include "mrd/profile/modbus_profile.hpp"

namespace {

using mrd::profile::CanIn;
using mrd::profile::CanOut;
using mrd::profile::ModbusOut;
constexpr int kSamples = 1024;

// The live telemetry message of a period (status_model_force, _demand, _command): begun,
// three signals set, sealed (the work PublishStatus adds per status period).
void CanTelemetry(benchmark::State& state, const mrd::profile::CanProfile& p) {
  mrd::profile::FrameCodec tx(p);
  const auto out = [&](CanOut r) { return p.outputs[static_cast<std::size_t>(r)]; };
  const int m = out(CanOut::kStatusModelForce).message;
  int k = 0;
  for (auto _ : state) {
    can_frame f{};
    tx.Begin(m, &f);
    for (const CanOut r :
         {CanOut::kStatusModelForce, CanOut::kStatusDemand, CanOut::kStatusCommand}) {
      if (out(r).message == m) (void)tx.Set(&f, out(r), 100.0 * std::sin(0.01 * k) + 200.0);
    }
    tx.Seal(m, &f);
    benchmark::DoNotOptimize(f);
    k = (k + 1) & (kSamples - 1);
  }
}

void CanPeriod(benchmark::State& state, const mrd::profile::CanProfile& p) {
  mrd::profile::FrameCodec tx(p), rx(p);
  const auto in = [&](CanIn r) { return p.inputs[static_cast<std::size_t>(r)]; };
  const auto out = [&](CanOut r) { return p.outputs[static_cast<std::size_t>(r)]; };
  if (!in(CanIn::kVelocity).mapped() || !in(CanIn::kDemand).mapped()) {
    state.SkipWithError("the profile maps no velocity or demand on CAN");
    return;
  }
  // The sensor frames of kSamples periods, built once (one frame when both share a message).
  const int motion_m = in(CanIn::kVelocity).message, demand_m = in(CanIn::kDemand).message;
  std::vector<can_frame> motion(kSamples), force(kSamples);
  for (int k = 0; k < kSamples; ++k) {
    tx.Begin(motion_m, &motion[k]);
    (void)tx.Set(&motion[k], in(CanIn::kVelocity), 10.0 * std::sin(0.01 * k));
    if (in(CanIn::kDisplacement).message == motion_m) {
      (void)tx.Set(&motion[k], in(CanIn::kDisplacement), 0.5 * std::cos(0.01 * k));
    }
    if (demand_m == motion_m)
      (void)tx.Set(&motion[k], in(CanIn::kDemand), 500.0 * std::sin(0.003 * k));
    tx.Seal(motion_m, &motion[k]);
    tx.Begin(demand_m, &force[k]);
    (void)tx.Set(&force[k], in(CanIn::kDemand), 500.0 * std::sin(0.003 * k));
    tx.Seal(demand_m, &force[k]);
  }
  const int frames = demand_m == motion_m ? 1 : 2;
  const int cmd = out(CanOut::kCommand).message;  // -1: the set-point is not on CAN
  mrd::profile::CommandMap map = p.command;
  int k = 0;
  double sum = 0.0;
  for (auto _ : state) {
    const can_frame* received[2] = {&motion[k], &force[k]};
    for (int i = 0; i < frames; ++i) {
      const can_frame& f = *received[i];
      const int m = rx.Find(f);
      if (rx.Check(m, f) == mrd::protocol::can::Reject::kNone) {
        double v = 0.0;
        (void)rx.Get(f, m == motion_m ? in(CanIn::kVelocity) : in(CanIn::kDemand), &v);
        sum += v;
      }
    }
    if (cmd >= 0) {
      can_frame c{};
      tx.Begin(cmd, &c);
      (void)tx.Set(&c, out(CanOut::kCommand), map.Apply(1.0 + 0.5 * std::sin(0.002 * k), 1e-3));
      if (out(CanOut::kEnable).mapped()) (void)tx.Set(&c, out(CanOut::kEnable), 1.0);
      if (out(CanOut::kEcho).mapped()) (void)tx.Set(&c, out(CanOut::kEcho), k & 255);
      tx.Seal(cmd, &c);
      benchmark::DoNotOptimize(c);
    }
    k = (k + 1) % kSamples;
    rx.ResetCounters();  // frames of the table repeat every kSamples periods
  }
  benchmark::DoNotOptimize(sum);
}

// A read reply PDU for request r from a unit's table storage (registers big-endian; bits
// packed LSB first).
std::vector<std::uint8_t> ReadReply(const mrd::profile::ModbusRequest& r,
                                    const std::vector<std::uint16_t>& words) {
  std::vector<std::uint8_t> pdu = {r.function};
  const bool bits = r.function == 0x01 || r.function == 0x02;
  const int bytes = bits ? (r.count + 7) / 8 : 2 * r.count;
  pdu.push_back(static_cast<std::uint8_t>(bytes));
  pdu.resize(2 + static_cast<std::size_t>(bytes), 0);
  for (int i = 0; i < r.count; ++i) {
    const std::uint16_t w = words[static_cast<std::size_t>(r.address + i)];
    if (bits) {
      if (w != 0)
        pdu[2 + static_cast<std::size_t>(i / 8)] |= static_cast<std::uint8_t>(1U << (i % 8));
    } else {
      pdu[2 + 2 * static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(w >> 8);
      pdu[3 + 2 * static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(w & 0xFF);
    }
  }
  return pdu;
}

void ModbusPeriod(benchmark::State& state, const mrd::profile::ModbusProfile& p) {
  // The server's side, once: every mapped input stored in its unit's table, each read's reply.
  std::vector<std::vector<std::uint8_t>> replies;
  for (const auto& r : p.reads) {
    std::vector<std::uint16_t> words(65536, 0);
    for (std::size_t i = 0; i < p.inputs.size(); ++i) {
      const auto& pt = p.inputs[i];
      if (pt.mapped && pt.unit == r.unit && pt.table == r.table) {
        (void)mrd::profile::StoreModbusPoint(p, pt, 1.5 + static_cast<double>(i), words.data());
      }
    }
    replies.push_back(ReadReply(r, words));
  }
  std::vector<std::uint16_t> words(static_cast<std::size_t>(p.MaxCount()) + 2, 0);
  std::array<std::uint8_t, 260> pdu{};
  mrd::profile::CommandMap map = p.command;
  int k = 0;
  double sum = 0.0;
  for (auto _ : state) {
    for (std::size_t r = 0; r < p.reads.size(); ++r) {
      std::uint8_t exception = 0;
      const auto& reply = replies[r];
      if (mrd::profile::CheckModbusRead(p.reads[r], reply.data(), static_cast<int>(reply.size()),
                                        &exception) != mrd::profile::ModbusReply::kOk) {
        continue;
      }
      for (const auto& pt : p.inputs) {
        if (pt.mapped && pt.request == static_cast<int>(r)) {
          sum += mrd::profile::ModbusPointValue(p, pt, reply.data());
        }
      }
    }
    for (std::size_t w = 0; w < p.writes.size(); ++w) {
      for (std::size_t o = 0; o < p.outputs.size(); ++o) {
        const auto& pt = p.outputs[o];
        if (!pt.mapped || pt.request != static_cast<int>(w)) continue;
        const double v = static_cast<ModbusOut>(o) == ModbusOut::kCommand
                             ? map.Apply(1.0 + 0.5 * std::sin(0.002 * k), 1e-3)
                             : 1.0;
        (void)mrd::profile::PutModbusPoint(p, pt, v, words.data());
      }
      benchmark::DoNotOptimize(mrd::profile::PutModbusWrite(p.writes[w], words.data(), pdu.data()));
    }
    k = (k + 1) % kSamples;
  }
  benchmark::DoNotOptimize(sum);
}

// Registers one profile file's period: Modbus when it has a [modbus] map, else CAN.
void RegisterProfile(const std::string& path) {
  const std::string name = std::filesystem::path(path).stem().string();
  std::string error;
  if (mrd::profile::IsModbusProfileFile(path)) {
    auto p = std::make_shared<mrd::profile::ModbusProfile>();
    if (!mrd::profile::LoadModbusProfile(path, p.get(), &error)) {
      std::fprintf(stderr, "bench: %s\n", error.c_str());
      return;
    }
    benchmark::RegisterBenchmark(("BM_ProfileModbusPeriod/" + name).c_str(),
                                 [p](benchmark::State& st) { ModbusPeriod(st, *p); });
    return;
  }
  auto p = std::make_shared<mrd::profile::CanProfile>();
  if (!mrd::profile::LoadCanProfile(path, p.get(), &error)) {
    std::fprintf(stderr, "bench: %s\n", error.c_str());
    return;
  }
  benchmark::RegisterBenchmark(("BM_ProfileCanPeriod/" + name).c_str(),
                               [p](benchmark::State& st) { CanPeriod(st, *p); });
  if (p->outputs[static_cast<std::size_t>(CanOut::kStatusModelForce)].mapped()) {
    benchmark::RegisterBenchmark(("BM_ProfileCanTelemetry/" + name).c_str(),
                                 [p](benchmark::State& st) { CanTelemetry(st, *p); });
  }
}

[[maybe_unused]] const bool kRegistered = [] {
  const std::filesystem::path source = MRD_SOURCE_DIR;
  std::vector<std::string> files;
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator(source / "firmware" / "profiles", ec)) {
    if (e.path().extension() == ".toml") files.push_back(e.path().string());
  }
  std::sort(files.begin(), files.end());
  files.push_back((source / "tests" / "data" / "profiles" / "test-driver.toml").string());
  if (const char* extra = std::getenv("MRD_BENCH_PROFILE")) files.push_back(extra);
  for (const auto& f : files) RegisterProfile(f);
  return true;
}();

}  // namespace
