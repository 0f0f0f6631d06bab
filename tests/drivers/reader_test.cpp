#include "imukit/drivers/reader.hpp"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <stdlib.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <ctime>
#include <stdexcept>
#include <thread>
#include <vector>

#include "imukit/drivers/text_codec.hpp"
#include "imukit/drivers/transport.hpp"

namespace imukit::drivers {
namespace {

TEST(DeviceReader, PipeClosedByTheWriterEndsCleanlyWithEverySample) {
  int fds[2];
  ASSERT_EQ(::pipe(fds), 0);
  auto transport = std::make_unique<FdTransport>(fds[0], true, "pipe");
  DeviceReader reader(std::move(transport), std::make_unique<TextCodec>(), ReaderOptions{20, 7, 0});
  reader.start();
  std::thread writer([w = fds[1]] {
    for (int i = 0; i < 500; ++i) {
      const std::string line = std::to_string(i) + ",0,0,9.8,0,0,0\n";
      ASSERT_EQ(::write(w, line.data(), line.size()), static_cast<ssize_t>(line.size()));
    }
    // The last line has no newline: it must still arrive (finish() at the end of the stream).
    ASSERT_EQ(::write(w, "500,1,1,1,1,1,1", 15), 15);
    ::close(w);  // the device is "unplugged"
  });
  writer.join();
  ASSERT_TRUE(reader.wait(10'000));
  const EndReason end = reader.end_reason();
  EXPECT_EQ(end.kind, EndKind::kEndOfStream);
  EXPECT_NE(end.message.find("end of stream"), std::string::npos) << end.message;
  const auto samples = reader.take();
  ASSERT_EQ(samples.size(), 501u);
  for (std::size_t i = 0; i < samples.size(); ++i)
    EXPECT_EQ(samples[i].device_time, static_cast<int64_t>(i) * 1'000'000);
  EXPECT_EQ(reader.stats().samples_decoded, 501u);
}

class ThrowingTransport : public ByteTransport {
 public:
  ReadResult read(std::span<uint8_t> buf, int) override {
    if (calls_++ == 0) {
      const std::string line = "1,2,3,4,5,6,7\n";
      std::copy(line.begin(), line.end(), buf.begin());
      return {line.size(), 5, false, {}};
    }
    throw std::runtime_error("EIO from the driver");
  }
  void write(std::span<const uint8_t>) override {}
  std::string describe() const override { return "throwing"; }

 private:
  int calls_ = 0;
};

TEST(DeviceReader, TransportExceptionEndsTheStreamWithItsMessage) {
  DeviceReader reader(std::make_unique<ThrowingTransport>(), std::make_unique<TextCodec>());
  reader.start();
  ASSERT_TRUE(reader.wait(10'000));
  EXPECT_EQ(reader.end_reason().kind, EndKind::kError);
  EXPECT_EQ(reader.end_reason().message, "EIO from the driver");
  EXPECT_EQ(reader.take().size(), 1u);  // what came before the failure is kept
}

TEST(DeviceReader, StopEndsAnIdleStream) {
  int fds[2];
  ASSERT_EQ(::pipe(fds), 0);
  DeviceReader reader(std::make_unique<FdTransport>(fds[0], true, "pipe"),
                      std::make_unique<TextCodec>());
  reader.start();
  EXPECT_FALSE(reader.wait(100));  // nothing arrives: still running
  reader.stop();
  EXPECT_EQ(reader.end_reason().kind, EndKind::kStopped);
  ::close(fds[1]);
}

TEST(DeviceReader, RunStopsAfterMaxSamples) {
  std::string text;
  for (int i = 0; i < 100; ++i) text += std::to_string(i) + " 0 0 0 0 0 0\n";
  MemoryTransport t(std::vector<uint8_t>(text.begin(), text.end()), 10);
  TextCodec codec;
  std::atomic<bool> stop{false};
  std::vector<Sample> out;
  const EndReason end = DeviceReader::run(t, codec, ReaderOptions{10, 4096, 30}, stop, out);
  EXPECT_EQ(end.kind, EndKind::kStopped);
  EXPECT_EQ(out.size(), 30u);  // a 10-byte read never holds two line ends
}

// The hint when nothing arrives names what the transport has to check: only a serial port has a
// baud rate (found in review: a silent pty given as fd:, a mock, HID and USB were told to check
// a baud rate they do not have).
// Receive times follow CLOCK_BOOTTIME from a wall-clock base (a wall-clock step during a
// recording bent its whole clock fit; review, 2026-11-27): differences equal CLOCK_BOOTTIME's
// to 0.1 ms, and the value is the Unix epoch's. (A test cannot step the machine's wall clock:
// this pins which clock the differences come from, not the step itself.)
TEST(Transport, HostTimeIsTheWallClockAdvancedByTheBootClock) {
  const auto read = [](clockid_t clock) {
    timespec ts{};
    clock_gettime(clock, &ts);
    return static_cast<TimeNs>(ts.tv_sec) * kNsPerSecond + ts.tv_nsec;
  };
  EXPECT_LT(std::abs(host_now() - read(CLOCK_REALTIME)), 1'000'000'000);
  for (int k = 0; k < 50; ++k) {
    const TimeNs m0 = read(CLOCK_BOOTTIME), h0 = host_now();
    std::this_thread::sleep_for(std::chrono::microseconds(200));
    const TimeNs m1 = read(CLOCK_BOOTTIME), h1 = host_now();
    // The two pairs are read within microseconds of each other; no step can hide in 200 us.
    ASSERT_LT(std::abs((h1 - h0) - (m1 - m0)), 100'000) << "reading " << k;
    ASSERT_GT(h1, h0);
  }
}

// A peer that stops reading blocked the command write, and with it the reader thread, --duration
// and Ctrl-C, for good (review, 2026-11-27): the write now ends within its deadline.
TEST(Transport, AWriteTheOtherEndDoesNotTakeFailsWithinItsDeadline) {
  int fds[2];
  ASSERT_EQ(::socketpair(AF_UNIX, SOCK_STREAM, 0, fds), 0);
  const std::vector<uint8_t> block(4096, 0xAA);
  while (::send(fds[0], block.data(), block.size(), MSG_DONTWAIT) > 0) {
  }
  FdTransport socket_end(fds[0], true, "socket");  // blocking, its buffer full
  const auto start = std::chrono::steady_clock::now();
  try {
    socket_end.write(std::vector<uint8_t>(64, 0x55));
    ADD_FAILURE() << "the write returned";
  } catch (const TransportError& e) {
    EXPECT_STREQ(
        e.what(),
        "socket: write: 0 of 64 command bytes taken in 1000 ms (does the other end read?)");
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_GT(seconds, 0.9);
  EXPECT_LT(seconds, 10.0);
  // Once the other end reads, commands go through again.
  std::vector<uint8_t> sink(1 << 20);
  while (::recv(fds[1], sink.data(), sink.size(), MSG_DONTWAIT) > 0) {
  }
  EXPECT_NO_THROW(socket_end.write(std::vector<uint8_t>(64, 0x55)));
  ::close(fds[1]);
}

// A regular file is a replay however it was opened: commands written at its offset overwrote
// the recorded bytes of a capture given as `fd:3 3<>capture.bin` (review, 2026-11-27).
TEST(Transport, ARegularFileIsNeverWrittenAndATerminalMayStartMidStream) {
  char path[] = "/tmp/imukit_replay_XXXXXX";
  const int fd = ::mkstemp(path);
  ASSERT_GE(fd, 0);
  ::unlink(path);
  const FdTransport file(fd, true, "file", true);
  EXPECT_TRUE(file.replay());
  EXPECT_FALSE(file.can_write());
  EXPECT_FALSE(file.may_start_mid_stream());
  int fds[2];
  ASSERT_EQ(::pipe(fds), 0);
  const FdTransport pipe_end(fds[1], true, "pipe");
  ::close(fds[0]);
  EXPECT_TRUE(pipe_end.can_write());
  EXPECT_FALSE(pipe_end.may_start_mid_stream());
  const int pty = ::posix_openpt(O_RDWR | O_NOCTTY);
  ASSERT_GE(pty, 0);
  const FdTransport terminal(pty, true, "pty");
  EXPECT_TRUE(terminal.may_start_mid_stream());
}

TEST(Transport, OnlyASerialPortIsToldToCheckItsBaudRate) {
  const MemoryTransport memory({});
  EXPECT_EQ(memory.when_silent(), "check the codec in the URI and that the device is streaming");

  int fds[2];
  ASSERT_EQ(::pipe(fds), 0);
  const FdTransport pipe_end(fds[0], true, "pipe");
  ::close(fds[1]);
  EXPECT_EQ(pipe_end.when_silent(),
            "nothing was written to the FIFO or pipe: has a writer opened it?");

  const int pty = ::posix_openpt(O_RDWR | O_NOCTTY);
  ASSERT_GE(pty, 0);
  const FdTransport terminal(pty, true, "pty");
  EXPECT_EQ(terminal.when_silent(), "check the codec in the URI and that the device is streaming");
}

}  // namespace
}  // namespace imukit::drivers
