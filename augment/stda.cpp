#include "augment/stda.hpp"

#include "core/error.hpp"

namespace imukit::augment {
namespace {
[[noreturn]] void todo(const char* what) {
  throw Error(std::string("augment: ") + what + " is not implemented yet");
}
}  // namespace
ChannelLayout ChannelLayout::imu(const std::vector<std::string>&) { todo("ChannelLayout::imu"); }
void ChannelLayout::validate(std::size_t) const { todo("ChannelLayout::validate"); }
std::string_view to_string(StdaMethod) { todo("to_string"); }
StdaMethod parse_stda_method(std::string_view) { todo("parse_stda_method"); }
void StdaSpec::validate() const { todo("validate"); }
std::string StdaSpec::describe() const { todo("describe"); }
void apply_stda(const StdaSpec&, const ChannelLayout&, std::span<float>, const BatchShape&, Rng&,
                StdaDraws*) {
  todo("apply_stda");
}
void apply_stda(const StdaSpec&, const ChannelLayout&, std::span<double>, const BatchShape&, Rng&,
                StdaDraws*) {
  todo("apply_stda");
}
void replay_stda(const StdaSpec&, const ChannelLayout&, std::span<float>, const BatchShape&,
                 const StdaDraws&) {
  todo("replay_stda");
}
void replay_stda(const StdaSpec&, const ChannelLayout&, std::span<double>, const BatchShape&,
                 const StdaDraws&) {
  todo("replay_stda");
}
std::vector<double> time_warp_positions(std::span<const double>, double, std::size_t) {
  todo("time_warp_positions");
}
std::vector<double> time_warp_speeds(std::span<const double>, double) { todo("time_warp_speeds"); }
std::vector<double> warp_curve(std::span<const double>, std::size_t) { todo("warp_curve"); }
}  // namespace imukit::augment
