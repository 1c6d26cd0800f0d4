#pragma once
// Maintenance commands of mrd-firmware for install scripts and the systemd unit's
// ExecStartPre (no control loop): --check-config, --check-table, --install-table.

namespace mrd::firmware {

// Runs the maintenance command in argv[1] and returns the exit status (0 ok, 2 refused or bad
// arguments, reason on stderr), or -1 when argv[1] is not a maintenance command.
int RunMaintenance(int argc, char** argv);

}  // namespace mrd::firmware
