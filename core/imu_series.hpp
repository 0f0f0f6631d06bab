// ImuSeries: one IMU stream as structure-of-arrays samples in SI units, and ImuSeriesView, a
// cheap non-owning slice of it. Recording: named streams plus metadata and events.
//
// Channels other than time are optional: a matrix with zero columns means "not recorded".
// Samples are columns (3 x N, column-major), so a slice of consecutive samples is one
// contiguous block and can be mapped without copying.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <map>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "imukit/core/time.hpp"

namespace imukit {

class ImuSeriesView;

struct ImuSeries {
  std::vector<TimeNs> t;          // sample times, ns
  Eigen::Matrix3Xd accel;         // specific force, m/s^2
  Eigen::Matrix3Xd gyro;          // angular rate, rad/s
  Eigen::Matrix3Xd mag;           // magnetic flux density, T
  Eigen::VectorXd temperature_c;  // degrees Celsius

  // An empty series of n samples with the chosen channels allocated (values uninitialised).
  static ImuSeries with_channels(std::size_t n, bool accel, bool gyro, bool mag = false,
                                 bool temperature = false);

  std::size_t size() const { return t.size(); }
  bool empty() const { return t.empty(); }
  bool has_accel() const { return accel.cols() > 0; }
  bool has_gyro() const { return gyro.cols() > 0; }
  bool has_mag() const { return mag.cols() > 0; }
  bool has_temperature() const { return temperature_c.size() > 0; }

  // Throws imukit::Error unless every present channel has size() samples and times never
  // decrease; the message starts with `source` (a file, a stream) when given.
  void validate(std::string_view source = {}) const;

  // Samples [begin, begin + count), without copying. Asserts the range is inside the series.
  ImuSeriesView slice(std::size_t begin, std::size_t count) const;
  ImuSeriesView view() const;
};

// Throws imukit::Error, naming `source` and the sample, where a time is before the one before.
void check_time_order(std::span<const TimeNs> t, std::string_view source);

// The first sample (column) of a channel with a NaN or infinite value, if any: what a caller
// that needs every sample (calibration, STDA datasets) names in its error.
std::optional<Eigen::Index> first_non_finite_sample(const Eigen::Matrix3Xd& channel);

// A read-only window into an ImuSeries; valid while the series is alive and not resized.
class ImuSeriesView {
 public:
  using Map3X = Eigen::Map<const Eigen::Matrix3Xd>;
  using MapX = Eigen::Map<const Eigen::VectorXd>;

  ImuSeriesView(std::span<const TimeNs> t, Map3X accel, Map3X gyro, Map3X mag, MapX temperature_c)
      : t(t), accel(accel), gyro(gyro), mag(mag), temperature_c(temperature_c) {}

  std::span<const TimeNs> t;
  Map3X accel;
  Map3X gyro;
  Map3X mag;
  MapX temperature_c;

  std::size_t size() const { return t.size(); }
  bool has_accel() const { return accel.cols() > 0; }
  bool has_gyro() const { return gyro.cols() > 0; }
  bool has_mag() const { return mag.cols() > 0; }
  bool has_temperature() const { return temperature_c.size() > 0; }

  ImuSeriesView slice(std::size_t begin, std::size_t count) const;
  ImuSeries copy() const;
};

// Something that happened at a time: a sync tap, a pose change, a note typed by the user.
struct Event {
  TimeNs t = 0;
  std::string kind;   // e.g. "tap", "pose", "note"
  std::string label;  // free text
};

// Everything one capture or simulation produced: streams by name (a device, a simulated
// sensor), free-form metadata (device info, configuration, gravity used) and events.
struct Recording {
  std::map<std::string, ImuSeries> streams;
  std::map<std::string, std::string> metadata;
  std::vector<Event> events;
};

}  // namespace imukit
