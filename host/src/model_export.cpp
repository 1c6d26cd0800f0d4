// ExportCheckedTable and its pieces (mrd/host/model_export.hpp).
#include "mrd/host/model_export.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <array>
#include <string>
#include <vector>

#include "mrd/host/input_error.hpp"
#include "mrd/host/table_export.hpp"

namespace mrd::host {

bool SetTableEnvelope(const ModelFile& m, CoefficientTable* table) {
  const Model& model = table->model;
  std::array<ChannelRange, kMaxChannels> env{};
  for (std::size_t c = 0; c < model.num_channels; ++c) {
    const auto ch = std::find_if(m.channels.begin(), m.channels.end(), [&](const ChannelInfo& ci) {
      return ci.name == model.channel_names[c].data();
    });
    if (ch == m.channels.end() || !ch->has_range) return false;
    env[c] = {ch->min, ch->max};
  }
  table->envelope = env;
  table->has_envelope = true;
  return true;
}

mrd::Model CheckExportInput(const ModelFile& m, int k, const std::string& input) {
  mrd::Model model = ToRuntimeModel(m, k);
  // The inverted input must be a signal of the model that iteration k's terms read.
  const std::vector<std::string> signals = m.spec.Signals();
  if (input == m.spec.output || std::find(signals.begin(), signals.end(), input) == signals.end()) {
    throw InputError(m.path, 0,
                     fmt::format("--input '{}' is not an input signal of the model (it has: {})",
                                 input, fmt::join(signals.begin() + 1, signals.end(), ",")));
  }
  if (model.ChannelIndex(input.c_str()) < 0) {
    throw InputError(m.path, 0,
                     fmt::format("iteration {} ({} terms) does not read input '{}': nothing to "
                                 "invert; export an iteration whose terms read it",
                                 k, m.Iteration(k).terms.size(), input));
  }
  return model;
}

ExportedTable ExportCheckedTable(const ModelFile& m, const ExportRequest& request) {
  const std::string& input = request.input;
  const mrd::Model model = CheckExportInput(m, request.iteration, input);  // named before the range
  ExportedTable out;
  out.range = ChooseCommandRange(m, input, request.e_min, request.e_max, request.profile);
  out.table = MakeUncheckedTable(model, out.range.e_min, out.range.e_max, input, m.path);
  // Operating envelope (table v2); model files from before it was recorded export without.
  out.envelope = SetTableEnvelope(m, &out.table);
  // Validated once, with its envelope.
  if (std::string p = DescribeTableProblem(out.table); !p.empty()) throw InputError(m.path, 0, p);
  out.invertibility = ExportInvertibility(m, input, out.table);
  RecordTableInvertibility(out.invertibility, &out.table);
  return out;
}

}  // namespace mrd::host
