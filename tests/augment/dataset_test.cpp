// Windowing, labels, the dataset writer read back, and generate_dataset's determinism.
#include "imukit/augment/dataset.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>

#include "imukit/core/error.hpp"
#include "imukit/core/npy.hpp"
#include "imukit/sim/placement.hpp"
#include "support/expect_error.hpp"
#include "support/procedural_scene.hpp"

namespace imukit::augment {
namespace {

TEST(Dataset, WindowStartsAndMajorityLabels) {
  EXPECT_EQ(window_starts(10, 4, 3), (std::vector<int64_t>{0, 3, 6}));
  EXPECT_EQ(window_starts(3, 4, 1), (std::vector<int64_t>{}));
  EXPECT_THROW(window_starts(10, 0, 1), Error);
  const std::vector<int64_t> labels = {1, 1, 2, 2, 2, kNoLabel, kNoLabel, kNoLabel, 7, 7};
  const std::vector<int64_t> starts = {0, 1, 4, 5, 6};
  // [1 1 2 2] tie -> 1; [1 2 2 2] -> 2; [2 - - -] -> none; [- - - 7] -> none; [- - 7 7] tie
  // -> 7 (unlabelled samples vote, and lose ties: until review, 2026-11-27, one labelled sample
  // labelled a window).
  EXPECT_EQ(window_labels(labels, starts, 4), (std::vector<int64_t>{1, 2, kNoLabel, kNoLabel, 7}));
  const std::vector<int64_t> at_zero = {0};
  const std::vector<int64_t> mostly_none = {kNoLabel, kNoLabel, 3, 4, kNoLabel};
  EXPECT_EQ(window_labels(mostly_none, at_zero, 5), (std::vector<int64_t>{kNoLabel}));
  const std::vector<int64_t> ties = {kNoLabel, kNoLabel, 4, 4, 3, 3};
  EXPECT_EQ(window_labels(ties, at_zero, 6), (std::vector<int64_t>{3}));
  const std::vector<int64_t> none = {kNoLabel, kNoLabel, kNoLabel};
  const std::vector<int64_t> s0 = {0};
  EXPECT_EQ(window_labels(none, s0, 3), (std::vector<int64_t>{kNoLabel}));
  EXPECT_EQ(window_labels({}, starts, 4), std::vector<int64_t>(5, kNoLabel));
  // Found in review: a negative start, or a window of 0, came back "unlabelled"; a stride near
  // 2^63 wrapped the loop (a MemoryError from Python).
  const std::vector<int64_t> negative = {-10};
  EXPECT_THROW(window_labels(labels, negative, 4), Error);
  EXPECT_THROW(window_labels(labels, s0, 0), Error);
  const std::vector<int64_t> late = {7};
  EXPECT_THROW(window_labels(labels, late, 4), Error);
  // Found in review (2026-11-27): a label below kNoLabel was a class (`augment --labels` wrote
  // -3 into y.npy).
  const std::vector<int64_t> below = {1, 1, -3, 2};
  EXPECT_THROW(window_labels(below, s0, 4), Error);
  EXPECT_EQ(window_starts(std::size_t{1} << 62, 2, std::size_t{1} << 61),
            (std::vector<int64_t>{0, int64_t{1} << 61}));
  EXPECT_THROW(window_starts(~std::size_t{0}, 2, std::size_t{1} << 63), Error);
}

TEST(Dataset, SegmentsBecomePerSampleLabels) {
  const std::vector<LabelSegment> segs = {{0.0, 0.5, 4}, {0.5, 1.0, 9}, {0.25, 0.35, 1}};
  const std::vector<int64_t> l = labels_from_segments(segs, uniform_times_s(12, 10.0));
  // Samples at 0.0 .. 1.1 s: [0, 0.5) -> 4, [0.5, 1.0) -> 9, then 0.3 s in [0.25, 0.35) -> 1.
  EXPECT_EQ(l, (std::vector<int64_t>{4, 4, 4, 1, 4, 9, 9, 9, 9, 9, kNoLabel, kNoLabel}));
  const std::string dir = ::testing::TempDir();
  std::ofstream(dir + "/seg.csv") << "start_s,end_s,label\n0,0.5,4\n0.5,1.0,9\n";
  EXPECT_EQ(read_labels(dir + "/seg.csv", uniform_times_s(12, 10.0))[7], 9);
  std::ofstream(dir + "/per.csv") << "label\n1\n2\n3\n";
  EXPECT_EQ(read_labels(dir + "/per.csv", uniform_times_s(3, 10.0)),
            (std::vector<int64_t>{1, 2, 3}));
  EXPECT_THROW(read_labels(dir + "/per.csv", uniform_times_s(4, 10.0)), Error);
  std::ofstream(dir + "/low.csv") << "start_s,end_s,label\n0,0.5,4\n0.5,1.0,-3\n";
  expect_error([&] { read_labels(dir + "/low.csv", uniform_times_s(12, 10.0)); },
               {"low.csv:3:9", "label -3: a label is a class index >= 0, or -1 for none"});
  std::ofstream(dir + "/bad.csv") << "label\n1\nx\n";
  try {
    read_labels(dir + "/bad.csv", uniform_times_s(2, 10.0));
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("bad.csv:3:1"), std::string::npos) << e.what();
  }
}

// Found in review: segments were placed at n / (mean rate), so a recording with a gap got labels
// shifted on both sides of it. Now at the samples' own times: 60 s at 100 Hz with 1 s missing at
// 30 s, segments 0-20, 20-45, 45-60 s: label 2 begins at sample 2000 and label 3 at 4400.
TEST(Dataset, SegmentsFollowTheTimeStampsThroughAGap) {
  std::vector<TimeNs> t;
  for (int64_t n = 0; n < 6000; ++n)
    if (n < 3000 || n >= 3100) t.push_back(n * 10'000'000);
  const std::vector<LabelSegment> segs = {{0, 20, 1}, {20, 45, 2}, {45, 60, 3}};
  const std::vector<int64_t> l = labels_from_segments(segs, times_since_first_s(t));
  ASSERT_EQ(l.size(), 5900u);
  EXPECT_EQ(l[1999], 1);
  EXPECT_EQ(l[2000], 2);
  EXPECT_EQ(l[4399], 2);  // 44.99 s: sample 4499 of the device, 4399 after the gap
  EXPECT_EQ(l[4400], 3);
  EXPECT_EQ(l.back(), 3);
}

TEST(Dataset, WriterOutputReadsBack) {
  const std::string dir = ::testing::TempDir() + "/ds_writer";
  const BatchShape shape{2, 3, 6};
  std::vector<float> X(shape.size());
  for (std::size_t k = 0; k < X.size(); ++k) X[k] = static_cast<float>(k) * 0.5f;
  const std::vector<int64_t> y = {3, kNoLabel}, sp = {12, -1};
  DatasetInfo info;
  info.sensors = {"watch"};
  info.rate_hz = 50;
  info.window = 3;
  info.stride = 1;
  info.mode = "ppda";
  info.policy_json = format_policy(builtin_policy("paper"));
  info.gravity_world = Eigen::Vector3d(0, 0, -9.81);
  write_dataset(dir, X, shape, y, sp, info);
  const NpyArray xa = read_npy(dir + "/X.npy");
  EXPECT_EQ(xa.dtype, NpyDtype::float32);
  EXPECT_EQ(xa.shape, (std::vector<std::size_t>{2, 3, 6}));
  EXPECT_EQ(xa.to_double()[7], 3.5);
  const NpyArray ya = read_npy(dir + "/y.npy");
  EXPECT_EQ(ya.dtype, NpyDtype::int64);
  EXPECT_EQ(ya.to_double(), (std::vector<double>{3, -1}));
  std::ifstream in(dir + "/dataset.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_EQ(j["schema"], "imukit.dataset/1");
  EXPECT_EQ(j["channels"][4], "watch.gy");
  EXPECT_EQ(j["policy"]["builtin"], "paper");
  EXPECT_EQ(j["units"]["gyroscope"], "rad/s");
  EXPECT_EQ(j["gravity_world_mps2"], nlohmann::json({0.0, 0.0, -9.81}));
  EXPECT_THROW(write_dataset(dir, X, {3, 3, 6}, y, sp, info), Error);
}

sim::Scene small_scene() {
  sim::Scene scene = testing::preset_scene({"left_wrist_watch"}, {.rate_hz = 50, .frames = 700});
  scene.sensors[0].spec.name = "watch";
  return scene;
}

// A batch shares one sub-policy, so its windows are drawn from all over the source, as a
// training mini-batch: batches of consecutive windows were runs of one activity, each class
// seen under one or two sub-policies (found in review, 2026-11-27). 70 windows, 7 labels of 10
// windows each, batches of 10: in time order each label was one batch.
TEST(Dataset, BatchesMixWindowsFromAllOverTheSource) {
  const sim::Scene scene =
      testing::preset_scene({"left_wrist_watch"}, {.rate_hz = 50, .frames = 3500});
  DatasetOptions o;
  o.window = 50;
  o.stride = 50;
  o.batch_size = 10;
  o.seed = 5;
  std::vector<int64_t> labels(3500);
  for (std::size_t k = 0; k < labels.size(); ++k) labels[k] = static_cast<int64_t>(k / 500);
  const Dataset d = generate_dataset(scene, builtin_policy("paper"), labels, o);
  ASSERT_EQ(d.y.size(), 70u);
  std::map<int64_t, std::set<int64_t>> sub_policies_of_label;
  std::map<int64_t, std::size_t> windows_of_sub_policy;
  for (std::size_t k = 0; k < 70; ++k) {
    EXPECT_EQ(d.y[k], static_cast<int64_t>(k / 10)) << k;
    sub_policies_of_label[d.y[k]].insert(d.sub_policy[k]);
    ++windows_of_sub_policy[d.sub_policy[k]];
  }
  ASSERT_EQ(windows_of_sub_policy.size(), 7u);  // 7 batches, 7 different draws of 810
  for (const auto& [sub, n] : windows_of_sub_policy) EXPECT_EQ(n, 10u) << sub;
  // 10 windows dealt at random into 7 batches of 10 land in at most 2 batches with a chance
  // below 1e-4.
  for (const auto& [label, subs] : sub_policies_of_label) EXPECT_GE(subs.size(), 3u) << label;
  // The written order is the window order, whatever the shuffle: the unaugmented dataset
  // (identity_fraction 1) is the plain windows in time order.
  o.identity_fraction = 1.0;
  const Dataset plain = generate_dataset(scene, builtin_policy("paper"), labels, o);
  PpdaAugmenter aug(scene, PpdaOptions{.window = 50});
  std::vector<float> expected(plain.X.size());
  Rng unused(0);
  aug.apply(SubPolicy{}, aug.window_starts(50), unused, expected, 1);
  EXPECT_EQ(plain.X, expected);
}

TEST(Dataset, GenerateIsBitIdenticalForAnyThreadCountAndRepeatsBaseWindows) {
  const sim::Scene scene = small_scene();
  const Policy policy = builtin_policy("imukit");
  DatasetOptions o;
  o.window = 50;
  o.stride = 50;
  o.count = 30;  // more than the base windows: they repeat under fresh draws
  o.batch_size = 8;
  o.seed = 77;
  std::vector<int64_t> labels(700);
  for (std::size_t k = 0; k < labels.size(); ++k) labels[k] = static_cast<int64_t>(k / 100);
  o.threads = 1;
  const Dataset a = generate_dataset(scene, policy, labels, o);
  o.threads = 2;
  const Dataset b = generate_dataset(scene, policy, labels, o);
  EXPECT_EQ(a.X, b.X);
  EXPECT_EQ(a.sub_policy, b.sub_policy);
  EXPECT_EQ(a.shape, (BatchShape{30, 50, 6}));
  ASSERT_TRUE(a.info.gravity_world.has_value());  // the value simulated with, for dataset.json
  EXPECT_EQ(*a.info.gravity_world, scene.options.gravity_world);
  PpdaOptions po;
  po.window = 50;
  const std::size_t nbase = PpdaAugmenter(scene, po).window_starts(50).size();
  ASSERT_EQ(nbase, 14u);  // 700 samples
  std::map<int64_t, std::size_t> per_sub_policy;
  for (std::size_t k = 0; k < 30; ++k) {
    const std::size_t base = k % nbase;
    EXPECT_EQ(a.y[k], static_cast<int64_t>(base * 50 / 100)) << k;  // X stays in window order
    ++per_sub_policy[a.sub_policy[k]];
  }
  // One sub-policy per batch of 8 (8, 8, 8 and 6 windows), the four drawn apart.
  std::vector<std::size_t> sizes;
  for (const auto& [sub, n] : per_sub_policy) sizes.push_back(n);
  std::sort(sizes.begin(), sizes.end());
  EXPECT_EQ(sizes, (std::vector<std::size_t>{6, 8, 8, 8}));
  // Found in review (2026-11-27): more labels than samples were taken (the first ones used),
  // where the recording path refused them.
  std::vector<int64_t> longer = labels;
  longer.push_back(0);
  EXPECT_THROW(generate_dataset(scene, policy, longer, o), Error);
  o.seed = 78;
  const Dataset c = generate_dataset(scene, policy, labels, o);
  EXPECT_NE(a.X, c.X);
  // Normalized: every channel has mean 0 and standard deviation 1.
  o.normalize = true;
  const Dataset n = generate_dataset(scene, policy, labels, o);
  ASSERT_TRUE(n.info.normalized);
  for (std::size_t ch = 0; ch < 6; ++ch) {
    double s = 0, s2 = 0;
    for (std::size_t r = 0; r < 30 * 50; ++r) {
      s += n.X[r * 6 + ch];
      s2 += double(n.X[r * 6 + ch]) * n.X[r * 6 + ch];
    }
    EXPECT_NEAR(s / 1500, 0.0, 1e-5);
    EXPECT_NEAR(std::sqrt(s2 / 1500), 1.0, 1e-5);
  }
}

// Review, 2026-11-27: a speed drawn too fast for the motion around a window ended the whole
// run ("a window of 200 samples at this speed needs ... frames"), losing what was made. Such a
// window is written unaugmented, marked -1, and counted.
TEST(Dataset, AWindowTooShortForItsDrawnSpeedIsWrittenUnaugmented) {
  const sim::Scene scene = small_scene();  // 700 samples
  Policy policy;
  policy.name = "fast";
  SubPolicy fast;
  fast.speed.method = WarpMethod::scaling;
  fast.speed.lo = 1.0;
  fast.speed.hi = 4.0;  // b above about 3.5 needs more than 700 samples for 200
  policy.sub_policies = {fast};
  policy.probabilities = {1.0};
  DatasetOptions o;
  o.window = 200;
  o.stride = 100;
  o.count = 24;
  o.batch_size = 4;
  o.seed = 3;
  o.threads = 2;
  const Dataset d = generate_dataset(scene, policy, {}, o);
  const auto plain = std::count(d.sub_policy.begin(), d.sub_policy.end(), int64_t{-1});
  EXPECT_GT(plain, 0);
  EXPECT_LT(plain, 24);
  EXPECT_EQ(d.info.too_short_windows, static_cast<std::size_t>(plain));
  PpdaOptions po;
  po.window = 200;
  PpdaAugmenter aug(scene, po);
  const std::vector<int64_t> base = aug.window_starts(100);
  const std::size_t T = 200, C = 6;
  for (std::size_t k = 0; k < 24; ++k) {
    if (d.sub_policy[k] != -1) continue;
    std::vector<float> expected(T * C);
    Rng rng(1);
    const int64_t start[] = {base[k % base.size()]};
    aug.apply(SubPolicy{}, start, rng, expected);
    EXPECT_TRUE(std::equal(expected.begin(), expected.end(),
                           d.X.begin() + static_cast<std::ptrdiff_t>(k * T * C)))
        << "window " << k;
  }
  const std::string dir = ::testing::TempDir() + "/ds_too_short";
  write_dataset(dir, d.X, d.shape, d.y, d.sub_policy, d.info);
  std::ifstream in(dir + "/dataset.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_EQ(j.at("too_short_windows"), plain);
  EXPECT_EQ(j.at("method"), "spline");
  EXPECT_EQ(j.at("seeds").at("identity_fraction"), 0.0);
}

TEST(Dataset, StdaFromRecordedStreams) {
  ImuSeries s = ImuSeries::with_channels(400, true, true);
  for (std::size_t i = 0; i < 400; ++i) {
    s.t[i] = static_cast<TimeNs>(i) * 20'000'000;  // 50 Hz
    s.accel.col(static_cast<Eigen::Index>(i)) = Eigen::Vector3d(0.1 * i, 0, 9.81);
    s.gyro.col(static_cast<Eigen::Index>(i)) = Eigen::Vector3d(0, 0.01 * i, 0);
  }
  DatasetOptions o;
  o.window = 40;
  o.stride = 20;
  o.batch_size = 4;
  o.identity_fraction = 1.0;  // unaugmented: the windows as recorded
  const Policy policy = builtin_policy("paper");
  const Dataset d = generate_dataset({"imu"}, {&s}, policy, {}, o);
  EXPECT_EQ(d.shape, (BatchShape{19, 40, 6}));
  EXPECT_NEAR(d.info.rate_hz, 50.0, 1e-9);
  EXPECT_FLOAT_EQ(d.X[(3 * 40 + 5) * 6 + 0], static_cast<float>(0.1 * (60 + 5)));
  EXPECT_FLOAT_EQ(d.X[(3 * 40 + 5) * 6 + 4], static_cast<float>(0.01 * (60 + 5)));
  o.identity_fraction = 0.0;
  o.threads = 2;
  const Dataset e = generate_dataset({"imu"}, {&s}, policy, {}, o);
  o.threads = 1;
  const Dataset f = generate_dataset({"imu"}, {&s}, policy, {}, o);
  EXPECT_EQ(e.X, f.X);
  EXPECT_NE(e.X, d.X);
}

TEST(Dataset, ExtractWindowsRefusesAWindowBeyondTheStreamsWhateverItsSize) {
  // Found in review, 2026-11-27: s0 + window wrapped for a window near 2^64 and the check
  // passed (an out-of-range read and writes past X); a window of 0 gave (N, 0, 6).
  ImuSeries s = ImuSeries::with_channels(50, true, true);
  for (std::size_t i = 0; i < 50; ++i) s.t[i] = static_cast<TimeNs>(i) * 20'000'000;
  const std::vector<int64_t> starts = {10};
  for (const std::size_t window : {std::size_t{41}, ~std::size_t{0}, ~std::size_t{0} - 5}) {
    testing::expect_error([&] { extract_windows({&s}, starts, window); },
                          {"windowing: a window lies outside the streams"});
  }
  testing::expect_error([&] { extract_windows({&s}, starts, 0); },
                        {"windowing: the window must be >= 1 sample"});
  EXPECT_EQ(extract_windows({&s}, starts, 40).size(), 40u * 6u);
}

TEST(Dataset, RecordedStreamsMustShareOneTimeBase) {
  // Found in review: a 400 Hz and a 100 Hz stream of equal length were stacked side by side as
  // one 400 Hz window (0.75 s of one beside 3 s of the other). Two devices' clocks a little
  // apart (here 3 ms at 50 Hz, under half a period) are still one time base.
  const auto stream = [](double rate, TimeNs offset) {
    ImuSeries s = ImuSeries::with_channels(200, true, true);
    for (std::size_t i = 0; i < 200; ++i) {
      s.t[i] = offset + static_cast<TimeNs>(std::llround(static_cast<double>(i) * 1e9 / rate));
      s.accel.col(static_cast<Eigen::Index>(i)) = Eigen::Vector3d(0, 0, 9.81);
    }
    return s;
  };
  DatasetOptions o;
  o.window = 40;
  o.stride = 20;
  const Policy policy = builtin_policy("paper");
  const ImuSeries a = stream(50.0, 0), near = stream(50.0, 3'000'000), fast = stream(200.0, 0);
  EXPECT_EQ(generate_dataset({"a", "b"}, {&a, &near}, policy, {}, o).shape,
            (BatchShape{9, 40, 12}));
  try {
    (void)generate_dataset({"a", "b"}, {&a, &fast}, policy, {}, o);
    ADD_FAILURE() << "streams at 50 and 200 Hz were stacked";
  } catch (const Error& e) {
    // Sample 1 is at 20 ms in a, 5 ms in b: the first more than 10 ms apart.
    EXPECT_EQ(std::string(e.what()).rfind(
                  "augment: sample 1 of stream 'b' is -0.015000 s off sample 1 of stream 'a'", 0),
              0u)
        << e.what();
  }
}

// Found in review: with --normalize the STDA counterparts acted on z-scored channels, where a
// rotation is not one (gravity stayed, norms changed by up to 1.6 m/s^2) and magnitude scaling
// scales only the deviations from the mean. Now they act on the physical signals and the
// z-scoring follows: undone with the stored statistics, a rotated window keeps every sample's
// norm, and a scaled window's mean is the original's times the drawn factor.
TEST(Dataset, NormalizedStdaRotatesAndScalesThePhysicalSignals) {
  const std::size_t n = 400;
  ImuSeries s = ImuSeries::with_channels(n, true, true);
  for (std::size_t i = 0; i < n; ++i) {
    const double t = 0.01 * static_cast<double>(i);
    s.t[i] = static_cast<TimeNs>(i) * 10'000'000;
    s.accel.col(static_cast<Eigen::Index>(i)) =
        Eigen::Vector3d(0.5 * std::sin(3 * t), 1.0 + 0.3 * std::cos(2 * t), 9.7);
    s.gyro.col(static_cast<Eigen::Index>(i)) =
        Eigen::Vector3d(0.2 * std::cos(5 * t), 0.1, -0.4 * std::sin(t));
  }
  DatasetOptions o;
  o.window = 50;
  o.stride = 50;
  o.batch_size = 1;
  o.normalize = true;
  const Policy rotate = parse_policy(R"({"schema": "imukit.policy/1", "sub_policies": [
      {"placement": {"rotation_deg": 25}}]})",
                                     "p.json", ".");
  const Dataset d = generate_dataset({"imu"}, {&s}, rotate, {}, o);
  ASSERT_EQ(d.shape, (BatchShape{8, 50, 6}));
  const auto physical = [&](const Dataset& ds, std::size_t w, std::size_t i, std::size_t c) {
    return ds.X[(w * 50 + i) * 6 + c] * ds.info.channel_std[c] + ds.info.channel_mean[c];
  };
  double worst = 0.0;
  for (std::size_t w = 0; w < 8; ++w) {
    for (std::size_t i = 0; i < 50; ++i) {
      const auto col = static_cast<Eigen::Index>(50 * w + i);
      for (std::size_t triad = 0; triad < 2; ++triad) {
        const Eigen::Vector3d v = triad == 0 ? s.accel.col(col) : s.gyro.col(col);
        const Eigen::Vector3d r(physical(d, w, i, 3 * triad), physical(d, w, i, 3 * triad + 1),
                                physical(d, w, i, 3 * triad + 2));
        worst = std::max(worst, std::abs(r.norm() - v.norm()) / v.norm());
      }
    }
  }
  EXPECT_LT(worst, 1e-5);  // float32 rounding
  // Gravity turned with the sensor: some window's mean z is well below 9.7.
  double lowest_z = 1e9;
  for (std::size_t w = 0; w < 8; ++w) {
    double z = 0.0;
    for (std::size_t i = 0; i < 50; ++i) z += physical(d, w, i, 2) / 50.0;
    lowest_z = std::min(lowest_z, z);
  }
  EXPECT_LT(lowest_z, 9.0);
}

// STDA time scaling of a recording reads the recording beyond the window: at twice the speed a
// window shows 2 T recorded samples of a ramp, slope doubled up to both edges (no held edge
// values), and near the recording's end the window moves inwards rather than running off it.
TEST(Dataset, TimeScalingOfARecordingReadsBeyondTheWindow) {
  const std::size_t n = 600;
  ImuSeries s = ImuSeries::with_channels(n, true, true);
  for (std::size_t i = 0; i < n; ++i) {
    s.t[i] = static_cast<TimeNs>(i) * 10'000'000;  // 100 Hz
    s.accel.col(static_cast<Eigen::Index>(i)) = Eigen::Vector3d(0.01 * i, 1.0, -0.02 * i);
    s.gyro.col(static_cast<Eigen::Index>(i)) = Eigen::Vector3d(0.001 * i, 0, 0);
  }
  Policy policy;
  SubPolicy sub;
  sub.speed.method = WarpMethod::scaling;
  sub.speed.lo = sub.speed.hi = 2.0;
  policy.sub_policies = {sub};
  policy.probabilities = {1.0};
  DatasetOptions o;
  o.window = 50;
  o.stride = 50;
  o.batch_size = 4;
  const Dataset d = generate_dataset({"imu"}, {&s}, policy, {}, o);
  ASSERT_EQ(d.shape, (BatchShape{12, 50, 6}));
  for (std::size_t w = 0; w < 12; ++w) {
    const double start = static_cast<double>(50 * w);
    // Positions start + 24.5 + 2 (i - 24.5), moved inside [0, 599].
    double first = start + 24.5 - 49.0;
    first = std::clamp(first, 0.0, 599.0 - 98.0);
    for (std::size_t i = 0; i < 50; ++i) {
      const double pos = first + 2.0 * static_cast<double>(i);
      const float* row = d.X.data() + (w * 50 + i) * 6;
      EXPECT_NEAR(row[0], 0.01 * pos, 1e-5) << w << " " << i;
      EXPECT_NEAR(row[1], 1.0, 1e-6);
      EXPECT_NEAR(row[2], -0.02 * pos, 1e-5) << w << " " << i;
      EXPECT_NEAR(row[3], 0.001 * pos, 1e-6) << w << " " << i;
    }
  }
}

}  // namespace
}  // namespace imukit::augment
