// libFuzzer target for DecodeTable (built with -DMRD_FUZZ=ON and clang; toolchain/fuzz.sh).
// Each input is decoded as is, and once more with its CRC rewritten so that the field checks
// behind the CRC gate are fuzzed too. A table that decodes must re-encode, decode again to
// the same image and run through the model evaluator without crashing.
//
// `table_decode_fuzz --write-seed DIR` writes a valid table (the firmware's compiled-in one)
// to DIR/builtin.bin and exits.
#include <array>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#include "mrd/common/crc32.hpp"
#include "mrd/common/model.hpp"
#include "mrd/common/table.hpp"
#include "mrd/firmware/builtin_table.hpp"

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

}  // namespace

extern "C" int LLVMFuzzerInitialize(int* argc, char*** argv) {
  for (int i = 1; i + 1 < *argc; ++i) {
    if (std::strcmp((*argv)[i], "--write-seed") == 0) {
      const auto image = mrd::EncodeTable(mrd::firmware::kBuiltinTable);
      const std::string path = std::string((*argv)[i + 1]) + "/builtin.bin";
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
