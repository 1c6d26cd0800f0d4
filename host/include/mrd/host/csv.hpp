#pragma once
// Data files: CSV with a header row, one column per signal, uniform sampling in column `t`.

#include <span>
#include <string>
#include <vector>

#include "mrd/host/atomic_write.hpp"

namespace mrd::host {

struct DataSet {
  std::string path;                          // source file, for messages
  std::vector<std::string> names;            // column names, in file order
  std::vector<std::vector<double>> columns;  // columns[i] holds names[i]
  double dt = 0.0;                           // sampling interval [s] (from column t)

  std::size_t rows() const { return columns.empty() ? 0 : columns.front().size(); }
  bool Has(const std::string& name) const;
  // Column by name; throws InputError (naming the file) when absent.
  const std::vector<double>& Column(const std::string& name) const;
};

// Reads and validates a data file. Throws InputError (file, line, reason) on: unreadable
// file, empty file, missing required column, duplicate column, wrong field count,
// non-numeric or non-finite value, fewer than 2 rows, non-increasing or non-uniform `t`
// (relative tolerance 1e-3 of the first interval). Extra columns are kept.
// required: column names that must be present (besides `t`, always required).
DataSet ReadCsv(const std::string& path, std::span<const std::string> required = {});

// A data set from columns held in memory (e.g. the Python module's arrays), checked by
// ReadCsv's rules: unique non-empty names, `t` and the required columns present, columns of
// equal length, at least 2 rows, every value finite and within +-kMaxDataMagnitude, `t`
// increasing and uniform. Throws InputError(source, 0, reason) with ReadCsv's reasons, a row's
// prefixed "row R: " (R from 0).
DataSet MakeDataSet(const std::string& source, std::vector<std::string> names,
                    std::vector<std::vector<double>> columns,
                    std::span<const std::string> required = {});

// Writes columns as CSV with a header through WriteFileAtomic (atomic_write.hpp), so a
// failure leaves nothing behind. Throws InputError (output path, data line) on a non-finite
// value, std::runtime_error on I/O failure.
void WriteCsv(const std::string& path, const std::vector<std::string>& names,
              const std::vector<std::vector<double>>& columns);

}  // namespace mrd::host
