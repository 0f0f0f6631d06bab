// Codec for the imukit wire protocol v1 (firmware_proto, docs/protocol.md): COBS frames with
// CRC-32C carrying DeviceInfo, SampleBlocks, Pongs, Acks, Nacks and Logs.
//
// Start-up (live devices): GetDeviceInfo; when DeviceInfo arrives, Stop (a device left streaming
// by an earlier session refuses Configure and Start, and numbers its samples from its own start),
// Configure (the rate asked for, else the device's first; every channel the device has, range
// index 0, samples per block), then Start. The stream is ours from the Ack of that Start: sample
// blocks before it (what the Stop flushed, an earlier session's stream) are not decoded and count
// in samples_before_start, not as losses, and sample 0 of ours is the first expected. Until that
// Ack the three are sent again, first after retry_ns (a frame lost on the link) and then after
// twice as long each round up to kMaxRetryNs, so a link whose round trip is longer than retry_ns
// still gets the Ack of the latest Start; a refused Configure or Start ends the stream with the
// device's reason, except "not allowed in this state" (a Stop that was lost: the next round stops
// the device again). A DeviceInfo numbered 0 after the stream began is a device that rebooted
// (idle, default configuration): the start-up runs again. Raw counts are scaled with the
// DeviceInfo's per-range scale and offset. Sample i of a block is stamped on the device clock at
// first_tick + floor(i * tick_hz * 1000 / rate_mhz) ticks, the device's own stepping rule,
// unwrapped to 64 bits (32-bit ticks, half-range rule around the tick the stepping rule gives the
// block's index from the last block's, so a loss of any length keeps the time). Gaps in the 32-bit
// cumulative sample index are counted as dropped samples. A block whose index is behind the stream
// (by the half-range rule) is a repeat or a late arrival when its frame is numbered just before the
// newest frame (proto::kReorderWindow) and its first tick is the one due at its index on this
// stream: its samples already passed are not handed out again (samples_stale). It is a loss of
// 2^31 samples or more, its index 2^32 further on, when its first tick is due there and not at
// the index behind (or, where the tick cannot tell the two, the host time since the last block
// covers half the loss). Otherwise the index went back for a new streaming session, counted as
// a counter reset.
//
// Time sync: every ping_interval a Ping carrying the host send time goes out; each Pong is kept
// as a SyncPoint (host send, host receive, device rx/tx ticks) for capture/ to fit the clock map.
#pragma once

#include <optional>

#include "imukit/drivers/codec.hpp"
#include "imukit/firmware_proto/frame.hpp"
#include "imukit/firmware_proto/messages.hpp"

namespace imukit::drivers {

struct ImukitCodecOptions {
  bool send_commands = true;  // false: decode only (replay of a capture)
  double rate_hz = 0.0;       // 0: the device's first listed rate
  int samples_per_block = 8;
  uint8_t channels = 0;                    // 0: every channel the device has
  TimeNs ping_interval_ns = kNsPerSecond;  // 0: no pings
  // Repeat an unanswered GetDeviceInfo, or Stop-Configure-Start until the Start is acknowledged
  // (the latter after twice as long each round, up to ImukitCodec::kMaxRetryNs).
  TimeNs retry_ns = 500'000'000;
};

class ImukitCodec : public Codec {
 public:
  explicit ImukitCodec(ImukitCodecOptions options = {});

  std::string name() const override { return "imukit"; }
  // The longest wait between two rounds of the start-up: links with a round trip up to this.
  static constexpr TimeNs kMaxRetryNs = 8 * kNsPerSecond;
  void start(TimeNs now) override;
  void tick(TimeNs now) override;
  std::size_t bytes_pending() const override {
    return cut_at_end_bytes_ > 0 ? 0 : decoder_.pending();
  }

  const std::optional<proto::DeviceInfo>& device_info() const { return info_; }
  std::span<const SyncPoint> sync_points() const override { return sync_; }
  const std::vector<proto::Nack>& nacks() const { return nacks_; }
  // The frame decoder's counts, where a DeviceInfo begins a numbering of its own: its number is
  // not compared with the frames before it (a device that rebooted numbers from 0 again), so it is
  // neither out of order nor a sequence gap.
  proto::DecoderStats frame_stats() const;
  // Log lines the device sent.
  const std::vector<std::string>& device_log() const { return log_; }
  bool streaming() const { return started_; }

 protected:
  void decode(std::span<const uint8_t> data, TimeNs host_time, std::vector<Sample>& out) override;
  void decode_end(TimeNs host_time, std::vector<Sample>& out) override;

 private:
  template <class M>
  void send(const M& m);
  void on_frame(const proto::Frame& f, TimeNs host_time, std::vector<Sample>& out);
  // A DeviceInfo arrived: the frames after it are numbered from it, and what the decoder counted
  // for it against the frames before (its stats then minus `before`) is not counted.
  void begin_numbering(const proto::DecoderStats& before);
  void on_block(const proto::SampleBlock& b, bool out_of_order, TimeNs host_time,
                std::vector<Sample>& out);
  void sync_frame_stats();
  // The unwrapped tick the device's stepping gives sample `index` of the current stream (the
  // rule extended before sample 0 too), when a block of it was handed out and the rate is known.
  std::optional<int64_t> tick_due(int64_t index) const;
  // Whether a block's first tick is the one the stepping gives `index` (within half a period).
  bool on_stepping(int64_t index, uint32_t first_tick) const;
  // A block whose index the half-range rule puts behind the stream (at `behind`) that is
  // 2^32 samples further on, a loss of 2^31 samples or more (docs/protocol.md, section 5.3).
  bool is_long_loss(int64_t behind, uint32_t first_tick, TimeNs host_time) const;
  int64_t unwrap_tick(uint32_t raw);  // half-range rule around the latest tick
  void send_configuration();

  ImukitCodecOptions opt_;
  proto::FrameDecoder decoder_;
  // What the decoder counted for DeviceInfo frames against the numbering before them
  // (sequence_gaps, frames_missed, frames_out_of_order), left out of frame_stats().
  proto::DecoderStats numbering_restarts_;
  uint16_t tx_sequence_ = 0;
  std::optional<proto::DeviceInfo> info_;
  uint32_t rate_mhz_ = 0;
  bool started_ = false;                        // Start sent
  bool configured_ = false;                     // the DeviceInfo that set off the start-up arrived
  bool stream_acked_ = false;                   // the device acknowledged our latest Start
  uint16_t start_sequence_ = 0;                 // that Start's frame sequence number
  std::optional<uint16_t> configure_sequence_;  // the latest Configure's
  TimeNs last_request_ = 0;
  TimeNs retry_interval_ = 0;          // the wait before the next round of the start-up
  uint32_t frames_missed_before_ = 0;  // frame numbers skipped just before the current frame
  // The first sample of the last block handed out: index and unwrapped tick, from which the
  // device's stepping rule gives the tick due at any other index of the stream, and when it
  // arrived.
  struct BlockStart {
    int64_t index;
    int64_t tick;
    TimeNs host;
  };
  std::optional<BlockStart> last_block_;
  std::optional<int64_t> tick_ref_;  // the latest unwrapped tick (blocks, pongs)
  int64_t next_index_ = 0;
  bool have_index_ = false;
  TimeNs last_ping_ = 0;
  bool pinged_ = false;
  std::vector<SyncPoint> sync_;
  std::vector<proto::Nack> nacks_;
  std::vector<std::string> log_;
  proto::SampleBlock block_;          // scratch: large, kept out of the stack
  std::size_t cut_at_end_bytes_ = 0;  // bytes of a frame the end of the stream cut off
};

// Encodes a host->device message as a frame (for tests and tools).
template <class M>
std::vector<uint8_t> encode_imukit_message(const M& m, uint16_t sequence) {
  std::vector<uint8_t> out(proto::kMaxFrameSize);
  out.resize(proto::encode_message(m, sequence, out.data(), out.size()));
  return out;
}

}  // namespace imukit::drivers
