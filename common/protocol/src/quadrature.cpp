#include "mrd/protocol/quadrature.hpp"

#include <limits>

namespace mrd::protocol {
namespace {

// Phase 0..3 of (A, B) along the table in the header.
int Phase(bool a, bool b) {
  if (!a && !b) return 0;
  if (a && !b) return 1;
  if (a && b) return 2;
  return 3;
}

}  // namespace

QuadratureLevels LevelsForCount(std::int64_t count) {
  const auto phase = static_cast<int>(((count % 4) + 4) % 4);
  constexpr QuadratureLevels kTable[4] = {
      {false, false}, {true, false}, {true, true}, {false, true}};
  return kTable[phase];
}

void QuadratureDecoder::Reset(bool a, bool b, std::int64_t count) {
  count_ = count;
  a_ = a;
  b_ = b;
  glitches_ = 0;
}

QuadratureStep QuadratureDecoder::Count(QuadratureStep step) {
  if (step == QuadratureStep::kForward) {
    if (count_ == std::numeric_limits<std::int64_t>::max()) return QuadratureStep::kOverflow;
    ++count_;
  } else if (step == QuadratureStep::kBackward) {
    if (count_ == std::numeric_limits<std::int64_t>::min()) return QuadratureStep::kOverflow;
    --count_;
  }
  return step;
}

QuadratureStep QuadratureDecoder::Update(bool a, bool b) {
  const int diff = (Phase(a, b) - Phase(a_, b_) + 4) % 4;
  a_ = a;
  b_ = b;
  switch (diff) {
    case 0:
      return QuadratureStep::kNone;
    case 1:
      return Count(QuadratureStep::kForward);
    case 3:
      return Count(QuadratureStep::kBackward);
    default:
      ++glitches_;
      return QuadratureStep::kGlitch;
  }
}

QuadratureStep QuadratureDecoder::OnEdge(bool line_b, bool rising) {
  const bool level = line_b ? b_ : a_;
  if (level == rising) {  // already at the level the edge goes to: an edge pair was lost
    ++glitches_;
    return QuadratureStep::kGlitch;
  }
  return line_b ? Update(a_, rising) : Update(rising, b_);
}

QuadratureBatch QuadratureDecoder::Feed(const QuadratureEdge* a, std::size_t num_a,
                                        const QuadratureEdge* b, std::size_t num_b) {
  QuadratureBatch r;
  std::size_t i = 0, j = 0;
  auto tally = [&r](QuadratureStep s) {
    if (s == QuadratureStep::kForward || s == QuadratureStep::kBackward) ++r.steps;
    if (s == QuadratureStep::kGlitch) ++r.glitches;
    if (s == QuadratureStep::kOverflow) ++r.overflows;
  };
  while (i < num_a || j < num_b) {
    if (i < num_a && j < num_b && a[i].t_ns == b[j].t_ns) {
      // One event changing both lines.
      if (a[i].rising == a_ || b[j].rising == b_) {
        ++glitches_;
        tally(QuadratureStep::kGlitch);
        a_ = a[i].rising;
        b_ = b[j].rising;
      } else {
        tally(Update(a[i].rising, b[j].rising));
      }
      r.last_t_ns = a[i].t_ns;
      ++i;
      ++j;
    } else if (j >= num_b || (i < num_a && a[i].t_ns < b[j].t_ns)) {
      const QuadratureStep s = OnEdge(false, a[i].rising);
      if (s == QuadratureStep::kGlitch) a_ = a[i].rising;
      tally(s);
      r.last_t_ns = a[i].t_ns;
      ++i;
    } else {
      const QuadratureStep s = OnEdge(true, b[j].rising);
      if (s == QuadratureStep::kGlitch) b_ = b[j].rising;
      tally(s);
      r.last_t_ns = b[j].t_ns;
      ++j;
    }
  }
  return r;
}

}  // namespace mrd::protocol
