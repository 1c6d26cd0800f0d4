#include "mrd/sim_gpio/sim_chip.hpp"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <ctime>

namespace mrd::sim_gpio {
namespace {

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

std::int64_t MonotonicNs() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

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
  close(fd);
  if (l == nullptr) return false;
  if (!Valid(l, path, error)) {
    munmap(l, sizeof(Layout));
    return false;
  }
  layout_ = l;
  path_ = path;
  return true;
}

void SimChip::Close() {
  if (layout_ != nullptr) munmap(layout_, sizeof(Layout));
  layout_ = nullptr;
}

bool SimChip::SetValue(std::size_t line, bool value, std::int64_t t_ns) {
  if (layout_ == nullptr || line >= kNumLines) return false;
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
  if (layout_ == nullptr || line >= kNumLines) return false;
  return layout_->lines[line].value.load(std::memory_order_acquire) != 0;
}

std::uint64_t SimChip::head(std::size_t line) const {
  if (layout_ == nullptr || line >= kNumLines) return 0;
  return layout_->lines[line].head.load(std::memory_order_acquire);
}

std::size_t SimChip::ReadEvents(std::size_t line, std::uint64_t* cursor, Event* out,
                                std::size_t max, std::uint64_t* lost) const {
  *lost = 0;
  if (layout_ == nullptr || line >= kNumLines) return 0;
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
