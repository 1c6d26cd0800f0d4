#pragma once
// Modal skyhook as the loop's body law (loop.hpp BodyLaw) over four channels in the corner order
// of modal_skyhook.hpp (front-left, front-right, rear-left, rear-right): each period it reads the
// four channels' body velocities and sets each channel's force demand (Input::kDemand), which
// the channel's Controller, on kForceTracking, clamps and inverts.
//
// Each demand is stamped with the oldest of the four body velocities' stamps: a stale corner
// sensor makes every corner's demand stale (each watchdog's stale_sensor cause), a never-sampled
// one leaves the demands unsampled, a non-finite one gives non-finite demands. With a channel
// count other than four it sets nothing (the configuration refuses that). Real-time safe.

#include <cstddef>
#include <cstdint>

#include "mrd/firmware/loop.hpp"
#include "mrd/firmware/modal_skyhook.hpp"

namespace mrd::firmware {

class ModalBodyLaw final : public BodyLaw {
 public:
  // law: configured; outlives this.
  explicit ModalBodyLaw(const ModalSkyhook& law) : law_(law) {}
  void Apply(SensorFrame* const* frames, std::size_t n, std::int64_t now_ns) override;

 private:
  const ModalSkyhook& law_;
};

}  // namespace mrd::firmware
