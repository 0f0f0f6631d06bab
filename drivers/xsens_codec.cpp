#include "imukit/drivers/xsens_codec.hpp"

#include <algorithm>
#include <cstring>

namespace imukit::drivers {
namespace {

uint32_t be32(const uint8_t* p) {
  return (uint32_t{p[0]} << 24) | (uint32_t{p[1]} << 16) | (uint32_t{p[2]} << 8) | p[3];
}

// One component of a vector item in the precision the data id's low two bits select.
double read_component(const uint8_t* p, unsigned precision) {
  switch (precision) {
    case 0: {  // IEEE float32, big-endian
      const uint32_t bits = be32(p);
      float f;
      std::memcpy(&f, &bits, 4);
      return f;
    }
    case 1:  // fixed point 12.20: signed 32-bit, 2^-20 per LSB
      return static_cast<double>(static_cast<int32_t>(be32(p))) / 1048576.0;
    case 2: {  // fixed point 16.32: 32-bit fraction, then signed 16-bit integer part
      const int64_t whole = static_cast<int16_t>((p[4] << 8) | p[5]);
      const uint64_t raw = (static_cast<uint64_t>(whole) << 32) | be32(p);
      return static_cast<double>(static_cast<int64_t>(raw)) / 4294967296.0;
    }
    default: {  // IEEE float64
      const uint64_t bits = (uint64_t{be32(p)} << 32) | be32(p + 4);
      double d;
      std::memcpy(&d, &bits, 8);
      return d;
    }
  }
}

constexpr std::size_t kWidth[4] = {4, 4, 6, 8};

bool read_vector(std::span<const uint8_t> v, unsigned precision, std::size_t n, double* out) {
  if (v.size() != n * kWidth[precision]) return false;
  for (std::size_t i = 0; i < n; ++i)
    out[i] = read_component(v.data() + i * kWidth[precision], precision);
  return true;
}

}  // namespace

std::vector<uint8_t> xsens_frame(uint8_t mid, std::span<const uint8_t> payload) {
  std::vector<uint8_t> f{xsens::kPreamble, xsens::kMasterBid, mid};
  if (payload.size() < 0xFF) {
    f.push_back(static_cast<uint8_t>(payload.size()));
  } else {
    f.push_back(0xFF);
    f.push_back(static_cast<uint8_t>(payload.size() >> 8));
    f.push_back(static_cast<uint8_t>(payload.size()));
  }
  f.insert(f.end(), payload.begin(), payload.end());
  uint8_t sum = 0;
  for (std::size_t i = 1; i < f.size(); ++i) sum = static_cast<uint8_t>(sum + f[i]);
  f.push_back(static_cast<uint8_t>(-sum));  // byte sum from BID to CS is 0 mod 256
  return f;
}

std::vector<uint8_t> xsens_output_configuration(std::span<const XsensOutput> outputs) {
  std::vector<uint8_t> p;
  for (const XsensOutput& o : outputs) {
    p.push_back(static_cast<uint8_t>(o.data_id >> 8));
    p.push_back(static_cast<uint8_t>(o.data_id));
    p.push_back(static_cast<uint8_t>(o.rate_hz >> 8));
    p.push_back(static_cast<uint8_t>(o.rate_hz));
  }
  return p;
}

std::vector<uint8_t> xsens_configure_commands(uint16_t rate_hz, uint16_t mag_rate_hz) {
  const uint16_t mag = std::min(rate_hz, mag_rate_hz);
  const XsensOutput outputs[] = {{xsens::kPacketCounter, xsens::kMaxRate},
                                 {xsens::kSampleTimeFine, xsens::kMaxRate},
                                 {xsens::kAcceleration, rate_hz},
                                 {xsens::kRateOfTurn, rate_hz},
                                 {xsens::kMagneticField, mag},
                                 {xsens::kTemperature, mag},
                                 {xsens::kStatusWord, xsens::kMaxRate}};
  std::vector<uint8_t> out = xsens_frame(xsens::kMidGoToConfig, {});
  const auto cfg =
      xsens_frame(xsens::kMidSetOutputConfiguration, xsens_output_configuration(outputs));
  out.insert(out.end(), cfg.begin(), cfg.end());
  const auto meas = xsens_frame(xsens::kMidGoToMeasurement, {});
  out.insert(out.end(), meas.begin(), meas.end());
  return out;
}

bool parse_mtdata2(std::span<const uint8_t> payload, XsensPacket& out) {
  out = XsensPacket{};
  std::size_t pos = 0;
  while (pos < payload.size()) {
    if (payload.size() - pos < 3) return false;
    const uint16_t id = static_cast<uint16_t>((payload[pos] << 8) | payload[pos + 1]);
    const std::size_t size = payload[pos + 2];
    pos += 3;
    if (payload.size() - pos < size) return false;
    const std::span<const uint8_t> v = payload.subspan(pos, size);
    pos += size;
    const unsigned precision = id & 0x3u;
    // The coordinate-system bits (2..3) do not change how values are read.
    switch (id & 0xFFF0u) {
      case xsens::kPacketCounter & 0xFFF0u:
        if (size != 2) return false;
        out.packet_counter = static_cast<uint16_t>((v[0] << 8) | v[1]);
        break;
      case xsens::kSampleTimeFine & 0xFFF0u:
        if (size != 4) return false;
        out.sample_time_fine = be32(v.data());
        break;
      case xsens::kAcceleration & 0xFFF0u:
      case xsens::kRateOfTurn & 0xFFF0u:
      case xsens::kMagneticField & 0xFFF0u: {
        std::array<double, 3> a{};
        if (!read_vector(v, precision, 3, a.data())) return false;
        const unsigned group = id & 0xFFF0u;
        if (group == (xsens::kAcceleration & 0xFFF0u))
          out.acceleration = a;
        else if (group == (xsens::kRateOfTurn & 0xFFF0u))
          out.rate_of_turn = a;
        else
          out.magnetic_field = a;
        break;
      }
      case xsens::kTemperature & 0xFFF0u: {
        double t = 0;
        if (!read_vector(v, precision, 1, &t)) return false;
        out.temperature = t;
        break;
      }
      case xsens::kStatusWord & 0xFFF0u:
        if (size != 4) return false;
        out.status_word = be32(v.data());
        break;
      default:
        break;  // quaternion, delta-v, pressure, ...: not imukit's business
    }
  }
  return true;
}

XsensCodec::XsensCodec(XsensCodecOptions options) : opt_(options) {}

void XsensCodec::start(TimeNs) {
  if (opt_.rate_hz > 0) {
    const auto cmds = xsens_configure_commands(opt_.rate_hz, opt_.mag_rate_hz);
    queue(cmds);
  }
}

void XsensCodec::decode(std::span<const uint8_t> data, TimeNs host_time, std::vector<Sample>& out) {
  stats_.bytes_received += data.size();
  buf_.insert(buf_.end(), data.begin(), data.end());
  parse(host_time, out, false);
}

void XsensCodec::decode_end(TimeNs host_time, std::vector<Sample>& out) {
  parse(host_time, out, true);
}

void XsensCodec::parse(TimeNs host_time, std::vector<Sample>& out, bool at_end) {
  for (;;) {
    // Skip to the next preamble.
    std::size_t p = head_;
    while (p < buf_.size() && buf_[p] != xsens::kPreamble) ++p;
    stats_.bytes_discarded += p - head_;
    // Bytes that are no frame, beyond the frame already counted: a frame whose preamble was
    // damaged. Its length is unknown, so what is rejected up to the next valid frame is part
    // of it.
    if (p != head_ && base_ + p > damaged_until_) {
      ++stats_.frames_corrupt;
      damaged_until_ = UINT64_MAX;
    }
    head_ = p;
    const std::size_t avail = buf_.size() - head_;
    if (avail == 0) break;
    const uint8_t* f = buf_.data() + head_;
    std::size_t header = 4;
    std::size_t len = 0;
    bool complete = false;
    bool bad = false;
    if (avail >= 4) {
      len = f[3];
      if (len == 0xFF) {
        header = 6;
        if (avail >= 6) {
          len = (std::size_t{f[4]} << 8) | f[5];
          if (len > xsens::kMaxDataLength) bad = true;
        }
      }
      if (!bad && avail >= header && avail >= header + len + 1) complete = true;
    }
    if (!complete && !bad) {
      if (!at_end) break;
      bad = true;  // the stream ended inside this frame
    }
    if (!bad) {
      uint8_t sum = 0;
      for (std::size_t i = 1; i < header + len + 1; ++i) sum = static_cast<uint8_t>(sum + f[i]);
      if (sum != 0) bad = true;
    }
    if (bad) {
      // Not a frame here (corruption, or a data byte that looked like a preamble): drop the
      // preamble byte and resynchronise on the next one. Preamble bytes inside the frame that
      // failed (up to the end its length gives) fail too but are not frames of their own; a
      // failure beyond it is the next damaged frame.
      if (base_ + head_ >= damaged_until_) {
        ++stats_.frames_corrupt;
        const bool length_known = avail >= header && len <= xsens::kMaxDataLength;
        damaged_until_ = length_known ? base_ + head_ + header + len + 1 : UINT64_MAX;
      }
      ++stats_.bytes_discarded;
      ++head_;
      continue;
    }
    damaged_until_ = 0;
    const std::size_t total = header + len + 1;
    stats_.bytes_accepted += total;
    ++stats_.frames_ok;
    on_message(f[2], std::span<const uint8_t>(f + header, len), host_time, out);
    head_ += total;
  }
  // Compact once the consumed prefix dominates.
  if (head_ > 4096 && head_ * 2 > buf_.size()) {
    buf_.erase(buf_.begin(), buf_.begin() + static_cast<std::ptrdiff_t>(head_));
    base_ += head_;
    head_ = 0;
  }
}

void XsensCodec::on_message(uint8_t mid, std::span<const uint8_t> data, TimeNs host_time,
                            std::vector<Sample>& out) {
  if (mid != xsens::kMidMtData2) {
    ++stats_.frames_other;
    if (mid == xsens::kMidError) ++stats_.device_errors;
    messages_.push_back(mid);
    return;
  }
  XsensPacket pk;
  if (!parse_mtdata2(data, pk)) {
    ++stats_.device_errors;  // checksum fine, content malformed: the device's fault
    ++stats_.frames_other;
    return;
  }
  Sample s;
  s.host_time = host_time;
  if (pk.packet_counter) {
    const bool first = !counter_.started();
    int64_t c = counter_.unwrap(*pk.packet_counter);
    if (counter_.last_step() > 1)
      stats_.samples_dropped += static_cast<uint64_t>(counter_.last_step() - 1);
    if (!first && counter_.last_step() <= 0) {
      // A repeated or earlier counter: the device restarted (or a packet came twice).
      // Counted, and the counter is followed from here.
      ++stats_.counter_resets;
      counter_.reset();
      c = counter_.unwrap(*pk.packet_counter);
    }
    s.sequence = static_cast<uint64_t>(c);
    s.has_sample_counter = true;
  } else {
    s.sequence = decoded_;
  }
  if (pk.sample_time_fine) {
    s.device_time = ticks_to_ns(time_.unwrap(*pk.sample_time_fine), 10'000);
    s.has_device_time = true;
  }
  if (pk.acceleration) {
    s.accel = *pk.acceleration;
    s.channels |= kHasAccel;
  }
  if (pk.rate_of_turn) {
    s.gyro = *pk.rate_of_turn;
    s.channels |= kHasGyro;
  }
  if (pk.magnetic_field) {
    s.mag = *pk.magnetic_field;
    s.mag_arbitrary_units = true;
    s.channels |= kHasMag;
  }
  if (pk.temperature) {
    s.temperature_c = *pk.temperature;
    s.channels |= kHasTemperature;
  }
  if (pk.status_word) s.status = *pk.status_word;
  if (s.channels == 0) {
    ++stats_.frames_other;  // e.g. orientation only: nothing imukit records
    return;
  }
  ++decoded_;
  ++stats_.samples_decoded;
  out.push_back(s);
}

}  // namespace imukit::drivers
