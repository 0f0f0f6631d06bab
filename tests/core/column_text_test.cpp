#include "imukit/core/column_text.hpp"

#include <gtest/gtest.h>
#include <cmath>

#include "imukit/core/error.hpp"
#include "support/expect_error.hpp"
#include "support/test_data.hpp"

namespace imukit {
namespace {

// Runs `fn`, expects an imukit::Error whose message contains every one of `parts`.
using imukit::testing::expect_error;

TEST(ColumnSpec, ParsesNamesSkipsAndRepeats) {
  const ColumnSpec s = ColumnSpec::parse("t,_,ax,ay,az,_3,gx,gy,gz,_*", "ax", TimeUnit::ms);
  ASSERT_EQ(s.columns.size(), 11u);
  EXPECT_EQ(s.columns[0], Column::t);
  EXPECT_FALSE(s.columns[1].has_value());
  EXPECT_EQ(s.columns[2], Column::ax);
  EXPECT_FALSE(s.columns[5].has_value());
  EXPECT_FALSE(s.columns[7].has_value());
  EXPECT_EQ(s.columns[8], Column::gx);
  EXPECT_TRUE(s.ignore_extra);
  EXPECT_TRUE(s.gappy[static_cast<std::size_t>(Column::ax)]);
  EXPECT_EQ(s.time_unit, TimeUnit::ms);
  EXPECT_EQ(s.to_string(), "t,_,ax,ay,az,_3,gx,gy,gz,_*");
  EXPECT_EQ(ColumnSpec::parse("t gx gy gz").to_string(), "t,gx,gy,gz");
}

TEST(ColumnSpec, RejectsBadMapsNamingTheToken) {
  expect_error([] { ColumnSpec::parse("t,ax,foo"); }, {"token 3", "'foo'", "unknown column"});
  expect_error([] { ColumnSpec::parse("t,ax,ax"); }, {"'ax'", "named twice"});
  expect_error([] { ColumnSpec::parse("t,_*,ax"); }, {"_* must be the last"});
  expect_error([] { ColumnSpec::parse("t,_0"); }, {"'_0'"});
  expect_error([] { ColumnSpec::parse("t,,ax"); }, {"token 2", "empty"});
  expect_error([] { ColumnSpec::parse("t,ax", "ay"); }, {"--gaps", "'ay' is not in --columns"});
  expect_error([] { ColumnSpec::parse("t,ax", "t"); }, {"time column cannot have gaps"});
  expect_error([] { parse_time_unit("min"); }, {"'min'", "s, ms, us, ns"});
}

TEST(ColumnText, ReadsHeaderCommasBlanksAndTimeUnits) {
  const std::string text =
      "time,acc_x,acc_y,acc_z\n"
      "1.5,1,2,3\n"
      "\n"
      "2.0, 4 ,5,6\r\n";
  const ColumnTable t =
      parse_column_text(text, "mem.csv", ColumnSpec::parse("t,ax,ay,az", {}, TimeUnit::ms));
  ASSERT_EQ(t.rows, 2u);
  ASSERT_EQ(t.header.size(), 4u);
  EXPECT_EQ(t.header[1], "acc_x");
  EXPECT_EQ(t.t[0], 1'500'000);
  EXPECT_EQ(t.t[1], 2'000'000);
  EXPECT_EQ(t[Column::ay][1], 5.0);
  EXPECT_TRUE(t.has(Column::az));
  EXPECT_FALSE(t.has(Column::gx));

  const ColumnTable blanks =
      parse_column_text("  10 0.5\t-0.5 \n20 1 2\n", "mem.txt", ColumnSpec::parse("t,gx,_"));
  ASSERT_EQ(blanks.rows, 2u);
  EXPECT_EQ(blanks.t[1], 20'000'000'000);
  EXPECT_EQ(blanks[Column::gx][0], 0.5);

  // Where the header's fields and the data rows are, for messages.
  EXPECT_EQ(t.first_row_line, 1);
  EXPECT_EQ(t.header_columns, (std::vector<int64_t>{1, 6, 12, 18}));
  EXPECT_EQ(t.line_of(0), 2);
  EXPECT_EQ(t.line_of(1), 4);
  const ColumnTable spaced =
      parse_column_text("\n\n1 2\n2 3\n\n3 4\n4 5\n5 6\n\n\n6 7\n", "m", ColumnSpec::parse("t,ax"));
  ASSERT_EQ(spaced.rows, 6u);
  const std::vector<int64_t> lines = {3, 4, 6, 7, 8, 11};
  for (std::size_t r = 0; r < lines.size(); ++r) EXPECT_EQ(spaced.line_of(r), lines[r]) << r;
}

// Found in review (2026-11-27): the header was told by the first field alone, so a file whose
// skipped first column is text (a date) lost its first data row silently. The first field the
// map reads decides.
TEST(ColumnText, AHeaderIsToldByTheFirstFieldTheMapReads) {
  const std::string rows =
      "2024-01-01T00:00:00Z,0.00,1,2,3\n"
      "2024-01-01T00:00:01Z,0.01,4,5,6\n";
  const ColumnTable dated = parse_column_text(rows, "m", ColumnSpec::parse("_,t,ax,ay,az"));
  ASSERT_EQ(dated.rows, 2u);
  EXPECT_TRUE(dated.header.empty());
  EXPECT_EQ(dated[Column::ax][0], 1.0);
  const ColumnTable headed =
      parse_column_text("date,time,ax,ay,az\n" + rows, "m", ColumnSpec::parse("_,t,ax,ay,az"));
  ASSERT_EQ(headed.rows, 2u);
  EXPECT_EQ(headed.header.size(), 5u);
  // An empty first field in a gappy column is a gap, not a header (review of 2026-11-27).
  const ColumnTable gap =
      parse_column_text(",1,2,0\n4,5,6,0.01\n", "m", ColumnSpec::parse("ax,ay,az,t", {"ax"}));
  EXPECT_EQ(gap.rows, 2u);
  // A first row whose first mapped field is a number and a later one is not is data: its error
  // names the field rather than the row being skipped as a header.
  expect_error([&] { parse_column_text("0,1,x,3\n", "m.csv", ColumnSpec::parse("t,ax,ay,az")); },
               {"m.csv:1:5", "'x' is not a number"});
}

TEST(ColumnText, GappyColumnsKeepNaNOthersRejectIt) {
  const ColumnSpec spec = ColumnSpec::parse("t,qw,px", "qw");
  const ColumnTable t = parse_column_text("0,nan,1\n1,,2\n2,0.5,3\n", "g.csv", spec);
  ASSERT_EQ(t.rows, 3u);
  EXPECT_TRUE(std::isnan(t[Column::qw][0]));
  EXPECT_TRUE(std::isnan(t[Column::qw][1]));
  EXPECT_EQ(t[Column::qw][2], 0.5);
  expect_error([&] { parse_column_text("0,1,nan\n", "g.csv", spec); },
               {"g.csv:1:5", "column 3 (px)", "NaN", "--gaps px"});
}

// Found in review: NaN with a payload ("nan(0x1)", MSVC's "-nan(ind)") passed the NaN check
// of columns not declared gappy, and a UTF-8 byte-order mark made the first data row a header
// (the sample was dropped without a word).
TEST(ColumnText, NaNWithAPayloadIsNaNAndAByteOrderMarkIsNoHeader) {
  const ColumnSpec spec = ColumnSpec::parse("t,ax,ay", {}, TimeUnit::s);
  for (const char* nan : {"nan(0x1)", "-nan(ind)", "NAN(abc)"}) {
    try {
      parse_column_text(std::string("0,1,2\n1,") + nan + ",3\n", "p.csv", spec);
      ADD_FAILURE() << nan << " accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("p.csv:2:3: column 2 (ax): NaN"), std::string::npos)
          << e.what();
    }
  }
  const ColumnSpec gappy = ColumnSpec::parse("t,ax,ay", "ax", TimeUnit::s);
  const ColumnTable g = parse_column_text("0,-nan(ind),2\n", "p.csv", gappy);
  EXPECT_TRUE(std::isnan(g[Column::ax][0]));
  const ColumnTable b = parse_column_text(
      "\xEF\xBB\xBF"
      "0,1,2\n1,3,4\n",
      "bom.csv", spec);
  EXPECT_EQ(b.rows, 2u);
  EXPECT_TRUE(b.header.empty());
  EXPECT_EQ(b.t.front(), 0);
  const ColumnTable h = parse_column_text(
      "\xEF\xBB\xBF"
      "t,ax,ay\n1,3,4\n",
      "bom.csv", spec);
  EXPECT_EQ(h.rows, 1u);
  EXPECT_EQ(h.header.front(), "t");
}

TEST(ColumnText, MalformedLinesNameFileLineAndColumn) {
  const ColumnSpec spec = ColumnSpec::parse("t,ax,ay,az");
  expect_error([&] { parse_column_text("0,1,2,3\n1,1,2\n", "bad.csv", spec); },
               {"bad.csv:2:1", "expected 4 columns", "found 3"});
  expect_error([&] { parse_column_text("0,1,2,3\n1,1,2,3,4\n", "bad.csv", spec); },
               {"bad.csv:2:1", "found 5", "_*"});
  expect_error([&] { parse_column_text("0,1,2,3\n1,1,abc,3\n", "bad.csv", spec); },
               {"bad.csv:2:5", "column 3 (ay)", "'abc' is not a number"});
  expect_error([&] { parse_column_text("0,1,2,3\n1,1,2,inf\n", "bad.csv", spec); },
               {"bad.csv:2:7", "infinite"});
  expect_error([&] { parse_column_text("0,1,2,3\n1,NaN,2,3\n", "bad.csv", spec); },
               {"bad.csv:2:3", "NaN is not allowed"});
  expect_error([&] { parse_column_text("5,1,2,3\n4,1,2,3\n", "bad.csv", spec); },
               {"bad.csv:2:1", "time goes backwards ('4' after 5 on the row before, in s)"});
  // Both times in the file's own unit (it used to print the earlier one in s whatever the unit).
  expect_error(
      [&] {
        parse_column_text("1500,1,2,3\n1250.5,1,2,3\n", "ms.csv",
                          ColumnSpec::parse("t,ax,ay,az", {}, TimeUnit::ms));
      },
      {"ms.csv:2:1", "('1250.5' after 1500 on the row before, in ms)"});
  // Bytes of the file are quoted escaped and short, never raw; a control byte is binary data.
  expect_error(
      [&] {
        parse_column_text("0,1,2,3\n1,\xff\xfezzzzzzzzzzzzzzzzzzzzzzzzzz,2,3\n", "bad.csv", spec);
      },
      {"'\\xFF\\xFEzzzzzzzzzzzzzzzzzzzzzz...' (28 bytes) is not a number"});
  expect_error(
      [&] {
        parse_column_text("0,1,2,3\n1,\x01\x02zzzzzzzzzzzzzzzzzzzzzzzzzz,2,3\n", "bad.csv", spec);
      },
      {"bad.csv:2:3: control byte 0x01: a binary file, not text"});
  expect_error([&] { parse_column_text("0,1,2,3\nx1,1,2,3\n", "bad.csv", spec); },
               {"bad.csv:2:1", "'x1'"});
  expect_error([&] { parse_column_text("0,1,2,3\n1,1,2,\n", "bad.csv", spec); },
               {"bad.csv:2:7", "empty field"});
}

TEST(ColumnText, ToImuSeriesScalesAndChecksTriads) {
  const ColumnTable t =
      parse_column_text("0 1 2 3 10 20 30\n", "m", ColumnSpec::parse("t,ax,ay,az,gx,gy,gz"));
  const ImuSeries s = to_imu_series(t, ChannelScale{9.80665, M_PI / 180.0, 1.0});
  ASSERT_EQ(s.size(), 1u);
  EXPECT_DOUBLE_EQ(s.accel(2, 0), 3 * 9.80665);
  EXPECT_DOUBLE_EQ(s.gyro(0, 0), 10 * M_PI / 180.0);
  EXPECT_FALSE(s.has_mag());
  const ColumnTable partial = parse_column_text("0 1 2\n", "m", ColumnSpec::parse("t,ax,ay"));
  expect_error([&] { to_imu_series(partial); }, {"accelerometer needs all three columns"});
  const ColumnTable no_time = parse_column_text("1 2 3\n", "m", ColumnSpec::parse("ax,ay,az"));
  expect_error([&] { to_imu_series(no_time); }, {"no time column"});
  // A finite value its unit turns into infinity, named at its file line (found in review,
  // 2026-11-27: "data row 1", counting neither the header nor blank lines).
  const ColumnTable big = parse_column_text("t,ax,ay,az\n\n0,1,0,0\n0.01,1e308,0,0\n", "big.csv",
                                            ColumnSpec::parse("t,ax,ay,az"));
  expect_error(
      [&] {
        to_imu_series(big, ChannelScale{9.80665, 1.0, 1.0});
      },
      {"big.csv:4: ax = 1e+308 times 9.80665"});
}

// Found in review: a partial triad was found only once the rows were read (after a row's column
// count error, if any); a reader of IMU samples can now refuse the map first.
TEST(ColumnSpec, RequireWholeTriadsNamesTheMapAndTheTriad) {
  expect_error([] { ColumnSpec::parse("t,ax,_*").require_whole_triads(); },
               {"--columns 't,ax,_*': the accelerometer needs all three columns ax,ay,az"});
  expect_error([] { ColumnSpec::parse("t,ax,ay,az,gz").require_whole_triads(); },
               {"--columns 't,ax,ay,az,gz': the gyroscope needs all three columns gx,gy,gz"});
  expect_error([] { ColumnSpec::parse("mx,my").require_whole_triads(); },
               {"the magnetometer needs all three columns mx,my,mz"});
  EXPECT_NO_THROW(ColumnSpec::parse("t,_,ax,ay,az,gx,gy,gz,temp,qw,px,_*").require_whole_triads());
}

// Every numeric text file in shared/data reads with an appropriate map (DESIGN.md promise).
struct DataFile {
  std::string path;
  std::string columns;
  std::string gaps;
  std::size_t rows;
  double first_time_s;
  double last_time_s;
};

TEST(ColumnText, ReadsEveryTextFileOfTheSharedData) {
  IMUKIT_REQUIRE_DATA(data);
  const std::vector<DataFile> files = {
      {"imu_tk_xsens/xsens_acc.txt", "t,ax,ay,az", "", 51175, 0.02984, 511.718},
      {"imu_tk_xsens/xsens_gyro.txt", "t,gx,gy,gz", "", 51175, 0.02984, 511.718},
      {"hfi_static/imu_data.txt", "t,gx,gy,gz,ax,ay,az", "", 27963, 1459.63, 4294.96},
      {"broad/02_undisturbed_slow_rotation_B.csv",
       "t,ax,ay,az,gx,gy,gz,mx,my,mz,qw,qx,qy,qz,px,py,pz,_", "qw,qx,qy,qz,px,py,pz", 53240, 0.0,
       186.3365},
      {"broad/07_undisturbed_fast_rotation_B.csv", "t,ax,ay,az,gx,gy,gz,_3,qw,qx,qy,qz,px,py,pz,_",
       "qw,qx,qy,qz,px,py,pz", 52518, 0.0, 183.8095},
      {"broad/16_undisturbed_fast_translation_B.csv", "t,ax,ay,az,gx,gy,gz,_*", "", 53392, 0.0,
       186.8685},
      // forearm_left is the 6th of 16 segments of 10 columns each.
      {"qmt_full_body/full_body_example_data.csv", "t,_50,ax,ay,az,gx,gy,gz,qw,qx,qy,qz,_*", "",
       10000, 40.0, 139.99},
      {"reference_sim/sceneA_imu_LWR_10s.csv", "t,ax,ay,az,gx,gy,gz", "", 1000, 0.0, 9.99},
      {"reference_sim/sceneA_imu_RWR_10s.csv", "t,ax,ay,az,gx,gy,gz", "", 1000, 0.0, 9.99},
      {"reference_sim/sceneA_D_translation_10s.csv", "t,px,py,pz", "", 1000, 0.0, 9.99},
      {"reference_sim/sceneA_D_orientation_10s.csv", "t,qw,qx,qy,qz,_44", "", 1000, 0.0, 9.99},
  };
  for (const DataFile& f : files) {
    SCOPED_TRACE(f.path);
    const ColumnTable t =
        read_column_text((data / f.path).string(), ColumnSpec::parse(f.columns, f.gaps));
    EXPECT_EQ(t.rows, f.rows);
    ASSERT_EQ(t.t.size(), f.rows);
    EXPECT_EQ(t.t.front(), from_seconds(f.first_time_s));
    EXPECT_EQ(t.t.back(), from_seconds(f.last_time_s));
  }
  // The Allan-deviation curves of imu_utils: one number per line, no header, no time.
  std::size_t curves = 0;
  for (const auto& entry : std::filesystem::directory_iterator(data / "imu_utils_allan")) {
    if (entry.path().extension() != ".txt") continue;
    const ColumnTable t = read_column_text(entry.path().string(), ColumnSpec::parse("gx"));
    EXPECT_GT(t.rows, 50u) << entry.path();
    for (double v : t[Column::gx]) EXPECT_GT(v, 0.0) << entry.path();
    ++curves;
  }
  EXPECT_EQ(curves, 96u);
}

TEST(ColumnText, BroadGapsAreNaNExactlyWhereTheFileSaysNan) {
  IMUKIT_REQUIRE_DATA(data);
  const ColumnTable t =
      read_column_text((data / "broad/02_undisturbed_slow_rotation_B.csv").string(),
                       ColumnSpec::parse("t,_9,qw,qx,qy,qz,_*", "qw,qx,qy,qz"));
  // README: optical data valid from 4.32 to 184.70 s, plus a 5-sample gap at 4.4 s.
  std::size_t missing = 0;
  for (std::size_t i = 0; i < t.rows; ++i) {
    if (!std::isnan(t[Column::qw][i])) continue;
    ++missing;
    const double ts = to_seconds(t.t[i]);
    EXPECT_TRUE(ts < 4.33 || ts > 184.69 || (ts > 4.35 && ts < 4.45)) << "unexpected gap at " << ts;
  }
  const std::size_t edges = static_cast<std::size_t>((4.32 + (186.3365 - 184.70)) * 285.714285);
  EXPECT_NEAR(static_cast<double>(missing), static_cast<double>(edges + 5), 10.0);
  const std::size_t mid = t.rows / 2;
  EXPECT_FALSE(std::isnan(t[Column::qw][mid]));
  double norm2 = 0.0;
  for (Column c : {Column::qw, Column::qx, Column::qy, Column::qz}) norm2 += t[c][mid] * t[c][mid];
  EXPECT_NEAR(std::sqrt(norm2), 1.0, 1e-6);  // printed with 7 decimals
}

}  // namespace
}  // namespace imukit
