// The floor under a lockstep period: one round trip of a 16-byte frame (a struct can_frame)
// between two threads over a UNIX SOCK_SEQPACKET socket pair, the local frame bus's transport
// (mrd/canbus/local_bus.hpp). A lockstep period needs at least one such round trip (grant out,
// status back). Two ways to wait for the answer:
//   BM_RoundTripBlocking  recv() sleeps until the frame is there (what the harness and the
//                         firmware do: each period costs two wake-ups)
//   BM_RoundTripSpinning  recv(MSG_DONTWAIT) in a loop (no sleep: both threads keep a core)
// The difference is the cost of the wake-ups on this machine; the spinning figure is what the
// system calls alone cost. Not a test: run build/tests/bench_round_trip.
#include <benchmark/benchmark.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <thread>

namespace {

constexpr int kFrameBytes = 16;  // sizeof(struct can_frame)

// Waits for one frame on fd; spin: without sleeping. false when the peer is gone.
bool Receive(int fd, char* frame, bool spin) {
  while (true) {
    const ssize_t n = recv(fd, frame, kFrameBytes, spin ? MSG_DONTWAIT : 0);
    if (n > 0) return true;
    if (n == 0 || (errno != EAGAIN && errno != EINTR)) return false;
  }
}

void RoundTrip(benchmark::State& state, bool spin) {
  int fds[2];
  if (socketpair(AF_UNIX, SOCK_SEQPACKET, 0, fds) != 0) {
    state.SkipWithError("socketpair failed");
    return;
  }
  std::thread echo([&] {
    char frame[kFrameBytes];
    while (Receive(fds[1], frame, spin)) {
      if (send(fds[1], frame, kFrameBytes, 0) != kFrameBytes) break;
    }
  });
  char frame[kFrameBytes] = {};
  for (auto _ : state) {
    if (send(fds[0], frame, kFrameBytes, 0) != kFrameBytes || !Receive(fds[0], frame, spin)) {
      state.SkipWithError("the echo thread is gone");
      break;
    }
  }
  shutdown(fds[0], SHUT_RDWR);  // the echo thread's recv returns 0
  echo.join();
  close(fds[0]);
  close(fds[1]);
}

void BM_RoundTripBlocking(benchmark::State& state) { RoundTrip(state, false); }
void BM_RoundTripSpinning(benchmark::State& state) { RoundTrip(state, true); }
BENCHMARK(BM_RoundTripBlocking)->UseRealTime();
BENCHMARK(BM_RoundTripSpinning)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
