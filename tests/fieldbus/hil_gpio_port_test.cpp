// The harness's GPIO port on a simulated chip: endpoint parsing, the encoder lines driven from
// the plant's displacement (decoded here independently), the fault line with its polarity, and
// the firmware's enable and heartbeat lines heard. Also the chip and decoder underneath.
#include <gtest/gtest.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <string>

#include "mrd/common/clock.hpp"
#include "mrd/hil/ports/gpio_port.hpp"
#include "mrd/protocol/quadrature.hpp"
#include "mrd/sim_gpio/sim_chip.hpp"

namespace mrd::hil {
namespace {

std::string ChipPath(const char* tag) {
  const std::string p = "/tmp/mrd-hil-gpio-" + std::string(tag) + "-" + std::to_string(getpid());
  unlink(p.c_str());
  return p;
}

TEST(HilGpioPort, EndpointDefaultsAndKeys) {
  GpioPortConfig c;
  std::string error;
  ASSERT_TRUE(ParseGpioEndpoint("/tmp/chip", &c, &error)) << error;
  EXPECT_EQ(c.path, "/tmp/chip");
  EXPECT_EQ(c.encoder_a_line, 4);
  EXPECT_EQ(c.encoder_b_line, 5);
  EXPECT_EQ(c.fault_line, 6);
  EXPECT_EQ(c.enable_line, 17);
  EXPECT_EQ(c.heartbeat_line, 18);
  EXPECT_DOUBLE_EQ(c.counts_per_cm, 400.0);
  EXPECT_FALSE(c.fault_active_low);
  ASSERT_TRUE(
      ParseGpioEndpoint("/tmp/c,encoder_a=1,encoder_b=2,fault=3,enable=60,heartbeat=63,"
                        "counts_per_cm=125.5,fault_active_low=1",
                        &c, &error))
      << error;
  EXPECT_EQ(c.encoder_a_line, 1);
  EXPECT_EQ(c.heartbeat_line, 63);
  EXPECT_DOUBLE_EQ(c.counts_per_cm, 125.5);
  EXPECT_TRUE(c.fault_active_low);
  for (const char* bad : {"", ",fault=3", "/tmp/c,fault=64", "/tmp/c,fault=-1", "/tmp/c,fault=x",
                          "/tmp/c,counts_per_cm=0", "/tmp/c,counts_per_cm=nan",
                          "/tmp/c,fault_active_low=yes", "/tmp/c,colour=red", "/tmp/c,enable=4"}) {
    EXPECT_FALSE(ParseGpioEndpoint(bad, &c, &error)) << bad;
    EXPECT_EQ(error.rfind("gpio endpoint '", 0), 0U) << error;
  }
  EXPECT_NE(error.find("two functions on line 4"), std::string::npos) << error;
}

TEST(HilGpioPort, DrivesTheEncoderAndFaultLineAndHearsEnableAndHeartbeat) {
  const std::string path = ChipPath("port");
  GpioPortConfig c;
  c.path = path;
  c.counts_per_cm = 200.0;
  c.fault_active_low = true;
  auto port = MakeGpioPort(c);
  std::string error;
  ASSERT_TRUE(port->Open(&error)) << error;
  // The firmware's side, by hand: an independent decoder on the chip's events.
  sim_gpio::SimChip fw;
  ASSERT_TRUE(fw.Open(path, /*create=*/false, &error)) << error;
  EXPECT_TRUE(fw.GetValue(6));  // active low: high = not asserted
  protocol::QuadratureDecoder decoder;
  decoder.Reset(fw.GetValue(4), fw.GetValue(5));
  std::uint64_t cursor_a = fw.head(4), cursor_b = fw.head(5);
  auto decode = [&] {
    std::array<sim_gpio::Event, 256> ea{}, eb{};
    std::array<protocol::QuadratureEdge, 256> qa{}, qb{};
    std::uint64_t lost = 0;
    const std::size_t na = fw.ReadEvents(4, &cursor_a, ea.data(), ea.size(), &lost);
    EXPECT_EQ(lost, 0U);
    const std::size_t nb = fw.ReadEvents(5, &cursor_b, eb.data(), eb.size(), &lost);
    EXPECT_EQ(lost, 0U);
    for (std::size_t i = 0; i < na; ++i) qa[i] = {ea[i].t_ns, ea[i].rising};
    for (std::size_t i = 0; i < nb; ++i) qb[i] = {eb[i].t_ns, eb[i].rising};
    return decoder.Feed(qa.data(), na, qb.data(), nb);
  };

  SensorOutput out;
  out.sample.x = 0.25;  // 50 counts
  port->Publish(out);
  protocol::QuadratureBatch b = decode();
  EXPECT_EQ(b.steps, 50U);
  EXPECT_EQ(b.glitches, 0U);
  EXPECT_EQ(decoder.count(), 50);
  out.sample.x = -0.1;  // -20 counts: 70 steps back
  out.fault_line = true;
  port->Publish(out);
  b = decode();
  EXPECT_EQ(decoder.count(), -20);
  EXPECT_FALSE(fw.GetValue(6));  // asserted, active low
  // A jump larger than one step's bound is spread over the following steps.
  out.sample.x = 5.0;  // 1000 counts
  port->Publish(out);
  decode();
  EXPECT_EQ(decoder.count(), -20 + kMaxStepsPerPublish);
  for (int k = 0; k < 10; ++k) {
    port->Publish(out);
    decode();
  }
  EXPECT_EQ(decoder.count(), 1000);
  EXPECT_EQ(decoder.glitches(), 0U);
  EXPECT_EQ(port->counters().published, 50U + 70U + 1020U);

  // Enable and heartbeat.
  DriverInput in;
  port->Poll(&in);
  EXPECT_TRUE(in.has_enable);
  EXPECT_FALSE(in.enable);
  EXPECT_EQ(in.heartbeat_ns, 0);
  fw.SetValue(17, true, common::MonotonicNs());
  fw.SetValue(18, true, common::MonotonicNs());
  fw.SetValue(18, false, common::MonotonicNs());
  port->Poll(&in);
  EXPECT_TRUE(in.enable);
  EXPECT_GT(in.heartbeat_ns, 0);
  const std::int64_t hb = in.heartbeat_ns;
  port->Poll(&in);
  EXPECT_EQ(in.heartbeat_ns, hb);  // no toggle: no new heartbeat
  EXPECT_EQ(port->counters().received, 3U);
  port->Close();
  fw.Close();
  unlink(path.c_str());
}

TEST(SimGpioChip, AReaderLappedByTheWriterCountsTheLostEvents) {
  const std::string path = ChipPath("lap");
  sim_gpio::SimChip w, r;
  std::string error;
  ASSERT_TRUE(w.Open(path, true, &error)) << error;
  ASSERT_TRUE(r.Open(path, false, &error)) << error;
  std::uint64_t cursor = r.head(3);
  for (std::size_t i = 0; i < sim_gpio::kRingSize + 10; ++i) {
    w.SetValue(3, i % 2 == 0, static_cast<std::int64_t>(i + 1));
  }
  w.SetValue(3, w.GetValue(3), 999);  // no change: no event
  std::array<sim_gpio::Event, sim_gpio::kRingSize> ev{};
  std::uint64_t lost = 0;
  const std::size_t n = r.ReadEvents(3, &cursor, ev.data(), ev.size(), &lost);
  EXPECT_EQ(lost, 10U);
  EXPECT_EQ(n, sim_gpio::kRingSize);
  EXPECT_EQ(ev[0].t_ns, 11);
  EXPECT_EQ(ev[n - 1].t_ns, static_cast<std::int64_t>(sim_gpio::kRingSize + 10));
  // A file that is not a chip is refused.
  const std::string not_chip = path + ".txt";
  {
    std::FILE* f = std::fopen(not_chip.c_str(), "w");
    std::fputs("hello\n", f);
    std::fclose(f);
  }
  sim_gpio::SimChip bad;
  EXPECT_FALSE(bad.Open(not_chip, false, &error));
  unlink(not_chip.c_str());
  EXPECT_NE(error.find("not a simulated chip"), std::string::npos) << error;
  unlink(path.c_str());
}

TEST(Quadrature, SimultaneousEdgesAndContradictingEdgesAreGlitches) {
  protocol::QuadratureDecoder d;
  d.Reset(false, false);
  const protocol::QuadratureEdge a[] = {{10, true}, {30, false}};
  const protocol::QuadratureEdge b[] = {{20, true}, {30, true}};  // t=30: both lines, one event
  const protocol::QuadratureBatch r = d.Feed(a, 2, b, 2);
  EXPECT_EQ(r.steps, 2U);  // 00 -> 10 -> 11
  EXPECT_EQ(r.glitches, 1U);
  EXPECT_EQ(d.count(), 2);
  EXPECT_EQ(d.OnEdge(false, false), protocol::QuadratureStep::kGlitch);  // A is already low
  EXPECT_EQ(d.OnEdge(true, false), protocol::QuadratureStep::kForward);  // 01 -> 00
  for (std::int64_t c = -9; c <= 9; ++c) {
    const protocol::QuadratureLevels l = protocol::LevelsForCount(c);
    const protocol::QuadratureLevels n = protocol::LevelsForCount(c + 1);
    EXPECT_NE(l.a != n.a, l.b != n.b) << c;  // one line per step
  }
}

}  // namespace
}  // namespace mrd::hil
