#include "imukit/drivers/text_codec.hpp"

#include <charconv>
#include <cmath>
#include <optional>

#include "imukit/core/error.hpp"
#include "imukit/core/text_parse.hpp"
#include "imukit/core/units.hpp"

namespace imukit::drivers {

TextCodecOptions text_codec_options(const CodecOptions& options) {
  TextCodecOptions o;
  const std::string t = option_string(options, "time_unit", "ms");
  if (t == "s")
    o.time_digits = 9;
  else if (t == "ms")
    o.time_digits = 6;
  else if (t == "us")
    o.time_digits = 3;
  else if (t == "ns")
    o.time_digits = 0;
  else
    throw Error("time_unit=" + t + ": expected s, ms, us or ns");
  const std::string bits = option_string(options, "time_bits", "0");
  const std::optional<int64_t> b = parse_scaled_integer(bits, 0);
  // At most 32: the counters that wrap within a recording are 32 bits or fewer, and a wider one
  // would let a few lines carry the unwrapped count past int64 (review of 2026-11-27).
  if (!b || bits.find_first_not_of("0123456789") != std::string::npos || *b > 32)
    throw Error("time_bits=" + bits + ": expected a whole number of bits, 1 to 32 (0: no wrap)");
  o.time_bits = static_cast<unsigned>(*b);
  // The command line's spellings too (core's unit lists): m/s^2, g, mg; rad/s, deg/s.
  const std::string a = option_string(options, "accel_unit", "mps2");
  const std::optional<double> accel = acceleration_unit_factor(a);
  if (!accel) throw Error("accel_unit=" + a + ": expected m/s^2 (mps2), g or mg");
  o.accel_scale = *accel;
  const std::string g = option_string(options, "gyro_unit", "rads");
  const std::optional<double> gyro = angular_rate_unit_factor(g);
  if (!gyro) throw Error("gyro_unit=" + g + ": expected rad/s (rads), deg/s (dps)");
  o.gyro_scale = *gyro;
  return o;
}

TextCodec::TextCodec(TextCodecOptions options) : opt_(options) {
  if (opt_.time_bits > 0) time_counter_.emplace(opt_.time_bits);
}

void TextCodec::decode(std::span<const uint8_t> data, TimeNs host_time, std::vector<Sample>& out) {
  stats_.bytes_received += data.size();
  for (const uint8_t c : data) {
    if (c == '\n') {
      if (overlong_) {
        stats_.bytes_discarded += overlong_bytes_ + 1;
        ++stats_.frames_corrupt;
        ++stats_.samples_dropped;
        ++lines_;
        overlong_ = false;
        overlong_bytes_ = 0;
      } else {
        on_line(line_.size() + 1, host_time, out);
      }
      line_.clear();
      continue;
    }
    if (overlong_) {
      ++overlong_bytes_;
      continue;
    }
    line_.push_back(static_cast<char>(c));
    if (line_.size() > kMaxLine) {
      overlong_ = true;
      overlong_bytes_ = line_.size();
      line_.clear();
    }
  }
}

void TextCodec::decode_end(TimeNs host_time, std::vector<Sample>& out) {
  if (overlong_) {
    stats_.bytes_discarded += overlong_bytes_;
    ++stats_.frames_corrupt;
    ++stats_.samples_dropped;
    overlong_ = false;
    overlong_bytes_ = 0;
  } else if (!line_.empty()) {
    on_line(line_.size(), host_time, out);  // a last line without its newline
  }
  line_.clear();
}

std::optional<int64_t> TextCodec::unwrap_time(std::string_view t) {
  // A wrapping counter is a whole number in [0, 2^bits): anything else is a damaged line.
  const std::optional<int64_t> count = parse_scaled_integer(t, 0);
  if (!count || t.find_first_not_of("0123456789") != std::string_view::npos ||
      *count >= (int64_t{1} << opt_.time_bits))
    return std::nullopt;
  const int64_t unwrapped = time_counter_->unwrap(static_cast<uint64_t>(*count));
  int64_t scale = 1, ns = 0;
  for (int d = 0; d < opt_.time_digits; ++d) scale *= 10;
  if (__builtin_mul_overflow(unwrapped, scale, &ns)) return std::nullopt;
  return ns;
}

void TextCodec::on_line(std::size_t raw_size, TimeNs host_time, std::vector<Sample>& out) {
  std::string_view line(line_);
  if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
  // Blank lines are idle output, neither data nor loss, nor the first line (found in review,
  // 2026-11-27: a sketch's blank Serial.println() before its header made the header a bad line).
  if (line.find_first_not_of(" \t") == std::string_view::npos) {
    stats_.bytes_accepted += raw_size;
    ++stats_.frames_other;
    return;
  }
  const bool first = lines_++ == 0;
  // A serial port opened while the board streams starts inside a line, and the tail of
  // "12345,..." reads as the sample "45,...", its time wrong (review, 2026-11-27). On such a
  // transport the first line is never data: discarded, and counted as a dropped sample if it
  // parses as one (it may have been whole).
  const bool cut = first && may_start_mid_stream_;
  double v[7];
  std::string_view t_field;
  int n = 0;
  bool ok = true;
  std::size_t pos = 0;
  const bool commas = line.find(',') != std::string_view::npos;
  while (pos <= line.size() && ok) {
    if (!commas) {
      while (pos < line.size() && (line[pos] == ' ' || line[pos] == '\t')) ++pos;
      if (pos == line.size()) break;
    }
    std::size_t end = commas ? line.find(',', pos) : line.find_first_of(" \t", pos);
    if (end == std::string_view::npos) end = line.size();
    std::string_view field = line.substr(pos, end - pos);
    while (!field.empty() && (field.front() == ' ' || field.front() == '\t'))
      field.remove_prefix(1);
    while (!field.empty() && (field.back() == ' ' || field.back() == '\t')) field.remove_suffix(1);
    if (n == 7 || field.empty()) {
      ok = false;
      break;
    }
    if (field.front() == '+') field.remove_prefix(1);
    if (n == 0) t_field = field;
    const auto r = std::from_chars(field.data(), field.data() + field.size(), v[n]);
    if (r.ec != std::errc() || r.ptr != field.data() + field.size() || !std::isfinite(v[n])) {
      ok = false;
      break;
    }
    ++n;
    pos = end + 1;
    if (end == line.size()) break;
  }
  if (cut) {
    stats_.bytes_discarded += raw_size;
    if (ok && n == 7) ++stats_.samples_dropped;
    return;
  }
  if (!ok || n != 7) {
    if (first) {
      stats_.bytes_accepted += raw_size;  // a header line
      ++stats_.frames_other;
      return;
    }
    stats_.bytes_discarded += raw_size;
    ++stats_.frames_corrupt;
    ++stats_.samples_dropped;
    return;
  }
  // The time exactly, as column text reads it: through a double, 1700000000.1234567 s came out
  // 68 ns off (found in review, 2026-11-27). Beyond int64 ns it is a bad line.
  std::optional<int64_t> t_ns = parse_scaled_integer(t_field, opt_.time_digits);
  if (time_counter_ && t_ns) t_ns = unwrap_time(t_field);
  Sample s;
  for (int k = 0; k < 3; ++k) {
    s.accel[k] = v[1 + k] * opt_.accel_scale;
    s.gyro[k] = v[4 + k] * opt_.gyro_scale;
  }
  // A value its unit scale makes infinite (1e308 g) is a bad line like one that does not parse:
  // refused here, before it takes a sequence number (the sequence is this codec's own count of
  // lines, so a gap in it would count the line a second time; found in review).
  const bool scaled_finite =
      std::isfinite(s.accel[0] + s.accel[1] + s.accel[2] + s.gyro[0] + s.gyro[1] + s.gyro[2]);
  if (!t_ns || !scaled_finite) {
    stats_.bytes_discarded += raw_size;
    ++stats_.frames_corrupt;
    ++stats_.samples_dropped;
    return;
  }
  stats_.bytes_accepted += raw_size;
  ++stats_.frames_ok;
  s.host_time = host_time;
  s.device_time = *t_ns;
  s.has_device_time = true;
  s.sequence = sequence_++;
  s.channels = kHasAccel | kHasGyro;
  ++stats_.samples_decoded;
  out.push_back(s);
}

}  // namespace imukit::drivers
