#include "imukit/drivers/imukit_codec.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <string>

#include "imukit/core/error.hpp"

namespace imukit::drivers {
namespace {

// floor(n * k / r) without overflow for r < 2^32: with n = q r + a and k = c r + b,
// n k / r = q k + a c + a b / r, and a b < r^2 < 2^64.
uint64_t floor_mul_div(uint64_t n, uint64_t k, uint64_t r) {
  const uint64_t q = n / r, a = n % r, c = k / r, b = k % r;
  return q * k + a * c + (a * b) / r;
}

// The same modulo 2^64 for a negative n too: floor(-m k / r) = -ceil(m k / r), and m k mod r is
// (m mod r)(k mod r) mod r.
uint64_t signed_floor_mul_div(int64_t n, uint64_t k, uint64_t r) {
  if (n >= 0) return floor_mul_div(static_cast<uint64_t>(n), k, r);
  const uint64_t m = 0 - static_cast<uint64_t>(n);
  const uint64_t inexact = (m % r) * (k % r) % r != 0 ? 1 : 0;
  return 0 - (floor_mul_div(m, k, r) + inexact);
}

// A 32-bit counter (a device tick, a sample index) raw as the 64-bit value nearest `near` (the
// half-range rule around a prediction rather than around the last value seen).
int64_t nearest(uint32_t raw, int64_t near) {
  return near + static_cast<int32_t>(raw - static_cast<uint32_t>(near));
}

// The range of the 32-bit sample index (docs/protocol.md, section 5.3).
constexpr int64_t kIndexRange = int64_t{1} << 32;

const char* nack_reason(proto::NackCode code) {
  using proto::NackCode;
  switch (code) {
    case NackCode::kUnknownMessage:
      return "unknown message";
    case NackCode::kMalformed:
      return "malformed request";
    case NackCode::kBadState:
      return "not allowed in this state";
    case NackCode::kUnsupportedRate:
      return "rate not supported (see DeviceInfo rates)";
    case NackCode::kUnsupportedSensor:
      return "a requested sensor is not present";
    case NackCode::kNoSensorsEnabled:
      return "no sensor enabled";
    case NackCode::kUnsupportedRange:
      return "range not supported";
    case NackCode::kInvalidBlockSize:
      return "samples per block must be 1..32";
    case NackCode::kHardwareError:
      return "the sensor hardware refused the configuration";
    case NackCode::kCalibrationInvalid:
      return "calibration invalid";
    case NackCode::kNoCalibration:
      return "no calibration stored";
    case NackCode::kStorageError:
      return "storage error";
  }
  return "unknown reason";
}

}  // namespace

ImukitCodec::ImukitCodec(ImukitCodecOptions options) : opt_(options) {
  // Decoding only (a replay), no Configure sets the rate: the rate given is the one the stream
  // was made at, and it times the samples of every block. (Live, the Configure sets it again.)
  if (opt_.rate_hz > 0) rate_mhz_ = static_cast<uint32_t>(std::llround(opt_.rate_hz * 1000.0));
}

template <class M>
void ImukitCodec::send(const M& m) {
  uint8_t buf[proto::kMaxFrameSize];
  const std::size_t n = proto::encode_message(m, tx_sequence_++, buf, sizeof buf);
  if (n > 0) queue(std::span<const uint8_t>(buf, n));
}

void ImukitCodec::start(TimeNs now) {
  last_ping_ = now;
  last_request_ = now;
  retry_interval_ = opt_.retry_ns;
  if (opt_.send_commands) send(proto::GetDeviceInfo{});
}

void ImukitCodec::send_configuration() {
  send(proto::Stop{});
  // Configure even without a rate asked for (then the device's first listed rate): a device
  // keeps what an earlier session configured, and the samples are scaled and timed by what this
  // one assumes, range 0 and every channel included (review of 2026-11-27).
  if (info_ && (opt_.rate_hz > 0 || info_->rate_count > 0)) {
    proto::Configure c;
    c.rate_mhz = opt_.rate_hz > 0 ? static_cast<uint32_t>(std::llround(opt_.rate_hz * 1000.0))
                                  : info_->rates_mhz[0];
    c.channels = opt_.channels != 0 ? static_cast<uint8_t>(opt_.channels & info_->channels())
                                    : info_->channels();
    c.samples_per_block = static_cast<uint8_t>(opt_.samples_per_block);
    rate_mhz_ = c.rate_mhz;
    configure_sequence_ = tx_sequence_;
    send(c);
  }
  start_sequence_ = tx_sequence_;
  send(proto::Start{});
  started_ = true;
}

void ImukitCodec::tick(TimeNs now) {
  if (!opt_.send_commands) return;
  // A request or its answer can be lost on the link (the device drops frames with a bad CRC
  // without answering): ask again until the device answers.
  if (!info_ && now - last_request_ >= opt_.retry_ns) {
    send(proto::GetDeviceInfo{});
    last_request_ = now;
  } else if (info_ && started_ && !stream_acked_ && now - last_request_ >= retry_interval_) {
    // Only the Ack of the latest Start begins the stream: rounds faster than the link's round
    // trip replaced every Start before its Ack came back, and a link slower than 0.5 s never
    // started, silently (review, 2026-11-27). Each round waits twice as long as the last.
    send_configuration();
    last_request_ = now;
    retry_interval_ = std::min(2 * retry_interval_, std::max(kMaxRetryNs, opt_.retry_ns));
  }
  if (opt_.ping_interval_ns <= 0 || !started_) return;
  if (!pinged_ || now - last_ping_ >= opt_.ping_interval_ns) {
    proto::Ping ping;
    ping.host_time = static_cast<uint64_t>(now);
    send(ping);
    last_ping_ = now;
    pinged_ = true;
  }
}

void ImukitCodec::decode(std::span<const uint8_t> data, TimeNs host_time,
                         std::vector<Sample>& out) {
  stats_.bytes_received += data.size();
  while (!data.empty()) {
    const proto::DecoderStats before = decoder_.stats();
    data = data.subspan(decoder_.consume(data.data(), data.size()));
    if (!decoder_.has_frame()) continue;
    if (decoder_.frame().type == static_cast<uint8_t>(proto::MessageType::kDeviceInfo))
      begin_numbering(before);
    frames_missed_before_ = decoder_.stats().frames_missed - before.frames_missed;
    on_frame(decoder_.frame(), host_time, out);
  }
  sync_frame_stats();
}

void ImukitCodec::begin_numbering(const proto::DecoderStats& before) {
  // A device sends its DeviceInfo when it boots (or when asked): the frames after it are
  // numbered from there, never repeats of frames before it (found in review: a device that
  // rebooted within 16 frames of its start had its new blocks taken for stale repeats). Nor is
  // its own number compared with theirs: a rebooted device's frame 0 counted as a frame out of
  // order, or as a gap of up to 65535 missed frames (found in review, 2026-11-26). The next frame
  // follows its number, so frames lost right after it count (review of 2026-11-27: forgotten).
  decoder_.restart_sequence(decoder_.frame().sequence);
  const proto::DecoderStats& now = decoder_.stats();
  numbering_restarts_.sequence_gaps += now.sequence_gaps - before.sequence_gaps;
  numbering_restarts_.frames_missed += now.frames_missed - before.frames_missed;
  numbering_restarts_.frames_out_of_order += now.frames_out_of_order - before.frames_out_of_order;
}

proto::DecoderStats ImukitCodec::frame_stats() const {
  proto::DecoderStats s = decoder_.stats();
  s.sequence_gaps -= numbering_restarts_.sequence_gaps;
  s.frames_missed -= numbering_restarts_.frames_missed;
  s.frames_out_of_order -= numbering_restarts_.frames_out_of_order;
  return s;
}

void ImukitCodec::decode_end(TimeNs /*host_time*/, std::vector<Sample>& /*out*/) {
  // A frame cut by the end of the stream never gets its delimiter: it is a corrupt frame, and
  // its bytes are discarded rather than pending forever.
  if (cut_at_end_bytes_ == 0 && decoder_.pending() > 0) {
    cut_at_end_bytes_ = decoder_.pending();
    sync_frame_stats();
  }
}

void ImukitCodec::sync_frame_stats() {
  // The frame decoder owns byte accounting; mirror it so the codec's invariant holds.
  const proto::DecoderStats& d = decoder_.stats();
  stats_.bytes_accepted = d.bytes_accepted;
  stats_.bytes_discarded = d.bytes_discarded + cut_at_end_bytes_;
  // Samples Codec::feed dropped for a non-finite value are corrupt frames too, as is a frame
  // cut by the end of the stream.
  stats_.frames_corrupt =
      d.frames_rejected() + stats_.samples_non_finite + (cut_at_end_bytes_ > 0 ? 1 : 0);
}

void ImukitCodec::on_frame(const proto::Frame& f, TimeNs host_time, std::vector<Sample>& out) {
  ++stats_.frames_ok;
  using proto::MessageType;
  switch (static_cast<MessageType>(f.type)) {
    case MessageType::kSampleBlock: {
      if (proto::parse_message(f, block_) != proto::ParseStatus::kOk) {
        // CRC-valid but malformed: the device's bug, not the link's; its samples are unknown.
        ++stats_.device_errors;
        ++stats_.frames_other;
        return;
      }
      on_block(block_, decoder_.out_of_order(), host_time, out);
      return;
    }
    case MessageType::kDeviceInfo: {
      ++stats_.frames_other;  // its frame numbering restarted in decode() (begin_numbering)
      proto::DeviceInfo info;
      const bool parsed = proto::parse_message(f, info) == proto::ParseStatus::kOk;
      bool finite = true;
      for (uint8_t i = 0; parsed && i < info.sensor_count; ++i) {
        const proto::SensorInfo& si = info.sensors[i];
        finite = finite && std::isfinite(si.offset);
        for (uint8_t r = 0; r < si.range_count; ++r)
          finite = finite && std::isfinite(si.ranges[r].scale);
      }
      // A DeviceInfo whose scales are not finite numbers would turn every count into NaN.
      if (!parsed || info.tick_hz == 0 || !finite) {
        ++stats_.device_errors;
        return;
      }
      info_ = info;
      if (rate_mhz_ == 0 && info.rate_count > 0) rate_mhz_ = info.rates_mhz[0];
      // Frame 0 after our stream began: the device rebooted and is idle with its default
      // configuration (docs/protocol.md, section 6). The start-up runs again; until review,
      // 2026-11-27, the session went on with no samples, no loss and no error. (Answers to our
      // repeated GetDeviceInfo all come before the Ack of the Start sent after them, so none
      // of them, its number wrapped to 0, is taken for a reboot.)
      const bool rebooted = stream_acked_ && f.sequence == 0;
      if (opt_.send_commands && (!configured_ || rebooted)) {
        configured_ = true;
        stream_acked_ = false;
        send_configuration();
        last_request_ = host_time;
        retry_interval_ = opt_.retry_ns;
      }
      return;
    }
    case MessageType::kPong: {
      ++stats_.frames_other;
      proto::Pong p;
      if (proto::parse_message(f, p) != proto::ParseStatus::kOk || !info_) return;
      SyncPoint s;
      s.host_send = static_cast<TimeNs>(p.host_time);
      s.host_receive = host_time;
      s.device_rx = ticks_to_ns(unwrap_tick(p.rx_tick), info_->tick_hz);
      s.device_tx = ticks_to_ns(unwrap_tick(p.tx_tick), info_->tick_hz);
      sync_.push_back(s);
      return;
    }
    case MessageType::kAck: {
      ++stats_.frames_other;
      proto::Ack a;
      if (proto::parse_message(f, a) != proto::ParseStatus::kOk) return;
      if (started_ && !stream_acked_ &&
          a.request_type == static_cast<uint8_t>(MessageType::kStart) &&
          a.request_sequence == start_sequence_) {
        // Our stream begins: the device numbers its samples from 0 and its blocks follow the
        // Ack, so a lost first block shows as a gap.
        stream_acked_ = true;
        have_index_ = true;
        next_index_ = 0;
        tick_ref_.reset();
        last_block_.reset();
      }
      return;
    }
    case MessageType::kNack: {
      ++stats_.frames_other;
      ++stats_.device_errors;
      proto::Nack n;
      if (proto::parse_message(f, n) != proto::ParseStatus::kOk) return;
      nacks_.push_back(n);
      // A refused configuration will not get better by asking again: end the stream with the
      // device's reason. "Not allowed in this state" means the device is still streaming (our
      // Stop was lost): the next round of the start-up stops it again. Only a Nack of this
      // session's own latest request: decoding a capture, or answers to another host's
      // requests, a Nack is recorded and the stream goes on (review, 2026-11-27: a replay
      // holding one ended with "the device refused Configure").
      const auto type = static_cast<MessageType>(n.request_type);
      const bool ours =
          opt_.send_commands &&
          ((type == MessageType::kConfigure && configure_sequence_ == n.request_sequence) ||
           (type == MessageType::kStart && started_ && start_sequence_ == n.request_sequence));
      if (ours && n.code != proto::NackCode::kBadState) {
        throw Error(std::string("the device refused ") +
                    (type == MessageType::kConfigure ? "Configure" : "Start") + ": " +
                    nack_reason(n.code));
      }
      return;
    }
    case MessageType::kLog: {
      ++stats_.frames_other;
      proto::Log l;
      if (proto::parse_message(f, l) == proto::ParseStatus::kOk) log_.emplace_back(l.text, l.size);
      return;
    }
    default:
      ++stats_.frames_other;  // CalibrationData, or a type this host does not know
      return;
  }
}

void ImukitCodec::on_block(const proto::SampleBlock& b, bool out_of_order, TimeNs host_time,
                           std::vector<Sample>& out) {
  if (opt_.send_commands && !stream_acked_) {
    // Not our stream yet (before the DeviceInfo or between our Start and its Ack): the stream
    // of an earlier session, the block our Stop flushed, or ours when the Start's Ack was lost
    // on the link. Not recorded, and no loss of this session, whose stream begins at the Ack
    // (found in review: an earlier session's leftovers were counted as dropped samples).
    ++stats_.frames_other;
    stats_.samples_before_start += b.count;
    return;
  }
  // The index unwrapped by the half-range rule around the one the stream expects.
  int64_t first = have_index_ ? nearest(b.sample_index, next_index_) : int64_t{b.sample_index};
  int skip = 0;  // leading samples of the block that the stream has already passed
  if (have_index_ && first < next_index_) {
    // A block before sample 0 is no copy of this stream's: a loss or a new stream.
    if (out_of_order && first >= 0 && on_stepping(first, b.first_tick)) {
      // A frame numbered just before the newest, its first tick where this stream's stepping
      // puts its index: the link repeated it or delivered it late (a device that restarts
      // numbers its frames and its samples anew). Its samples were handed out, or counted as
      // dropped when a later block skipped them, and the stream cannot go back for them (found
      // in review: a repeated block counted as a counter reset, its 8 samples recorded twice
      // and every later time shifted by 80 ms).
      skip = static_cast<int>(std::min<int64_t>(b.count, next_index_ - first));
      stats_.samples_stale += static_cast<uint64_t>(skip);
      if (skip == b.count) return;
    } else if (is_long_loss(first, b.first_tick, host_time)) {
      first += kIndexRange;  // found in review (2026-11-26): it was taken for a counter reset
    } else {
      // A new streaming session (index restarts at 0, the clock somewhere else), which begins
      // with this block. When frames were lost just before it, enough to hold the samples before
      // its index, those were the new session's first blocks: lost samples (review, 2026-11-27:
      // they counted nothing). Otherwise the index is taken as it comes (a stream caught late).
      ++stats_.counter_resets;
      first = b.sample_index;
      const bool lead_lost =
          b.sample_index > 0 &&
          b.sample_index <= uint64_t{frames_missed_before_} * proto::kMaxBlockSamples;
      next_index_ = lead_lost ? 0 : first;
      tick_ref_.reset();
      last_block_.reset();
    }
  }
  if (have_index_ && first > next_index_)
    stats_.samples_dropped += static_cast<uint64_t>(first - next_index_);
  if (!info_) {
    // Counts cannot be scaled without the DeviceInfo (a capture that starts mid-stream).
    stats_.samples_dropped += b.count;
    next_index_ = first + b.count;
    have_index_ = true;
    return;
  }
  const proto::DeviceInfo& info = *info_;
  // The first tick, unwrapped around where the device's stepping puts it from the last block:
  // right across a loss of any length (found in review: a loss of 2^31 ticks or more unwrapped
  // back by 2^32 ticks and gave a 100 Hz stream a rate of 705.755 Hz).
  const std::optional<int64_t> due = tick_due(first);
  const int64_t tick0 = due ? nearest(b.first_tick, *due) : unwrap_tick(b.first_tick);
  if (skip == 0) last_block_ = BlockStart{first, tick0, host_time};
  tick_ref_ = std::max(tick_ref_.value_or(tick0), tick0);
  const uint64_t per_second_mticks = static_cast<uint64_t>(info.tick_hz) * 1000u;
  auto scale_of = [&](proto::SensorKind kind, float& scale, float& offset) {
    const proto::SensorInfo* s = info.find(kind);
    if (!s || s->range_count == 0) return false;
    // Range index as configured by us (0), or the device default (0).
    scale = s->ranges[0].scale;
    offset = s->offset;
    return true;
  };
  float sa = 0, oa = 0, sg = 0, og = 0, sm = 0, om = 0, st = 0, ot = 0;
  const bool ha =
      (b.channels & proto::kChannelAccel) && scale_of(proto::SensorKind::kAccelerometer, sa, oa);
  const bool hg =
      (b.channels & proto::kChannelGyro) && scale_of(proto::SensorKind::kGyroscope, sg, og);
  const bool hm =
      (b.channels & proto::kChannelMag) && scale_of(proto::SensorKind::kMagnetometer, sm, om);
  const bool ht = (b.channels & proto::kChannelTemperature) &&
                  scale_of(proto::SensorKind::kTemperature, st, ot);
  for (int i = skip; i < b.count; ++i) {
    Sample s;
    s.host_time = host_time;
    s.sequence = static_cast<uint64_t>(first + i);
    s.has_sample_counter = true;
    if (rate_mhz_ > 0 && first >= 0) {
      // The device's stepping counts from the session start: sample n is due at
      // start + floor(n * tick_hz * 1000 / rate_mhz), so within a block the offset from
      // first_tick is the difference of two such floors (not floor(i * period)).
      const auto n0 = static_cast<uint64_t>(first);
      const int64_t offset_ticks = static_cast<int64_t>(
          floor_mul_div(n0 + static_cast<uint64_t>(i), per_second_mticks, rate_mhz_) -
          floor_mul_div(n0, per_second_mticks, rate_mhz_));
      s.device_time = ticks_to_ns(tick0 + offset_ticks, info.tick_hz);
      s.has_device_time = true;
      s.device_ticks = static_cast<uint64_t>(tick0 + offset_ticks);
      s.tick_hz = static_cast<double>(info.tick_hz);
    }
    for (int k = 0; k < 3; ++k) {
      if (ha) s.accel[k] = static_cast<double>(oa) + static_cast<double>(sa) * b.accel[i][k];
      if (hg) s.gyro[k] = static_cast<double>(og) + static_cast<double>(sg) * b.gyro[i][k];
      if (hm) s.mag[k] = static_cast<double>(om) + static_cast<double>(sm) * b.mag[i][k];
    }
    if (ht) s.temperature_c = static_cast<double>(ot) + static_cast<double>(st) * b.temperature[i];
    for (int k = 0; k < 3; ++k) {
      s.raw_accel[k] = b.accel[i][k];
      s.raw_gyro[k] = b.gyro[i][k];
      s.raw_mag[k] = b.mag[i][k];
    }
    s.raw_temperature = b.temperature[i];
    s.channels = static_cast<uint8_t>((ha ? kHasAccel : 0) | (hg ? kHasGyro : 0) |
                                      (hm ? kHasMag : 0) | (ht ? kHasTemperature : 0));
    s.raw_channels =
        static_cast<uint8_t>(((b.channels & proto::kChannelAccel) ? kHasAccel : 0) |
                             ((b.channels & proto::kChannelGyro) ? kHasGyro : 0) |
                             ((b.channels & proto::kChannelMag) ? kHasMag : 0) |
                             ((b.channels & proto::kChannelTemperature) ? kHasTemperature : 0));
    out.push_back(s);
  }
  stats_.samples_decoded += static_cast<uint64_t>(b.count - skip);
  next_index_ = first + b.count;
  have_index_ = true;
}

std::optional<int64_t> ImukitCodec::tick_due(int64_t index) const {
  // Also before sample 0, where the half-range rule can put a block behind a stream that began
  // at 0: is_long_loss judges it on the stepping there as behind any other (found in review,
  // 2026-11-26, fourth round: no tick was due there, so the tick alone said a loss and the host
  // time was never asked).
  if (!last_block_ || !info_ || rate_mhz_ == 0) return std::nullopt;
  // t(n) = t0 + floor(n tick_hz 1000 / rate_mhz) (docs/protocol.md, sample timing).
  const uint64_t per_second_mticks = static_cast<uint64_t>(info_->tick_hz) * 1000u;
  // A tick beyond 2^62, or 2^33 s (272 years) of device time, is no real stream's (a crafted
  // one): not predicted, so that no tick nor its time in ns below can overflow.
  const double approx = static_cast<double>(last_block_->tick) +
                        static_cast<double>(index - last_block_->index) *
                            static_cast<double>(per_second_mticks) / rate_mhz_;
  if (!(std::abs(approx) < 0x1p62 && std::abs(approx) / info_->tick_hz < 0x1p33 &&
        std::abs(static_cast<double>(last_block_->tick)) < 0x1p62))
    return std::nullopt;
  // Each floor is exact modulo 2^64 (floor_mul_div wraps), so their difference is exact: it is
  // far inside the int64 range.
  return last_block_->tick +
         static_cast<int64_t>(
             signed_floor_mul_div(index, per_second_mticks, rate_mhz_) -
             signed_floor_mul_div(last_block_->index, per_second_mticks, rate_mhz_));
}

bool ImukitCodec::on_stepping(int64_t index, uint32_t first_tick) const {
  const std::optional<int64_t> due = tick_due(index);
  return due && std::abs(nearest(first_tick, *due) - *due) <=
                    static_cast<int64_t>(info_->tick_hz) * 500 / rate_mhz_;
}

bool ImukitCodec::is_long_loss(int64_t behind, uint32_t first_tick, TimeNs host_time) const {
  // The 32-bit index cannot tell a loss of J >= 2^31 samples from a step back of 2^32 - J; the
  // device's clock can, as it tells a gap from a restart in capture's DeviceClock. On this
  // stream's stepping at the index ahead and not at the one behind, the tick says a loss.
  const int64_t ahead = behind + kIndexRange;
  if (!on_stepping(ahead, first_tick)) return false;
  if (!on_stepping(behind, first_tick)) return true;
  // On the stepping at both: the period is a whole number of ticks (or near one), so 2^32
  // samples are whole tick wraps and the tick cannot tell. The host time can: a loss of J
  // samples arrives J periods after the last block (J >= 2^31: 24.8 days at 1 kHz), a block of
  // the stream's past at once (half the loss's time lies far from both; a replay, whose host
  // times are when the bytes were read, is a step back as the half-range rule reads it).
  const double loss_ns =
      static_cast<double>(ahead - next_index_) * 1e12 / static_cast<double>(rate_mhz_);
  return static_cast<double>(host_time - last_block_->host) >= 0.5 * loss_ns;
}

int64_t ImukitCodec::unwrap_tick(uint32_t raw) {
  const int64_t t = tick_ref_ ? nearest(raw, *tick_ref_) : int64_t{raw};
  tick_ref_ = std::max(tick_ref_.value_or(t), t);
  return t;
}

}  // namespace imukit::drivers
