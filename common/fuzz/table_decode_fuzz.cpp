// libFuzzer target for DecodeTable (built with -DMRD_FUZZ=ON and clang; toolchain/fuzz.sh).
// Each input is decoded as is, and once more with its CRC rewritten so that the field checks
// behind the CRC gate are fuzzed too. A table that decodes must re-encode, decode again to
// the same image and run through the model evaluator without crashing.
//
// `table_decode_fuzz --write-seed DIR` writes a valid table (SeedTable below, encoded by
// common's EncodeTable) to DIR/seed.bin and exits. Common only: nothing above it is included.
#include <array>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <initializer_list>
#include <string>

#include "mrd/common/crc32.hpp"
#include "mrd/common/model.hpp"
#include "mrd/common/table.hpp"

namespace {

void Check(const mrd::Result<mrd::CoefficientTable>& r) {
  if (!r.ok()) return;
  const auto image = mrd::EncodeTable(r.value());
  if (!image.ok()) __builtin_trap();  // decoded but does not encode
  const auto again = mrd::DecodeTable(image.value());
  if (!again.ok()) __builtin_trap();
  const auto image2 = mrd::EncodeTable(again.value());
  if (!image2.ok() || image2.value() != image.value()) __builtin_trap();
  mrd::ModelRunner runner(r.value().model);
  std::array<double, mrd::kMaxChannels> raw{};
  for (int k = 0; k < 4; ++k) {
    for (std::size_t c = 0; c < raw.size(); ++c) raw[c] = 0.5 * k - 0.3 * static_cast<double>(c);
    (void)runner.Step(raw);
  }
}

// A valid version-2 table that reaches every field of the format: three channels (output f,
// input E in [0, 2.25] V, velocity v), a regressor of every transform, delays, powers, a
// constant term and an envelope.
mrd::CoefficientTable SeedTable() {
  mrd::CoefficientTable t{};
  t.input_channel = 1;
  t.e_min = 0.0;
  t.e_max = 2.25;
  t.has_envelope = true;
  t.envelope[0] = {-1500.0, 1500.0};
  t.envelope[1] = {0.0, 2.25};
  t.envelope[2] = {-15.0, 15.0};
  mrd::Model& m = t.model;
  m.num_channels = 3;
  m.output_channel = 0;
  m.channel_names[0] = {'f'};
  m.scales[0] = {0.0, 1500.0};
  m.channel_names[1] = {'E'};
  m.scales[1] = {0.0, 2.25};
  m.channel_names[2] = {'v'};
  m.scales[2] = {0.0, 15.0};
  m.num_regressors = 7;
  m.regressors[0] = {0, mrd::Transform::kIdentity, 1.0};
  m.regressors[1] = {1, mrd::Transform::kIdentity, 1.0};
  m.regressors[2] = {2, mrd::Transform::kAbsPow, 0.2};
  m.regressors[3] = {2, mrd::Transform::kSign, 1.0};
  m.regressors[4] = {1, mrd::Transform::kLowPass, 3.0};
  m.regressors[5] = {2, mrd::Transform::kTanh, 0.5};
  m.regressors[6] = {2, mrd::Transform::kClip, 0.8};
  const auto term = [&m](std::size_t i, std::initializer_list<mrd::Factor> factors, double theta) {
    m.terms[i].num_factors = static_cast<std::uint8_t>(factors.size());
    std::size_t j = 0;
    for (const mrd::Factor& f : factors) m.terms[i].factors[j++] = f;
    m.coefficients[i] = theta;
  };
  term(0, {{0, 1, 1}}, 0.85);
  term(1, {{0, 1, 2}}, -0.02);
  term(2, {{3, 0, 1}}, 0.03);
  term(3, {{1, 0, 1}, {2, 0, 1}, {3, 0, 1}}, 0.08);
  term(4, {{1, 0, 2}, {3, 0, 1}}, -0.02);
  term(5, {{1, 0, 1}, {3, 1, 1}}, 0.01);
  term(6, {{4, 1, 1}, {5, 0, 1}}, 0.02);
  term(7, {{6, 2, 1}}, 0.01);
  term(8, {}, 0.001);
  m.num_terms = 9;
  return t;
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int* argc, char*** argv) {
  for (int i = 1; i + 1 < *argc; ++i) {
    if (std::strcmp((*argv)[i], "--write-seed") == 0) {
      const auto image = mrd::EncodeTable(SeedTable());
      const std::string path = std::string((*argv)[i + 1]) + "/seed.bin";
      FILE* f = std::fopen(path.c_str(), "wb");
      if (f == nullptr || !image.ok()) std::exit(1);
      std::fwrite(image.value().data(), 1, image.value().size(), f);
      std::fclose(f);
      std::exit(0);
    }
  }
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  Check(mrd::DecodeTable(std::span<const std::uint8_t>(data, size)));
  if (size == mrd::kTableSize) {
    mrd::TableBytes b{};
    std::memcpy(b.data(), data, size);
    const std::uint32_t crc =
        mrd::Crc32(std::span<const std::uint8_t>(b.data(), mrd::kTableCrcOffset));
    for (std::size_t i = 0; i < 4; ++i) {
      b[mrd::kTableCrcOffset + i] = static_cast<std::uint8_t>(crc >> (8 * i));
    }
    Check(mrd::DecodeTable(b));
  }
  return 0;
}
