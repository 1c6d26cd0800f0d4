#pragma once
// Runs gnuplot on a script file: the program found on PATH by FindProgram (find_program.hpp:
// not posix_spawnp), its stdout to /dev/null, its stderr to a log file (created or
// truncated). Used by the host's plots (mrd report, judge) and the harness's (mrd-hil).

#include <string>

namespace mrd::common {

// gnuplot's exit status (0: the script ran), or -1 when it could not be started (not on PATH,
// the log cannot be opened, ...) or died on a signal. *error (may be null): when it could not
// start, "cannot run gnuplot (install the Debian package gnuplot-nox)" (not on PATH) or
// "cannot run gnuplot: REASON (log LOG)"; when it ran, the log's text (its messages).
int RunGnuplot(const std::string& script, const std::string& log, std::string* error);

}  // namespace mrd::common
