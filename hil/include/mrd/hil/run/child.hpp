#pragma once
// The firmware under test as a child process of the harness: spawned with its output in files,
// polled for exit, stopped cleanly (SIGTERM, then SIGKILL after a timeout) or killed. A child
// gets SIGTERM when the harness dies (PR_SET_PDEATHSIG), so it never outlives its run.

#include <sys/types.h>

#include <csignal>
#include <string>
#include <vector>

namespace mrd::hil {

class Child {
 public:
  Child() = default;
  ~Child();
  Child(const Child&) = delete;
  Child& operator=(const Child&) = delete;

  // argv[0] is the executable; stdout and stderr go to the given files. false: *error.
  bool Spawn(const std::vector<std::string>& argv, const std::string& stdout_path,
             const std::string& stderr_path, std::string* error);
  // True while the process runs (reaps it when it has exited).
  bool Alive();
  // Waits up to timeout_s for the exit; the exit status (128 + signal), or -1 on timeout.
  int Wait(double timeout_s);
  // sig (SIGTERM by default), then SIGKILL after term_timeout_s; the exit status (128 +
  // signal when killed).
  int Stop(double term_timeout_s, int sig = SIGTERM);
  void Kill();  // SIGKILL, reaped
  pid_t pid() const { return pid_; }
  int status() const { return status_; }
  bool started() const { return pid_ > 0; }

 private:
  pid_t pid_ = -1;
  bool exited_ = false;
  int status_ = -1;
};

}  // namespace mrd::hil
