// Conformance (labels conformance, hardening): a simulated GPIO chip file truncated while
// mapped. Its users see a damaged chip (Check false, writes refused, reads empty) instead of
// a SIGBUS, also when the truncation lands between the check and the access; the firmware's
// GPIO device turns it into a device fault (kFault: the gpio_bus cause, the safe state). A
// SIGBUS outside any chip still ends the process as before.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/mman.h>
#include <unistd.h>

#include <memory>
#include <string>

#include "mrd/firmware/io/gpio/gpio_device.hpp"
#include "mrd/sim_gpio/sim_chip.hpp"
#include "support/io_time.hpp"

namespace mrd {
namespace {

using sim_gpio::SimChip;

class ChipFile {
 public:
  explicit ChipFile(const char* tag)
      : path_("/tmp/mrd-trunc-" + std::string(tag) + "-" + std::to_string(getpid()) + ".chip") {
    unlink(path_.c_str());
    std::string error;
    EXPECT_TRUE(owner_.Open(path_, /*create=*/true, &error)) << error;
  }
  ~ChipFile() {
    owner_.Close();
    unlink(path_.c_str());
  }
  const std::string& path() const { return path_; }
  SimChip& owner() { return owner_; }
  void Truncate(off_t size) { ASSERT_EQ(truncate(path_.c_str(), size), 0); }

 private:
  std::string path_;
  SimChip owner_;
};

TEST(SimChipTruncation, ACheckSeesTheTruncationAndTheChipFailsSafely) {
  ChipFile file("check");
  SimChip user;
  std::string error;
  ASSERT_TRUE(user.Open(file.path(), false, &error)) << error;
  ASSERT_TRUE(user.Check());
  ASSERT_TRUE(user.SetValue(3, true, 10));
  file.Truncate(0);
  EXPECT_FALSE(user.Check());
  EXPECT_TRUE(user.damaged());
  EXPECT_FALSE(user.SetValue(3, false, 20));
  EXPECT_FALSE(user.GetValue(3));
  EXPECT_EQ(user.head(3), 0U);
  sim_gpio::Event ev[4];
  std::uint64_t cursor = 0, lost = 0;
  EXPECT_EQ(user.ReadEvents(3, &cursor, ev, 4, &lost), 0U);
  EXPECT_FALSE(file.owner().Check());  // the creator's mapping too
  // Half the size, or the full size again (zeros: the magic is gone): damaged as well.
  for (const off_t size : {static_cast<off_t>(sizeof(sim_gpio::Layout) / 2),
                           static_cast<off_t>(sizeof(sim_gpio::Layout))}) {
    ChipFile other("resize");
    SimChip u;
    ASSERT_TRUE(u.Open(other.path(), false, &error)) << error;
    other.Truncate(0);
    other.Truncate(size);
    EXPECT_FALSE(u.Check()) << size;
  }
}

TEST(SimChipTruncation, AnAccessRightAfterATruncationIsNoCrash) {
  ChipFile file("race");
  SimChip user;
  std::string error;
  ASSERT_TRUE(user.Open(file.path(), false, &error)) << error;
  file.Truncate(0);
  // No Check between the truncation and the accesses: each would raise SIGBUS.
  user.SetValue(5, true, 10);
  EXPECT_TRUE(user.damaged());
  EXPECT_FALSE(user.SetValue(5, false, 20));
  EXPECT_FALSE(user.GetValue(5));
  EXPECT_EQ(file.owner().head(5), 0U);  // the creator's mapping faults and is replaced too
  EXPECT_TRUE(file.owner().damaged());
  // A chip opened afresh on a new file works.
  ChipFile fresh("fresh");
  SimChip again;
  ASSERT_TRUE(again.Open(fresh.path(), false, &error)) << error;
  EXPECT_TRUE(again.SetValue(5, true, 30));
  EXPECT_TRUE(again.Check());
  EXPECT_TRUE(again.GetValue(5));
}

TEST(SimChipTruncationDeathTest, ASigbusOutsideAnyChipStillEndsTheProcess) {
  ChipFile file("other");  // the handler is installed
  const std::string other = file.path() + ".plain";
  EXPECT_EXIT(
      {
        const int fd = open(other.c_str(), O_RDWR | O_CREAT | O_TRUNC, 0600);
        if (fd < 0 || ftruncate(fd, 4096) != 0) _exit(3);
        auto* p = static_cast<volatile char*>(
            mmap(nullptr, 4096, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0));
        if (ftruncate(fd, 0) != 0) _exit(4);
        p[0] = 1;  // beyond the file's end: SIGBUS
        _exit(0);
      },
      testing::KilledBySignal(SIGBUS), "");
  unlink(other.c_str());
}

TEST(SimChipTruncation, TheFirmwaresGpioDeviceReportsAFault) {
  ChipFile file("device");
  firmware::GpioConfig c;
  c.enabled = true;
  c.inputs =
      firmware::Bit(firmware::Input::kDisplacement) | firmware::Bit(firmware::Input::kFaultLine);
  c.outputs =
      firmware::Bit(firmware::Output::kEnable) | firmware::Bit(firmware::Output::kHeartbeat);
  c.sim_chip = file.path();
  c.encoder_a_line = 4;
  c.encoder_b_line = 5;
  c.fault_line = 6;
  c.enable_line = 17;
  c.heartbeat_line = 18;
  firmware::GpioDevice device(c);
  std::string error;
  ASSERT_TRUE(device.Configure(&error) && device.Activate(&error)) << error;
  firmware::SensorFrame frame;
  firmware::IoError why = firmware::IoError::kNone;
  EXPECT_NE(device.Read(::mrd::test::NowIo(), &frame, &why), firmware::IoStatus::kFault);
  EXPECT_EQ(device.Write(::mrd::test::NowIo(), {1.0, true, false, 1}, &why),
            firmware::IoStatus::kOk);
  file.Truncate(0);
  frame = firmware::SensorFrame{};
  EXPECT_EQ(device.Read(::mrd::test::NowIo(), &frame, &why), firmware::IoStatus::kFault);
  EXPECT_EQ(why, firmware::IoError::kSystem);
  EXPECT_TRUE(frame.fault_line);  // an unreadable fault line counts as asserted
  EXPECT_EQ(device.fault_cause(), firmware::FaultCause::kGpioBus);
  EXPECT_EQ(device.Write(::mrd::test::NowIo(), {1.0, true, false, 2}, &why),
            firmware::IoStatus::kFault);
  device.Deactivate();
}

}  // namespace
}  // namespace mrd
