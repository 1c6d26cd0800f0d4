#pragma once
// Readable time plots of long records: a window of a few seconds drawn sample by sample, plus
// an overview of the whole record as a min/max envelope (what a plot of 20 000 samples in
// 1000 pixels shows anyway, without the solid band), and whether a signal is periodic enough
// for a force-displacement loop to be read. Host and harness side (allocates).

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

namespace mrd {

inline constexpr double kDefaultWindowS = 5.0;  // default window: the first 5 s

struct TimeWindow {
  double from_s = 0.0, to_s = 0.0;  // [s], from < to
};

// "A:B" in seconds (finite, A < B). false with *why ("'A:B' ... reason") otherwise.
bool ParseTimeWindow(std::string_view text, TimeWindow* window, std::string* why);

// The window a plot draws: `asked` clipped to the record's [t.front(), t.back()] when given,
// else the first kDefaultWindowS of the record (all of it when shorter). A window outside the
// record gives the first kDefaultWindowS and *note says so (else *note is "").
TimeWindow PlotWindow(const std::vector<double>& t, const TimeWindow* asked, std::string* note);

// Samples [first, last) of a sorted t inside the window.
struct SampleRange {
  std::size_t first = 0, last = 0;
};
SampleRange SamplesIn(const std::vector<double>& t, const TimeWindow& w);

// A copy of v[r.first, r.last).
std::vector<double> Slice(const std::vector<double>& v, const SampleRange& r);

// The overview: per bucket of consecutive samples (at most `buckets` buckets), the bucket's
// minimum and maximum at its mean time, in time order (min, then max): a line through them
// draws the record's envelope. Non-finite samples are skipped (a bucket of them: a gap, NaN).
void Envelope(const std::vector<double>& t, const std::vector<double>& y, std::size_t buckets,
              std::vector<double>* t_out, std::vector<double>* y_out);

// True when x repeats itself: after the autocorrelation of x (mean removed, at most 4000
// samples after decimation) first falls below zero, it comes back above 0.9 at a later lag
// within the first half of the record. Sine and other periodic excitations pass; random road
// or band-limited noise records do not (their force-displacement plot is a cloud).
bool LooksPeriodic(const std::vector<double>& x);

}  // namespace mrd
