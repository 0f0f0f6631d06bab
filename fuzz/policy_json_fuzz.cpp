// Fuzzes the policy JSON reader (imukit.policy/1). Only imukit::Error may escape. Profile files
// named inside resolve against a folder that does not exist, and inputs naming absolute paths are
// skipped (a fuzzer must not read /dev/zero). A policy that parses must validate, write itself
// back, read back to the same sub-policies, and sample an index inside its range.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "augment/policy.hpp"
#include "core/error.hpp"
#include "fuzz/json_fuzz.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  if (imukit::fuzz::json_names_absolute_path(text)) return 0;
  imukit::augment::Policy policy;
  try {
    policy = imukit::augment::parse_policy(text, "fuzz.json", "/nonexistent-imukit-fuzz");
  } catch (const imukit::Error&) {
    return 0;
  }
  policy.validate();  // whatever parses is valid
  const imukit::augment::Policy back =
      imukit::augment::parse_policy(imukit::augment::format_policy(policy), "back.json", "");
  if (back.sub_policies.size() != policy.sub_policies.size()) std::abort();
  for (std::size_t k = 0; k < policy.sub_policies.size(); ++k) {
    if (back.sub_policies[k].describe() != policy.sub_policies[k].describe()) std::abort();
  }
  imukit::Rng rng(1);
  if (imukit::augment::sample_sub_policy(policy, rng) >= policy.sub_policies.size()) std::abort();
  return 0;
}
