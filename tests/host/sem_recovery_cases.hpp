#pragma once
// The structure-recovery suite's GoogleTest cases (sem_recovery_test.cpp: 20 seeds each;
// sem_recovery_rate_test.cpp: the 200-seed campaigns): a system, a noise type and a record
// length, checked against the target rate with the default settings.
#include <gtest/gtest.h>

#include <ostream>
#include <stdexcept>
#include <string>

#include "sem_recovery.hpp"

namespace mrd::test {

struct Case {
  std::size_t system;  // index into RecoverySystems()
  Noise noise;
  std::size_t n;
};

inline void PrintTo(const Case& c, std::ostream* os) {
  *os << RecoverySystems()[c.system].name << " " << NoiseName(c.noise) << " " << c.n;
}

inline std::string CaseName(const testing::TestParamInfo<Case>& info) {
  const auto& c = info.param;
  return RecoverySystems()[c.system].name + "_" + NoiseName(c.noise) + "_" + std::to_string(c.n);
}

// Seeds 1 ... seeds of the case, default settings; the target as a rate: 19 in 20 at
// N = 1000, 17 in 20 at N = 500 (seeds a multiple of 20). workers: threads sharing the seeds
// (CountRecovered; 0: one per core), each seed identified on one thread.
inline void ExpectTargetRate(const Case& c, int seeds, unsigned workers = 1) {
  host::SemOptions o;
  o.threads = 1;  // CTest runs the cases in parallel
  const RecoveryCount r =
      CountRecovered(RecoverySystems()[c.system], c.noise, c.n, seeds, o, kRecoverySpec, workers);
  testing::Test::RecordProperty("hits", r.hits);
  EXPECT_GE(r.hits, seeds / 20 * (c.n >= 1000 ? 19 : 17)) << r.hits << "/" << seeds << "; misses:\n"
                                                          << r.misses;
}

// Index of a system of RecoverySystems() by name (throws for an unknown one).
inline std::size_t SystemIndex(const std::string& name) {
  const auto all = RecoverySystems();
  for (std::size_t i = 0; i < all.size(); ++i) {
    if (all[i].name == name) return i;
  }
  throw std::runtime_error("no recovery system '" + name + "'");
}

}  // namespace mrd::test
