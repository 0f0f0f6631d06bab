// EuRoC / Kalibr CSV for one IMU stream, the layout Kalibr, OpenVINS, ORB-SLAM and pandas read:
//   #timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],
//   a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]
// Integer nanosecond timestamps; values printed with 17 significant digits, so a round trip is
// bit-exact.
#pragma once

#include <cstdio>
#include <string>
#include <string_view>

#include "imukit/core/imu_series.hpp"

namespace imukit {

inline constexpr std::string_view kEurocHeader =
    "#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],"
    "a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]";

// Needs accelerometer and gyroscope. Throws imukit::Error naming the path on any write failure
// (including a full disk); what was written before the failure stays in the file.
void write_euroc_csv(const std::string& path, const ImuSeriesView& series);
// The same into an open stream (`name` is used in error messages).
void write_euroc_csv(std::FILE* out, const std::string& name, const ImuSeriesView& series);

// Reads the layout above. The header row is required (its first field must start with
// "#timestamp" or "timestamp"); errors name file, line and column.
ImuSeries read_euroc_csv(const std::string& path);
ImuSeries parse_euroc_csv(std::string_view text, const std::string& source_name);

}  // namespace imukit
