#include "mrd/firmware/platform/params_server.hpp"

#include <fcntl.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <vector>

#include "mrd/common/input_file.hpp"
#include "mrd/firmware/platform/config_save.hpp"

namespace mrd::firmware::platform {
namespace {

constexpr std::size_t kMaxRequest = 4096;           // [bytes]
constexpr std::size_t kMaxClients = 64;             // connections served at once
constexpr std::chrono::seconds kClientDeadline{2};  // to send a request line

std::string Errno(const std::string& what) { return what + ": " + std::strerror(errno); }

bool Address(const std::string& path, sockaddr_un* addr, std::string* error) {
  *addr = sockaddr_un{};
  addr->sun_family = AF_UNIX;
  if (path.empty() || path.size() >= sizeof addr->sun_path) {
    *error = "control socket path '" + Printable(path) + "' must be 1 to " +
             std::to_string(sizeof addr->sun_path - 1) + " bytes";
    return false;
  }
  std::memcpy(addr->sun_path, path.c_str(), path.size() + 1);
  return true;
}

// A connected socket to path, or -1 with errno.
int Connect(const std::string& path, int timeout_s) {
  sockaddr_un addr{};
  std::string ignored;
  if (!Address(path, &addr, &ignored)) {
    errno = ENAMETOOLONG;
    return -1;
  }
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return -1;
  const timeval tv{timeout_s, 0};
  ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  ::setsockopt(fd, SOL_SOCKET, SO_SNDTIMEO, &tv, sizeof tv);
  if (::connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0) {
    const int saved = errno;
    ::close(fd);
    errno = saved;
    return -1;
  }
  return fd;
}

bool SendAll(int fd, const std::string& text) {
  for (std::size_t done = 0; done < text.size();) {
    const ssize_t n = ::send(fd, text.data() + done, text.size() - done, MSG_NOSIGNAL);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    done += static_cast<std::size_t>(n);
  }
  return true;
}

std::string Row(const ParamInfo& p) {
  return p.name + "\t" + p.value + "\t" + p.type + "\t" + p.unit + "\t" + p.accepts + "\t" +
         TunableName(p.tunable) + "\n";
}

}  // namespace

ParamsServer::ParamsServer(RuntimeParams& params, std::string config_path)
    : params_(params), config_path_(std::move(config_path)) {}

ParamsServer::~ParamsServer() { Stop(); }

std::string ParamsServer::Open(const std::string& path) {
  sockaddr_un addr{};
  std::string error;
  if (!Address(path, &addr, &error)) return error;
  const std::string shown = Printable(path);
  struct stat st {};
  if (::lstat(path.c_str(), &st) == 0) {
    if (!S_ISSOCK(st.st_mode)) {
      return "control socket " + shown +
             " exists and is not a socket: refused (remove it or "
             "give another path)";
    }
    const int probe = Connect(path, 2);
    if (probe >= 0) {
      ::close(probe);
      return "control socket " + shown +
             " is in use by a running firmware (mrd-firmware ctl "
             "--socket " +
             shown + " list talks to it): refused; stop it or give another path";
    }
    if (errno != ECONNREFUSED) return Errno("control socket " + shown + ": cannot check it");
    if (::unlink(path.c_str()) != 0) {  // stale: its firmware is gone
      return Errno("control socket " + shown + ": cannot replace the stale socket file");
    }
  }
  const auto slash = path.rfind('/');
  if (slash != std::string::npos && slash > 0) {
    const std::string folder = path.substr(0, slash);
    if (::mkdir(folder.c_str(), 0700) != 0 && errno != EEXIST) {
      return Errno("control socket " + shown + ": cannot create its folder " + Printable(folder));
    }
  }
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return Errno("control socket " + shown);
  const mode_t mask = ::umask(0177);  // the socket file is created 0600
  const int bound = ::bind(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr);
  const int bind_errno = errno;
  ::umask(mask);
  if (bound != 0) {
    ::close(fd);
    errno = bind_errno;
    return Errno("control socket " + shown + ": cannot create it");
  }
  if (::chmod(path.c_str(), 0600) != 0 || ::listen(fd, 64) != 0) {
    const std::string why = Errno("control socket " + shown);
    ::close(fd);
    ::unlink(path.c_str());
    return why;
  }
  fd_ = fd;
  path_ = path;
  return "";
}

void ParamsServer::Start(std::function<void()> idle) {
  idle_ = std::move(idle);
  stop_.store(false);
  thread_ = std::thread([this] { Serve(); });
}

void ParamsServer::Stop() {
  stop_.store(true);
  if (thread_.joinable()) thread_.join();
  if (fd_ >= 0) {
    ::close(fd_);
    fd_ = -1;
    ::unlink(path_.c_str());
  }
}

void ParamsServer::Serve() {
  // Every client at once (non-blocking, one poll over all): a silent one holds only its own
  // slot until its deadline, never the others. Full: the oldest connection is dropped.
  struct Client {
    int fd = -1;
    std::string line;
    std::chrono::steady_clock::time_point deadline;
  };
  std::vector<Client> clients;
  const auto finish = [&](std::size_t i, bool answer) {
    Client& c = clients[i];
    if (answer) {
      const auto nl = c.line.find('\n');
      if (nl != std::string::npos) c.line.resize(nl);
      const int flags = ::fcntl(c.fd, F_GETFL);
      ::fcntl(c.fd, F_SETFL, flags & ~O_NONBLOCK);  // the reply: bounded by SO_SNDTIMEO
      (void)SendAll(c.fd, Handle(c.line));
    }
    ::close(c.fd);
    clients.erase(clients.begin() + static_cast<std::ptrdiff_t>(i));
  };
  while (!stop_.load()) {
    if (fd_ < 0) {
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
      if (idle_) idle_();
      continue;
    }
    std::vector<pollfd> fds;
    fds.push_back({fd_, POLLIN, 0});
    for (const Client& c : clients) fds.push_back({c.fd, POLLIN, 0});
    const int ready = ::poll(fds.data(), fds.size(), 50);
    const auto now = std::chrono::steady_clock::now();
    // Clients first (their indices match fds[1..]), from the back so erasing keeps them valid.
    for (std::size_t i = clients.size(); ready > 0 && i-- > 0;) {
      if ((fds[i + 1].revents & (POLLIN | POLLHUP | POLLERR)) == 0) continue;
      char buf[512];
      const ssize_t n = ::recv(clients[i].fd, buf, sizeof buf, 0);
      if (n < 0 && (errno == EINTR || errno == EAGAIN)) continue;
      if (n <= 0) {
        finish(i, n == 0 && !clients[i].line.empty());  // EOF: answer what came
        continue;
      }
      clients[i].line.append(buf, static_cast<std::size_t>(n));
      if (clients[i].line.find('\n') != std::string::npos || clients[i].line.size() > kMaxRequest) {
        finish(i, true);  // too long: Handle refuses it
      }
    }
    for (std::size_t i = clients.size(); i-- > 0;) {
      if (now > clients[i].deadline) finish(i, false);  // silent: dropped
    }
    if (ready > 0 && (fds[0].revents & POLLIN) != 0) {
      const int c = ::accept4(fd_, nullptr, nullptr, SOCK_CLOEXEC | SOCK_NONBLOCK);
      if (c >= 0) {
        if (clients.size() >= kMaxClients) finish(0, false);  // the oldest makes room
        const timeval tv{2, 0};
        ::setsockopt(c, SOL_SOCKET, SO_SNDTIMEO, &tv, sizeof tv);
        clients.push_back({c, std::string(), now + kClientDeadline});
      }
    }
    if (idle_) idle_();
  }
  for (std::size_t i = clients.size(); i-- > 0;) finish(i, false);
}

std::string ParamsServer::Handle(const std::string& request) {
  if (request.size() > kMaxRequest) return "refused: request longer than 4096 bytes\n";
  std::string line = request;
  while (!line.empty() && (line.back() == '\r' || line.back() == ' ')) line.pop_back();
  const auto sp = line.find(' ');
  const std::string cmd = line.substr(0, sp);
  std::string rest = sp == std::string::npos ? "" : line.substr(sp + 1);
  while (!rest.empty() && rest.front() == ' ') rest.erase(0, 1);
  if (cmd == "list" && rest.empty()) {
    std::string out;
    for (const ParamInfo& p : params_.List()) out += Row(p);
    return out + "ok\n";
  }
  if (cmd == "get" && !rest.empty() && rest.find(' ') == std::string::npos) {
    for (const ParamInfo& p : params_.List()) {
      if (p.name == rest) return Row(p) + "ok\n";
    }
    return "refused: unknown parameter '" + Printable(rest) +
           "' (mrd-firmware ctl list names them)\n";
  }
  if (cmd == "set") {
    const auto sp2 = rest.find(' ');
    if (sp2 == std::string::npos || rest.find_first_not_of(' ', sp2) == std::string::npos) {
      return "refused: usage: set NAME VALUE\n";
    }
    const std::string name = rest.substr(0, sp2);
    const std::string value = rest.substr(rest.find_first_not_of(' ', sp2));
    const RuntimeParams::Result r = params_.Set(name, value);
    if (r.status == RuntimeParams::Status::kRefused)
      return "refused: " + Printable(r.message) + "\n";
    if (r.status == RuntimeParams::Status::kFailed) return "error: " + Printable(r.message) + "\n";
    std::string now;
    for (const ParamInfo& p : params_.List()) {
      if (p.name == name) now = p.value;
    }
    return "ok period " + std::to_string(r.period) + " version " + std::to_string(r.version) +
           " value " + now + "\n";
  }
  if (cmd == "save" && rest.empty()) {
    if (config_path_.empty()) {
      return "refused: the firmware was started without --config: no file to save to\n";
    }
    const std::string why = SaveConfigFile(config_path_, params_.config());
    if (!why.empty()) return "error: " + Printable(why) + "\n";
    return "ok saved " + Printable(config_path_) + "\n";
  }
  return "refused: bad request '" + Printable(line) +
         "' (list | get NAME | set NAME VALUE | save)\n";
}

bool CtlRequest(const std::string& path, const std::string& request, std::string* reply,
                std::string* error) {
  const int fd = Connect(path, 30);
  if (fd < 0) {
    *error = Errno("no firmware at " + Printable(path));
    return false;
  }
  if (!SendAll(fd, request + "\n")) {
    *error = Errno("cannot send to " + Printable(path));
    ::close(fd);
    return false;
  }
  reply->clear();
  char buf[4096];
  for (;;) {
    const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) {
      *error = Errno("no reply from " + Printable(path));
      ::close(fd);
      return false;
    }
    if (n == 0) break;
    reply->append(buf, static_cast<std::size_t>(n));
  }
  ::close(fd);
  if (reply->empty()) {
    *error = "no reply from " + Printable(path) + " (the firmware closed the connection)";
    return false;
  }
  return true;
}

}  // namespace mrd::firmware::platform
