#include "mrd/sim_gpio/sim_chip.hpp"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <csignal>
#include <cstdint>
#include <cstring>
#include <ctime>
#include <mutex>

namespace mrd::sim_gpio {
namespace {

// Mapped chips of this process, for the SIGBUS handler: start address (0: free slot) and the
// damaged flag. Lock-free atomics only (read inside the handler).
constexpr std::size_t kMaxMapped = 32;
struct Mapped {
  std::atomic<std::uintptr_t> start{0};
  std::atomic<bool> damaged{false};
};
Mapped g_mapped[kMaxMapped];
std::atomic<std::size_t> g_map_bytes{0};  // sizeof(Layout) rounded up to whole pages
struct sigaction g_previous_sigbus {};
std::mutex g_mapped_mutex;  // Open and Close (slot allocation, handler installation)
bool g_handler_installed = false;

std::size_t MapBytes() {
  const auto page = static_cast<std::size_t>(sysconf(_SC_PAGESIZE));
  return (sizeof(Layout) + page - 1) / page * page;
}

// Zero pages in place of a chip's mapping: any later access reads zeros, writes go nowhere.
bool ReplaceWithZeros(std::uintptr_t start) {
  void* p = mmap(reinterpret_cast<void*>(start), g_map_bytes.load(), PROT_READ | PROT_WRITE,
                 MAP_PRIVATE | MAP_ANONYMOUS | MAP_FIXED, -1, 0);
  return p != MAP_FAILED;
}

extern "C" void OnSigbus(int sig, siginfo_t* info, void* context) {
  const auto addr = reinterpret_cast<std::uintptr_t>(info->si_addr);
  for (Mapped& m : g_mapped) {
    const std::uintptr_t start = m.start.load(std::memory_order_acquire);
    if (start != 0 && addr >= start && addr - start < g_map_bytes.load() &&
        ReplaceWithZeros(start)) {
      m.damaged.store(true, std::memory_order_release);
      return;  // the access runs again, on the zero pages
    }
  }
  // Not a chip's fault: what would have happened without this handler.
  if ((g_previous_sigbus.sa_flags & SA_SIGINFO) != 0 && g_previous_sigbus.sa_sigaction != nullptr) {
    g_previous_sigbus.sa_sigaction(sig, info, context);
    return;
  }
  if ((g_previous_sigbus.sa_flags & SA_SIGINFO) == 0 && g_previous_sigbus.sa_handler != SIG_DFL &&
      g_previous_sigbus.sa_handler != SIG_IGN) {
    g_previous_sigbus.sa_handler(sig);
    return;
  }
  signal(SIGBUS, SIG_DFL);  // the access faults again and ends the process as usual
}

// A free slot for a mapping at start (installs the handler on first use); -1 when full.
int Register(void* start) {
  std::lock_guard<std::mutex> lock(g_mapped_mutex);
  if (!g_handler_installed) {
    g_map_bytes.store(MapBytes());
    struct sigaction sa {};
    sa.sa_sigaction = OnSigbus;
    sa.sa_flags = SA_SIGINFO;
    sigemptyset(&sa.sa_mask);
    if (sigaction(SIGBUS, &sa, &g_previous_sigbus) != 0) return -1;
    g_handler_installed = true;
  }
  for (std::size_t i = 0; i < kMaxMapped; ++i) {
    if (g_mapped[i].start.load() == 0) {
      g_mapped[i].damaged.store(false);
      g_mapped[i].start.store(reinterpret_cast<std::uintptr_t>(start), std::memory_order_release);
      return static_cast<int>(i);
    }
  }
  return -1;
}

void Unregister(int slot) {
  std::lock_guard<std::mutex> lock(g_mapped_mutex);
  g_mapped[slot].start.store(0, std::memory_order_release);
  g_mapped[slot].damaged.store(false);
}

std::string Why(const std::string& path, const std::string& reason) {
  return "sim chip " + path + ": " + reason;
}

// Maps fd as a chip; nullptr with *error.
Layout* Map(int fd, const std::string& path, std::string* error) {
  struct stat st {};
  if (fstat(fd, &st) != 0) {
    *error = Why(path, std::strerror(errno));
    return nullptr;
  }
  if (static_cast<std::size_t>(st.st_size) != sizeof(Layout)) {
    *error = Why(path, "not a simulated chip (size " + std::to_string(st.st_size) +
                           " bytes, expected " + std::to_string(sizeof(Layout)) + ")");
    return nullptr;
  }
  void* p = mmap(nullptr, sizeof(Layout), PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
  if (p == MAP_FAILED) {
    *error = Why(path, std::string("mmap: ") + std::strerror(errno));
    return nullptr;
  }
  return static_cast<Layout*>(p);
}

bool Valid(const Layout* l, const std::string& path, std::string* error) {
  if (l->magic.load(std::memory_order_acquire) != kMagic) {
    *error = Why(path, "not a simulated chip (bad magic)");
    return false;
  }
  if (l->version.load() != kVersion || l->num_lines.load() != kNumLines ||
      l->ring_size.load() != kRingSize) {
    *error = Why(path, "layout version " + std::to_string(l->version.load()) +
                           " not supported (expected " + std::to_string(kVersion) + ")");
    return false;
  }
  return true;
}

}  // namespace

bool SimChip::Open(const std::string& path, bool create, std::string* error) {
  Close();
  int fd = open(path.c_str(), O_RDWR | O_CLOEXEC);
  if (fd < 0 && errno == ENOENT && create) {
    // A fresh chip under a temporary name, linked into place once initialised.
    const std::string tmp = path + ".tmp." + std::to_string(getpid());
    const int t = open(tmp.c_str(), O_RDWR | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
    if (t < 0) {
      *error = Why(path, std::string("cannot create: ") + std::strerror(errno));
      return false;
    }
    if (ftruncate(t, static_cast<off_t>(sizeof(Layout))) != 0) {
      *error = Why(path, std::string("cannot size: ") + std::strerror(errno));
      close(t);
      unlink(tmp.c_str());
      return false;
    }
    Layout* l = Map(t, path, error);
    if (l == nullptr) {
      close(t);
      unlink(tmp.c_str());
      return false;
    }
    l->version.store(kVersion);
    l->num_lines.store(kNumLines);
    l->ring_size.store(kRingSize);
    l->magic.store(kMagic, std::memory_order_release);
    munmap(l, sizeof(Layout));
    const bool linked = link(tmp.c_str(), path.c_str()) == 0;
    const int link_errno = errno;
    unlink(tmp.c_str());
    close(t);
    if (!linked && link_errno != EEXIST) {  // EEXIST: another creator won; use theirs
      *error = Why(path, std::string("cannot create: ") + std::strerror(link_errno));
      return false;
    }
    fd = open(path.c_str(), O_RDWR | O_CLOEXEC);
  }
  if (fd < 0) {
    *error = Why(path, std::strerror(errno));
    if (errno == ENOENT) *error += " (the peer creates it: mrd-hil serve --port gpio=" + path + ")";
    return false;
  }
  Layout* l = Map(fd, path, error);
  if (l == nullptr) {
    close(fd);
    return false;
  }
  const int slot = Register(l);
  if (slot < 0) {
    *error = Why(
        path, "more than " + std::to_string(kMaxMapped) + " simulated chips open in this process");
    munmap(l, sizeof(Layout));
    close(fd);
    return false;
  }
  if (!Valid(l, path, error)) {
    Unregister(slot);
    munmap(l, sizeof(Layout));
    close(fd);
    return false;
  }
  layout_ = l;
  fd_ = fd;
  slot_ = slot;
  path_ = path;
  return true;
}

void SimChip::Close() {
  if (layout_ != nullptr) {
    Unregister(slot_);
    munmap(layout_, sizeof(Layout));
    close(fd_);
  }
  layout_ = nullptr;
  fd_ = -1;
  slot_ = -1;
}

bool SimChip::damaged() const {
  return layout_ == nullptr || g_mapped[slot_].damaged.load(std::memory_order_acquire);
}

void SimChip::MarkDamaged() {
  if (layout_ == nullptr || damaged()) return;
  ReplaceWithZeros(reinterpret_cast<std::uintptr_t>(layout_));
  g_mapped[slot_].damaged.store(true, std::memory_order_release);
}

bool SimChip::Check() {
  if (damaged()) return false;
  struct stat st {};
  if (fstat(fd_, &st) != 0 || static_cast<std::size_t>(st.st_size) < sizeof(Layout) ||
      layout_->magic.load(std::memory_order_acquire) != kMagic) {
    MarkDamaged();
    return false;
  }
  return true;
}

bool SimChip::SetValue(std::size_t line, bool value, std::int64_t t_ns) {
  if (damaged() || line >= kNumLines) return false;
  LineState& s = layout_->lines[line];
  const std::uint64_t v = value ? 1 : 0;
  if (s.value.load(std::memory_order_relaxed) == v) return true;
  s.value.store(v, std::memory_order_release);
  const std::uint64_t n = s.head.load(std::memory_order_relaxed);
  EventSlot& slot = s.ring[n % kRingSize];
  slot.seq.store(0, std::memory_order_relaxed);
  std::atomic_thread_fence(std::memory_order_release);
  slot.t_ns.store(t_ns, std::memory_order_relaxed);
  slot.rising.store(v, std::memory_order_relaxed);
  slot.seq.store(n + 1, std::memory_order_release);
  s.head.store(n + 1, std::memory_order_release);
  return true;
}

bool SimChip::GetValue(std::size_t line) const {
  if (damaged() || line >= kNumLines) return false;
  return layout_->lines[line].value.load(std::memory_order_acquire) != 0;
}

std::uint64_t SimChip::head(std::size_t line) const {
  if (damaged() || line >= kNumLines) return 0;
  return layout_->lines[line].head.load(std::memory_order_acquire);
}

std::size_t SimChip::ReadEvents(std::size_t line, std::uint64_t* cursor, Event* out,
                                std::size_t max, std::uint64_t* lost) const {
  *lost = 0;
  if (damaged() || line >= kNumLines) return 0;
  const LineState& s = layout_->lines[line];
  const std::uint64_t h = s.head.load(std::memory_order_acquire);
  if (h < *cursor) *cursor = h;  // the chip was recreated: start over from its head
  if (h - *cursor > kRingSize) {
    *lost += h - kRingSize - *cursor;
    *cursor = h - kRingSize;
  }
  std::size_t n = 0;
  while (*cursor < h && n < max) {
    const EventSlot& slot = s.ring[*cursor % kRingSize];
    const std::uint64_t want = *cursor + 1;
    const std::uint64_t s0 = slot.seq.load(std::memory_order_acquire);
    const std::int64_t t = slot.t_ns.load(std::memory_order_relaxed);
    const std::uint64_t r = slot.rising.load(std::memory_order_relaxed);
    std::atomic_thread_fence(std::memory_order_acquire);
    const std::uint64_t s1 = slot.seq.load(std::memory_order_relaxed);
    ++*cursor;
    if (s0 != want || s1 != want) {  // overwritten (or being overwritten) by a lapping writer
      ++*lost;
      continue;
    }
    out[n++] = {want, t, r != 0};
  }
  return n;
}

}  // namespace mrd::sim_gpio
