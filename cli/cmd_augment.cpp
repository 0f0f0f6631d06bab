// imukit augment: a training dataset (X.npy, y.npy, sub_policy.npy, dataset.json; DESIGN.md) from
// a simulated scene under physically plausible augmentation (PPDA), or from a recording under the
// policy's STDA counterparts. One sub-policy per batch, the same bytes for the same seed whatever
// --threads says.
#include <fmt/core.h>

#include <algorithm>
#include <memory>
#include <optional>

#include "command.hpp"
#include "imukit/augment/dataset.hpp"
#include "imukit/augment/policy.hpp"
#include "imukit/core/error.hpp"
#include "imukit/core/sampling.hpp"
#include "imukit/sim/scene.hpp"
#include "inputs.hpp"
#include "options.hpp"

namespace imukit::cli {
namespace {

struct AugmentArgs {
  std::string scene;
  std::string input;
  std::string policy = "imukit";
  std::string output;
  std::string labels;
  // The options bind straight to the dataset's fields (and their defaults), except the seed,
  // whose default is the scene's.
  augment::DatasetOptions dataset;
  std::optional<uint64_t> seed;
  bool method_given = false;
  bool list = false;
};

int list_sub_policies(const augment::Policy& p) {
  fmt::print("policy {}: {} sub-policies\n", p.name, p.sub_policies.size());
  for (std::size_t k = 0; k < p.sub_policies.size(); ++k)
    fmt::print("{:4} p={:.6f} {}\n", k, p.probabilities[k], p.sub_policies[k].describe());
  return 0;
}

int run_augment(const AugmentArgs& a, const std::vector<std::string>& extra) {
  const augment::Policy policy = augment::read_policy(a.policy);
  if (a.list) return list_sub_policies(policy);
  if (a.output.empty()) throw UsageError("augment: give the output folder with -o DIR");
  if (a.scene.empty() == a.input.empty())
    throw UsageError("augment: give either --scene SCENE.json or --input RECORDING");
  if (!a.scene.empty() && !extra.empty())
    throw UsageError("augment: unexpected argument " + quote_excerpt(extra.front()));
  if (!a.input.empty() && a.method_given)
    throw UsageError(
        "augment: --method chooses how a --scene is simulated again; a recording "
        "(--input) is not simulated");
  augment::DatasetOptions o = a.dataset;
  augment::Dataset d;
  if (!a.scene.empty()) {
    sim::Scene scene = sim::read_scene(a.scene);
    for (const std::string& w : scene.warnings) fmt::print(stderr, "warning: {}\n", w);
    o.seed = a.seed.value_or(scene.seed);
    std::vector<int64_t> labels;
    if (!a.labels.empty()) {
      // Labels are per sensor sample of the scene.
      labels = augment::read_labels(
          a.labels,
          augment::uniform_times_s(static_cast<std::size_t>(sim::scene_sample_count(scene)),
                                   sim::scene_rate_hz(scene)));
    }
    d = augment::generate_dataset(scene, policy, labels, o);
    d.info.source = a.scene;
    if (d.info.too_short_windows > 0) {
      const auto augmented = static_cast<std::size_t>(std::count_if(
          d.sub_policy.begin(), d.sub_policy.end(), [](int64_t k) { return k >= 0; }));
      fmt::print(stderr,
                 "warning: augment: {} of the {} windows to augment ({:.1f} %) are written "
                 "unaugmented (sub_policy -1): their drawn speed needs more motion than the scene "
                 "has around them\n",
                 d.info.too_short_windows, augmented + d.info.too_short_windows,
                 100.0 * static_cast<double>(d.info.too_short_windows) /
                     static_cast<double>(augmented + d.info.too_short_windows));
    }
  } else {
    std::vector<std::string> tokens{a.input};
    tokens.insert(tokens.end(), extra.begin(), extra.end());
    const std::vector<InputArg> inputs = parse_input_args(tokens);
    if (inputs.size() != 1) throw UsageError("augment: give one --input recording");
    const Recording rec = load_recording(inputs.front());
    std::vector<std::string> names;
    std::vector<const ImuSeries*> streams;
    for (const auto& [name, series] : rec.streams) {
      if (!series.has_accel() || !series.has_gyro()) {
        fmt::print(stderr, "augment: stream {} skipped (needs accelerometer and gyroscope)\n",
                   name);
        continue;
      }
      names.push_back(name);
      streams.push_back(&series);
    }
    if (streams.empty()) throw Error(a.input + ": no stream with both accelerometer and gyroscope");
    o.seed = a.seed.value_or(0);
    std::vector<int64_t> labels;
    if (!a.labels.empty()) {
      const ImuSeries& s = *streams.front();
      measured_rate_hz(s.t, a.input);  // refuses times that do not advance, naming the file
      labels = augment::read_labels(a.labels, augment::times_since_first_s(s.t));
    }
    d = augment::generate_dataset(names, streams, policy, labels, o);
    d.info.source = a.input;
  }
  augment::write_dataset(a.output, d.X, d.shape, d.y, d.sub_policy, d.info);
  fmt::print("augment: {} windows x {} samples x {} channels ({}, policy {}, seed {}) -> {}\n",
             d.shape.windows, d.shape.samples, d.shape.channels, d.info.mode, policy.name, o.seed,
             a.output);
  return 0;
}

}  // namespace

IMUKIT_REGISTER_COMMAND(
    augment,
    CommandSpec{
        "augment",
        "Make a training dataset: physically plausible augmentation of a simulated scene, or "
        "classic augmentation of a recording",
        70, [](CLI::App& sub) -> std::function<int()> {
          auto a = std::make_shared<AugmentArgs>();
          augment::DatasetOptions& o = a->dataset;  // defaults in the help are its own
          sub.add_option("--scene", a->scene, "Scene JSON (imukit.scene/1): PPDA");
          sub.add_option("--input", a->input,
                         "A recording (MCAP, EuRoC CSV, column text): the policy's STDA "
                         "counterparts");
          sub.add_option(
              "--policy", a->policy,
              "Policy JSON (imukit.policy/1) or a built-in grid: imukit (default), paper");
          sub.add_option("-o,--output", a->output, "Output folder");
          sub.add_option("--labels", a->labels,
                         "Label CSV: header 'label' (one row per sample) or 'start_s,end_s,label'");
          sub.add_option("--window", o.window,
                         fmt::format("Samples per window (default {})", o.window))
              ->check(whole_in(2, 10'000'000, "samples"));
          sub.add_option("--stride", o.stride,
                         fmt::format("Samples between window starts (default {})", o.stride))
              ->check(whole_in(1, 10'000'000, "samples"));
          sub.add_option("--count", o.count,
                         "Windows to write (default: one pass over the windows; more repeat them "
                         "under fresh draws)")
              ->check(whole_in(0, 1'000'000'000'000, "windows"));
          sub.add_option("--batch-size", o.batch_size,
                         fmt::format("Windows per sub-policy draw (default {})", o.batch_size))
              ->check(whole_in(1, 10'000'000, "windows"));
          sub.add_option("--seed", a->seed, "Seed (default: the scene's seed, or 0)")
              ->check(seed_range());
          sub.add_option("--threads", o.threads,
                         "Worker threads (0 = all cores); the output does not depend on it")
              ->check(whole_in(0, 1024));
          sub.add_flag("--normalize", o.normalize,
                       "z-score every channel (statistics in dataset.json); STDA jitter is then in "
                       "standard deviations");
          sub.add_option("--identity-fraction", o.identity_fraction,
                         "Fraction of batches left unaugmented (the paper's comparison uses 0.5)")
              ->check(real_in(0, 1, ""));
          sub.add_option_function<std::string>(
                 "--method",
                 [&o, a](const std::string& m) {
                   o.method = sim::parse_derivative_method(m);
                   a->method_given = true;
                 },
                 "Derivative method of the re-simulation (--scene): spline (default) or fd "
                 "(faster)")
              ->check(CLI::IsMember({"spline", "fd"}));
          sub.add_flag("--list-sub-policies", a->list, "Print the policy's sub-policies and exit");
          sub.allow_extras();
          sub.footer(input_options_help() +
                     "\n\nExamples:\n"
                     "  imukit augment --scene scene.json --policy paper --window 100 --stride 25 "
                     "--count 10000 -o ds/\n"
                     "  imukit augment --input walk.mcap --policy my_policy.json --normalize -o "
                     "ds/\n"
                     "  imukit augment --policy paper --list-sub-policies\n");
          return [&sub, a] { return run_augment(*a, sub.remaining()); };
        }});

}  // namespace imukit::cli
