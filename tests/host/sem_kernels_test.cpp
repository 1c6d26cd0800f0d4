// The SEM engine's vectorised kernels (host/src/sem/engine/kernels.hpp) against the scalar
// reference loops they replace: every result bit for bit equal, at each vector width (4; 8 where
// the CPU has AVX-512F), for every lane count, term count, y power count, factor count and tail
// length.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "sem/engine/kernels.hpp"

namespace mrd::host::internal {
namespace {

constexpr std::size_t kN = 3 * kSubBlock + 3;  // samples of every test column

// The kernels at one vector width (the parameter); skipped where the CPU lacks it.
class SemKernelsTest : public ::testing::TestWithParam<std::size_t> {
 protected:
  void SetUp() override {
    if (!SetLaneWidth(GetParam())) GTEST_SKIP() << "no " << GetParam() << "-wide kernels here";
    ASSERT_EQ(LaneWidth(), GetParam());
  }
  void TearDown() override { SetLaneWidth(0); }
};

struct Columns {
  std::vector<std::vector<double>> data;
  std::vector<const double*> ptr;
};

Columns RandomColumns(std::size_t count, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.5, 1.5);
  Columns c;
  c.data.assign(count, std::vector<double>(kN));
  for (auto& col : c.data) {
    for (double& v : col) v = u(rng);
  }
  for (const auto& col : c.data) c.ptr.push_back(col.data());
  return c;
}

// The scalar lane sum of the engine before vectorisation (terms in fours, then singly).
double RefSum(const Columns& u, const std::vector<double>& theta, std::size_t lanes, std::size_t l,
              std::size_t m, std::size_t k) {
  double c = 0.0;
  std::size_t j = 0;
  bool first = true;
  for (; j + 4 <= m; j += 4) {
    const double g =
        (theta[j * lanes + l] * u.ptr[j][k] + theta[(j + 1) * lanes + l] * u.ptr[j + 1][k]) +
        (theta[(j + 2) * lanes + l] * u.ptr[j + 2][k] +
         theta[(j + 3) * lanes + l] * u.ptr[j + 3][k]);
    c = first ? g : c + g;
    first = false;
  }
  for (; j < m; ++j) {
    const double g = theta[j * lanes + l] * u.ptr[j][k];
    c = first ? g : c + g;
    first = false;
  }
  return c;
}

TEST_P(SemKernelsTest, LaneSumsEqualTheScalarSumsBitForBit) {
  std::mt19937 rng(1);
  const Columns u = RandomColumns(11, rng);
  std::uniform_real_distribution<double> t(-2.0, 2.0);
  for (int nv = 1; nv <= 4; ++nv) {
    const std::size_t lanes = LaneWidth() * static_cast<std::size_t>(nv);
    for (std::size_t m = 0; m <= 11; ++m) {
      for (std::size_t len : {std::size_t{1}, std::size_t{7}, kSubBlock}) {
        std::vector<double> theta(m * lanes);
        for (double& v : theta) v = t(rng);
        const std::size_t off = 5;
        std::vector<double> c(len * lanes, std::nan(""));
        LaneSums(nv, u.ptr.data(), off, theta.data(), m, len, c.data());
        for (std::size_t s = 0; s < len; ++s) {
          for (std::size_t l = 0; l < lanes; ++l) {
            ASSERT_EQ(c[s * lanes + l], RefSum(u, theta, lanes, l, m, off + s))
                << "nv " << nv << " m " << m << " len " << len << " s " << s << " lane " << l;
          }
        }
      }
    }
  }
}

TEST_P(SemKernelsTest, LaneFreeRunEqualsTheScalarRecursionAndFlagsDivergence) {
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> coef(-0.6, 0.6);
  const Columns yw = RandomColumns(2, rng);
  for (int nv = 1; nv <= 4; ++nv) {
    const std::size_t lanes = LaneWidth() * static_cast<std::size_t>(nv);
    for (std::size_t nq = 1; nq <= 4; ++nq) {
      const std::size_t len = kSubBlock - 3;
      std::vector<double> c(nq * kSubBlock * lanes);
      for (double& v : c) v = coef(rng);
      c[(0 * kSubBlock + 9) * lanes + 1] = 50.0;  // lane 1 leaves |y| <= 10 at sample 9
      c[(0 * kSubBlock + 4) * lanes + 2] = std::numeric_limits<double>::quiet_NaN();
      std::vector<double> p(lanes), acc(lanes);
      for (std::size_t l = 0; l < lanes; ++l) {
        p[l] = coef(rng);
        acc[l] = 0.25 * static_cast<double>(l);
      }
      auto p_ref = p, acc_ref = acc;
      bool bad[kMaxLanes] = {};
      LaneFreeRun(nv, nq, c.data(), kSubBlock, yw.ptr[0], yw.ptr[1], len, 10.0, p.data(),
                  acc.data(), bad);
      for (std::size_t l = 0; l < lanes; ++l) {
        bool b = false;
        for (std::size_t s = 0; s < len; ++s) {
          double yk = c[((nq - 1) * kSubBlock + s) * lanes + l];
          for (std::size_t q = nq - 1; q-- > 0;) {
            yk = yk * p_ref[l] + c[(q * kSubBlock + s) * lanes + l];
          }
          const double e = yw.ptr[0][s] - yk;
          acc_ref[l] += yw.ptr[1][s] * (e * e);
          b |= !(std::fabs(yk) <= 10.0);
          p_ref[l] = yk;
        }
        if (std::isnan(acc_ref[l])) {
          EXPECT_TRUE(std::isnan(acc[l]));
        } else {
          EXPECT_EQ(acc[l], acc_ref[l]) << "nv " << nv << " nq " << nq << " lane " << l;
          EXPECT_EQ(p[l], p_ref[l]);
        }
        EXPECT_EQ(bad[l], b) << "nv " << nv << " nq " << nq << " lane " << l;
      }
      EXPECT_TRUE(bad[2]);  // NaN
      if (nq == 1) {
        EXPECT_TRUE(bad[1]);
      }
    }
  }
}

TEST_P(SemKernelsTest, LaneExtraAddsEachLanesProductToItsOwnYPower) {
  std::mt19937 rng(3);
  const Columns f = RandomColumns(5, rng);
  std::vector<double> ones(kN, 1.0);
  std::uniform_real_distribution<double> t(-2.0, 2.0);
  std::uniform_int_distribution<int> pick(0, 4);
  for (int nv = 1; nv <= 4; ++nv) {
    const std::size_t lanes = LaneWidth() * static_cast<std::size_t>(nv);
    for (std::size_t nf = 1; nf <= 4; ++nf) {
      for (std::size_t len : {std::size_t{3}, std::size_t{13}, kSubBlock}) {
        const std::size_t nq = 3;
        const std::vector<char> fresh = {0, 1, 0};
        std::vector<const double*> cols(lanes * nf);
        std::vector<std::size_t> used(lanes);  // factors before the padding with ones
        std::vector<double> th(lanes);
        std::vector<int> q(lanes);
        for (std::size_t l = 0; l < lanes; ++l) {
          used[l] = 1 + l % nf;
          for (std::size_t k = 0; k < nf; ++k) {
            cols[l * nf + k] =
                k < used[l] ? f.ptr[static_cast<std::size_t>(pick(rng))] : ones.data();
          }
          th[l] = t(rng);
          q[l] = static_cast<int>(l % 4) - 1;  // -1 (none), 0, 1, 2
        }
        std::vector<double> c(nq * kSubBlock * lanes);
        for (double& v : c) v = t(rng);
        const auto before = c;
        const std::size_t off = 17;
        LaneExtra(nv, cols.data(), nf, off, th.data(), q.data(), nq, fresh.data(), len, c.data(),
                  kSubBlock);
        for (std::size_t qq = 0; qq < nq; ++qq) {
          for (std::size_t s = 0; s < len; ++s) {
            for (std::size_t l = 0; l < lanes; ++l) {
              const std::size_t i = (qq * kSubBlock + s) * lanes + l;
              double want = fresh[qq] ? 0.0 : before[i];
              if (q[l] == static_cast<int>(qq)) {
                double x = cols[l * nf][off + s];
                for (std::size_t k = 1; k < used[l]; ++k) x *= cols[l * nf + k][off + s];
                want += th[l] * x;
              }
              ASSERT_EQ(c[i], want)
                  << "nv " << nv << " nf " << nf << " q " << qq << " s " << s << " lane " << l;
            }
          }
        }
      }
    }
  }
}

TEST_P(SemKernelsTest, LaneGramSumsInSampleOrderBitForBit) {
  std::mt19937 rng(4);
  const Columns f = RandomColumns(6, rng);
  std::vector<double> ones(kN, 1.0);
  std::uniform_int_distribution<int> pick(0, 5);
  for (int nv = 1; nv <= 4; ++nv) {
    const std::size_t lanes = LaneWidth() * static_cast<std::size_t>(nv);
    for (std::size_t nf = 1; nf <= 5; ++nf) {
      for (bool square : {false, true}) {
        std::vector<const double*> cols(lanes * nf);
        for (std::size_t l = 0; l < lanes; ++l) {
          for (std::size_t k = 0; k < nf; ++k) {
            cols[l * nf + k] =
                k <= l % nf ? f.ptr[static_cast<std::size_t>(pick(rng))] : ones.data();
          }
        }
        const double* x = square ? nullptr : f.ptr[0];
        std::vector<double> acc(lanes, 0.5);
        // Two calls (sums go on across calls), odd lengths.
        LaneGram(nv, cols.data(), nf, 1, x, 37, acc.data());
        LaneGram(nv, cols.data(), nf, 38, x, 23, acc.data());
        for (std::size_t l = 0; l < lanes; ++l) {
          double want = 0.5;
          for (std::size_t i = 1; i < 61; ++i) {
            double phi = cols[l * nf][i];
            for (std::size_t k = 1; k < nf; ++k) phi *= cols[l * nf + k][i];
            want += square ? phi * phi : phi * x[i];
          }
          EXPECT_EQ(acc[l], want) << "nv " << nv << " nf " << nf << " lane " << l;
        }
      }
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Widths, SemKernelsTest, ::testing::Values(std::size_t{4}, std::size_t{8}),
                         [](const auto& p) { return std::string(p.param == 4 ? "w4" : "w8"); });

}  // namespace
}  // namespace mrd::host::internal
