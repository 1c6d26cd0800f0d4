// The search's extras (spec keys exchange and one_step_start): the second start is bounded
// by the first path's largest model, and the result says what each extra cost.
#include <gtest/gtest.h>

#include <algorithm>
#include <string>

#include "sem_recovery.hpp"

namespace mrd::test {
namespace {

host::SemResult IdentifyLinear2(const std::string& algorithm, int max_iterations) {
  const host::SemSpec spec =
      host::ParseSemSpec(std::string(kRecoverySpec) + "[algorithm]\n" + algorithm, "x.toml");
  const std::vector<host::DataSet> id{
      SuiteData(RecoverySystemNamed("linear2"), Noise::kEquation, 1000, 1)};
  host::SemOptions o;
  o.threads = 1;
  o.max_iterations = max_iterations;
  return host::Identify(spec, id, {}, o);
}

// linear2 needs its four terms together; forward regression on the one-step error picks at
// least those. With one major iteration the first path holds at most 2 terms, so the second
// start is cut to that size.
TEST(SemExtrasTest, SecondStartHasNoMoreTermsThanTheFirstPathsLargestModel) {
  const host::SemResult full = IdentifyLinear2("", 20);
  ASSERT_GE(full.second_start_s, 0.0);
  EXPECT_GE(full.second_start_terms, 4u);  // unbounded here: the first path grows further
  const host::SemResult short_run = IdentifyLinear2("", 1);
  ASSERT_GE(short_run.second_start_s, 0.0);
  EXPECT_GE(short_run.second_start_terms, 1u);
  EXPECT_LE(short_run.second_start_terms, 2u);
}

TEST(SemExtrasTest, CostsAreReportedAndOffExtrasSaySo) {
  const host::SemResult on = IdentifyLinear2("", 3);
  EXPECT_GT(on.path_s, 0.0);
  EXPECT_GE(on.exchange_s, 0.0);
  EXPECT_GE(on.second_start_s, 0.0);
  const host::SemResult off = IdentifyLinear2("exchange = false\none_step_start = false\n", 3);
  EXPECT_EQ(off.exchange_s, 0.0);
  EXPECT_LT(off.second_start_s, 0.0);  // not run
  EXPECT_EQ(off.second_start_terms, 0u);
}

}  // namespace
}  // namespace mrd::test
