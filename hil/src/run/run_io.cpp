// The scenario run's waits, sensor publications and firmware child (run_session.hpp): used by
// every phase.
#include <csignal>

#include "run_session.hpp"

namespace mrd::hil {

// Waits up to timeout_ns for the firmware: on CAN by relaying the bus meanwhile (returns when
// something moved: true), else on the port (false: not known).
bool ScenarioRun::Pump(std::int64_t timeout_ns) {
  if (relay_bus_) return relay_.Step(static_cast<int>((timeout_ns + 999'999) / 1'000'000));
  if (timeout_ns > 0) port_->Wait(timeout_ns);
  return false;
}

void ScenarioRun::PumpFor(std::int64_t ns) {
  const std::int64_t until = common::MonotonicNs() + ns;
  for (std::int64_t now = common::MonotonicNs(); now < until; now = common::MonotonicNs())
    Pump(until - now);
}

// A sensor frame out, stamped and remembered by sequence number (the latency of the command
// that echoes it).
void ScenarioRun::Publish(SensorOutput out) {
  const std::int64_t t = common::MonotonicNs();
  out.t_ns = t;
  published_seq_[out.seq % kRing] = out.seq;
  published_ns_[out.seq % kRing] = t;
  port_->Publish(out);
}

// Starts the next firmware instance (its output under Tag(n)); nothing with --attach.
bool ScenarioRun::Spawn(std::string* e) {
  if (o_.attach) return true;
  const std::string tag = Tag(r_->firmware_starts);
  if (!fw_.Spawn(FirmwareArgv(o_, r_->config_path, o_.table, fw_duration_),
                 o_.work_dir + "/firmware" + tag + ".json",
                 o_.work_dir + "/firmware" + tag + ".err", e)) {
    return false;
  }
  if (r_->firmware_starts > 0) port_->PeerRestarted();
  ++r_->firmware_starts;
  return true;
}

int ScenarioRun::Interrupted() const {
  return o_.interrupt != nullptr ? o_.interrupt->load(std::memory_order_relaxed) : 0;
}

// Ends the run early (error or signal): the firmware child stopped and reaped (the signal
// forwarded), the ports closed; returns 1.
int ScenarioRun::EndRun(const std::string& why, int sig) {
  *error_ = why;
  r_->interrupted = sig;
  if (!o_.attach) {
    r_->firmware_exit = fw_.Stop(2.0, sig != 0 ? sig : SIGTERM);
    ReadFile(o_.work_dir + "/firmware" + Tag(r_->firmware_starts - 1) + ".err",
             &r_->firmware_stderr);
  }
  if (port_open_) port_->Close();
  gpio_.Close();
  return 1;
}

}  // namespace mrd::hil
