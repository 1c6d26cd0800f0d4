// The CAN device's CANopen (CiA 301) side (can_device.hpp, "CANopen"): NMT start and the
// start-up SDO downloads (Activate), the drive's heartbeat consumed (Read), the firmware's
// heartbeat and SYNC produced (Write), the re-configuration after a drive's boot-up.
#include <linux/can.h>
#include <poll.h>

#include <cstdio>
#include <ctime>

#include "mrd/canbus/socket.hpp"
#include "mrd/common/clock.hpp"
#include "mrd/firmware/io/can/can_device.hpp"
#include "mrd/profile/canopen_codec.hpp"

namespace mrd::firmware {
namespace {

namespace co = profile::canopen;

constexpr std::int64_t kLockstepSdoTimeoutNs = 2'000'000'000;  // the harness answers on wall time

can_frame Frame(std::uint32_t id, int len) {
  can_frame f{};
  f.can_id = id;
  f.len = static_cast<std::uint8_t>(len);
  return f;
}

std::uint32_t StandardId(const can_frame& f) {
  return (f.can_id & CAN_EFF_FLAG) != 0 ? 0xFFFFFFFFU : (f.can_id & CAN_SFF_MASK);
}

}  // namespace

void CanDevice::IndexCanopen() {
  if (!profile_->canopen) return;
  canopen_ = &*profile_->canopen;
  const int node = canopen_->node_id;
  for (const profile::SdoDownload& s : canopen_->sdo) {
    can_frame f = Frame(co::SdoRequestId(node), 8);
    (void)co::EncodeSdoDownload(s.index, s.subindex, s.size, s.value, f.data);
    sdo_frames_.push_back(f);
  }
  // SocketCAN: the drive's heartbeat (and boot-up) and its SDO answers.
  for (const std::uint32_t id : {co::HeartbeatId(node), co::SdoResponseId(node)}) {
    filters_.push_back({id, CAN_SFF_MASK | CAN_EFF_FLAG | CAN_RTR_FLAG});
  }
}

void CanDevice::SendNmtStart(std::int64_t now) {
  can_frame f = Frame(co::kNmtId, 2);
  f.data[0] = co::kNmtStart;
  f.data[1] = static_cast<std::uint8_t>(canopen_->node_id);
  (void)Send(f, now);
}

bool CanDevice::StartCanopen(std::string* error) {
  const std::int64_t timeout = config_.lockstep && canopen_->sdo_timeout_ns < kLockstepSdoTimeoutNs
                                   ? kLockstepSdoTimeoutNs
                                   : canopen_->sdo_timeout_ns;
  // The SDO list first, then NMT start (as after a re-boot): a refused or unanswered download
  // leaves the drive pre-operational, never operational and unconfigured.
  for (std::size_t i = 0; i < sdo_frames_.size(); ++i) {
    const profile::SdoDownload& s = canopen_->sdo[i];
    std::int64_t now = common::MonotonicNs();
    const std::int64_t until = now + timeout;
    if (!Send(sdo_frames_[i], now)) {
      *error = "can: cannot send SDO " + profile::DescribeSdo(s) + " to the drive (node " +
               std::to_string(canopen_->node_id) + ")";
      return false;
    }
    bool answered = false;
    char other[64] = "";  // the last SDO response that answered something else
    while (!answered) {
      now = common::MonotonicNs();
      iface_.Flush(now);
      can_frame f{};
      std::int64_t stamp = 0;
      const canbus::CanResult r = iface_.Receive(&f, &stamp);
      if (r == canbus::CanResult::kOk) {
        if (StandardId(f) == co::SdoResponseId(canopen_->node_id)) {
          std::uint32_t code = 0;
          const co::SdoReply reply = co::DecodeSdoReply(f.data, f.len, s.index, s.subindex, &code);
          if (reply == co::SdoReply::kAbort) {
            *error = "can: " + profile::SdoRefusalMessage(s, code);
            return false;
          }
          answered = reply == co::SdoReply::kAck;
          if (!answered) {
            std::snprintf(other, sizeof other, "a response (0x%02X) for 0x%04X:%02X", f.data[0],
                          static_cast<unsigned>(f.data[1] | f.data[2] << 8), f.data[3]);
          }
        } else {
          // Sensors, grants, the drive's heartbeat: taken as in the loop.
          (void)Handle(f, stamp, now);
        }
        continue;
      }
      if (r == canbus::CanResult::kDisconnected) {
        *error = "can: the bus went away during the CANopen start-up (SDO " +
                 profile::DescribeSdo(s) + ")";
        return false;
      }
      if (now >= until) {
        char id[8];
        std::snprintf(id, sizeof id, "%03X", co::SdoResponseId(canopen_->node_id));
        if (other[0] != '\0') {  // it answered, but not this download
          *error = "can: drive (node " + std::to_string(canopen_->node_id) + ") answered SDO " +
                   profile::DescribeSdo(s) + " with " + other +
                   ", not for the object downloaded (a wrong index or subindex, or a reply "
                   "that is no download confirmation), and no confirmation within " +
                   std::to_string(timeout / 1'000'000) + " ms";
          return false;
        }
        *error = "can: drive (node " + std::to_string(canopen_->node_id) + ") did not answer SDO " +
                 profile::DescribeSdo(s) + " within " + std::to_string(timeout / 1'000'000) +
                 " ms (no SDO response on 0x" + id + ")";
        return false;
      }
      const std::int64_t wait = until - now < 2'000'000 ? until - now : 2'000'000;
      const timespec ts{0, static_cast<long>(wait)};
      pollfd p{iface_.fd(), POLLIN, 0};
      (void)ppoll(&p, 1, &ts, nullptr);
    }
    ++sdo_downloads_;
  }
  if (canopen_->nmt_start) {
    const std::int64_t now = common::MonotonicNs();
    SendNmtStart(now);
    iface_.Flush(now);
  }
  return true;
}

bool CanDevice::HandleCanopen(const can_frame& f, std::int64_t wall_ns) {
  const std::uint32_t id = StandardId(f);
  const int node = canopen_->node_id;
  if (id == co::HeartbeatId(node)) {
    if (f.len < 1) {
      Reject(protocol::can::Reject::kWrongDlc);
      return true;
    }
    ++counters_.rx_ok;
    drive_heartbeat_ns_ = Now(wall_ns);
    // Lockstep: the heartbeat belongs to the step whose grant follows it (as sensor values).
    drive_heartbeat_unstamped_ = config_.lockstep;
    const auto state = static_cast<std::uint8_t>(f.data[0] & 0x7FU);
    drive_state_ = state;
    if (state == co::kStateBootUp && active_) {
      // The drive restarted: its object dictionary is back to defaults. The SDO list again,
      // then NMT start (the fault holds until it reports operational).
      ++drive_boot_ups_;
      reconfig_sdo_ = -1;
      reconfig_failed_ = false;
      ReconfigureNext(wall_ns);
    }
    return true;
  }
  if (id == co::SdoResponseId(node)) {
    if (reconfig_sdo_ >= 0) {
      const profile::SdoDownload& s = canopen_->sdo[static_cast<std::size_t>(reconfig_sdo_)];
      std::uint32_t code = 0;
      const co::SdoReply reply = co::DecodeSdoReply(f.data, f.len, s.index, s.subindex, &code);
      if (reply == co::SdoReply::kAck) {
        ++sdo_downloads_;
        ReconfigureNext(wall_ns);
      } else if (reply == co::SdoReply::kAbort) {
        reconfig_sdo_ = -1;  // refused: no NMT start; the fault holds until the next boot-up
        reconfig_failed_ = true;
        Count(IoError::kRejectedFrame);
      }
    }
    return true;  // a late answer otherwise: read over
  }
  return false;
}

void CanDevice::ReconfigureNext(std::int64_t now) {
  const int next = reconfig_sdo_ + 1;
  if (static_cast<std::size_t>(next) < sdo_frames_.size()) {
    reconfig_sdo_ = next;
    reconfig_sent_ns_ = Now(now);
    (void)Send(sdo_frames_[static_cast<std::size_t>(next)], now);
    return;
  }
  reconfig_sdo_ = -1;
  if (canopen_->nmt_start) SendNmtStart(now);
}

bool CanDevice::IsCanopenManagement(const can_frame& f) const {
  const std::uint32_t id = StandardId(f);
  return id == co::kNmtId || (id >= co::kSyncId && id <= 0x0FFU) ||           // SYNC, EMCY
         (id >= 0x581U && id <= 0x5FFU) || (id >= 0x601U && id <= 0x67FU) ||  // SDO
         (id >= 0x701U && id <= 0x77FU);                                      // heartbeat
}

bool CanDevice::DriveFault(std::int64_t wall_ns) {
  const std::int64_t now = Now(wall_ns);
  if (reconfig_sdo_ >= 0 && now - reconfig_sent_ns_ > canopen_->sdo_timeout_ns) {
    reconfig_sdo_ = -1;  // no answer: the fault holds until the next boot-up
    reconfig_failed_ = true;
    Count(IoError::kTimeout);
  }
  // Not configured (yet): whatever the drive says (one that starts itself included).
  if (reconfig_sdo_ >= 0 || reconfig_failed_) return true;
  if (drive_state_ != kDriveStateUnknown && drive_state_ != co::kStateOperational) return true;
  const std::int64_t timeout = canopen_->drive_heartbeat_timeout_ns;
  return timeout > 0 && now - drive_heartbeat_ns_ > timeout;
}

bool CanDevice::ProduceCanopen(std::int64_t now, std::int64_t t) {
  if (!config_.node_frames) return true;  // another channel's device speaks for the node
  bool ok = true;
  const std::int64_t hb = canopen_->heartbeat_ns;
  if (hb > 0 && t >= next_own_heartbeat_ns_) {
    next_own_heartbeat_ns_ += hb;
    if (next_own_heartbeat_ns_ <= t) next_own_heartbeat_ns_ = t + hb;
    can_frame f = Frame(co::HeartbeatId(canopen_->own_node_id), 1);
    f.data[0] = co::kStateOperational;
    ok = Send(f, now) && ok;
  }
  const std::int64_t sync = canopen_->sync_period_ns;
  if (sync > 0 && t >= next_sync_ns_) {
    next_sync_ns_ += sync;
    if (next_sync_ns_ <= t) next_sync_ns_ = t + sync;
    ok = Send(Frame(co::kSyncId, 0), now) && ok;
  }
  return ok;
}

}  // namespace mrd::firmware
