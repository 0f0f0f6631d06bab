// imukit motion: body motion from 3D keypoints (sim/keypoints.hpp, docs/keypoints.md). Reads a
// keypoint CSV or .npy file with a named (or JSON) topology and writes the motion as a
// joint-quaternion CSV or a BVH file, optionally the body as a scene "body" object and a report.
#include <fmt/core.h>

#include <cstdio>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>

#include "command.hpp"
#include "imukit/core/error.hpp"
#include "imukit/core/input_file.hpp"
#include "imukit/sim/bvh.hpp"
#include "imukit/sim/keypoints.hpp"
#include "imukit/sim/scene.hpp"
#include "options.hpp"

namespace imukit::cli {
namespace {

struct MotionArgs {
  std::string keypoints;
  std::string topology;
  std::string output;
  std::string body_json;
  std::string report;
  std::string print_topology;
  double rate_hz = 0.0;
  double output_rate_hz = 100.0;
  double cutoff_hz = 3.0;
  std::vector<double> up;
  bool no_repairs = false;
  bool quiet = false;
};

nlohmann::json report_of(const sim::KeypointMotion& r, const MotionArgs& a) {
  nlohmann::json j;
  j["schema"] = "imukit.keypoint_motion/1";
  j["keypoints"] = a.keypoints;
  j["topology"] = a.topology;
  j["input_rate_hz"] = r.input_rate_hz;
  j["rate_hz"] = r.motion.rate_hz();
  j["frames"] = r.motion.frames();
  j["cutoff_hz"] = a.cutoff_hz;
  j["start_s"] = r.start_s;
  j["up_source"] = r.up_source;
  j["up_input"] = {r.up_input.x(), r.up_input.y(), r.up_input.z()};
  nlohmann::json R = nlohmann::json::array();
  for (int i = 0; i < 3; ++i)
    R.push_back({r.R_world_input(i, 0), r.R_world_input(i, 1), r.R_world_input(i, 2)});
  j["R_world_input"] = R;
  j["origin_input"] = {r.origin_input.x(), r.origin_input.y(), r.origin_input.z()};
  j["missing_frames"] = r.missing_frames;
  j["frozen_frames"] = r.frozen_frames;
  j["swapped_frames"] = r.swapped_frames;
  j["outlier_frames"] = r.outlier_frames;
  j["jump_frames"] = r.jump_frames;
  j["flagged_frames"] = r.flagged_frames;
  nlohmann::json gaps = nlohmann::json::array();
  for (const auto& [b, e] : r.invalid_motion) gaps.push_back({b, e});
  j["invalid_motion_ns"] = gaps;
  nlohmann::json segs = nlohmann::json::array();
  for (const sim::SegmentReport& s : r.segments) {
    segs.push_back({{"joint", s.joint},
                    {"length_m", s.length_m},
                    {"length_iqr_m", s.length_iqr_m},
                    {"twist_observed", s.twist_observed}});
  }
  j["segments"] = segs;
  j["warnings"] = r.warnings;
  return j;
}

int run_motion(const MotionArgs& a) {
  if (!a.print_topology.empty()) {
    fmt::print("{}", sim::keypoint_topology_json(sim::load_keypoint_topology(a.print_topology)));
    return 0;
  }
  if (a.keypoints.empty() || a.topology.empty())
    throw UsageError(
        "motion: give --keypoints FILE and --topology NAME (or --print-topology NAME)");
  if (a.output.empty())
    throw UsageError("motion: give -o FILE.csv (joint quaternions) or FILE.bvh");
  std::string ext = std::filesystem::path(a.output).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (ext != ".csv" && ext != ".bvh")
    throw UsageError("motion: -o " + a.output + ": expected a .csv or .bvh file name");
  const sim::KeypointTopology topo = sim::load_keypoint_topology(a.topology);
  const sim::Keypoints k = sim::read_keypoints(
      a.keypoints, topo, a.rate_hz > 0.0 ? std::optional<double>(a.rate_hz) : std::nullopt);
  sim::KeypointMotionOptions o;
  o.rate_hz = a.output_rate_hz;
  o.cutoff_hz = a.cutoff_hz;
  if (!a.up.empty()) {
    if (a.up.size() != 3)
      throw UsageError("motion: --up takes 3 numbers (x,y,z in the input's frame)");
    o.up = Eigen::Vector3d(a.up[0], a.up[1], a.up[2]);
  }
  if (a.no_repairs) {
    o.fix_swaps = false;
    o.drop_frozen_frames = false;
    o.max_bone_deviation = 0.0;
    o.jump_speed_mps = 0.0;
  }
  const sim::KeypointMotion r = sim::motion_from_keypoints(k, topo, o);
  if (ext == ".bvh") {
    sim::write_bvh(a.output, r.body, r.motion);
  } else {
    sim::write_quaternion_csv(a.output, r.body, r.motion);
  }
  if (!a.body_json.empty())
    write_text_file(
        a.body_json,
        nlohmann::json::parse(sim::body_json(r.body, /*with_schema=*/true)).dump(2) + "\n");
  if (!a.report.empty()) write_text_file(a.report, report_of(r, a).dump(2) + "\n");
  if (!a.quiet) {
    for (const std::string& w : r.warnings) fmt::print(stderr, "imukit: warning: {}\n", w);
    fmt::print(stderr,
               "{}: {} frames at {:.2f} Hz -> {} frames at {} Hz ({} joints), up from {}, {} input "
               "frames repaired -> {}\n",
               a.keypoints, k.frames(), r.input_rate_hz, r.motion.frames(), r.motion.rate_hz(),
               r.body.size(), r.up_source, r.flagged_frames, a.output);
  }
  return 0;
}

}  // namespace

IMUKIT_REGISTER_COMMAND(
    motion,
    CommandSpec{
        "motion", "Body motion (joint quaternions or BVH) from 3D keypoints (Kinect, video pose)",
        55, [](CLI::App& sub) -> std::function<int()> {
          auto a = std::make_shared<MotionArgs>();
          sub.add_option("--keypoints", a->keypoints,
                         "Keypoints: CSV (t,<kp>_x,<kp>_y,<kp>_z,...) or .npy (frames, J, 3), m");
          sub.add_option("--topology", a->topology,
                         "kinect_v1_20, h36m_17, or a topology JSON file (docs/formats.md)");
          sub.add_option("-o,--output", a->output,
                         "FILE.csv (joint-quaternion CSV) or FILE.bvh (Y up, metres)");
          // The ranges motion_from_keypoints accepts, checked when the line is parsed (found in
          // review: nan reached the library, 1e9 Hz a singular spline system).
          sub.add_option("--rate", a->rate_hz,
                         "Input frame rate in Hz (a .npy file, or a CSV without a t column)")
              ->check(real_in(0.0, 1e4, "Hz", LowEnd::open));
          sub.add_option("--output-rate", a->output_rate_hz,
                         "Output frame rate in Hz (default 100)")
              ->check(real_in(0.0, 1e4, "Hz", LowEnd::open));
          sub.add_option("--cutoff", a->cutoff_hz,
                         "Smoothing cut-off in Hz: gain 1/2 there (default 3)")
              ->check(real_in(0.0, 1e3, "Hz", LowEnd::open));
          sub.add_option("--up", a->up,
                         "Up direction in the input's frame: x,y,z (default: "
                         "estimated from the upright body)")
              ->delimiter(',')
              ->expected(3);
          sub.add_option("--body-json", a->body_json,
                         "Also write the body as a scene \"body\" object ({\"joints\": [...]})");
          sub.add_option("--report", a->report,
                         "Also write a JSON report: repairs by frame, world frame, segments");
          sub.add_flag("--no-repairs", a->no_repairs,
                       "Keep frozen frames, limb swaps and bone-length outliers as they are (and "
                       "flag no jumps)");
          sub.add_flag("-q,--quiet", a->quiet, "No summary or warnings on stderr");
          sub.add_option("--print-topology", a->print_topology,
                         "Print a topology as JSON (a starting point for your own) and exit");
          sub.footer(
              "\nExamples:\n"
              "  imukit motion --keypoints a1_s1_t1.csv --topology kinect_v1_20 -o a1.bvh\n"
              "  imukit motion --keypoints pose3d.npy --rate 50 --topology h36m_17 -o m.csv "
              "--body-json body.json --report report.json\n"
              "  imukit motion --print-topology h36m_17 > my_rig.json\n");
          return [a] { return run_motion(*a); };
        }});

}  // namespace imukit::cli
