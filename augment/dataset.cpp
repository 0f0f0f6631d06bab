#include "augment/dataset.hpp"

#include "core/error.hpp"

namespace imukit::augment {
namespace {
[[noreturn]] void todo(const char* what) {
  throw Error(std::string("augment: ") + what + " is not implemented yet");
}
}  // namespace
std::vector<int64_t> labels_from_segments(std::span<const LabelSegment>, std::size_t, double) {
  todo("labels_from_segments");
}
std::vector<int64_t> read_labels(const std::string&, std::size_t, double) { todo("read_labels"); }
std::vector<int64_t> window_starts(std::size_t, std::size_t, std::size_t) { todo("window_starts"); }
std::vector<int64_t> window_labels(std::span<const int64_t>, std::span<const int64_t>,
                                   std::size_t) {
  todo("window_labels");
}
std::vector<float> extract_windows(const std::vector<const ImuSeries*>&, std::span<const int64_t>,
                                   std::size_t) {
  todo("extract_windows");
}
void write_dataset(const std::string&, std::span<const float>, const BatchShape&,
                   std::span<const int64_t>, std::span<const int64_t>, const DatasetInfo&) {
  todo("write_dataset");
}
Dataset generate_dataset(const sim::Scene&, const Policy&, std::span<const int64_t>,
                         const DatasetOptions&) {
  todo("generate_dataset");
}
Dataset generate_dataset(const std::vector<std::string>&, const std::vector<const ImuSeries*>&,
                         const Policy&, std::span<const int64_t>, const DatasetOptions&) {
  todo("generate_dataset");
}
}  // namespace imukit::augment
