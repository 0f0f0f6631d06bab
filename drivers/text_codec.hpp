// Codec for the text lines many Arduino sketches print: `t,ax,ay,az,gx,gy,gz` separated by
// commas or blanks, one sample per line ("\n" or "\r\n"). Units are stated, never guessed:
// time_unit s|ms|us|ns (default ms, Arduino's millis()), accel_unit g|mps2 (default mps2),
// gyro_unit dps|rads (default rads). A first line that is not numeric is a header and skipped;
// any later line that does not parse (wrong field count, not a number, non-finite, longer than
// 512 bytes) is counted as a corrupt frame and a dropped sample. The device time is the t column.
#pragma once

#include "imukit/drivers/codec.hpp"

namespace imukit::drivers {

struct TextCodecOptions {
  int time_digits = 6;       // decimal digits from the unit of t to ns (s 9, ms 6, us 3, ns 0)
  double accel_scale = 1.0;  // m/s^2 per unit
  double gyro_scale = 1.0;   // rad/s per unit
};

// Options from `time_unit`, `accel_unit`, `gyro_unit` keys; throws imukit::Error naming a bad
// key value.
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

  TextCodecOptions opt_;
  std::string line_;
  bool overlong_ = false;
  std::size_t overlong_bytes_ = 0;
  uint64_t lines_ = 0;
  uint64_t sequence_ = 0;
};

}  // namespace imukit::drivers
