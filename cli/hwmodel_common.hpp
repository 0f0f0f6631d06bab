// What `imukit characterize`, `imukit calibrate` and `imukit demo` share: grouping input files
// into recordings (files with identical time stamps are channels of one recording and are
// merged), the characterization (noise of each axis, turn-on bias across recordings) and the
// multi-position calibration as the commands run them, their printed tables and profile
// sections, and gnuplot output (SVG) with the data and script left beside it.
#pragma once

#include <Eigen/Core>
#include <array>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "imukit/core/imu_series.hpp"
#include "imukit/core/profile.hpp"
#include "imukit/core/units.hpp"
#include "imukit/hwmodel/allan.hpp"
#include "imukit/hwmodel/calibration.hpp"
#include "imukit/hwmodel/characterize.hpp"
#include "imukit/hwmodel/noise_fit.hpp"
#include "inputs.hpp"

namespace imukit::cli {

struct LoadedRun {
  std::string name;  // the first file's path
  ImuSeries series;
  Recording context;  // the first file's metadata and events (MCAP), streams empty
};

// Before the work: the profile `path` will be created or updated, so it must be absent or a
// valid profile, in a folder that takes new files (found in review: an invalid profile was found
// only after the whole computation).
void check_profile_to_update(const std::string& path);

// Loads every input; an input whose time stamps equal the previous run's adds its channels to
// that run (a channel present in both is an error), any other starts a new run.
std::vector<LoadedRun> load_runs(const std::vector<InputArg>& inputs);

// Writes DIR/NAME.gp and runs gnuplot on it to make DIR/NAME.svg. Returns false (after a
// note on stderr) when gnuplot is not installed: the script and data stay for later.
bool run_gnuplot(const std::filesystem::path& dir, const std::string& name,
                 const std::string& script);

// ---- characterize -------------------------------------------------------------------------

struct CharacterizeOptions {
  double gravity = kStandardGravity;
  int points_per_decade = 10;
  double fit_tau_min_s = 0.0;
  // Recordings were taken level with z up: also give the accelerometer turn-on bias, as the
  // mean minus the specific force a still, level sensor reads. That is level_reading when set
  // (e.g. diag(scale) misalignment (0, 0, g) from a calibration), else (0, 0, g).
  bool level = false;
  std::optional<Eigen::Vector3d> level_reading;
};

struct CharacterizeResult {
  std::string noise_run;  // the (longest) recording(s) the noise came from, per sensor
  std::optional<hwmodel::TriadNoise> accel, gyro;
  std::vector<Eigen::Vector3d> accel_run_bias, gyro_run_bias;  // per recording, in input order
  DeviceProfile update;  // the noise and turn_on_bias sections
};

// Noise from the longest recording, turn-on bias across all of them; prints the tables.
// Throws imukit::Error when the recordings hold neither accelerometer nor gyroscope data.
CharacterizeResult characterize_runs(const std::vector<LoadedRun>& runs,
                                     const CharacterizeOptions& options);
// The axes whose noise-model fit does not describe their Allan curve, chi^2/dof above 100 (still
// real sensors give 1 to 34, docs/validation.md; a record with motion 1e4 and more), each as
// "gyroscope x (chi2/dof 2.1e+04)". Their numbers are no noise model.
std::vector<std::string> axes_without_noise_model(const CharacterizeResult& result);
// DIR/accelerometer_allan.svg and DIR/gyroscope_allan.svg (and their .dat and .gp).
void plot_noise(const std::filesystem::path& dir, const CharacterizeResult& result);

// ---- calibrate ----------------------------------------------------------------------------

struct CalibrateOptions {
  double gravity = kStandardGravity;
  bool raw = false;  // readings are ADC counts
  bool gyro = true;  // calibrate the gyroscope too (when the recording has one)
  double init_static_s = 50.0;
};

// The initial static period a guided capture (`imukit record --guide multipos`) recorded: its
// length (metadata imukit.guide.initial_still_s) and where it starts (the "initial_still"
// event). nullopt for other recordings.
struct InitialStill {
  double seconds = 0.0;
  TimeNs start = 0;
};
std::optional<InitialStill> guided_initial_still(const LoadedRun& run);

struct CalibrateResult {
  hwmodel::CalibrationResult fit;
  bool gyro = false;
  DeviceProfile update;  // the calibration sections (forward model, core/profile.hpp)
};

// Multi-position calibration of one recording; prints the estimates and residuals.
CalibrateResult calibrate_series(const ImuSeries& series, const CalibrateOptions& options);
// DIR/calibration_residuals.svg (and .dat, .gp).
void plot_calibration(const std::filesystem::path& dir, const ImuSeries& series,
                      const CalibrateResult& result);

}  // namespace imukit::cli
