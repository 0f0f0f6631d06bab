#include "imukit/sim/motion.hpp"

#include <gtest/gtest.h>

#include <cstdio>

#include <cmath>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "imukit/core/error.hpp"
#include "support/expect_error.hpp"

namespace imukit::sim {
namespace {

Body small_body() {
  Body b;
  b.add_joint("pelvis", -1, Eigen::Vector3d::Zero());
  b.add_joint("left_elbow", 0, Eigen::Vector3d(0.3, 0, 0));
  return b;
}

TEST(Motion, LimitedMotionEndsAtItsLimitAndReadsThrough) {
  Motion m(50.0, 2, 10);
  m.rotation(3, 1) = Eigen::Quaterniond(0.0, 1.0, 0.0, 0.0);
  LimitedMotion limited(m, 4);
  EXPECT_EQ(limited.frame_count(), 4);
  EXPECT_EQ(limited.rate_hz(), 50.0);
  EXPECT_EQ(limited.joint_count(), 2u);
  MotionChunk chunk;
  const int joints[] = {1};
  limited.read(3, 1, joints, chunk);
  MotionChunk direct;
  m.read(3, 1, joints, direct);
  ASSERT_EQ(chunk.frames, 1);
  EXPECT_EQ(chunk.rotation(0, 0).coeffs(), direct.rotation(0, 0).coeffs());
  EXPECT_EQ(chunk.rotation(0, 0).coeffs(), Eigen::Vector4d(1.0, 0.0, 0.0, 0.0));  // x, y, z, w
}

TEST(Motion, FramesToSimulateCapsByTheLimitAndNamesTheCaller) {
  const Motion m(50.0, 2, 10);
  EXPECT_EQ(frames_to_simulate(m, std::nullopt, "x"), 10);
  EXPECT_EQ(frames_to_simulate(m, 4, "x"), 4);
  EXPECT_EQ(frames_to_simulate(m, 40, "x"), 10);
  try {
    (void)frames_to_simulate(m, 1, "simulation");
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), "simulation: at least 2 frames are needed, got 1");
  }
  const Motion empty(50.0, 2, 0);
  EXPECT_THROW((void)frames_to_simulate(empty, std::nullopt, "x"), Error);
}

TEST(Motion, QuaternionCsvReadsJointsByNameAndRateFromTime) {
  const std::string text =
      "t,root_x,root_y,root_z,L_ELBOW_qw,L_ELBOW_qx,L_ELBOW_qy,L_ELBOW_qz\n"
      "0,1,2,3,1,0,0,0\n"
      "0.02,1,2,3,0,1,0,0\n"
      "0.04,1,2,3.5,0,0,0,2\n";
  std::vector<std::string> warnings;
  const Motion m = parse_quaternion_csv(text, "m.csv", small_body(), std::nullopt, &warnings);
  EXPECT_NEAR(m.rate_hz(), 50.0, 1e-9);
  // A given rate must agree with the t column (it was silently taken over it).
  EXPECT_EQ(parse_quaternion_csv(text, "m.csv", small_body(), 50.0).rate_hz(), 50.0);
  try {
    (void)parse_quaternion_csv(text, "m.csv", small_body(), 100.0);
    ADD_FAILURE() << "a rate disagreeing with t accepted";
  } catch (const Error& e) {
    EXPECT_NE(
        std::string(e.what()).find("m.csv: the t column steps at 50 Hz, the given rate is 100"),
        std::string::npos)
        << e.what();
  }
  EXPECT_EQ(m.frames(), 3);
  EXPECT_EQ(m.root_translation(2), Eigen::Vector3d(1, 2, 3.5));
  EXPECT_EQ(m.rotation(1, 1).coeffs(), Eigen::Quaterniond(0, 1, 0, 0).coeffs());
  // The non-unit (norm 2) quaternion was renormalised, with a warning naming frame and joint.
  EXPECT_EQ(m.rotation(2, 1).coeffs(), Eigen::Quaterniond(0, 0, 0, 1).coeffs());
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find("frame 2, joint left_elbow"), std::string::npos) << warnings[0];
  EXPECT_EQ(m.rotation(0, 0).coeffs(), Eigen::Quaterniond::Identity().coeffs());
}

// Found in review, 2026-11-27: a second root column was taken (the last winning), a second time
// column gave "not uniform", and a given rate of NaN, 0 or -5 became the motion's rate.
TEST(Motion, QuaternionCsvRefusesRepeatedTimeOrRootColumnsAndBadRates) {
  const std::string rows = "0,1,2,3,1,0,0,0\n0.02,1,2,3,1,0,0,0\n";
  testing::expect_error(
      [&] {
        (void)parse_quaternion_csv(
            "t,root_x,root_x,root_z,L_ELBOW_qw,L_ELBOW_qx,L_ELBOW_qy\n" + rows, "m.csv",
            small_body());
      },
      {"m.csv:1:10: a second 'root_x' column"});
  testing::expect_error(
      [&] {
        (void)parse_quaternion_csv("t,time,root_y,root_z,L_ELBOW_qw,L_ELBOW_qx,L_ELBOW_qy\n" + rows,
                                   "m.csv", small_body());
      },
      {"m.csv:1:3: a second time column"});
  const std::string text = "root_x,root_y,root_z\n1,2,3\n1,2,3\n";
  for (const double bad : {std::numeric_limits<double>::quiet_NaN(), 0.0, -5.0,
                           std::numeric_limits<double>::infinity()})
    EXPECT_THROW((void)parse_quaternion_csv(text, "m.csv", small_body(), bad), Error) << bad;
  EXPECT_EQ(parse_quaternion_csv(text, "m.csv", small_body(), 25.0).rate_hz(), 25.0);
}

// Review, 2026-11-27: each step had to match the mean step to 1e-6, so times printed to the
// microsecond at 30 Hz, epoch seconds and imukit's own ns-rounded CSV at 7 kHz were refused as
// "not uniform". Each step within 1 % of the median and each frame within 1 % of a period of
// the grid is read; a missing frame or a drifting step is not.
TEST(Motion, QuaternionCsvTimesRoundedWhenPrintedReadAtTheirRate) {
  const auto csv = [](double rate, double t0, int frames, const char* format, int skip = -1) {
    std::string text = "t,L_ELBOW_qw,L_ELBOW_qx,L_ELBOW_qy,L_ELBOW_qz\n";
    char buf[64];
    for (int f = 0; f < frames; ++f) {
      if (f == skip) continue;
      std::snprintf(buf, sizeof buf, format, t0 + f / rate);
      text += std::string(buf) + ",1,0,0,0\n";
    }
    return text;
  };
  struct Case {
    double rate, t0;
    const char* format;
  };
  for (const Case& c : {Case{30.0, 0.0, "%.6f"}, Case{120.0, 0.0, "%.6f"},
                        Case{100.0, 1.73e9, "%.17g"}, Case{7000.0, 0.0, "%.9f"}}) {
    const Motion m = parse_quaternion_csv(csv(c.rate, c.t0, 40, c.format), "q.csv", small_body());
    EXPECT_NEAR(m.rate_hz(), c.rate, 1e-5 * c.rate) << c.rate << " Hz, " << c.format;
    EXPECT_EQ(parse_quaternion_csv(csv(c.rate, c.t0, 40, c.format), "q.csv", small_body(), c.rate)
                  .rate_hz(),
              c.rate);
  }
  // Steps ramping from 0.0099 to 0.0101 s each pass the step test, but drift 5 periods off the
  // grid: refused too.
  std::string drifting = "t,L_ELBOW_qw,L_ELBOW_qx,L_ELBOW_qy,L_ELBOW_qz\n";
  double t = 0.0;
  for (int f = 0; f < 2000; ++f) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.9f,1,0,0,0\n", t);
    drifting += buf;
    t += 0.0099 + 0.0002 * f / 1999.0;
  }
  try {
    (void)parse_quaternion_csv(drifting, "d.csv", small_body());
    ADD_FAILURE() << "a drifting step accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("periods off the uniform grid"), std::string::npos)
        << e.what();
  }
  try {
    (void)parse_quaternion_csv(csv(30.0, 0.0, 40, "%.6f", 20), "q.csv", small_body());
    ADD_FAILURE() << "a missing frame accepted";
  } catch (const Error& e) {
    EXPECT_NE(
        std::string(e.what()).find(
            "q.csv:22:1: t is not uniform: frame 20 comes 0.066667 s after the one before, 2"),
        std::string::npos)
        << e.what();
  }
}

TEST(Motion, TinyNormErrorsAreRenormalisedSilently) {
  Motion m(10.0, 1, 2);
  m.rotation(0, 0) = Eigen::Quaterniond(1.0 + 1e-9, 0, 0, 0);
  EXPECT_TRUE(m.validate_and_normalize().empty());
  EXPECT_EQ(m.rotation(0, 0).w(), 1.0);
}

TEST(Motion, NonFiniteValuesNameFrameAndJoint) {
  Motion m(10.0, 2, 3);
  m.rotation(2, 1).x() = NAN;
  try {
    m.validate_and_normalize(nullptr);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("frame 2, joint #1"), std::string::npos) << e.what();
  }
  Motion z(10.0, 1, 1);
  z.rotation(0, 0) = Eigen::Quaterniond(0, 0, 0, 0);
  EXPECT_THROW(z.validate_and_normalize(), Error);
  const std::string bad =
      "t,L_ELBOW_qw,L_ELBOW_qx,L_ELBOW_qy,L_ELBOW_qz\n0,1,0,0,0\n0.1,inf,0,0,0\n";
  try {
    parse_quaternion_csv(bad, "bad.csv", small_body());
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.where()->line, 3);
    EXPECT_EQ(e.where()->column, 5);
  }
}

// Any finite quaternion but zero is a rotation. A component of 1e155 squared to inf, q / inf
// gave the zero quaternion and the simulator aborted in so3_log (found in review, 2026-11-26);
// 1e-300 squared to 0 and was refused as "zero norm". Expected: the unit quaternion, to 4e-16 (2
// ulp).
TEST(Motion, HugeAndTinyQuaternionsNormaliseWithoutOverflow) {
  const std::string text =
      "t,L_ELBOW_qw,L_ELBOW_qx,L_ELBOW_qy,L_ELBOW_qz\n"
      "0,1,0,0,0\n"
      "0.01,1e155,0,0,0.02\n"
      "0.02,1e-300,0,0,0\n"
      "0.03,1e300,-1e300,0,0\n"
      "0.04,0,0,4.9e-324,0\n"
      "0.05,3e-160,0,4e-160,0\n";
  std::vector<std::string> warnings;
  const Motion m = parse_quaternion_csv(text, "big.csv", small_body(), std::nullopt, &warnings);
  const double h = std::sqrt(0.5);
  const Eigen::Vector4d expected[] = {{0, 0, 0, 1},  {2e-157, 0, 0, 1}, {0, 0, 0, 1},
                                      {-h, 0, 0, h}, {0, 1, 0, 0},      {0, 0.8, 0, 0.6}};
  for (int64_t f = 0; f < 6; ++f) {
    for (int k = 0; k < 4; ++k)
      EXPECT_NEAR(m.rotation(f, 1).coeffs()[k], expected[f][k], 4e-16) << f << " " << k;
  }
  // Every rotation but the first was off; the worst (|q| = 1e300, frame 3) is on line 5.
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_EQ(warnings[0].rfind("big.csv:5: 5 quaternions had norms", 0), 0u) << warnings[0];
  EXPECT_NE(warnings[0].find("at frame 3, joint left_elbow"), std::string::npos) << warnings[0];
  // A Motion built in memory goes through the same normalisation.
  Motion direct(100.0, 1, 2);
  direct.rotation(1, 0) = Eigen::Quaterniond(1e200, 0, 0, 1e200);
  (void)direct.validate_and_normalize();
  EXPECT_NEAR(direct.rotation(1, 0).w(), h, 4e-16);
  EXPECT_NEAR(direct.rotation(1, 0).z(), h, 4e-16);
}

// Only four zeros cannot be normalised: the error names the file, the row's line, the column of
// the joint's qw, the frame and the joint (before: "motion: frame 2, joint left_elbow:
// quaternion has zero norm", no file or line).
TEST(Motion, AnAllZeroQuaternionIsAnErrorAtItsLineAndColumn) {
  const std::string text =
      "t,L_ELBOW_qw,L_ELBOW_qx,L_ELBOW_qy,L_ELBOW_qz\n"
      "0,1,0,0,0\n"
      "0.01,1,0,0,0\n"
      "0.02,0,0,0,-0\n"
      "0.03,1,0,0,0\n";
  try {
    parse_quaternion_csv(text, "zero.csv", small_body());
    ADD_FAILURE() << "accepted a zero quaternion";
  } catch (const Error& e) {
    ASSERT_TRUE(e.where().has_value()) << e.what();
    EXPECT_EQ(e.where()->file, "zero.csv");
    EXPECT_EQ(e.where()->line, 4);
    EXPECT_EQ(e.where()->column, 6);
    EXPECT_EQ(e.reason(),
              "frame 2, joint left_elbow: quaternion is all zeros (no rotation to normalise)");
  }
}

// Every message about a row names the same frame: the rows before it, blank lines not counted
// (a NaN in a quaternion column said frame 5 where one in t said frame 4, found in review,
// 2026-11-26), and the line is the row's own (a non-uniform t was put 1 line early per blank
// line skipped before it).
TEST(Motion, CsvMessagesNameTheRowsFrameAndLine) {
  const std::string head =
      "t,L_ELBOW_qw,L_ELBOW_qx,L_ELBOW_qy,L_ELBOW_qz\n0,1,0,0,0\n\n"
      "0.01,1,0,0,0\n0.02,1,0,0,0\n0.03,1,0,0,0\n";
  // Line 7 is frame 4.
  for (const auto& [row, column] : std::vector<std::pair<std::string, int64_t>>{
           {"nan,1,0,0,0", 1}, {"0.04,1,nan,0,0", 8}, {"0.04,0,0,0,0", 6}}) {
    try {
      parse_quaternion_csv(head + row + "\n0.05,1,0,0,0\n", "rows.csv", small_body());
      ADD_FAILURE() << row;
    } catch (const Error& e) {
      ASSERT_TRUE(e.where().has_value()) << e.what();
      EXPECT_EQ(e.where()->line, 7) << row;
      EXPECT_EQ(e.where()->column, column) << row;
      EXPECT_EQ(e.reason().rfind("frame 4", 0), 0u) << e.what();
    }
  }
  try {
    parse_quaternion_csv(head + "0.05,1,0,0,0\n", "rows.csv", small_body());
    ADD_FAILURE() << "a skipped step accepted";
  } catch (const Error& e) {
    // Steps of 0.01 s and one of 0.02 s: the step into the last frame, on line 7 (against the
    // mean step, frame 1 on line 4 was named until review, 2026-11-27; line 3, the blank one,
    // before that).
    EXPECT_EQ(e.where()->line, 7) << e.what();
  }
  std::vector<std::string> warnings;
  (void)parse_quaternion_csv(head + "0.04,2,0,0,0\n", "rows.csv", small_body(), std::nullopt,
                             &warnings);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_EQ(warnings[0].rfind("rows.csv:7: 1 quaternions had norms", 0), 0u) << warnings[0];
  EXPECT_NE(warnings[0].find("at frame 4, joint left_elbow"), std::string::npos) << warnings[0];
}

// Found by fuzzing (fuzz/quaternion_csv_fuzz.cpp, issue 16): a t column stepping by 3.3e20 s gave
// a rate of 3e-21 Hz and the simulator looped forever on sample times beyond int64 ns; a step
// of 1e-12 s would put every frame at the same ns. The rate from t is bounded like a BVH's.
TEST(Motion, AbsurdFrameStepsInTheTimeColumnAreRejected) {
  for (const char* t1 : {"333333333333333333333", "1e-12", "7200"}) {
    const std::string text =
        std::string("t,L_ELBOW_qw,L_ELBOW_qx,L_ELBOW_qy,L_ELBOW_qz\n0,1,0,0,0\n") + t1 +
        ",1,0,0,0\n";
    try {
      parse_quaternion_csv(text, "steps.csv", small_body());
      ADD_FAILURE() << "accepted a step of " << t1 << " s";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("steps.csv: t steps by"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("1 frame per hour to 1e6 frames per second"),
                std::string::npos)
          << e.what();
    }
  }
  EXPECT_NO_THROW(parse_quaternion_csv(
      "t,L_ELBOW_qw,L_ELBOW_qx,L_ELBOW_qy,L_ELBOW_qz\n0,1,0,0,0\n3600,1,0,0,0\n", "hour.csv",
      small_body()));
}

TEST(Motion, CsvErrorsAreClear) {
  EXPECT_THROW(parse_quaternion_csv("", "e.csv", small_body()), Error);
  EXPECT_THROW(parse_quaternion_csv("t,knee_qw\n", "e.csv", small_body()), Error);
  EXPECT_THROW(parse_quaternion_csv("t,left_elbow_qw\n0,1\n", "e.csv", small_body()), Error);
  // One frame: no rate from t, and no simulation anyway.
  EXPECT_THROW(parse_quaternion_csv("t\n0\n", "e.csv", small_body()), Error);
  EXPECT_THROW(parse_quaternion_csv("t\n0\n0.1\n0.3\n", "e.csv", small_body()), Error);
  Motion one(100.0, 1, 1);
  EXPECT_THROW(require_simulatable(one, "x"), Error);
}

TEST(Motion, ProceduralFramesDependOnlyOnTheAbsoluteIndex) {
  ProceduralMotionOptions a;
  ProceduralMotion from_zero(3, a);
  ProceduralMotionOptions b = a;
  b.start_frame = 8'639'000;
  ProceduralMotion late(3, b);
  const std::vector<int> joints = {0, 2};
  MotionChunk ca, cb;
  from_zero.read(8'639'000, 50, joints, ca);
  late.read(0, 50, joints, cb);
  EXPECT_EQ(ca.root_translation, cb.root_translation);
  for (std::size_t i = 0; i < ca.rotations.size(); ++i)
    EXPECT_EQ(ca.rotations[i].coeffs(), cb.rotations[i].coeffs());
  // Smooth and in the stated band: the largest frame-to-frame angle at 100 Hz stays below
  // 3 sinusoids x 0.1 rad x 2 pi x 1.2 Hz / 100.
  for (int64_t f = 1; f < 50; ++f) {
    EXPECT_LT(ca.rotation(f, 0).angularDistance(ca.rotation(f - 1, 0)),
              3 * 0.1 * 2 * M_PI * 1.2 / 100.0);
  }
  ProceduralMotionOptions fractional;
  fractional.rate_hz = 99.5;
  EXPECT_THROW(ProceduralMotion(1, fractional), Error);
}

TEST(ProceduralMotion, RefusesAmplitudesOutOfRange) {
  // Found in review, 2026-11-27: only the scene reader checked amplitude_rad; from Python a NaN
  // amplitude reached an assertion and a NaN or infinite translation gave NaN samples.
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  for (const double a : {nan, inf, -1.0, 10.5}) {
    ProceduralMotionOptions o;
    o.amplitude_rad = a;
    imukit::testing::expect_error(
        [&] { ProceduralMotion(1, o); },
        {"procedural motion: amplitude_rad must be in [0, 10] rad, got "});
  }
  for (const double t : {nan, inf, -0.1}) {
    ProceduralMotionOptions o;
    o.translation_amplitude_m = t;
    imukit::testing::expect_error(
        [&] { ProceduralMotion(1, o); },
        {"procedural motion: translation_amplitude_m must be finite and >= 0 m, got "});
  }
  ProceduralMotionOptions edges;
  edges.amplitude_rad = 10.0;
  edges.translation_amplitude_m = 0.0;
  EXPECT_NO_THROW(ProceduralMotion(1, edges));
}

}  // namespace
}  // namespace imukit::sim
