#pragma once
// The control socket of a running mrd-firmware: a non-real-time thread serving a local UNIX
// stream socket (mode 0600) with a line protocol, one request per connection, and calling an
// idle function about every 50 ms (the SIGHUP reload watch). docs/tuning.md. Clients are
// served side by side (up to 64 connections; each has 2 s to send its line, a silent one holds
// only its own slot; when all are taken the oldest is dropped).
//
//   request (one line, at most 4 KiB):  list | get NAME | set NAME VALUE | save
//   reply:  list, get: a line per parameter  NAME \t VALUE \t TYPE \t UNIT \t ACCEPTS \t SET
//           set:       "ok period N version V value VALUE"
//           then always one final line:  "ok[ TEXT]" | "refused: REASON" | "error: REASON"
// "refused" changed nothing (bad input); "error" is any other failure.

#include <atomic>
#include <functional>
#include <string>
#include <thread>

#include "mrd/firmware/platform/runtime_params.hpp"

namespace mrd::firmware::platform {

class ParamsServer {
 public:
  // config_path: the file `save` writes ("" : none, save is refused).
  ParamsServer(RuntimeParams& params, std::string config_path);
  ~ParamsServer();
  ParamsServer(const ParamsServer&) = delete;
  ParamsServer& operator=(const ParamsServer&) = delete;

  // Binds the socket at path: refuses a path a live firmware serves and one that is not a
  // socket; replaces a stale socket file; creates a missing last folder (mode 0700).
  // "" or the reason. Start-up.
  std::string Open(const std::string& path);
  // Starts the thread (serving the socket when open).
  void Start(std::function<void()> idle);
  // Stops and joins the thread, closes and removes the socket.
  void Stop();
  // One request line -> its reply (for tests; the thread calls it).
  std::string Handle(const std::string& request);

 private:
  void Serve();

  RuntimeParams& params_;
  std::string config_path_;
  std::string path_;
  int fd_ = -1;
  std::function<void()> idle_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

// The client side: sends one request line to the socket at path and returns the reply in
// *reply. False with *error when no firmware answers there (exit 1 for mrd-firmware ctl).
bool CtlRequest(const std::string& path, const std::string& request, std::string* reply,
                std::string* error);

}  // namespace mrd::firmware::platform
