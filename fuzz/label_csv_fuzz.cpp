// Fuzzes the label CSV reader of `imukit augment --labels` (per-sample `label` or segments
// `start_s,end_s,label`) and what augment does with the labels: one per sample, then the
// majority label of each window. The first two bytes choose the sample count (0..1023) and the
// rate (1..256 Hz); the rest is the file. Only imukit::Error may escape; labels of the wrong
// count abort.
#include <cstddef>
#include <cstdint>
#include <cstdlib>

#include "imukit/augment/dataset.hpp"
#include "imukit/core/error.hpp"
#include "temp_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 2) return 0;
  const std::size_t samples = (static_cast<std::size_t>(data[0]) << 2) | (data[1] & 3u);
  const double rate_hz = 1.0 + (data[1] >> 2) * 4.0;
  const std::string path = imukit::fuzz::temp_folder().write("labels.csv", data + 2, size - 2);
  try {
    const std::vector<int64_t> labels =
        imukit::augment::read_labels(path, imukit::augment::uniform_times_s(samples, rate_hz));
    if (labels.size() != samples) std::abort();
    const std::vector<int64_t> starts = imukit::augment::window_starts(samples, 16, 8);
    const std::vector<int64_t> windows = imukit::augment::window_labels(labels, starts, 16);
    if (windows.size() != starts.size()) std::abort();
  } catch (const imukit::Error&) {
  }
  return 0;
}
