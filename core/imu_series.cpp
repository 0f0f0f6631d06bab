#include "core/imu_series.hpp"

#include <cassert>

#include "core/error.hpp"

namespace imukit {
namespace {

ImuSeriesView::Map3X map_columns(const Eigen::Matrix3Xd& m, std::size_t begin, std::size_t count) {
  if (m.cols() == 0) return {nullptr, 3, 0};
  return {m.data() + 3 * begin, 3, static_cast<Eigen::Index>(count)};
}

ImuSeriesView::Map3X map_columns(const ImuSeriesView::Map3X& m, std::size_t begin,
                                 std::size_t count) {
  if (m.cols() == 0) return {nullptr, 3, 0};
  return {m.data() + 3 * begin, 3, static_cast<Eigen::Index>(count)};
}

template <typename Vector>
ImuSeriesView::MapX map_range(const Vector& v, std::size_t begin, std::size_t count) {
  if (v.size() == 0) return {nullptr, 0};
  return {v.data() + begin, static_cast<Eigen::Index>(count)};
}

void check_columns(const char* name, Eigen::Index cols, std::size_t n) {
  if (cols != 0 && static_cast<std::size_t>(cols) != n) {
    throw Error(std::string("ImuSeries: channel ") + name + " has " + std::to_string(cols) +
                " samples but the series has " + std::to_string(n) + " timestamps");
  }
}

}  // namespace

ImuSeries ImuSeries::with_channels(std::size_t n, bool accel, bool gyro, bool mag,
                                   bool temperature) {
  ImuSeries s;
  const auto cols = static_cast<Eigen::Index>(n);
  s.t.resize(n);
  if (accel) s.accel.resize(3, cols);
  if (gyro) s.gyro.resize(3, cols);
  if (mag) s.mag.resize(3, cols);
  if (temperature) s.temperature_c.resize(cols);
  return s;
}

void ImuSeries::validate() const {
  check_columns("accel", accel.cols(), size());
  check_columns("gyro", gyro.cols(), size());
  check_columns("mag", mag.cols(), size());
  check_columns("temperature", temperature_c.size(), size());
  for (std::size_t i = 1; i < t.size(); ++i) {
    if (t[i] < t[i - 1]) {
      throw Error("ImuSeries: time goes backwards at sample " + std::to_string(i) + " (" +
                  std::to_string(t[i - 1]) + " ns then " + std::to_string(t[i]) + " ns)");
    }
  }
}

ImuSeriesView ImuSeries::slice(std::size_t begin, std::size_t count) const {
  assert(begin + count <= size());
  return ImuSeriesView(std::span<const TimeNs>(t).subspan(begin, count),
                       map_columns(accel, begin, count), map_columns(gyro, begin, count),
                       map_columns(mag, begin, count), map_range(temperature_c, begin, count));
}

ImuSeriesView ImuSeries::view() const { return slice(0, size()); }

ImuSeriesView ImuSeriesView::slice(std::size_t begin, std::size_t count) const {
  assert(begin + count <= size());
  return ImuSeriesView(t.subspan(begin, count), map_columns(accel, begin, count),
                       map_columns(gyro, begin, count), map_columns(mag, begin, count),
                       map_range(temperature_c, begin, count));
}

ImuSeries ImuSeriesView::copy() const {
  ImuSeries s;
  s.t.assign(t.begin(), t.end());
  s.accel = accel;
  s.gyro = gyro;
  s.mag = mag;
  s.temperature_c = temperature_c;
  return s;
}

}  // namespace imukit
