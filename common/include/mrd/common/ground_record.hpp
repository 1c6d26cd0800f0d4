#pragma once
// A ground-acceleration record (El Centro 1940 NS: hil/data/el_centro_1940_ns.csv) read from
// a user's CSV. One reader for the harness's structure plant and the mrd-structure study.
// Start-up only.

#include <string>
#include <vector>

namespace mrd {

// Equally spaced ground-acceleration samples.
struct GroundRecord {
  std::string path;
  std::vector<double> ag_g;  // ground acceleration [g], |a| <= 10 g
  double dt_s = 0.02;        // spacing [s], > 0
};

// Reads a CSV of `t_s,ag_g` rows: '#' comment lines, one header line starting `t_s,ag_g`,
// CRLF line ends allowed, equally spaced increasing times, at least 2 samples, a regular file
// of at most 64 MiB. false: *error = "FILE:LINE: reason" (or "FILE: reason"), *record
// untouched.
bool LoadGroundRecord(const std::string& path, GroundRecord* record, std::string* error);

}  // namespace mrd
