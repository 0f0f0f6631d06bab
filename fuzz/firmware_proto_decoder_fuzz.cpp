// Fuzzes the imukit wire protocol v1 (firmware_proto) from both ends of the link:
//  - the host side: FrameDecoder over the input in chunk sizes the input itself chooses, every
//    frame parsed as its message type; a payload that parses must re-encode to the same bytes,
//    and the decoder's byte accounting must balance;
//  - COBS on its own: a successful decode re-encodes to something that decodes the same;
//  - the device side: the same bytes sent to a DeviceModel (with a fake HAL whose clock advances
//    on every call, so streaming starts when the input asks for it); everything the device writes
//    must decode as valid frames with consecutive sequence numbers and parse.
// Any violation traps. Seed corpus: the golden frames of docs/protocol.md
// (fuzz/corpus/firmware_proto). Full run: ./build-fuzz/fuzz/fuzz_firmware_proto_decoder
// -max_total_time=600 fuzz/corpus/firmware_proto
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <vector>

#include "imukit/firmware_proto/cobs.hpp"
#include "imukit/firmware_proto/device_model.hpp"
#include "imukit/firmware_proto/frame.hpp"
#include "imukit/firmware_proto/messages.hpp"

namespace {

namespace proto = imukit::proto;

void check(bool ok) {
  if (!ok) __builtin_trap();
}

template <class M>
void roundtrip(const proto::Frame& f) {
  M m;
  if (proto::parse_message(f, m) != proto::ParseStatus::kOk) return;
  uint8_t out[proto::kMaxPayloadSize];
  proto::ByteWriter w(out, sizeof out);
  check(proto::write_payload(w, m));
  check(w.size() == f.payload_size);
  check(f.payload_size == 0 || std::memcmp(out, f.payload, f.payload_size) == 0);
}

void parse_any(const proto::Frame& f) {
  using proto::MessageType;
  switch (static_cast<MessageType>(f.type)) {
    case MessageType::kGetDeviceInfo:
      return roundtrip<proto::GetDeviceInfo>(f);
    case MessageType::kConfigure:
      return roundtrip<proto::Configure>(f);
    case MessageType::kStart:
      return roundtrip<proto::Start>(f);
    case MessageType::kStop:
      return roundtrip<proto::Stop>(f);
    case MessageType::kPing:
      return roundtrip<proto::Ping>(f);
    case MessageType::kCalibrationRead:
      return roundtrip<proto::CalibrationRead>(f);
    case MessageType::kCalibrationWrite:
      return roundtrip<proto::CalibrationWrite>(f);
    case MessageType::kDeviceInfo:
      return roundtrip<proto::DeviceInfo>(f);
    case MessageType::kSampleBlock:
      return roundtrip<proto::SampleBlock>(f);
    case MessageType::kPong:
      return roundtrip<proto::Pong>(f);
    case MessageType::kCalibrationData:
      return roundtrip<proto::CalibrationData>(f);
    case MessageType::kAck:
      return roundtrip<proto::Ack>(f);
    case MessageType::kNack:
      return roundtrip<proto::Nack>(f);
    case MessageType::kLog:
      return roundtrip<proto::Log>(f);
  }
}

// Receives what the device writes and checks it.
class FuzzHal final : public proto::Hal {
 public:
  uint32_t clock = 0;
  bool storage_full = false;
  uint8_t storage[proto::kMaxCalibrationBlobSize] = {};
  size_t stored = 0;
  proto::FrameDecoder host;
  uint32_t frames = 0;

  uint32_t ticks() override { return clock += 97; }
  bool read_sensors(uint32_t tick, uint8_t, proto::SensorSample& out) override {
    out.accel[0] = static_cast<int16_t>(tick);
    out.gyro[2] = static_cast<int16_t>(tick >> 3);
    return (tick & 0x3F0) != 0x3F0;  // now and then a failed read
  }
  bool write(const uint8_t* data, size_t n) override {
    check(n > 0 && n <= proto::kMaxFrameSize && data[n - 1] == 0);
    host.feed(data, n, [&](const proto::Frame& f) {
      check(f.sequence == static_cast<uint16_t>(frames));
      ++frames;
      parse_any(f);
    });
    check(host.stats().frames_rejected() == 0 && host.pending() == 0);
    return (clock & 0x700) != 0x700;  // and now and then a refused write
  }
  bool apply_configuration(const proto::Configure&) override { return true; }
  bool store_calibration(const uint8_t* blob, size_t n) override {
    check(n <= sizeof storage);
    std::memcpy(storage, blob, n);
    stored = n;
    return true;
  }
  size_t load_calibration(uint8_t* out, size_t capacity) override {
    check(stored <= capacity);
    std::memcpy(out, storage, stored);
    return stored;
  }
};

// The device of the golden frames (docs/protocol.md), so the corpus' Configure is accepted.
proto::DeviceInfo fuzz_device() {
  proto::DeviceInfo d;
  d.vendor.set("imukit");
  d.model.set("GF-1");
  d.serial.set("42");
  d.tick_hz = 1000000;
  d.rate_count = 2;
  d.rates_mhz[0] = 100000;
  d.rates_mhz[1] = 1000000;
  d.sensor_count = 3;
  d.sensors[0] = {proto::SensorKind::kAccelerometer,
                  3,
                  0.0f,
                  2,
                  {{16.0f, 0.00048828125f}, {128.0f, 0.00390625f}}};
  d.sensors[1] = {proto::SensorKind::kGyroscope, 3, 0.0f, 1, {{8.0f, 0.000244140625f}}};
  d.sensors[2] = {proto::SensorKind::kTemperature, 1, 25.0f, 1, {{128.0f, 0.00390625f}}};
  return d;
}

// Raw mode: the input is a byte stream from the link, for the decoder, COBS and the device.
void fuzz_stream(const uint8_t* data, size_t size) {
  // Host side, chunked by a pattern taken from the first byte.
  {
    proto::FrameDecoder decoder;
    const size_t chunk_base = size > 0 ? 1 + data[0] % 64 : 1;
    size_t pos = 0;
    size_t k = 0;
    while (pos < size) {
      size_t chunk = chunk_base + (k++ * 7) % 13;
      if (chunk > size - pos) chunk = size - pos;
      decoder.feed(data + pos, chunk, [&](const proto::Frame& f) {
        check(f.payload_size <= proto::kMaxPayloadSize && f.version == proto::kProtocolVersion);
        parse_any(f);
      });
      pos += chunk;
    }
    const proto::DecoderStats& s = decoder.stats();
    check(s.bytes_received == size);
    check(s.bytes_received == s.bytes_accepted + s.bytes_discarded + decoder.pending());
  }
  // COBS alone.
  {
    std::vector<uint8_t> decoded(size + 1);
    const size_t n = proto::cobs_decode(data, size, decoded.data());
    if (n != proto::kCobsError) {
      check(n < size);
      std::vector<uint8_t> again(proto::cobs_max_encoded_size(n));
      const size_t m = proto::cobs_encode(decoded.data(), n, again.data(), again.size());
      check(m > 0);
      std::vector<uint8_t> back(m);
      check(proto::cobs_decode(again.data(), m, back.data()) == n);
      check(std::memcmp(back.data(), decoded.data(), n) == 0);
    }
  }
  // Device side: the input as host traffic, polling between chunks of 16 bytes.
  {
    FuzzHal hal;
    proto::DeviceModel device(hal, fuzz_device());
    check(device.valid_info());
    for (size_t pos = 0; pos < size; pos += 16) {
      const size_t chunk = size - pos < 16 ? size - pos : 16;
      device.on_bytes(data + pos, chunk);
      device.poll();
    }
    const proto::DeviceStats& s = device.stats();
    check(s.samples_taken ==
          s.samples_sent + s.samples_dropped + s.sensor_read_errors + device.pending_samples());
  }
}

// Message mode: records of type u8, length u16 LE, payload. Mutations of the payload then reach
// the parsers and the device without first having to match a CRC: each record goes to the
// parsers as a decoded frame, and, framed with a correct CRC, to the device.
void fuzz_messages(const uint8_t* data, size_t size) {
  FuzzHal hal;
  proto::DeviceModel device(hal, fuzz_device());
  uint8_t wire[proto::kMaxFrameSize];
  uint16_t seq = 0;
  size_t pos = 0;
  while (size - pos >= 3) {
    const uint8_t type = data[pos];
    size_t n = static_cast<size_t>(data[pos + 1] | data[pos + 2] << 8);
    pos += 3;
    if (n > size - pos) n = size - pos;
    if (n > proto::kMaxPayloadSize) n = proto::kMaxPayloadSize;
    // A copy of exactly n bytes, so ASan sees any read past the payload.
    std::vector<uint8_t> payload(data + pos, data + pos + n);
    pos += n;
    const proto::Frame frame{proto::kProtocolVersion, type, seq, payload.data(), n};
    parse_any(frame);
    const size_t w = proto::encode_frame(type, seq++, payload.data(), n, wire, sizeof wire);
    check(w > 0);
    device.on_bytes(wire, w);
    hal.clock += 5000;
    device.poll();
  }
  const proto::DeviceStats& s = device.stats();
  check(s.samples_taken ==
        s.samples_sent + s.samples_dropped + s.sensor_read_errors + device.pending_samples());
}

}  // namespace

// Inputs starting with 0xA5 are message records (fuzz_messages), all others a raw byte stream.
extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size > 0 && data[0] == 0xA5) {
    fuzz_messages(data + 1, size - 1);
  } else {
    fuzz_stream(data, size);
  }
  return 0;
}
