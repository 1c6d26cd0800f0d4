#pragma once
// Quadrature encoder: two lines A and B, 90 degrees apart, 4 counts per line cycle.
//
//   count mod 4:  0    1    2    3        phase of (A, B)
//   (A, B):      00   10   11   01        A leads B when the count rises
//
// The GPIO wire format shared by the firmware (decoder) and the HIL harness (generator). Pure:
// no I/O, no allocation, real-time safe.
//
// Glitches: a change of both lines in one event (00 -> 11: two counts, direction unknown) or
// an edge that contradicts the line's known level (a rising edge on a line already high: an
// edge pair was lost) is rejected: the count does not move, the decoder takes the new levels
// and counts a glitch. The count never wraps: a step past the int64 range is refused
// (kOverflow) and the count holds.

#include <cstddef>
#include <cstdint>

namespace mrd::protocol {

// Levels of (A, B) for a count (the table above; negative counts continue it).
struct QuadratureLevels {
  bool a = false;
  bool b = false;
};
QuadratureLevels LevelsForCount(std::int64_t count);

enum class QuadratureStep : std::uint8_t {
  kNone = 0,  // levels unchanged
  kForward,   // count + 1
  kBackward,  // count - 1
  kGlitch,    // both lines changed, or an edge that contradicts the level: rejected
  kOverflow,  // the step would leave the int64 range: refused
};

// One edge on one line with its (kernel) timestamp [ns].
struct QuadratureEdge {
  std::int64_t t_ns = 0;
  bool rising = false;
};

// What a batch of edges did.
struct QuadratureBatch {
  std::uint32_t steps = 0;      // counts moved (either direction)
  std::uint32_t glitches = 0;   // rejected edges / simultaneous changes
  std::uint32_t overflows = 0;  // refused steps
  std::int64_t last_t_ns = 0;   // timestamp of the latest edge applied (0: none)
};

class QuadratureDecoder {
 public:
  // Starts at `count` with the current levels (a, b).
  void Reset(bool a, bool b, std::int64_t count = 0);
  // New levels after an event (either or both lines may have changed).
  QuadratureStep Update(bool a, bool b);
  // One edge on line A (line_b false) or B.
  QuadratureStep OnEdge(bool line_b, bool rising);
  // Merges the pending edges of A and B (each oldest first) by timestamp; edges of A and B
  // with the same timestamp are one event (both changed: a glitch unless one of them
  // contradicts its level, which is a glitch as well).
  QuadratureBatch Feed(const QuadratureEdge* a, std::size_t num_a, const QuadratureEdge* b,
                       std::size_t num_b);

  std::int64_t count() const { return count_; }
  bool a() const { return a_; }
  bool b() const { return b_; }
  std::uint64_t glitches() const { return glitches_; }

 private:
  QuadratureStep Count(QuadratureStep step);

  std::int64_t count_ = 0;
  bool a_ = false;
  bool b_ = false;
  std::uint64_t glitches_ = 0;
};

}  // namespace mrd::protocol
