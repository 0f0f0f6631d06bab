#!/usr/bin/env bash
# Cross-compiles firmware_proto (the imukit wire protocol, docs/protocol.md) for a Cortex-M4 the
# way a firmware would build it, links it into a small program that uses the encoder, the decoder,
# every message parser and a DeviceModel (so nothing is discarded by --gc-sections), prints code
# and RAM sizes, and fails if anything pulls in the heap (malloc/free, operator new/delete),
# exceptions (__cxa_throw, personality routines, unwinder) or RTTI (typeinfo, dynamic_cast), or
# any part of libstdc++/libsupc++ at all.
#
# The link uses -nostdlib -nostartfiles with an explicit -lc -lgcc, so the program contains only
# what firmware_proto and the small main below need (memcpy, memchr, ... from newlib, 64-bit
# division from libgcc): no C runtime startup whose own use of malloc would hide ours.
#
# Needs: apt-get install --no-install-recommends gcc-arm-none-eabi libnewlib-arm-none-eabi
# Usage: bash scripts/check_firmware_size.sh   (exit status 0 = pass; one line per finding)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
prefix=arm-none-eabi-
for tool in g++ nm size; do
  if ! command -v "${prefix}${tool}" >/dev/null 2>&1; then
    echo "check_firmware_size: FAIL: ${prefix}${tool} not found (apt-get install gcc-arm-none-eabi libnewlib-arm-none-eabi)"
    exit 1
  fi
done

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# The protocol's headers are included as "imukit/firmware_proto/x.hpp", as the CMake build and an
# installed tree have them: a firmware that vendors the folder makes the same link.
mkdir -p "$work/include/imukit"
ln -s "$root/firmware_proto" "$work/include/imukit/firmware_proto"

cflags=(-mcpu=cortex-m4 -mthumb -Os -fno-exceptions -fno-rtti -ffreestanding -std=c++20
        -Wall -Wextra -Wpedantic -Werror -ffunction-sections -fdata-sections -I"$work/include")

# A stand-in firmware: a HAL over static buffers, one DeviceModel, and calls into every public
# entry point, with inputs read through volatile pointers so the compiler cannot fold them away.
cat >"$work/main.cpp" <<'EOF'
#include <stddef.h>
#include <stdint.h>

#include "imukit/firmware_proto/cobs.hpp"
#include "imukit/firmware_proto/crc32c.hpp"
#include "imukit/firmware_proto/device_model.hpp"
#include "imukit/firmware_proto/frame.hpp"
#include "imukit/firmware_proto/messages.hpp"

namespace proto = imukit::proto;

// Bare-metal ports define this themselves: the libsupc++ version would drag in std::terminate.
extern "C" void __cxa_pure_virtual() {
  for (;;) {
  }
}

volatile uint32_t g_timer;        // stands in for a hardware timer register
volatile uint8_t g_uart_rx[64];   // and a receive FIFO
volatile uint8_t g_uart_tx_last;  // and a transmit register
volatile uint32_t g_sink;

class BoardHal final : public proto::Hal {
 public:
  uint32_t ticks() override { return g_timer; }
  bool read_sensors(uint32_t tick, uint8_t, proto::SensorSample& out) override {
    out.accel[0] = static_cast<int16_t>(tick);
    out.gyro[1] = static_cast<int16_t>(tick >> 4);
    out.temperature = 25;
    return true;
  }
  bool write(const uint8_t* data, size_t n) override {
    for (size_t i = 0; i < n; ++i) g_uart_tx_last = data[i];
    return true;
  }
  bool apply_configuration(const proto::Configure& c) override { return c.rate_mhz != 0; }
  bool store_calibration(const uint8_t* blob, size_t n) override {
    for (size_t i = 0; i < n && i < sizeof flash_; ++i) flash_[i] = blob[i];
    stored_ = n;
    return true;
  }
  size_t load_calibration(uint8_t* out, size_t capacity) override {
    for (size_t i = 0; i < stored_ && i < capacity; ++i) out[i] = flash_[i];
    return stored_;
  }

 private:
  uint8_t flash_[proto::kMaxCalibrationBlobSize] = {};
  size_t stored_ = 0;
};

proto::DeviceInfo make_info() {
  proto::DeviceInfo info;
  info.vendor.set("acme");
  info.model.set("m4-band");
  info.serial.set("0001");
  info.tick_hz = 1000000;
  info.rate_count = 1;
  info.rates_mhz[0] = 100000;
  info.sensor_count = 2;
  info.sensors[0] = {proto::SensorKind::kAccelerometer, 3, 0.0f, 1, {{156.9f, 0.0048f}}};
  info.sensors[1] = {proto::SensorKind::kGyroscope, 3, 0.0f, 1, {{34.9f, 0.0011f}}};
  return info;
}

BoardHal g_hal;
proto::DeviceModel g_device(g_hal, make_info());
proto::FrameDecoder g_host_decoder;  // a host-side decoder too, as a gateway firmware would have

template <class M>
void parse_as(const proto::Frame& f) {
  M m;
  g_sink = g_sink + static_cast<uint32_t>(proto::parse_message(f, m));
}

extern "C" [[noreturn]] void Reset_Handler() {
  uint8_t rx[sizeof g_uart_rx];
  uint8_t frame[proto::kMaxFrameSize];
  for (;;) {
    for (size_t i = 0; i < sizeof rx; ++i) rx[i] = g_uart_rx[i];
    g_device.on_bytes(rx, sizeof rx, g_timer);
    g_device.poll();
    g_device.log(proto::LogLevel::kInfo, "tick");
    proto::SampleBlock block;
    block.count = 1;
    block.channels = proto::kChannelAccel;
    const size_t n = proto::encode_message(block, static_cast<uint16_t>(g_timer), frame, sizeof frame);
    g_host_decoder.feed(frame, n, [](const proto::Frame& f) {
      parse_as<proto::DeviceInfo>(f);
      parse_as<proto::SampleBlock>(f);
      parse_as<proto::Pong>(f);
      parse_as<proto::CalibrationData>(f);
      parse_as<proto::Ack>(f);
      parse_as<proto::Nack>(f);
      parse_as<proto::Log>(f);
    });
    g_sink = g_sink + proto::crc32c(rx, sizeof rx) +
             static_cast<uint32_t>(proto::cobs_decode(rx, sizeof rx, frame));
  }
}
EOF

status=0
finding() {
  echo "check_firmware_size: FAIL: $*"
  status=1
}

# Symbols that must not appear in the program (nm names, anchored patterns).
forbidden='^(_?malloc|_?free|_?calloc|_?realloc|_malloc_r|_free_r|_calloc_r|_realloc_r|_sbrk|_sbrk_r|_Znw.*|_Zna.*|_Zdl.*|_Zda.*|__cxa_allocate_exception|__cxa_throw|__cxa_rethrow|__cxa_begin_catch|__cxa_end_catch|__gxx_personality_.*|_Unwind_.*|__aeabi_unwind_cpp_pr[0-9]|__cxa_call_unexpected|_ZSt9terminatev|_ZTI.*|_ZTS.*|_ZTVN10__cxxabiv1.*|__dynamic_cast|__cxa_bad_cast|__cxa_bad_typeid|__cxa_guard_acquire|__cxa_atexit|atexit)$'

build() {  # build VARIANT EXTRA_FLAGS...
  local variant=$1
  shift
  local dir="$work/$variant"
  mkdir -p "$dir"
  local objects=()
  for src in "$root"/firmware_proto/*.cpp; do
    local obj="$dir/$(basename "${src%.cpp}").o"
    if ! "${prefix}g++" "${cflags[@]}" "$@" -c "$src" -o "$obj" 2>"$dir/errors.txt"; then
      finding "$variant: $(basename "$src") does not compile for Cortex-M4: $(head -n 3 "$dir/errors.txt" | tr '\n' ' ')"
      return
    fi
    objects+=("$obj")
  done
  if ! "${prefix}g++" "${cflags[@]}" "$@" -c "$work/main.cpp" -o "$dir/main.o" 2>"$dir/errors.txt"; then
    finding "$variant: the test firmware does not compile: $(head -n 3 "$dir/errors.txt" | tr '\n' ' ')"
    return
  fi
  if ! "${prefix}g++" "${cflags[@]}" "$@" -nostdlib -nostartfiles -Wl,--gc-sections \
       -Wl,-e,Reset_Handler -Wl,-Map="$dir/firmware.map" -o "$dir/firmware.elf" \
       "$dir/main.o" "${objects[@]}" -Wl,--start-group -lc -lgcc -Wl,--end-group \
       2>"$dir/errors.txt"; then
    finding "$variant: link failed: $(head -n 5 "$dir/errors.txt" | tr '\n' ' ')"
    return
  fi

  # Sizes: the library's objects (everything, before garbage collection), then the linked program
  # (what a firmware using all of it keeps, newlib's mem* and libgcc's division included).
  echo "== firmware_proto for Cortex-M4 ($variant): object sizes (bytes, before --gc-sections)"
  "${prefix}size" -t "${objects[@]}" | sed "s|$dir/||"
  echo "== linked test firmware ($variant): text = flash code + constants, data + bss = static RAM"
  "${prefix}size" "$dir/firmware.elf" | sed "s|$dir/||"
  local nm_sizes
  nm_sizes=$("${prefix}nm" -C -S --size-sort "$dir/firmware.elf")
  size_of() {  # size in bytes of the symbol whose demangled name is $1
    local hex
    hex=$(awk -v name="$1" '{sym = $0; sub(/^[^ ]+ [^ ]+ [^ ]+ /, "", sym)} sym == name {print $2}' \
          <<<"$nm_sizes" | head -n 1)
    if [ -n "$hex" ]; then echo $((16#$hex)); else echo "?"; fi
  }
  local model decoder tables
  model=$(size_of g_device)
  decoder=$(size_of g_host_decoder)
  tables=$(size_of "imukit::proto::(anonymous namespace)::kTables")
  echo "   RAM of one DeviceModel (decoder, frame and calibration buffers included): $model bytes"
  echo "   RAM of one FrameDecoder: $decoder bytes; CRC tables in flash: $tables bytes"

  # Forbidden symbols anywhere in the program.
  # nm on its own first: `|| true` on the whole pipe hid a failing nm, and an empty list passed.
  local bad symbols
  symbols=$("${prefix}nm" "$dir/firmware.elf" | awk '{print $NF}')
  bad=$(grep -E "$forbidden" <<<"$symbols" | sort -u || true)
  for sym in $bad; do
    finding "$variant: the program contains '$sym' (heap, exceptions or RTTI): see $dir/firmware.map"
  done
  # Anything at all from the C++ runtime libraries.
  local cxxlibs
  cxxlibs=$(grep -E "^[^ ]*lib(stdc\+\+|supc\+\+)[^ ]*\.a\(" "$dir/firmware.map" | sort -u || true)
  while IFS= read -r member; do
    [ -n "$member" ] && finding "$variant: links C++ runtime member $member"
  done <<<"$cxxlibs"
  # What the library needs from outside itself: only C string functions and compiler helpers.
  local undefined
  "${prefix}nm" --defined-only "${objects[@]}" | awk 'NF == 3 {print $3}' | sort -u >"$dir/defined.txt"
  undefined=$("${prefix}nm" -u "${objects[@]}" | awk 'NF == 2 {print $2}' | sort -u |
              comm -23 - "$dir/defined.txt" |
              grep -vE '^(memchr|memcmp|memcpy|memmove|memset|strlen|__aeabi_.*)$' || true)
  for sym in $undefined; do
    finding "$variant: firmware_proto references '$sym', outside <string.h> and compiler helpers"
  done
}

# Default build (32-bit: one-table CRC), and the fast slicing-by-16 CRC a bigger MCU may choose.
build default
build fast-crc -DIMUKIT_PROTO_FAST_CRC

if [ "$status" -eq 0 ]; then
  echo "check_firmware_size: OK: no heap, exceptions, RTTI or C++ runtime in firmware_proto"
fi
exit "$status"
