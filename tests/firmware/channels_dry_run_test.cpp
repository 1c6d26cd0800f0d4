// mrd-firmware --dry-run with several channels ([channels] count > 1): the per-channel summary,
// bit-identical on repeat in lockstep; one channel's fault under fault_policy "all" and
// "channel"; the one-channel summary unchanged by the section.
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "host/test_util.hpp"

namespace mrd::test {
namespace {

std::string Firmware() { return Bin("mrd-firmware"); }

constexpr const char* kModal =
    "[channels]\ncount = 4\nbody_law = \"modal-skyhook\"\ncg_to_front_m = 1.2\n"
    "cg_to_rear_m = 1.4\ntrack_front_m = 1.5\ntrack_rear_m = 1.5\nmotion_ratio = 0.7\n";

// The --json output of a 2 s lockstep dry run on a config holding text ("": no config).
CommandResult DryRun(const TempDir& dir, const std::string& text) {
  std::string args = " --dry-run 2 --lockstep --json";
  if (!text.empty()) {
    std::ofstream(dir.File("fw.toml")) << text;
    args = " --config " + dir.File("fw.toml") + args;
  }
  return test::Run(Firmware() + args);
}

TEST(ChannelsDryRunTest, FourChannelsInLockstepGiveEachChannelsSummaryBitIdenticalOnRepeat) {
  TempDir dir;
  const CommandResult a = DryRun(dir, kModal);
  const CommandResult b = DryRun(dir, kModal);
  ASSERT_EQ(a.status, 0) << a.output;
  EXPECT_EQ(a.output, b.output);
  const auto j = nlohmann::json::parse(a.output);
  EXPECT_EQ(j["fault_policy"], "all");
  ASSERT_EQ(j["channels"].size(), 4u);
  for (std::size_t i = 0; i < 4; ++i) {
    const auto& c = j["channels"][i];
    EXPECT_EQ(c["channel"], i);
    EXPECT_EQ(c["table"], "compiled-in");
    EXPECT_EQ(c["ticks"], 2000);
    EXPECT_EQ(c["safe_periods"], 0);
    EXPECT_EQ(c["final_safe_state"], true);
    EXPECT_EQ(c["last_causes"], "");
  }
  // Channel 0's counters are the top-level ones; the corners move differently.
  EXPECT_EQ(j["channels"][0]["passive_demands"], j["passive_demands"]);
  EXPECT_NE(j["channels"][0]["passive_demands"], j["channels"][1]["passive_demands"]);
}

// Channel 0 (the largest stroke, 12.6 cm/s peak) passes the 12 cm/s velocity limit at every
// peak; the others (8 % smaller each) never do.
TEST(ChannelsDryRunTest, OneChannelsFaultPutsTheOthersSafeUnderAllAndNotUnderChannel) {
  for (const std::string policy : {"all", "channel"}) {
    SCOPED_TRACE(policy);
    TempDir dir;
    const CommandResult r = DryRun(dir,
                                   "[safety]\nvelocity_limit = 12\n[channels]\ncount = 4\n"
                                   "fault_policy = \"" +
                                       policy + "\"\n");
    ASSERT_EQ(r.status, 0) << r.output;
    const auto j = nlohmann::json::parse(r.output);
    ASSERT_EQ(j["channels"].size(), 4u);
    const auto& faulted = j["channels"][0];
    EXPECT_GT(faulted["trips"]["implausible"], 0);
    EXPECT_EQ(faulted["trips"]["other_channel"], 0);
    EXPECT_GT(faulted["safe_periods"], 0);
    for (std::size_t i = 1; i < 4; ++i) {
      const auto& c = j["channels"][i];
      EXPECT_EQ(c["trips"]["implausible"], 0) << i;
      if (policy == "all") {
        // Safe after each of channel 0's faults, counted as other_channel, per channel.
        EXPECT_EQ(c["trips"]["other_channel"], faulted["trips"]["implausible"]) << i;
        EXPECT_GT(c["safe_periods"], 0) << i;
      } else {
        EXPECT_EQ(c["trips"]["other_channel"], 0) << i;
        EXPECT_EQ(c["safe_periods"], 0) << i;
      }
    }
  }
}

TEST(ChannelsDryRunTest, OneChannelKeepsTheSummaryAsItWas) {
  TempDir dir;
  const CommandResult none = DryRun(dir, "");
  const CommandResult one = DryRun(dir, "[channels]\ncount = 1\nfault_policy = \"channel\"\n");
  ASSERT_EQ(none.status, 0) << none.output;
  EXPECT_EQ(none.output, one.output);
  EXPECT_EQ(none.output.find("\"channels\""), std::string::npos);
  EXPECT_EQ(none.output.find("\"fault_policy\""), std::string::npos);
}

TEST(ChannelsDryRunTest, ChannelsOnTheirTablesRunAsOnTheRunsTable) {
  TempDir dir;
  ASSERT_EQ(test::Run(Firmware() + " --write-table " + dir.File("t.bin")).status, 0);
  const CommandResult run = DryRun(dir, "[channels]\ncount = 2\n");
  const CommandResult own = DryRun(dir, "[channels]\ncount = 2\ntables = [\"t.bin\", \"t.bin\"]\n");
  ASSERT_EQ(own.status, 0) << own.output;
  const auto a = nlohmann::json::parse(run.output), b = nlohmann::json::parse(own.output);
  EXPECT_EQ(b["channels"][1]["table"], "t.bin");
  for (std::size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(a["channels"][i]["passive_demands"], b["channels"][i]["passive_demands"]) << i;
    EXPECT_EQ(a["channels"][i]["unreachable_demands"], b["channels"][i]["unreachable_demands"]);
  }
}

}  // namespace
}  // namespace mrd::test
