#pragma once
// Published peak responses beside the study's: `mrd-structure study --reference FILE` reads a
// paper's table (e.g. Dyke et al. 1996, El Centro) and prints each measured cell's difference
// from it, and whether the clipped-optimal law's changes against the passive cases go the
// same way as in the paper. Host only.

#include <array>
#include <string>
#include <vector>

#include "mrd/structure/study.hpp"

namespace mrd::structure {

// The peak-response columns, in the study table's order: x1..x3, d1..d3 [cm], xa1..xa3
// [cm/s^2], f [N].
inline constexpr std::size_t kReferenceColumns = 10;
extern const std::array<const char*, kReferenceColumns> kReferenceColumnNames;

struct ReferenceRow {
  Case which = Case::kUncontrolled;
  std::array<double, kReferenceColumns> value{};  // published peak; valid where given
  std::array<bool, kReferenceColumns> given{};    // false: the cell was left empty
};

struct Reference {
  std::string path;
  std::string source;  // the file's first '#' comment line, without '#' (may be empty)
  std::vector<ReferenceRow> rows;
};

// Reads a CSV: '#' comment lines, the header `case,x1,x2,x3,d1,d2,d3,xa1,xa2,xa3,f`, then one
// row per case (uncontrolled, passive-off, passive-on, clipped-optimal; each at most once).
// A cell is a number >= 0 or empty (not published). false with *error = "FILE:LINE: reason".
bool LoadReference(const std::string& path, Reference* out, std::string* error);

struct ReferenceCheck {
  std::string table;        // Markdown: per case, measured, reference and difference per cell
  int cells = 0;            // reference cells compared
  int outside = 0;          // of them, differing by more than the tolerance
  int changes = 0;          // clipped-optimal vs passive cells the reference gives both of
  int changes_matched = 0;  // of them, changing the same way (see CompareWithReference)
};

// Compares the measured peaks with the reference: difference = 100 (measured - ref) / ref [%],
// outside when |difference| > tolerance_percent (a zero reference cell: outside unless the
// measured one is zero too). A change of clipped-optimal against passive-off and against
// passive-on, c = (co - passive) / passive, matches the reference's when both have the same
// sign or both are within +-5 %.
ReferenceCheck CompareWithReference(const std::vector<Response>& measured,
                                    const Reference& reference, double tolerance_percent);

}  // namespace mrd::structure
