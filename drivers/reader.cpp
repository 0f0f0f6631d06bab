#include "imukit/drivers/reader.hpp"

#include <chrono>
#include <exception>

#include "imukit/core/error.hpp"

namespace imukit::drivers {
namespace {

// Feature reports a codec needs (HID calibration), read once before streaming. Each is asked
// for up to kFeatureAttempts times, as hid-playstation does: another hidraw user (Steam) can be
// answered in between, and a clone pad's reply can be short.
constexpr int kFeatureAttempts = 3;

void fetch_features(Transport& transport, Codec& codec) {
  auto* reports = dynamic_cast<ReportTransport*>(&transport);
  if (!reports) return;
  for (const FeatureRequest& f : codec.feature_requests()) {
    std::exception_ptr failure;
    for (int attempt = 0; attempt < kFeatureAttempts; ++attempt) {
      try {
        codec.on_feature_report(f.report_id, reports->get_feature_report(f.report_id, f.size));
        failure = nullptr;
        break;
      } catch (const Error&) {  // a TransportError, or a report the codec cannot use
        failure = std::current_exception();
      }
    }
    if (failure && !f.optional) std::rethrow_exception(failure);
    if (failure) codec.on_optional_feature_report_missing();
  }
}

void flush_commands(Transport& transport, Codec& codec) {
  std::vector<uint8_t> cmd = codec.take_outgoing();
  if (cmd.empty()) return;
  if (auto* bytes = dynamic_cast<ByteTransport*>(&transport)) {
    if (bytes->can_write()) bytes->write(cmd);
  } else if (auto* reports = dynamic_cast<ReportTransport*>(&transport)) {
    reports->write_report(cmd);
  }
}

}  // namespace

DeviceReader::DeviceReader(std::unique_ptr<Transport> transport, std::unique_ptr<Codec> codec,
                           ReaderOptions options)
    : transport_(std::move(transport)), codec_(std::move(codec)), options_(options) {}

DeviceReader::~DeviceReader() { stop(); }

void DeviceReader::start() {
  if (thread_.joinable()) return;
  thread_ = std::thread([this] { thread_main(); });
}

void DeviceReader::stop() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
}

bool DeviceReader::wait(int timeout_ms) {
  std::unique_lock lock(mutex_);
  return ended_cv_.wait_for(lock, std::chrono::milliseconds(timeout_ms),
                            [&] { return ended_.load(); });
}

std::vector<Sample> DeviceReader::take() {
  std::lock_guard lock(mutex_);
  std::vector<Sample> out;
  out.swap(queue_);
  return out;
}

EndReason DeviceReader::end_reason() const {
  std::lock_guard lock(mutex_);
  return end_;
}

CodecStats DeviceReader::stats() const {
  std::lock_guard lock(mutex_);
  return stats_;
}

EndReason DeviceReader::run(Transport& transport, Codec& codec, const ReaderOptions& options,
                            const std::atomic<bool>& stop, std::vector<Sample>& out) {
  return run(transport, codec, options, stop, [&](std::vector<Sample>& batch) {
    out.insert(out.end(), batch.begin(), batch.end());
  });
}

EndReason DeviceReader::run(Transport& transport, Codec& codec, const ReaderOptions& options,
                            const std::atomic<bool>& stop,
                            const std::function<void(std::vector<Sample>&)>& sink) {
  EndReason end;
  uint64_t total = 0;
  std::vector<Sample> batch;
  TimeNs last_bytes_at = 0;  // host time of the last read that brought data
  // After every read that brought bytes, even when they decoded to nothing: the sink is where
  // callers take the codec's counts (a stream of bytes that never decode must show them).
  auto deliver = [&](bool bytes_arrived) {
    if (batch.empty() && !bytes_arrived) return;
    total += batch.size();
    sink(batch);
    batch.clear();
  };
  try {
    auto* bytes = dynamic_cast<ByteTransport*>(&transport);
    auto* reports = dynamic_cast<ReportTransport*>(&transport);
    fetch_features(transport, codec);
    codec.set_may_start_mid_stream(transport.may_start_mid_stream());
    codec.start(transport.now());
    flush_commands(transport, codec);
    std::vector<uint8_t> buf(codec.report_based() ? std::size_t{1024} : options.read_size);
    last_bytes_at = transport.now();
    while (!stop.load()) {
      const ReadResult r = bytes ? bytes->read(buf, options.read_timeout_ms)
                                 : reports->read_report(buf, options.read_timeout_ms);
      if (r.size > 0) {
        codec.feed(std::span<const uint8_t>(buf.data(), r.size), r.host_time, batch);
        last_bytes_at = r.host_time;
      }
      deliver(r.size > 0);
      if (r.end) {
        end = {EndKind::kEndOfStream, r.end_reason};
        break;
      }
      codec.tick(transport.now());
      flush_commands(transport, codec);
      if (options.max_samples > 0 && total >= options.max_samples) {
        end = {EndKind::kStopped, "collected " + std::to_string(total) + " samples"};
        break;
      }
    }
    if (end.kind == EndKind::kRunning) end = {EndKind::kStopped, "stopped by the host"};
  } catch (const std::exception& e) {
    end = {EndKind::kError, e.what()};
  } catch (...) {
    end = {EndKind::kError, "unknown error in the reader"};
  }
  // Whatever ended the stream, hand out what the codec still holds.
  try {
    codec.finish(last_bytes_at, batch);
    deliver(false);
  } catch (const std::exception& e) {
    if (end.kind != EndKind::kError) end = {EndKind::kError, e.what()};
  } catch (...) {
    if (end.kind != EndKind::kError)
      end = {EndKind::kError, "unknown error at the end of the stream"};
  }
  return end;
}

void DeviceReader::thread_main() {
  EndReason end;
  try {
    end = run(*transport_, *codec_, options_, stop_, [this](std::vector<Sample>& batch) {
      std::lock_guard lock(mutex_);
      queue_.insert(queue_.end(), batch.begin(), batch.end());
      samples_total_ += batch.size();
      stats_ = codec_->stats();
    });
  } catch (...) {
    // run() catches everything itself; this guards the sink's allocation.
    end = {EndKind::kError, "unknown error in the reader"};
  }
  {
    std::lock_guard lock(mutex_);
    stats_ = codec_->stats();
    end_ = end;
    ended_ = true;
  }
  ended_cv_.notify_all();
}

}  // namespace imukit::drivers
