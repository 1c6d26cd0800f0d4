// Statistical campaigns of the structure-recovery suite (sem_recovery_test.cpp): the target
// rates over 200 seeds. Labels sem, campaign and extended: `toolchain/test.sh --all` runs them
// (and CI), the default tier does not.
#include <gtest/gtest.h>

#include "sem_recovery_cases.hpp"

namespace mrd::test {
namespace {

// The same targets as rates over 200 seeds (1 ... 200, the suite's 20 among them): 190/200 at
// N = 1000, 170/200 at N = 500. Run here for the case below target on seeds 1-20 (billings EE
// 500, 183/200 measured), the cases closest to their rate (billings OE 1000, 193/200;
// sysidentpy_ma, 194/200) and metamss_s3 (195/200; 106/200 when scored by the free run). Every
// case: build/tests/sem_recovery --seeds 200 --case SYSTEM EE|OE|MA N (docs/results.md,
// "Structure recovery").
class SemRecoveryRateTest : public testing::TestWithParam<Case> {};

// The seeds shared among one thread per core (CTest reserves the cores: PROCESSORS); the
// count is the serial run's.
TEST_P(SemRecoveryRateTest, DefaultSettingsRecoverAtTheTargetRateOver200Seeds) {
  ExpectTargetRate(GetParam(), 200, 0);
}

INSTANTIATE_TEST_SUITE_P(
    Seeds200, SemRecoveryRateTest,
    testing::Values(Case{0, Noise::kEquation, 500}, Case{0, Noise::kOutput, 1000},
                    Case{SystemIndex("metamss_s3"), Noise::kEquation, 1000},
                    Case{SystemIndex("sysidentpy_ma"), Noise::kColoured, 1000}),
    CaseName);

}  // namespace
}  // namespace mrd::test
