#pragma once
// Helpers for host tests: temporary files and running the CLI.

#include <sys/wait.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

namespace mrd::test {

// A fresh temporary directory, removed on destruction.
class TempDir {
 public:
  TempDir() {
    std::string tmpl = (std::filesystem::temp_directory_path() / "mrd-test-XXXXXX").string();
    path_ = mkdtemp(tmpl.data());
  }
  ~TempDir() { std::filesystem::remove_all(path_); }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;

  std::string File(const std::string& name) const { return (path_ / name).string(); }
  std::string Write(const std::string& name, const std::string& text) const {
    std::ofstream(File(name)) << text;
    return File(name);
  }

 private:
  std::filesystem::path path_;
};

// The whole content of a file ("" when it cannot be read).
inline std::string FileBytes(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

struct CommandResult {
  int status = -1;     // exit status
  std::string output;  // stdout and stderr
};

// Runs a shell command line, capturing stdout+stderr.
inline CommandResult Run(const std::string& command) {
  CommandResult r;
  FILE* p = popen((command + " 2>&1").c_str(), "r");
  if (p == nullptr) return r;
  char buf[4096];
  std::size_t n;
  while ((n = fread(buf, 1, sizeof buf, p)) > 0) r.output.append(buf, n);
  const int st = pclose(p);
  r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return r;
}

// Command line of an executable in build/bin (or in $MRD_TEST_BIN_DIR, e.g. to run the CLI
// tests against another build), behind the emulator in a cross build (MRD_TEST_EMULATOR, e.g.
// "qemu-arm -L /usr/arm-linux-gnueabihf").
inline std::string Bin(const std::string& name) {
  const char* dir = std::getenv("MRD_TEST_BIN_DIR");
  const std::string path =
      std::string(dir != nullptr && *dir != '\0' ? dir : MRD_BIN_DIR) + "/" + name;
#ifdef MRD_TEST_EMULATOR
  const std::string emulator = MRD_TEST_EMULATOR;
  if (!emulator.empty()) return emulator + " " + path;
#endif
  return path;
}

}  // namespace mrd::test
