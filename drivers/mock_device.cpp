#include "imukit/drivers/mock_device.hpp"

#include <algorithm>
#include <cassert>
#include <chrono>
#include <cmath>
#include <sstream>
#include <thread>

#include "imukit/core/error.hpp"
#include "imukit/core/profile.hpp"
#include "imukit/core/units.hpp"
#include "imukit/drivers/codec.hpp"
#include "imukit/drivers/sources.hpp"

namespace imukit::drivers {
namespace {
constexpr TimeNs kStepNs = 1'000'000;  // virtual-time step: 1 ms
}  // namespace

MockDevice::MockDevice(std::shared_ptr<SignalSource> source, MockOptions options)
    : source_(std::move(source)),
      opt_(std::move(options)),
      link_rng_(opt_.seed, 1),
      sensor_rng_(opt_.seed, 2),
      uplink_rng_(opt_.seed, 3) {
  info_.vendor.set("imukit");
  info_.model.set("mock");
  info_.serial.set(("mock-" + std::to_string(opt_.seed)).c_str());
  info_.firmware_major = 1;
  info_.tick_hz = opt_.tick_hz;
  // The asked rate first (the device's default), then the usual ones.
  std::vector<uint32_t> rates{static_cast<uint32_t>(std::llround(opt_.rate_hz * 1000.0))};
  for (uint32_t r : {100'000u, 200'000u, 400'000u, 800'000u, 1'000'000u}) {
    if (r != rates.front()) rates.push_back(r);
  }
  info_.rate_count = static_cast<uint8_t>(std::min<std::size_t>(rates.size(), proto::kMaxRates));
  for (uint8_t i = 0; i < info_.rate_count; ++i) info_.rates_mhz[i] = rates[i];
  info_.sensor_count = 3;
  proto::SensorInfo& a = info_.sensors[0];
  a.kind = proto::SensorKind::kAccelerometer;
  a.axes = 3;
  a.range_count = 1;
  a.ranges[0].full_scale = static_cast<float>(opt_.accel_range_g * kStandardGravity);
  a.ranges[0].scale = static_cast<float>(opt_.accel_range_g * kStandardGravity / 32768.0);
  proto::SensorInfo& g = info_.sensors[1];
  g.kind = proto::SensorKind::kGyroscope;
  g.axes = 3;
  g.range_count = 1;
  g.ranges[0].full_scale = static_cast<float>(opt_.gyro_range_dps * kRadPerDeg);
  g.ranges[0].scale = static_cast<float>(opt_.gyro_range_dps * kRadPerDeg / 32768.0);
  proto::SensorInfo& t = info_.sensors[2];
  t.kind = proto::SensorKind::kTemperature;
  t.axes = 1;
  t.offset = 25.0f;
  t.range_count = 1;
  t.ranges[0].full_scale = 128.0f;
  t.ranges[0].scale = 1.0f / 256.0f;
  model_ = std::make_unique<proto::DeviceModel>(static_cast<proto::Hal&>(*this), info_);
  real_start_ = host_now();
  if (opt_.streams_from_power_on) power_on_stream();
}

// The firmware of a device that cannot be commanded starts itself: the mock gives its own model
// GetDeviceInfo, whose answer goes to the host (so that a decoding codec can scale the counts),
// and Start, whose Ack goes to the host too (a decoding host passes it by). Found in review:
// with commands=false the mock waited for a Start that never came, and no sample ever arrived;
// and (2026-11-27) a muted Ack still took its frame number, so every such stream showed one
// frame lost.
void MockDevice::power_on_stream() {
  const auto request = [&](const auto& message, uint16_t sequence) {
    uint8_t frame[proto::kMaxFrameSize];
    model_->on_bytes(frame, proto::encode_message(message, sequence, frame, sizeof frame));
  };
  // A profile that cannot run at the rate would be refused (Nack) where nobody hears it: say so.
  validate_hardware_model(opt_.hardware, opt_.rate_hz);
  request(proto::GetDeviceInfo{}, 0);
  request(proto::Start{}, 1);
  assert(model_->state() == proto::DeviceState::kStreaming);
}

MockDevice::~MockDevice() = default;

std::string MockDevice::describe() const {
  std::ostringstream s;
  s << "mock imukit device at " << opt_.rate_hz << " Hz ("
    << (opt_.virtual_time ? "virtual" : "real") << " time, seed " << opt_.seed << ")";
  return s.str();
}

TimeNs MockDevice::now() const { return opt_.virtual_time ? opt_.epoch + t_ : host_now(); }

TimeNs MockDevice::device_ticks_at(TimeNs t) const {
  const long double ticks = static_cast<long double>(t) * opt_.tick_hz *
                            (1.0L + static_cast<long double>(opt_.drift_ppm) * 1e-6L) / 1e9L;
  return static_cast<TimeNs>(std::floor(ticks));
}

uint32_t MockDevice::ticks() { return static_cast<uint32_t>(device_ticks_at(t_)); }

bool MockDevice::apply_configuration(const proto::Configure& config) {
  const double rate = config.rate_mhz / 1000.0;
  try {
    validate_hardware_model(opt_.hardware, rate);
    draw_errors(rate);
  } catch (const Error&) {
    return false;  // NACK kHardwareError: the profile cannot run at this rate
  }
  configured_rate_hz_ = rate;
  return true;
}

void MockDevice::draw_errors(double rate_hz) {
  errors_.emplace(opt_.hardware, rate_hz, sensor_rng_);
  truth_->drawn = true;
  truth_->accelerometer_bias = errors_->accelerometer_constant_bias();
  truth_->gyroscope_bias = errors_->gyroscope_constant_bias();
}

bool MockDevice::read_sensors(uint32_t tick, uint8_t channels, proto::SensorSample& out) {
  if (opt_.disconnect_after > 0 && samples_made_ >= opt_.disconnect_after) {
    gone_ = true;  // the block so far is flushed, then nothing more leaves the device
    return false;
  }
  if (!errors_) {
    draw_errors(configured_rate_hz_ > 0 ? configured_rate_hz_ : opt_.rate_hz);
  }
  // The sample's device tick, unwrapped against the clock now, back to true time.
  const TimeNs now_ticks = device_ticks_at(t_);
  const auto behind = static_cast<uint32_t>(static_cast<uint32_t>(now_ticks) - tick);
  const TimeNs sample_ticks = now_ticks - behind;
  const long double t_true =
      static_cast<long double>(sample_ticks) * 1e9L /
      (opt_.tick_hz * (1.0L + static_cast<long double>(opt_.drift_ppm) * 1e-6L));
  const TimeNs t = static_cast<TimeNs>(std::llround(t_true));
  source_->evaluate(std::span<const TimeNs>(&t, 1), &f_, &w_);
  errors_->apply_gyroscope(w_, f_);
  errors_->apply_accelerometer(f_);
  auto quantise = [](double v, float scale) {
    const double raw = std::round(v / static_cast<double>(scale));
    return static_cast<int16_t>(std::clamp(raw, -32768.0, 32767.0));
  };
  if (channels & proto::kChannelAccel) {
    for (int k = 0; k < 3; ++k) out.accel[k] = quantise(f_(k, 0), info_.sensors[0].ranges[0].scale);
  }
  if (channels & proto::kChannelGyro) {
    for (int k = 0; k < 3; ++k) out.gyro[k] = quantise(w_(k, 0), info_.sensors[1].ranges[0].scale);
  }
  out.temperature = 0;  // 25 degC
  ++samples_made_;
  return true;
}

bool MockDevice::write(const uint8_t* data, std::size_t n) {
  // The block flushed as the device goes is the last frame that leaves it.
  if (gone_ && flushed_after_gone_) return true;
  if (gone_) flushed_after_gone_ = true;
  if (opt_.drop > 0 && link_rng_.uniform() < opt_.drop) {
    ++frames_dropped_;
    // Count the samples it carried: decode our own frame.
    proto::FrameDecoder peek;
    peek.feed(data, n, [&](const proto::Frame& f) {
      proto::SampleBlock b;
      if (proto::parse_message(f, b) == proto::ParseStatus::kOk) samples_in_dropped_ += b.count;
    });
    return true;  // the device believes it was sent; the link lost it
  }
  Pending p;
  p.bytes.assign(data, data + n);
  if (opt_.flip > 0) {
    for (uint8_t& b : p.bytes) {
      if (link_rng_.uniform() < opt_.flip) {
        b = static_cast<uint8_t>(b ^ (1u << link_rng_.uniform_index(8)));
        ++bytes_flipped_;
      }
    }
  }
  TimeNs due = t_ + static_cast<TimeNs>(std::llround(opt_.latency_us * 1e3));
  if (opt_.jitter_us > 0)
    due += static_cast<TimeNs>(std::llround(link_rng_.uniform() * opt_.jitter_us * 1e3));
  const TimeNs stall_start = static_cast<TimeNs>(std::llround(opt_.stall_at_s * 1e9));
  const TimeNs stall_end = stall_start + static_cast<TimeNs>(std::llround(opt_.stall_ms * 1e6));
  if (opt_.stall_ms > 0 && t_ >= stall_start && t_ < stall_end) due = std::max(due, stall_end);
  due = std::max(due, last_due_);  // a serial link keeps order
  last_due_ = due;
  p.due = due;
  pending_.push_back(std::move(p));
  return true;
}

bool MockDevice::store_calibration(const uint8_t* blob, std::size_t n) {
  calibration_.assign(blob, blob + n);
  return true;
}

std::size_t MockDevice::load_calibration(uint8_t* out, std::size_t capacity) {
  if (calibration_.empty() || calibration_.size() > capacity) return 0;
  std::copy(calibration_.begin(), calibration_.end(), out);
  return calibration_.size();
}

void MockDevice::advance_to(TimeNs t) {
  // Host bytes arrive at their own due times, between the samples that fall before and after.
  while (!inbound_.empty() && inbound_.front().due <= t) {
    t_ = std::max(t_, inbound_.front().due);
    model_->poll();
    if (!gone_) model_->on_bytes(inbound_.front().bytes.data(), inbound_.front().bytes.size());
    inbound_.pop_front();
  }
  t_ = std::max(t_, t);
  model_->poll();
}

ReadResult MockDevice::read(std::span<uint8_t> buf, int timeout_ms) {
  ReadResult r;
  const TimeNs deadline = t_ + static_cast<TimeNs>(timeout_ms) * 1'000'000;
  for (;;) {
    if (!pending_.empty() && pending_.front().due <= t_) {
      // Deliver everything due, up to the buffer size.
      TimeNs last = 0;
      while (!pending_.empty() && pending_.front().due <= t_ && r.size < buf.size()) {
        Pending& p = pending_.front();
        const std::size_t n = std::min(buf.size() - r.size, p.bytes.size());
        std::copy_n(p.bytes.begin(), n, buf.begin() + static_cast<std::ptrdiff_t>(r.size));
        r.size += n;
        last = p.due;
        if (n == p.bytes.size()) {
          pending_.pop_front();
        } else {
          p.bytes.erase(p.bytes.begin(), p.bytes.begin() + static_cast<std::ptrdiff_t>(n));
        }
      }
      r.host_time = opt_.virtual_time ? opt_.epoch + last : host_now();
      return r;
    }
    if (gone_ && pending_.empty()) {
      r.end = true;
      r.end_reason = "mock device disconnected after " + std::to_string(samples_made_) +
                     " samples (disconnect_after)";
      r.host_time = now();
      return r;
    }
    if (t_ >= deadline) {
      r.host_time = now();
      return r;
    }
    if (opt_.virtual_time) {
      // Step to the next sample's due time (so frames leave exactly when a firmware would send
      // them), at most 1 ms, never past the read's deadline.
      TimeNs next = t_ + kStepNs;
      if (model_->state() == proto::DeviceState::kStreaming) {
        const TimeNs now_ticks = device_ticks_at(t_);
        const uint32_t ahead = model_->next_sample_tick() - static_cast<uint32_t>(now_ticks);
        if (ahead < 0x80000000u) {
          const long double due =
              static_cast<long double>(now_ticks + ahead) * 1e9L /
              (opt_.tick_hz * (1.0L + static_cast<long double>(opt_.drift_ppm) * 1e-6L));
          next = std::clamp(static_cast<TimeNs>(std::ceil(due)), t_ + 1, t_ + kStepNs);
        }
      }
      advance_to(std::min(deadline, next));
    } else {
      std::this_thread::sleep_for(std::chrono::microseconds(500));
      advance_to(host_now() - real_start_);
    }
  }
}

void MockDevice::write(std::span<const uint8_t> bytes) {
  if (gone_) return;  // the cable is out: commands go nowhere, read() reports the end
  if (opt_.latency_us <= 0 && opt_.jitter_us <= 0) {
    model_->on_bytes(bytes.data(), bytes.size());
    return;
  }
  TimeNs due = t_ + static_cast<TimeNs>(std::llround(opt_.latency_us * 1e3));
  if (opt_.jitter_us > 0)
    due += static_cast<TimeNs>(std::llround(uplink_rng_.uniform() * opt_.jitter_us * 1e3));
  if (!inbound_.empty()) due = std::max(due, inbound_.back().due);  // in order
  inbound_.push_back({due, std::vector<uint8_t>(bytes.begin(), bytes.end())});
}

std::unique_ptr<MockDevice> make_mock_device(const std::string& kind,
                                             const std::map<std::string, std::string>& keys) {
  MockOptions o;
  o.rate_hz = option_double(keys, "rate", 400.0);
  if (!(o.rate_hz > 0 && o.rate_hz <= 16000)) throw Error("rate: expected 0 < rate <= 16000 Hz");
  const int64_t seed = option_int(keys, "seed", 1);
  // A negative seed would wrap to a huge unsigned one (found in review: seed=-1 ran as
  // 18446744073709551615): refused, so a seed means what it says.
  if (seed < 0) throw Error("seed=" + keys.at("seed") + ": expected an integer >= 0");
  o.seed = static_cast<uint64_t>(seed);
  o.drop = option_double(keys, "drop", 0.0);
  o.flip = option_double(keys, "flip", 0.0);
  if (o.drop < 0 || o.drop > 1) throw Error("drop: expected a probability in [0, 1]");
  if (o.flip < 0 || o.flip > 1) throw Error("flip: expected a probability in [0, 1]");
  o.drift_ppm = option_double(keys, "drift_ppm", 0.0);
  if (std::abs(o.drift_ppm) > 1e5) throw Error("drift_ppm: expected |drift| <= 100000 ppm");
  o.latency_us = option_double(keys, "latency_us", 0.0);
  o.jitter_us = option_double(keys, "jitter_us", 0.0);
  o.stall_ms = option_double(keys, "stall_ms", 0.0);
  o.stall_at_s = option_double(keys, "stall_at_s", 1.0);
  // Bounded so that every delay stays a representable count of ns: 1e7 us and ms (10 s and
  // about 3 h) are far beyond any link.
  if (!(o.latency_us >= 0 && o.latency_us <= 1e7) || !(o.jitter_us >= 0 && o.jitter_us <= 1e7) ||
      !(o.stall_ms >= 0 && o.stall_ms <= 1e7) || !(o.stall_at_s >= 0 && o.stall_at_s <= 1e7)) {
    throw Error("latency_us, jitter_us, stall_ms and stall_at_s must be in [0, 1e7]");
  }
  const int64_t disc = option_int(keys, "disconnect_after", 0);
  if (disc < 0) throw Error("disconnect_after: expected a sample count >= 0");
  o.disconnect_after = static_cast<uint64_t>(disc);
  const std::string clock = option_string(keys, "clock", "real");
  if (clock != "real" && clock != "virtual")
    throw Error("clock=" + clock + ": expected real or virtual");
  o.virtual_time = clock == "virtual";
  // The host will send nothing (the URI's codec only decodes): the device starts by itself.
  o.streams_from_power_on = !option_bool(keys, "commands", true);
  const std::string profile = option_string(keys, "profile", "");
  if (!profile.empty()) o.hardware = to_hardware_model(read_profile(profile));
  const double gravity = option_double(keys, "gravity", kStandardGravity);
  if (!(gravity > 0 && gravity <= 100)) throw Error("gravity: expected (0, 100] m/s^2");

  std::shared_ptr<SignalSource> source;
  if (kind == "static") {
    Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
    const std::string qs = option_string(keys, "quat", "");
    if (!qs.empty()) {
      double v[4];
      std::size_t pos = 0;
      for (int i = 0; i < 4; ++i) {
        const std::size_t end = qs.find(',', pos);
        if ((i < 3) == (end == std::string::npos)) throw Error("quat=" + qs + ": expected w,x,y,z");
        const std::map<std::string, std::string> one{{"quat", qs.substr(pos, end - pos)}};
        v[i] = option_double(one, "quat", 0.0);
        pos = end + 1;
      }
      q = Eigen::Quaterniond(v[0], v[1], v[2], v[3]);
      if (!(q.norm() > 1e-9)) throw Error("quat=" + qs + ": a zero quaternion is no rotation");
      q.normalize();
    }
    source = std::make_shared<StaticSource>(q, gravity);
  } else if (kind == "poses") {
    const double hold = option_double(keys, "hold_s", 5.0);
    const double move = option_double(keys, "move_s", 2.0);
    // The first pose is held long enough for the initial still period `record --guide` asks
    // for (10 s by default, plus the guide's stillness window).
    const double init = option_double(keys, "init_s", 12.0);
    if (!(hold >= 0 && hold <= 3600) || !(move > 0 && move <= 3600) || !(init >= 0 && init <= 3600))
      throw Error("hold_s and init_s must be in [0, 3600] s, move_s in (0, 3600] s");
    const int64_t count = option_int(keys, "poses", 6);
    if (count < 1 || count > 26)
      throw Error("poses: expected 1 to 26 poses (6: the six faces; more: a tilt tour)");
    // Six or fewer: the faces (what the existing recordings and tests use); more: the tilt tour.
    auto poses = PosesSource::six_faces();
    if (count > 6) {
      poses = PosesSource::tilt_tour(static_cast<int>(count));
    } else {
      poses.resize(static_cast<std::size_t>(count));
    }
    source = std::make_shared<PosesSource>(std::move(poses), hold, move, gravity, init);
  } else {
    throw Error("mock:" + kind + ": unknown mock (known: static, poses)");
  }
  return std::make_unique<MockDevice>(std::move(source), std::move(o));
}

}  // namespace imukit::drivers
