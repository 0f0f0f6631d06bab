// The static detector and the calibration refuse options and recordings they cannot use with a
// message instead of an Eigen assertion, undefined behaviour or a flood of Ceres NaNs (issue 16).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "imukit/core/error.hpp"
#include "imukit/core/time.hpp"
#include "imukit/hwmodel/calibration.hpp"
#include "support/expect_error.hpp"

namespace imukit::hwmodel {
namespace {

using imukit::testing::expect_error;

// `n` samples at 100 Hz of a noiseless accelerometer that holds each of `faces` (gravity along
// +z, +x, +y, -z, -x, -y, then tilted between them) for 5 s, 10 s for the first, with a 1 s turn
// between poses.
struct Recording {
  std::vector<TimeNs> t;
  Eigen::Matrix3Xd accel;
};
Recording noiseless_poses(int poses) {
  std::vector<Eigen::Vector3d> dirs;
  for (int k = 0; k < poses; ++k) {
    const double a = 0.7 * k, b = 1.3 * k + 0.4;
    dirs.emplace_back(std::sin(a) * std::cos(b), std::sin(a) * std::sin(b), std::cos(a));
  }
  std::vector<Eigen::Vector3d> f;
  for (int k = 0; k < poses; ++k) {
    for (int i = 0; i < (k == 0 ? 1000 : 500); ++i) f.push_back(9.80665 * dirs[size_t(k)]);
    if (k + 1 < poses) {
      for (int i = 0; i < 100; ++i) {
        const double u = (i + 0.5) / 100;
        f.push_back(9.80665 * ((1 - u) * dirs[size_t(k)] + u * dirs[size_t(k + 1)]).normalized());
      }
    }
  }
  Recording r;
  r.accel.resize(3, Eigen::Index(f.size()));
  for (size_t i = 0; i < f.size(); ++i) {
    r.t.push_back(sample_time(0, int64_t(i), 100.0));
    r.accel.col(Eigen::Index(i)) = f[i];
  }
  return r;
}

TEST(BadInput, StaticDetectorRefusesNonsenseInitialPeriods) {
  const Recording r = noiseless_poses(3);
  // -5, 1e300 and NaN hit an Eigen assertion, 0 was undefined behaviour.
  for (const double init : {-5.0, 0.0, 1e300, std::numeric_limits<double>::quiet_NaN()}) {
    StaticDetectorOptions o;
    o.init_static_s = init;
    SCOPED_TRACE(init);
    expect_error([&] { detect_static_intervals(r.t, r.accel, o); },
                 {"static detector", "positive and finite"});
  }
  StaticDetectorOptions o;
  o.init_static_s = 1000;
  expect_error([&] { detect_static_intervals(r.t, r.accel, o); },
               {"is shorter than the initial static period (1000 s) plus a window (1 s)"});
}

TEST(BadInput, CalibrationRefusesImplausibleGravityAndTooShortRecordings) {
  const Recording r = noiseless_poses(10);
  const Eigen::Matrix3Xd no_gyro(3, 0);
  for (const double g : {0.0, -9.8, 1e300, std::numeric_limits<double>::quiet_NaN()}) {
    CalibrationOptions o;
    o.gravity = g;
    o.calibrate_gyro = false;
    SCOPED_TRACE(g);
    expect_error([&] { calibrate(r.t, r.accel, no_gyro, o); }, {"gravity", "not plausible"});
  }
  // One row said "time stamps and samples differ in count".
  CalibrationOptions o;
  o.calibrate_gyro = false;
  const std::vector<TimeNs> one{0};
  expect_error([&] { calibrate(one, Eigen::Matrix3Xd::Zero(3, 1), no_gyro, o); },
               {"the recording has 1 sample(s)", "initial static period", "9 or more"});
}

TEST(BadInput, NoiselessPosesAreStillFound) {
  // A noiseless initial period has zero variance: the threshold used to be 0 and no window was
  // still (a mock device without a noise model calibrated to "only 1 static pose").
  const Recording r = noiseless_poses(10);
  StaticDetectorOptions o;
  o.init_static_s = 8;
  EXPECT_EQ(detect_static_intervals(r.t, r.accel, o).size(), 10u);
}

}  // namespace
}  // namespace imukit::hwmodel
