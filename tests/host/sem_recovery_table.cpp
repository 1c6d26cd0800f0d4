// Counts table of the structure-recovery suite (sem_recovery.hpp): exact recoveries of the
// selected model per system, noise and record length, default settings, no validation data.
//   build/tests/sem_recovery [--seeds N] [--strategy best|first] [--threads N] [--before] [--misses]
#include <cstdio>
#include <cstdlib>
#include <string>

#include "sem_recovery.hpp"

int main(int argc, char** argv) {
  int seeds = 20;
  bool misses = false;
  std::string spec = mrd::test::kRecoverySpec;
  mrd::host::SemOptions o;
  o.threads = 2;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--seeds" && i + 1 < argc) {
      seeds = std::atoi(argv[++i]);
    } else if (a == "--threads" && i + 1 < argc) {
      o.threads = std::atoi(argv[++i]);
    } else if (a == "--strategy" && i + 1 < argc) {
      const std::string s = argv[++i];
      o.strategy = s == "first" ? mrd::host::Strategy::kFirst : mrd::host::Strategy::kBest;
    } else if (a == "--before") {  // the rules before issue 15: best, 5 % tolerance
      spec = std::string(mrd::test::kRecoverySpec) +
             "[algorithm]\nstrategy = \"best\"\nselection = \"tolerance\"\n";
    } else if (a == "--misses") {
      misses = true;
    } else {
      std::fprintf(stderr, "usage: sem_recovery [--seeds N] [--strategy best|first] "
                           "[--threads N] [--before] [--misses]\n");
      return 2;
    }
  }
  std::printf("%-10s %-6s %6s %6s\n", "system", "noise", "N=1000", "N=500");
  for (const auto& s : mrd::test::RecoverySystems()) {
    for (const auto noise : {mrd::test::Noise::kEquation, mrd::test::Noise::kOutput}) {
      const auto a = mrd::test::CountRecovered(s, noise, 1000, seeds, o, spec);
      const auto b = mrd::test::CountRecovered(s, noise, 500, seeds, o, spec);
      std::printf("%-10s %-6s %3d/%-2d %3d/%-2d\n", s.name.c_str(),
                  noise == mrd::test::Noise::kEquation ? "EE" : "OE", a.hits, a.seeds, b.hits,
                  b.seeds);
      if (misses) std::printf("%s%s", a.misses.c_str(), b.misses.c_str());
      std::fflush(stdout);
    }
  }
  return 0;
}
