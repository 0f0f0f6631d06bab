#include "augment/ppda.hpp"

#include "core/error.hpp"

namespace imukit::augment {
namespace {
[[noreturn]] void todo(const char* what) {
  throw Error(std::string("augment: ") + what + " is not implemented yet");
}
}  // namespace
struct PpdaAugmenter::Impl {};
PpdaAugmenter::PpdaAugmenter(const sim::Scene&, PpdaOptions) { todo("PpdaAugmenter"); }
PpdaAugmenter::~PpdaAugmenter() = default;
PpdaAugmenter::PpdaAugmenter(PpdaAugmenter&&) noexcept = default;
PpdaAugmenter& PpdaAugmenter::operator=(PpdaAugmenter&&) noexcept = default;
std::size_t PpdaAugmenter::window() const { todo("window"); }
std::size_t PpdaAugmenter::channels() const { todo("channels"); }
ChannelLayout PpdaAugmenter::layout() const { todo("layout"); }
std::vector<std::string> PpdaAugmenter::sensor_names() const { todo("sensor_names"); }
double PpdaAugmenter::rate_hz() const { todo("rate_hz"); }
int64_t PpdaAugmenter::sample_count() const { todo("sample_count"); }
std::vector<int64_t> PpdaAugmenter::window_starts(std::size_t) const { todo("window_starts"); }
void PpdaAugmenter::apply(const SubPolicy&, std::span<const int64_t>, Rng&, std::span<float>,
                          unsigned, std::vector<PpdaWindowLog>*) {
  todo("apply");
}
void PpdaAugmenter::apply(const Policy&, std::size_t, std::span<const int64_t>, Rng&,
                          std::span<float>, unsigned) {
  todo("apply");
}
void PpdaAugmenter::apply_window(const SubPolicy&, int64_t, Rng&, std::span<double>,
                                 PpdaWindowLog*) {
  todo("apply_window");
}
}  // namespace imukit::augment
