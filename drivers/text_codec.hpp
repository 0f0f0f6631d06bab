// Codec for the text lines many Arduino sketches print: `t,ax,ay,az,gx,gy,gz` separated by
// commas or blanks, one sample per line ("\n" or "\r\n"). Units are stated, never guessed:
// time_unit s|ms|us|ns (default ms, Arduino's millis()), accel_unit g|mps2 (default mps2),
// gyro_unit dps|rads (default rads). A first line that is not numeric is a header and skipped;
// any later line that does not parse (wrong field count, not a number, non-finite, longer than
// 512 bytes) is counted as a corrupt frame and a dropped sample. The device time is the t column,
// unwrapped where time_bits says it counts modulo 2^bits (Arduino's micros() is 32 bits: at
// time_unit=us it wraps every 71.6 minutes, which would read as a restart of the device clock).
#pragma once

#include <optional>

#include "imukit/drivers/codec.hpp"

namespace imukit::drivers {

struct TextCodecOptions {
  int time_digits = 6;  // decimal digits from the unit of t to ns (s 9, ms 6, us 3, ns 0)
  // t counts modulo 2^time_bits (1..32; t a whole number); 0: it does not wrap.
  unsigned time_bits = 0;
  double accel_scale = 1.0;  // m/s^2 per unit
  double gyro_scale = 1.0;   // rad/s per unit
};

// Options from `time_unit`, `time_bits`, `accel_unit`, `gyro_unit` keys; throws imukit::Error
// naming a bad key value.
TextCodecOptions text_codec_options(const CodecOptions& options);

class TextCodec : public Codec {
 public:
  explicit TextCodec(TextCodecOptions options = {});
  std::string name() const override { return "text"; }
  // An overlong line's bytes are held (not yet discarded) until its newline.
  std::size_t bytes_pending() const override { return line_.size() + overlong_bytes_; }

  static constexpr std::size_t kMaxLine = 512;

 protected:
  void decode(std::span<const uint8_t> data, TimeNs host_time, std::vector<Sample>& out) override;
  void decode_end(TimeNs host_time, std::vector<Sample>& out) override;

 private:
  void on_line(std::size_t raw_size, TimeNs host_time, std::vector<Sample>& out);
  // t (a whole count modulo 2^time_bits) unwrapped, in ns; nullopt for a damaged t.
  std::optional<int64_t> unwrap_time(std::string_view t);

  TextCodecOptions opt_;
  std::string line_;
  bool overlong_ = false;
  std::size_t overlong_bytes_ = 0;
  uint64_t lines_ = 0;
  uint64_t sequence_ = 0;
  std::optional<CounterUnwrapper> time_counter_;  // with time_bits
};

}  // namespace imukit::drivers
