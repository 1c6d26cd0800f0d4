// gnuplot.hpp: posix_spawn of the program FindProgram finds, waited for.
#include "mrd/common/gnuplot.hpp"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <iterator>

#include "mrd/common/find_program.hpp"

extern char** environ;

namespace mrd::common {

int RunGnuplot(const std::string& script, const std::string& log, std::string* error) {
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, log.c_str(),
                                   O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, "/dev/null", O_WRONLY, 0);
  std::string prog = FindProgram("gnuplot");
  char* argv[] = {prog.data(), const_cast<char*>(script.c_str()), nullptr};
  pid_t pid = 0;
  const int rc =
      prog.empty() ? ENOENT : posix_spawn(&pid, prog.c_str(), &actions, nullptr, argv, environ);
  posix_spawn_file_actions_destroy(&actions);
  if (rc != 0) {
    // ENOENT: not on PATH; otherwise the system's reason (e.g. the log file cannot be opened).
    if (error != nullptr) {
      *error = rc == ENOENT
                   ? std::string("cannot run gnuplot (install the Debian package gnuplot-nox)")
                   : "cannot run gnuplot: " + std::string(std::strerror(rc)) + " (log " + log + ")";
    }
    return -1;
  }
  int status = 0;
  waitpid(pid, &status, 0);
  if (error != nullptr) {
    std::ifstream in(log);
    error->assign(std::istreambuf_iterator<char>(in), {});
  }
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

}  // namespace mrd::common
