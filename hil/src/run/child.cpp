#include "mrd/hil/run/child.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <thread>

extern char** environ;

namespace mrd::hil {

Child::~Child() {
  if (pid_ > 0 && !exited_) Kill();
}

bool Child::Spawn(const std::vector<std::string>& argv, const std::string& stdout_path,
                  const std::string& stderr_path, std::string* error) {
  // Everything the child needs is prepared here: between fork and exec only async-signal-safe
  // calls.
  std::vector<std::string> copy = argv;
  std::vector<char*> args;
  for (auto& a : copy) args.push_back(a.data());
  args.push_back(nullptr);
  int report[2];  // exec failure: errno through a close-on-exec pipe
  if (pipe2(report, O_CLOEXEC) != 0) {
    *error = std::string("cannot start ") + argv[0] + ": pipe: " + std::strerror(errno);
    return false;
  }
  const pid_t parent = getpid();
  const pid_t pid = fork();
  if (pid < 0) {
    const int e = errno;
    close(report[0]);
    close(report[1]);
    *error = "cannot start " + argv[0] + ": " + std::strerror(e);
    return false;
  }
  if (pid == 0) {
    close(report[0]);
    // Dies with the harness (SIGTERM: the firmware's clean stop); the parent may already be gone.
    if (prctl(PR_SET_PDEATHSIG, SIGTERM) != 0 || getppid() != parent) _exit(127);
    const int in = open("/dev/null", O_RDONLY);
    const int out = open(stdout_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int err = open(stderr_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (in < 0 || out < 0 || err < 0 || dup2(in, 0) < 0 || dup2(out, 1) < 0 || dup2(err, 2) < 0) {
      const int e = errno;
      (void)!write(report[1], &e, sizeof e);
      _exit(127);
    }
    sigset_t none;
    sigemptyset(&none);
    sigprocmask(SIG_SETMASK, &none, nullptr);
    execve(args[0], args.data(), environ);
    const int e = errno;
    (void)!write(report[1], &e, sizeof e);
    _exit(127);
  }
  close(report[1]);
  int child_errno = 0;
  ssize_t n;
  while ((n = read(report[0], &child_errno, sizeof child_errno)) < 0 && errno == EINTR) {
  }
  close(report[0]);
  if (n == static_cast<ssize_t>(sizeof child_errno)) {
    int st = 0;
    while (waitpid(pid, &st, 0) < 0 && errno == EINTR) {
    }
    *error = "cannot start " + argv[0] + ": " + std::strerror(child_errno);
    return false;
  }
  pid_ = pid;
  exited_ = false;
  status_ = -1;
  return true;
}

bool Child::Alive() {
  if (pid_ <= 0 || exited_) return false;
  int st = 0;
  const pid_t r = waitpid(pid_, &st, WNOHANG);
  if (r == pid_) {
    exited_ = true;
    status_ = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
    return false;
  }
  return true;
}

int Child::Wait(double timeout_s) {
  const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (Alive()) {
    if (std::chrono::steady_clock::now() > until) return -1;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  return pid_ > 0 ? status_ : -1;
}

int Child::Stop(double term_timeout_s, int sig) {
  if (!Alive()) return status_;
  kill(pid_, sig);
  const int st = Wait(term_timeout_s);
  if (st >= 0) return st;
  Kill();
  return status_;
}

void Child::Kill() {
  if (pid_ <= 0 || exited_) return;
  kill(pid_, SIGKILL);
  int st = 0;
  while (waitpid(pid_, &st, 0) < 0 && errno == EINTR) {
  }
  exited_ = true;
  status_ = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
}

}  // namespace mrd::hil
