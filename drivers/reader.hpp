// DeviceReader: runs a transport and a codec on a thread of its own and collects the samples.
//
// Guarantees: no exception leaves the thread (a transport or codec error ends the stream with
// that error's message as the reason); the end of the stream (EOF, unplug, HID read error,
// stop()) is clean: the codec is finished so nothing received is lost, and end_reason() says
// why it ended. Commands the codec queues are written between reads (not for read-only
// transports such as file replays).
#pragma once

#include <atomic>
#include <cassert>
#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "imukit/drivers/codec.hpp"
#include "imukit/drivers/transport.hpp"

namespace imukit::drivers {

enum class EndKind {
  kRunning,      // not ended yet
  kStopped,      // stop() was called, or max_samples reached
  kEndOfStream,  // the device or file ended the stream (EOF, unplug, read error)
  kError,        // a transport or codec failure (message says which)
};

struct EndReason {
  EndKind kind = EndKind::kRunning;
  std::string message;
};

struct ReaderOptions {
  int read_timeout_ms = 50;
  std::size_t read_size = 4096;  // byte transports: bytes per read
  uint64_t max_samples = 0;      // stop after this many samples (0: no limit)
};

class DeviceReader {
 public:
  DeviceReader(std::unique_ptr<Transport> transport, std::unique_ptr<Codec> codec,
               ReaderOptions options = {});
  ~DeviceReader();  // stops and joins
  DeviceReader(const DeviceReader&) = delete;
  DeviceReader& operator=(const DeviceReader&) = delete;

  void start();
  // Asks the thread to end and joins it.
  void stop();
  // Waits until the stream ended (true) or the timeout passed (false).
  bool wait(int timeout_ms);
  bool running() const { return !ended_.load(); }

  // Samples received since the last take().
  std::vector<Sample> take();
  EndReason end_reason() const;
  CodecStats stats() const;
  uint64_t samples_total() const { return samples_total_.load(); }
  // The codec, for what only it knows (ImukitCodec::sync_points(), device_info()). Only after
  // the stream ended (wait() returned true, or stop()): the reader thread uses it until then.
  Codec& codec() {
    assert(!thread_.joinable() || ended_.load());
    return *codec_;
  }

  // Runs the same loop on the calling thread until the stream ends or `stop` turns true;
  // appends every sample to out. Never throws for transport or codec failures.
  static EndReason run(Transport& transport, Codec& codec, const ReaderOptions& options,
                       const std::atomic<bool>& stop, std::vector<Sample>& out);
  // The same, handing each read's samples to `sink` (which may move them away): after every
  // read that brought bytes, with an empty batch when they decoded to nothing.
  static EndReason run(Transport& transport, Codec& codec, const ReaderOptions& options,
                       const std::atomic<bool>& stop,
                       const std::function<void(std::vector<Sample>&)>& sink);

 private:
  void thread_main();

  std::unique_ptr<Transport> transport_;
  std::unique_ptr<Codec> codec_;
  ReaderOptions options_;
  std::thread thread_;
  std::atomic<bool> stop_{false};
  std::atomic<bool> ended_{false};
  std::atomic<uint64_t> samples_total_{0};
  mutable std::mutex mutex_;
  std::condition_variable ended_cv_;
  std::vector<Sample> queue_;
  EndReason end_;
  CodecStats stats_;
};

}  // namespace imukit::drivers
