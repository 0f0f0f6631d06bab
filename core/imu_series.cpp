#include "imukit/core/imu_series.hpp"

#include <fmt/core.h>

#include <cassert>

#include "imukit/core/error.hpp"

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

void check_columns(std::string_view source, const char* name, Eigen::Index cols, std::size_t n) {
  if (cols != 0 && static_cast<std::size_t>(cols) != n) {
    throw Error(fmt::format("{}: channel {} has {} samples but the series has {} time stamps",
                            source, name, cols, n));
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

void ImuSeries::validate(std::string_view source) const {
  if (source.empty()) source = "ImuSeries";
  check_columns(source, "accel", accel.cols(), size());
  check_columns(source, "gyro", gyro.cols(), size());
  check_columns(source, "mag", mag.cols(), size());
  check_columns(source, "temperature", temperature_c.size(), size());
  check_time_order(t, source);
}

void check_time_order(std::span<const TimeNs> t, std::string_view source) {
  for (std::size_t i = 1; i < t.size(); ++i) {
    if (t[i] < t[i - 1]) {
      throw Error(
          fmt::format("{}: time goes backwards at sample {} ({} ns after {} ns, {} ns earlier)",
                      source, i, t[i], t[i - 1], t[i - 1] - t[i]));
    }
  }
}

std::optional<Eigen::Index> first_non_finite_sample(const Eigen::Matrix3Xd& channel) {
  for (Eigen::Index i = 0; i < channel.cols(); ++i)
    if (!channel.col(i).allFinite()) return i;
  return std::nullopt;
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
