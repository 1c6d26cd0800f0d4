#pragma once
// Export of an identified model as a coefficient table (docs/table_format.md): the binary
// image for loading/flashing and a generated C++ header with a constexpr table for compiling
// into the firmware. Both decode to the same table (tests/host/table_export_test.cpp).

#include <cstddef>
#include <string>
#include <string_view>

#include "mrd/common/table.hpp"

namespace mrd::host {

// Shape of a model before it is squeezed into the fixed-size mrd::Model (e.g. from a model
// file), so that a model too big for the table is refused with a reason, never truncated.
struct ModelShape {
  std::size_t channels = 0;
  std::size_t regressors = 0;
  std::size_t terms = 0;
  std::size_t max_factors = 0;  // most factors in one term
  std::size_t max_delay = 0;    // [samples]
  std::size_t max_power = 0;
};

// "" when the shape fits table format version 1; otherwise the first reason, e.g.
// "model has 70 terms; table format v1 holds at most 64".
std::string TableFitProblem(const ModelShape& shape);

// "" when the table encodes; otherwise the first problem in words (capacity, index, value).
std::string DescribeTableProblem(const CoefficientTable& table);

// Builds a table from a model: input channel by name (normally "E") and its admissible range
// [e_min, e_max] [V]. Throws InputError(source, 0, reason) when the channel is missing, the
// range is empty or the model does not fit / validate.
CoefficientTable MakeTable(const Model& model, double e_min, double e_max,
                           std::string_view input_channel = "E", const std::string& source = "");

// MakeTable without the validation, for a caller that completes the table (SetTableEnvelope)
// and then validates it once (DescribeTableProblem). Throws InputError(source, 0, reason) when
// the model has no such input channel.
CoefficientTable MakeUncheckedTable(const Model& model, double e_min, double e_max,
                                    std::string_view input_channel, const std::string& source);

// The binary image; throws InputError("", 0, reason) for a table that does not encode.
TableBytes TableImage(const CoefficientTable& table);

// C++ header text defining `inline constexpr mrd::CoefficientTable <name>` where symbol is
// "name" or "ns::...::name" (namespaces emitted around it). Doubles are written in their
// shortest round-trip form, so the header encodes to the same bytes as TableImage().
// Throws std::invalid_argument for a symbol that is not a (qualified) C++ identifier and
// InputError for a table that does not encode.
std::string TableHeader(const CoefficientTable& table, std::string_view symbol);
// The same text from the table's image already encoded (image == TableImage(table)).
std::string TableHeader(const CoefficientTable& table, std::string_view symbol,
                        const TableBytes& image);

}  // namespace mrd::host
