#include "augment/policy.hpp"

#include "core/error.hpp"

namespace imukit::augment {
namespace {
[[noreturn]] void todo(const char* what) {
  throw Error(std::string("augment: ") + what + " is not implemented yet");
}
}  // namespace
std::string_view to_string(WarpMethod) { todo("to_string"); }
bool SubPolicy::is_identity() const { todo("is_identity"); }
std::string SubPolicy::describe() const { todo("describe"); }
void Policy::validate() const { todo("validate"); }
Policy builtin_policy(std::string_view) { todo("builtin_policy"); }
std::vector<std::string> builtin_policy_names() { todo("builtin_policy_names"); }
std::vector<AmplitudeOp> paper_amplitude_options() { todo("grid"); }
std::vector<SpeedOp> paper_speed_options() { todo("grid"); }
std::vector<PlacementOp> paper_placement_options() { todo("grid"); }
std::vector<HardwareOp> paper_hardware_options(bool) { todo("grid"); }
Policy parse_policy(std::string_view, const std::string&, const std::string&) {
  todo("parse_policy");
}
Policy read_policy(const std::string&) { todo("read_policy"); }
std::string format_policy(const Policy&) { todo("format_policy"); }
std::size_t sample_sub_policy(const Policy&, Rng&) { todo("sample_sub_policy"); }
std::vector<StdaSpec> stda_counterparts(const SubPolicy&, const Policy&, bool) {
  todo("stda_counterparts");
}
}  // namespace imukit::augment
