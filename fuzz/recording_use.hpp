// Shared by the recording fuzzers: what `imukit convert` does with a recording read from MCAP.
// Each stream is validated (an imukit::Error is a fine outcome), written as EuRoC CSV and read
// back, which must give the same samples bit for bit (anything else aborts: a bug).
#pragma once

#include <cstdio>
#include <cstdlib>
#include <string>

#include "imukit/core/error.hpp"
#include "imukit/core/euroc_csv.hpp"
#include "imukit/core/imu_series.hpp"

namespace imukit::fuzz {

inline void use_recording(const Recording& recording) {
  for (const auto& [name, series] : recording.streams) {
    try {
      series.validate();
    } catch (const Error&) {
      continue;
    }
    char* text = nullptr;
    std::size_t size = 0;
    std::FILE* out = ::open_memstream(&text, &size);
    if (!out) std::abort();
    write_euroc_csv(out, name, series.view());
    std::fclose(out);
    const std::string csv(text, size);
    std::free(text);
    ImuSeries back;
    try {
      back = parse_euroc_csv(csv, name + ".csv");
    } catch (const Error&) {
      std::abort();  // imukit cannot read what it wrote
    }
    if (back.t != series.t || back.accel != series.accel || back.gyro != series.gyro) std::abort();
  }
}

}  // namespace imukit::fuzz
