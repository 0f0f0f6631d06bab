// imukit identify: fit the sensor's placement, biases and clock offset on its joint so that the
// simulator reproduces a real IMU recording (sim/identify.hpp, docs/identification.md). The
// motion is a skeleton's (BVH or joint-quaternion CSV, with --joint) or a rigid body's pose track
// from optical motion capture (--pose, read with the column grammar: t, qw..qz, px..pz).
//
// --imu and --pose take per-input options after them (--columns, --gaps, --time-unit, ...), as
// the other commands' input files do.
#include <fmt/core.h>
#include <fmt/os.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "command.hpp"
#include "hwmodel_common.hpp"
#include "imukit/core/column_text.hpp"
#include "imukit/core/error.hpp"
#include "imukit/core/input_file.hpp"
#include "imukit/core/so3.hpp"
#include "imukit/core/units.hpp"
#include "imukit/sim/bvh.hpp"
#include "imukit/sim/identify.hpp"
#include "imukit/sim/motion.hpp"
#include "imukit/sim/placement.hpp"
#include "inputs.hpp"
#include "options.hpp"

namespace imukit::cli {
namespace {

struct IdentifyArgs {
  std::string output;
  std::string motion;
  std::string joint;
  std::string init;
  std::string plot_dir;
  BvhArgs bvh;
  double height = 1.75;
  std::vector<std::string> fix;
  std::vector<std::string> estimate;
  std::vector<std::string> segments;
  double segment_prior = 0.05;
  std::optional<double> time_offset;
  std::optional<double> motion_start;
  // Options of a skeleton's motion given with --pose, where they do not apply.
  std::vector<std::string> skeleton_only_given;
  double max_time_offset = 1.0;
  double gravity = kStandardGravity;
  int threads = 1;
  double max_clock_rate = 2e-4;
  std::string correct = "none";
  double knot_spacing = 0.3;
  // The library's defaults (1.5 rad, 0.1 rad) in degrees.
  double twist_prior_deg = 1.5 * kDegPerRad;
  double tilt_prior_deg = 0.1 * kDegPerRad;
  double correction_smoothness = 30.0;
  double function_tolerance = 1e-12;
  double accel_bias_prior = 0.0;
  double gyro_bias_prior = 0.0;
  std::string scene_out;
  std::string sensor_name;
};

// --imu FILE [options] and --pose FILE [options], from the tokens CLI11 left over.
struct RoleInputs {
  std::optional<InputArg> imu, pose;
};

RoleInputs split_inputs(const std::vector<std::string>& tokens) {
  RoleInputs r;
  std::vector<std::string> group;
  std::string role;
  auto flush = [&] {
    if (role.empty()) return;
    const auto parsed = parse_input_args(group);
    if (parsed.size() != 1)
      throw UsageError(fmt::format("identify: {} takes exactly one file", role));
    (role == "--imu" ? r.imu : r.pose) = parsed.front();
  };
  for (std::size_t i = 0; i < tokens.size(); ++i) {
    if (tokens[i] == "--imu" || tokens[i] == "--pose") {
      flush();
      role = tokens[i];
      if (i + 1 >= tokens.size()) throw UsageError(fmt::format("identify: {} needs a file", role));
      if ((role == "--imu" ? r.imu : r.pose).has_value())
        throw UsageError(fmt::format("identify: {} given twice", role));
      group = {tokens[++i]};
      continue;
    }
    if (role.empty())
      throw UsageError(fmt::format("identify: unexpected '{}' (see --help)", tokens[i]));
    group.push_back(tokens[i]);
  }
  flush();
  return r;
}

sim::PoseTrack load_pose_track(const InputArg& in) {
  if (in.columns.empty()) {
    throw UsageError(fmt::format(
        "{}: say where the pose is with --columns, e.g. --columns t,qw,qx,qy,qz,px,py,pz",
        in.path));
  }
  const ColumnSpec spec = column_spec(in);
  for (Column c : {Column::t, Column::qw, Column::qx, Column::qy, Column::qz, Column::px,
                   Column::py, Column::pz}) {
    if (!spec.has(c)) {
      throw UsageError(
          fmt::format("{}: a pose track needs columns t, qw, qx, qy, qz, px, py, pz (missing {})",
                      in.path, column_name(c)));
    }
  }
  const ColumnTable table = read_column_text(in.path, spec);
  sim::PoseTrack track;
  track.t = table.t;
  track.p_world_body.resize(3, static_cast<Eigen::Index>(table.rows));
  for (std::size_t i = 0; i < table.rows; ++i) {
    track.q_world_body.emplace_back(table[Column::qw][i], table[Column::qx][i],
                                    table[Column::qy][i], table[Column::qz][i]);
    track.p_world_body.col(static_cast<Eigen::Index>(i)) =
        Eigen::Vector3d(table[Column::px][i], table[Column::py][i], table[Column::pz][i]);
  }
  return track;
}

void apply_names(const std::vector<std::string>& names, bool value, sim::IdentifyOptions& o,
                 const char* option) {
  for (const std::string& n : names) {
    if (n == "rotation")
      o.rotation = value;
    else if (n == "position")
      o.position = value;
    else if (n == "accel_bias")
      o.accel_bias = value;
    else if (n == "gyro_bias")
      o.gyro_bias = value;
    else if (n == "accel_scale")
      o.accel_scale = value;
    else if (n == "gyro_scale")
      o.gyro_scale = value;
    else if (n == "time_offset")
      o.time_offset = value;
    else if (n == "clock_rate")
      o.clock_rate = value;
    else {
      throw UsageError(
          fmt::format("identify: {} '{}' is not one of rotation, position, accel_bias, gyro_bias, "
                      "accel_scale, gyro_scale, time_offset, clock_rate",
                      option, n));
    }
  }
}

void write_plot(const std::string& dir, const sim::IdentifyResult& r) {
  std::filesystem::create_directories(dir);
  const std::string dat = "identify_signals.dat";  // beside the script (run_gnuplot)
  {
    auto out = fmt::output_file((std::filesystem::path(dir) / dat).string());
    out.print(
        "# t_s  measured ax ay az gx gy gz  simulated-before ax ay az gx gy gz  simulated-after ax "
        "ay az gx gy gz\n");
    const double t0 = static_cast<double>(r.t.front());
    for (std::size_t i = 0; i < r.t.size(); ++i) {
      const auto c = static_cast<Eigen::Index>(i);
      out.print("{:.6f}", (static_cast<double>(r.t[i]) - t0) * 1e-9);
      for (const Eigen::Matrix3Xd* m :
           {&r.accel, &r.gyro, &r.accel_before, &r.gyro_before, &r.accel_after, &r.gyro_after})
        out.print(" {:.7g} {:.7g} {:.7g}", (*m)(0, c), (*m)(1, c), (*m)(2, c));
      out.print("\n");
    }
  }
  std::string script = fmt::format(
      "set multiplot layout 3,2 title 'measured vs simulated (identified placement, bias, time "
      "offset)'\n"
      "set grid\n");
  const char* axis = "xyz";
  for (int k = 0; k < 3; ++k) {
    for (int s = 0; s < 2; ++s) {  // accelerometer column 2+k, gyroscope 5+k
      const int col = 2 + 3 * s + k;
      // One legend, above the first panel: inside a panel it covers the data.
      const std::string key = k == 0 && s == 0   ? "set key above horizontal font ',9'\n"
                              : k == 0 && s == 1 ? "unset key\n"
                                                 : "";
      script += fmt::format(
          "{}set ylabel '{}_{} [{}]'\n{}plot '{}' u 1:{} w l lc rgb '#999999' t 'measured', '' u "
          "1:{} w l lc 1 t "
          "'simulated, identified', '' u 1:{} w l lc 2 dt 2 t 'simulated, before'\n",
          key, s == 0 ? "a" : "w", axis[k], s == 0 ? "m/s^2" : "rad/s",
          k == 2 ? "set xlabel 't [s]'\n" : "", dat, col, col + 12, col + 6);
    }
  }
  script += "unset multiplot\n";
  run_gnuplot(dir, "identify_signals", script);
}

// The options from the command line; the joint and the motion's timing come with the motion.
sim::IdentifyOptions identify_options(const IdentifyArgs& a) {
  sim::IdentifyOptions o;
  o.threads = a.threads;
  o.max_time_offset_s = a.max_time_offset;
  o.segment_prior = a.segment_prior;
  o.gravity_world = Eigen::Vector3d(0, 0, -std::abs(a.gravity));
  o.max_clock_rate = a.max_clock_rate;
  o.correction = sim::parse_segment_correction(a.correct);
  o.correction_knot_spacing_s = a.knot_spacing;
  // Divided, not multiplied by kRadPerDeg: the defaults above come back as the library's exact
  // values (0.1 * kDegPerRad * kRadPerDeg is 0.10000000000000002).
  o.twist_prior_rad = a.twist_prior_deg / kDegPerRad;
  o.tilt_prior_rad = a.tilt_prior_deg / kDegPerRad;
  o.correction_smoothness_radps2 = a.correction_smoothness;
  o.function_tolerance = a.function_tolerance;
  o.accel_bias_prior_mps2 = a.accel_bias_prior;
  o.gyro_bias_prior_radps = a.gyro_bias_prior;
  // A name in both lists was estimated here and fixed from Python (found in review,
  // 2026-11-27): refused in both.
  for (const std::string& n : a.fix)
    if (std::find(a.estimate.begin(), a.estimate.end(), n) != a.estimate.end())
      throw UsageError("identify: '" + n + "' is both in --fix and in --estimate");
  apply_names(a.fix, false, o, "--fix");
  apply_names(a.estimate, true, o, "--estimate");
  if (a.time_offset) {
    o.coarse_time_offset = false;
    o.time_offset_init_s = *a.time_offset;
  }
  return o;
}

// The body and its motion to fit on.
struct FitMotion {
  sim::Body body;
  std::shared_ptr<sim::Motion> motion;
};

// A rigid body's pose track (--pose): the tracked body is the joint; its gaps are filled and left
// out of the fit.
FitMotion pose_motion(const IdentifyArgs& a, const InputArg& pose, sim::IdentifyOptions& o) {
  if (!a.joint.empty() || !a.init.empty() || !a.segments.empty())
    throw UsageError(
        "identify --pose: the tracked body is the joint; --joint, --init and --segments do not "
        "apply");
  // They were taken and ignored (found in review, 2026-11-27).
  if (!a.skeleton_only_given.empty())
    throw UsageError("identify --pose: " + a.skeleton_only_given.front() +
                     " is an option of a skeleton's motion (--motion); it does not apply");
  sim::PoseMotion pm = sim::pose_track_motion(load_pose_track(pose), pose.path);
  FitMotion m;
  m.body = std::move(pm.body);
  m.motion = std::make_shared<sim::Motion>(std::move(pm.motion));
  o.joint = 0;
  // The track's first row, on the track's clock, unless --motion-start puts it on the IMU's (a
  // track on another clock); the option was silently ignored until review, 2026-11-27.
  o.motion_start_ns = a.motion_start ? from_seconds(*a.motion_start) : pm.start_ns;
  o.invalid_motion = pm.gaps;
  // The tracked orientation is the sensor frame's or close to it: start from identity.
  o.init_rotation_from_data = false;
  if (pm.missing_rows > 0) {
    fmt::print("pose track: {} missing rows in {} gap(s) filled and left out of the fit\n",
               pm.missing_rows, pm.gaps.size());
  }
  return m;
}

// A skeleton's motion (--motion, BVH or joint-quaternion CSV) with the sensor's joint from
// --joint and/or --init, the segments to fit, and frame 0 at --motion-start (default: the first
// IMU sample). The reader's warnings go to `warnings`.
FitMotion skeleton_motion(const IdentifyArgs& a, const ImuSeries& imu, sim::IdentifyOptions& o,
                          std::vector<std::string>& warnings) {
  FitMotion m;
  const std::filesystem::path mp(a.motion);
  if (mp.extension() == ".bvh") {
    sim::BvhData d = load_bvh(a.motion, a.bvh);
    m.body = std::move(d.body);
    m.motion = std::make_shared<sim::Motion>(std::move(d.motion));
    warnings = std::move(d.warnings);
  } else {
    m.body = sim::Body::default_humanoid(a.height);
    m.motion = std::make_shared<sim::Motion>(
        sim::read_quaternion_csv(a.motion, m.body, std::nullopt, &warnings));
  }
  const sim::Body& body = m.body;
  if (!a.init.empty()) {
    o.init = sim::preset_placement(a.init, body);
    o.joint = o.init.joint;
  }
  if (!a.joint.empty()) {
    const int j = body.index_of(a.joint);
    if (!a.init.empty() && j != o.joint) {
      throw UsageError(fmt::format("identify: preset '{}' sits on '{}', not on --joint '{}'",
                                   a.init, body.joint(static_cast<std::size_t>(o.joint)).name,
                                   a.joint));
    }
    o.joint = j;
  }
  if (o.joint < 0)
    throw UsageError("identify --motion: name the sensor's joint with --joint (or --init PRESET)");
  for (const std::string& s : a.segments) o.segments.push_back(body.index_of(s));
  o.motion_start_ns = a.motion_start ? from_seconds(*a.motion_start) : imu.t.front();
  return m;
}

// The fit on stdout (warnings on stderr): the estimates in display units, the correction, the
// residuals and the fidelity before and after.
void print_result(const sim::IdentifyResult& r, const sim::IdentifyOptions& o) {
  fmt::print(
      "{} IMU samples used ({} left out: outside the motion or in gaps), fit in {:.2f} s, {} "
      "iterations{}\n",
      r.samples_used, r.samples_excluded, r.seconds, r.iterations,
      r.converged ? "" : " (not converged)");
  for (const std::string& w : r.warnings) fmt::print(stderr, "warning: {}\n", w);
  fmt::print("time offset the fine fit started from: {:.4f} s\n", r.coarse_time_offset_s);
  fmt::print("{:<22} {:>14} {:>12}\n", "parameter", "value", "std error");
  for (const sim::ParameterEstimate& e : r.parameters) {
    if (!e.estimated) continue;
    const bool deg = e.name.rfind("rotation.", 0) == 0;
    const bool ms = e.name == "time_offset";
    const double f = deg ? kDegPerRad : ms ? 1e3 : e.name == "clock_rate" ? 1e6 : 1.0;
    const std::string unit = deg ? "deg" : ms ? "ms" : e.name == "clock_rate" ? "ppm" : e.unit;
    if (!e.observable) {
      fmt::print("{:<22} {:>14} {:>12}  {}\n", e.name, "unobservable", "-", unit);
      continue;
    }
    fmt::print("{:<22} {:>14.6g} {:>12.3g}  {}\n", e.name, e.value * f, e.std_error * f, unit);
  }
  if (o.clock_rate) fmt::print("time scale (1 + clock_rate): {:.6f}\n", 1.0 + r.clock_rate);
  if (r.correction.dims > 0) {
    const char* names[3] = {"twist", "tilt (anterior axis)", "tilt (normal axis)"};
    const auto n = static_cast<double>(std::max<Eigen::Index>(1, r.correction_angles.cols()));
    for (int d = 0; d < r.correction.dims; ++d) {
      fmt::print(
          "segment correction {}: RMS {:.2f} deg, max {:.2f} deg ({} knots every {:.3f} s)\n",
          names[d], std::sqrt(r.correction_angles.row(d).squaredNorm() / n) * kDegPerRad,
          r.correction_angles.row(d).cwiseAbs().maxCoeff() * kDegPerRad,
          r.correction.control.cols(), r.correction.knot_spacing_s);
    }
  }
  fmt::print(
      "residual RMS  accelerometer {:.4f} -> {:.4f} m/s^2, gyroscope {:.5f} -> {:.5f} rad/s "
      "(before -> after)\n",
      r.rms_before.accel, r.rms_after.accel, r.rms_before.gyro, r.rms_after.gyro);
  fmt::print("fidelity per axis, before -> after:\n");
  for (int k = 0; k < 3; ++k) {
    fmt::print(
        "  a{}: RMSE {:.3f} -> {:.3f} m/s^2, r {:.3f} -> {:.3f}   g{}: RMSE {:.4f} -> {:.4f} "
        "rad/s, r {:.3f} -> {:.3f}\n",
        "xyz"[k], r.fidelity_before.accel.rmse[k], r.fidelity_after.accel.rmse[k],
        r.fidelity_before.accel.correlation[k], r.fidelity_after.accel.correlation[k], "xyz"[k],
        r.fidelity_before.gyro.rmse[k], r.fidelity_after.gyro.rmse[k],
        r.fidelity_before.gyro.correlation[k], r.fidelity_after.gyro.correlation[k]);
  }
}

// --scene-out: the fitted motion on the IMU's clock (sim::fitted_scene_clock) in a scene.
void write_scene(const IdentifyArgs& a, const FitMotion& m, const ImuSeries& imu,
                 const sim::IdentifyResult& r, const sim::IdentifyOptions& o) {
  const sim::Body& body = m.body;
  const sim::FittedSceneClock clock = sim::fitted_scene_clock(imu.t);
  const double rate = clock.rate_hz;
  const sim::Motion fitted =
      sim::fitted_motion(body, *m.motion, r, clock.first_ns, clock.frames, clock.rate_hz);
  sim::write_fitted_scene(a.scene_out, body, fitted, r,
                          a.sensor_name.empty()
                              ? body.joint(static_cast<std::size_t>(r.placement.joint)).name
                              : a.sensor_name,
                          o.gravity_world);
  fmt::print("wrote the fitted scene in {} (scene.json, motion.csv at {:.6g} Hz, placement.json)\n",
             a.scene_out, rate);
}

int run_identify(const IdentifyArgs& a, const std::vector<std::string>& tokens) {
  const RoleInputs in = split_inputs(tokens);
  if (!in.imu) throw UsageError("identify: give the IMU recording with --imu FILE");
  if (in.pose.has_value() == !a.motion.empty())
    throw UsageError(
        "identify: give the motion with either --motion FILE (with --joint) or --pose FILE");
  // Checked before the fit (found in review: refused only after it, with -o already written).
  if (!a.scene_out.empty() && in.pose)
    throw UsageError("identify --scene-out: needs a skeleton motion (--motion), not --pose");
  // The name becomes the scene's sensor name, which names output files.
  if (a.sensor_name.find('/') != std::string::npos)
    throw UsageError("identify --sensor-name: " + quote_excerpt(a.sensor_name) +
                     " names output files, so it cannot hold '/'");
  ImuSeries imu = load_imu_series(*in.imu);
  imu.validate(in.imu->path);
  if (imu.size() < 2) {
    throw Error(fmt::format("{}: holds {} IMU sample(s); identify needs a recording", in.imu->path,
                            imu.size()));
  }
  sim::IdentifyOptions o = identify_options(a);
  std::vector<std::string> warnings;
  const FitMotion m = in.pose ? pose_motion(a, *in.pose, o) : skeleton_motion(a, imu, o, warnings);
  for (const std::string& w : warnings) fmt::print(stderr, "warning: {}\n", w);

  const sim::IdentifyResult r = sim::identify(m.body, *m.motion, imu, o);
  print_result(r, o);
  write_text_file(a.output, sim::placement_json(r, m.body));
  fmt::print("wrote {}\n", a.output);
  if (!a.scene_out.empty()) write_scene(a, m, imu, r, o);
  if (!a.plot_dir.empty()) {
    write_plot(a.plot_dir, r);
    fmt::print("plots in {}\n", a.plot_dir);
  }
  if (!r.unobservable.empty()) {
    std::string names;
    for (const std::string& n : r.unobservable) names += (names.empty() ? "" : ", ") + n;
    fmt::print(stderr,
               "imukit: identify: not identifiable from this motion: {} (written as null); record "
               "motion that "
               "turns about more axes, or hold them with --fix\n",
               names);
    return kBadInput;  // the output is written, but the motion could not determine all asked
  }
  return 0;
}

}  // namespace

IMUKIT_REGISTER_COMMAND(
    identify,
    CommandSpec{
        "identify", "Fit placement, biases and clock offset so the simulator reproduces a real IMU",
        62, [](CLI::App& sub) -> std::function<int()> {
          auto a = std::make_shared<IdentifyArgs>();
          sub.allow_extras();
          sub.add_option("-o,--output", a->output, "placement JSON to write (imukit.placement/1)")
              ->required();
          sub.add_option("--motion", a->motion,
                         "body motion: BVH (.bvh) or joint-quaternion CSV (default humanoid)");
          sub.add_option("--joint", a->joint, "the joint (or segment) carrying the sensor");
          sub.add_option("--init", a->init,
                         "placement preset to start from (see imukit simulate --list-presets)");
          add_bvh_options(sub, a->bvh);
          sub.add_option("--height", a->height,
                         "stature of the default humanoid for a quaternion CSV, m")
              ->check(real_in(0.3, 3, "m"));
          sub.add_option("--fix", a->fix,
                         "hold at the initial value (comma list): rotation, position, accel_bias, "
                         "gyro_bias, time_offset")
              ->delimiter(',');
          sub.add_option("--estimate", a->estimate,
                         "also estimate (comma list): accel_scale, gyro_scale, clock_rate")
              ->delimiter(',');
          sub.add_option("--segments", a->segments,
                         "joints on the sensor's chain whose offset from the parent (segment "
                         "length) to fit")
              ->delimiter(',');
          sub.add_option("--segment-prior", a->segment_prior,
                         "relative width of the segment-length prior (default 0.05)")
              ->check(real_in(0, 10, "", LowEnd::open));
          sub.add_option(
                 "--time-offset", a->time_offset,
                 "initial time offset, s: the cross-correlation searches only +-0.25 s around it "
                 "(--fix time_offset holds it exactly)")
              ->check(real_in(-86400, 86400, "s"));
          sub.add_option("--max-time-offset", a->max_time_offset,
                         "search range of the cross-correlation, s (default 1)")
              ->check(real_in(0, 3600, "s", LowEnd::open));
          sub.add_option("--motion-start", a->motion_start,
                         "IMU-clock time of motion frame 0 (with --pose: of the track's first "
                         "row), s (default: the first IMU sample; with --pose the track's own "
                         "time)")
              ->check(real_in(-4e9, 4e9, "s"));
          sub.add_option("--gravity", a->gravity, "gravity magnitude, m/s^2")
              ->check(gravity_range());
          sub.add_option("--threads", a->threads, "threads for the Jacobian (default 1)")
              ->check(whole_in(1, 64));
          sub.add_option("--max-clock-rate", a->max_clock_rate,
                         "bound of |clock_rate| with --estimate clock_rate (default 2e-4; streams "
                         "aligned by duration need e.g. 0.1, which also searches it coarsely)")
              ->check(real_in(0, 0.5, ""));
          sub.add_option("--correct", a->correct,
                         "smooth correction of the sensor segment's rotation: none (default), "
                         "twist (about the segment's long axis) or rotation (twist + two tilts)")
              ->check(CLI::IsMember({"none", "twist", "rotation"}));
          sub.add_option("--knot-spacing", a->knot_spacing,
                         "knot spacing of the correction's spline, s (default 0.3)")
              ->check(real_in(0.01, 3600, "s"));
          sub.add_option("--twist-prior", a->twist_prior_deg,
                         "1-sigma prior of the twist angle, deg (default 85.94, 1.5 rad)")
              ->check(real_in(0, 1e4, "deg", LowEnd::open));
          sub.add_option("--tilt-prior", a->tilt_prior_deg,
                         "1-sigma prior of the two tilt angles, deg (default 5.73, 0.1 rad)")
              ->check(real_in(0, 1e4, "deg", LowEnd::open));
          sub.add_option("--correction-smoothness", a->correction_smoothness,
                         "1-sigma prior of the correction's angular acceleration at each knot, "
                         "rad/s^2 (default 30)")
              ->check(real_in(0, 1e6, "rad/s^2", LowEnd::open));
          sub.add_option("--function-tolerance", a->function_tolerance,
                         "stop when a step changes the cost by less than this fraction "
                         "(default 1e-12; 1e-6 with a clock rate, docs/identification.md)")
              ->check(real_in(0, 1, "", LowEnd::open));
          sub.add_option("--accel-bias-prior", a->accel_bias_prior,
                         "1-sigma Gaussian prior of the accelerometer bias, m/s^2 (0: none)")
              ->check(real_in(0, 1e3, "m/s^2"));
          sub.add_option("--gyro-bias-prior", a->gyro_bias_prior,
                         "1-sigma Gaussian prior of the gyroscope bias, rad/s (0: none)")
              ->check(real_in(0, 1e3, "rad/s"));
          sub.add_option("--scene-out", a->scene_out,
                         "folder for the fitted scene: scene.json, motion.csv (the fit baked into "
                         "the motion, on the IMU's clock) and placement.json");
          sub.add_option("--sensor-name", a->sensor_name,
                         "the sensor's name in the fitted scene (default: the joint's name)");
          sub.add_option("--plot", a->plot_dir,
                         "folder for an SVG of measured against simulated signals (gnuplot)");
          sub.footer("--imu FILE and --pose FILE each take the per-input options after them.\n" +
                     input_options_help() +
                     "\n\nExamples:\n"
                     "  imukit identify --imu watch.csv --motion walk.bvh --bvh-scale 0.056444 "
                     "--init left_wrist_watch \\\n"
                     "      -o placement.json --plot plots\n"
                     "  imukit identify --imu 02_undisturbed_slow_rotation_B.csv --columns "
                     "'t,ax,ay,az,gx,gy,gz,_*' \\\n"
                     "      --pose 02_undisturbed_slow_rotation_B.csv --columns "
                     "t,_9,qw,qx,qy,qz,px,py,pz,_ \\\n"
                     "      --gaps qw,qx,qy,qz,px,py,pz -o placement.json\n");
          return [&sub, a] {
            for (const char* name : {"--height", "--bvh-scale", "--up"})
              if (sub.count(name) > 0) a->skeleton_only_given.emplace_back(name);
            return run_identify(*a, sub.remaining());
          };
        }});

}  // namespace imukit::cli
