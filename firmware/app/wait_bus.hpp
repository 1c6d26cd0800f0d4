#pragma once
// `mrd-firmware --wait-for-bus FILE.toml [--timeout SECONDS]`: the systemd unit's bounded wait
// (ExecStartPre) for the SocketCAN interface the config names, which a board may bring up late
// (a USB adapter, a driver loaded after network.target). No control loop.

namespace mrd::firmware {

// Waits until the config's [can] interface exists and is up (checked every 0.2 s), at most
// the timeout (default 30 s, at most 3600). Exit status: 0 up, or nothing to wait for (no [can]
// interface: a local bus, Modbus or GPIO only); 1 not up in time (the interface named on
// stderr; the unit retries later); 2 bad arguments or a config that does not load.
int RunWaitForBus(int argc, char** argv);

}  // namespace mrd::firmware
