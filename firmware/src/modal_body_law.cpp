#include "mrd/firmware/modal_body_law.hpp"

namespace mrd::firmware {

void ModalBodyLaw::Apply(SensorFrame* const* frames, std::size_t n, std::int64_t now_ns) {
  (void)now_ns;  // the demands carry their inputs' time, not the period's
  if (n != static_cast<std::size_t>(kModalCorners)) return;
  double body[kModalCorners];
  double demand[kModalCorners];
  std::int64_t oldest = (*frames[0])[Input::kBodyVelocity].stamp_ns;
  for (int i = 0; i < kModalCorners; ++i) {
    const Stamped& vb = (*frames[i])[Input::kBodyVelocity];
    body[i] = vb.value;
    if (vb.stamp_ns < oldest) oldest = vb.stamp_ns;
  }
  law_.Demands(body, demand);
  for (int i = 0; i < kModalCorners; ++i) (*frames[i])[Input::kDemand] = Stamped{demand[i], oldest};
}

}  // namespace mrd::firmware
