#include "imukit/core/euroc_csv.hpp"

#include <gtest/gtest.h>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "imukit/core/error.hpp"
#include "imukit/core/rng.hpp"
#include "support/expect_error.hpp"
#include "support/test_data.hpp"

namespace imukit {
namespace {

TEST(EurocCsv, RoundTripIsBitExact) {
  // Values chosen to need all 17 digits: random doubles over many magnitudes, subnormals,
  // negative zero and extremes.
  Rng rng(7);
  const std::size_t n = 2000;
  ImuSeries s = ImuSeries::with_channels(n, true, true);
  for (std::size_t i = 0; i < n; ++i) {
    const auto c = static_cast<Eigen::Index>(i);
    s.t[i] = 1'700'000'000'000'000'000 + static_cast<TimeNs>(i) * 2'500'001;
    for (int k = 0; k < 3; ++k) {
      s.accel(k, c) = rng.normal() * std::pow(10.0, rng.uniform(-12.0, 12.0));
      s.gyro(k, c) = rng.uniform(-1.0, 1.0) / 3.0;
    }
  }
  s.accel(0, 0) = -0.0;
  s.accel(1, 0) = 4.9406564584124654e-324;
  s.accel(2, 0) = 1.7976931348623157e308;
  s.gyro(0, 1) = 2.2250738585072014e-308;
  testing::TempDir dir;
  const std::string path = (dir / "imu0.csv").string();
  write_euroc_csv(path, s.view());
  const ImuSeries back = read_euroc_csv(path);
  ASSERT_EQ(back.size(), n);
  EXPECT_EQ(back.t, s.t);
  EXPECT_EQ(std::memcmp(back.accel.data(), s.accel.data(), sizeof(double) * 3 * n), 0);
  EXPECT_EQ(std::memcmp(back.gyro.data(), s.gyro.data(), sizeof(double) * 3 * n), 0);
  EXPECT_TRUE(std::signbit(back.accel(0, 0)));
}

TEST(EurocCsv, WritesTheKalibrHeaderAndColumnOrder) {
  ImuSeries s = ImuSeries::with_channels(1, true, true);
  s.t[0] = 1403636579758555392;
  s.gyro.col(0) << 0.5, -0.25, 0.125;
  s.accel.col(0) << 9.5, 0.0, -1.0;
  testing::TempDir dir;
  const std::string path = (dir / "imu0.csv").string();
  write_euroc_csv(path, s.view());
  EXPECT_EQ(testing::read_file(path),
            "#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],"
            "a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]\n"
            "1403636579758555392,0.5,-0.25,0.125,9.5,0,-1\n");
}

TEST(EurocCsv, MalformedLinesAreRejectedWithTheLineNumber) {
  const std::string header(kEurocHeader);
  struct Case {
    std::string body;
    std::string expect;
  };
  const std::vector<Case> cases = {
      {"1,0,0,0,0,0\n", "x.csv:3:1: expected 7 columns"},  // missing column
      {"1,0,0,zero,0,0,9.8\n", "x.csv:3:7: column 4 (gz): 'zero' is not a number"},
      {"1,0,0,0,nan,0,9.8\n", "x.csv:3:9: column 5 (ax): NaN is not allowed"},
      {"1,0,0,0,0,inf,9.8\n", "x.csv:3:11: column 6 (ay): infinite value"},
      {"1,0,0,0,0,0,-Infinity\n", "x.csv:3:13: column 7 (az): infinite value"},
      {"abc,0,0,0,0,0,9.8\n", "x.csv:3:1: column 1 (t): 'abc' is not a finite decimal time"},
      // Found in review: EuRoC's integer nanoseconds were read from a fraction or an exponent.
      {"1000.5,0,0,0,0,0,9.8\n",
       "x.csv:3:1: column 1 (t): '1000.5' is not an integer number of ns (this format's times are "
       "written as integers)"},
      {"1e3,0,0,0,0,0,9.8\n",
       "x.csv:3:1: column 1 (t): '1e3' is not an integer number of ns (this format's times are "
       "written as integers)"},
  };
  for (const Case& c : cases) {
    const std::string text = header + "\n0,0,0,0,0,0,9.8\n" + c.body;
    try {
      parse_euroc_csv(text, "x.csv");
      ADD_FAILURE() << "accepted: " << c.body;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(c.expect), std::string::npos)
          << e.what() << "\n  expected: " << c.expect;
    }
  }
}

TEST(EurocCsv, RequiresTheHeader) {
  EXPECT_THROW(parse_euroc_csv("0,0,0,0,0,0,9.8\n", "x.csv"), Error);
  // No rows at all: the file is named, no line 0 (review of 2026-11-27).
  expect_error([] { parse_euroc_csv("\n\n", "x.csv"); },
               {"x.csv: not an EuRoC IMU CSV: the first row must be the header"});
  EXPECT_NO_THROW(parse_euroc_csv("timestamp,wx,wy,wz,ax,ay,az\n0,0,0,0,0,0,9.8\n", "x.csv"));
  EXPECT_NO_THROW(parse_euroc_csv(std::string(kEurocHeader) + "\n0,0,0,0,0,0,9.8\n", "x.csv"));
  // Found in review: only the first field was checked, so these were read with accelerometer
  // and gyroscope swapped, or their times in seconds taken for nanoseconds.
  const struct {
    std::string header, expect;
  } bad[] = {
      {"timestamp,ax,ay,az,gx,gy,gz", "x.csv:1:11: not an EuRoC IMU CSV: column 2 is 'ax'"},
      // At the header's line and the field's character (found in review, 2026-11-27: always
      // line 1, and the field's number for its column).
      {"\n\ntimestamp, ax,ay,az,gx,gy,gz", "x.csv:3:12: not an EuRoC IMU CSV: column 2 is 'ax'"},
      {"#timestamp [ns],a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2],"
       "w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1]",
       "column 2 is 'a_RS_S_x [m s^-2]', where EuRoC has the gyroscope"},
      {"timestamp [s],wx,wy,wz,ax,ay,az", "x.csv:1:1: not an EuRoC IMU CSV: column 1 is in [s]"},
      {"timestamp,wx [deg/s],wy,wz,ax,ay,az", "column 2 is in [deg/s]"},
      {"timestamp,wx,wy,wz,ax,ay", "the header has 6 columns"},
  };
  // Found in review: a CSV of other columns was refused by its first row ("expected 7 columns
  // (t,gx,...), found 18; skip extra columns with _"), about a map the user never gave.
  try {
    std::string row = "0.01";
    for (int k = 0; k < 17; ++k) row += ",1";
    parse_euroc_csv("t,ax,ay,az,gx,gy,gz,mx,my,mz,q0,q1,q2,q3,a,b,c,d\n" + row + "\n", "broad.csv");
    ADD_FAILURE() << "accepted";
  } catch (const Error& e) {
    EXPECT_EQ(
        std::string(e.what()).rfind("broad.csv:1:1: not an EuRoC IMU CSV: column 1 is 't'", 0), 0u)
        << e.what();
  }
  for (const auto& c : bad) {
    try {
      parse_euroc_csv(c.header + "\n0,0,0,0,0,0,9.8\n", "x.csv");
      ADD_FAILURE() << "accepted: " << c.header;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(c.expect), std::string::npos)
          << e.what() << "\n  expected: " << c.expect;
    }
  }
}

// Found in review (2026-11-27): times that go back were written, into a file read_euroc_csv
// refuses. Refused before anything is written.
TEST(EurocCsv, TimesThatGoBackAreRefusedBeforeWriting) {
  ImuSeries s = ImuSeries::with_channels(3, true, true);
  s.t = {0, 10, 5};
  s.accel.setZero();
  s.gyro.setZero();
  const std::string path = ::testing::TempDir() + "/back.csv";
  std::remove(path.c_str());
  expect_error([&] { write_euroc_csv(path, s.view()); },
               {"back.csv: time goes backwards at sample 2"});
  EXPECT_FALSE(std::filesystem::exists(path));
}

TEST(EurocCsv, UnwritablePathIsAClearError) {
  ImuSeries s = ImuSeries::with_channels(1, true, true);
  s.t[0] = 0;
  s.accel.setZero();
  s.gyro.setZero();
  try {
    write_euroc_csv("/nonexistent-dir/imu0.csv", s.view());
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent-dir/imu0.csv"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("cannot open for writing"), std::string::npos);
  }
}

TEST(EurocCsv, DiskFullIsAClearError) {
  std::FILE* full = std::fopen("/dev/full", "wb");
  if (!full) GTEST_SKIP() << "/dev/full is not available";
  ImuSeries s = ImuSeries::with_channels(20000, true, true);
  for (std::size_t i = 0; i < s.size(); ++i) s.t[i] = static_cast<TimeNs>(i);
  s.accel.setConstant(1.0 / 3.0);
  s.gyro.setConstant(2.0 / 3.0);
  EXPECT_THROW(write_euroc_csv(full, "/dev/full", s.view()), Error);
  std::fclose(full);
}

}  // namespace
}  // namespace imukit
