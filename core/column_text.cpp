#include "imukit/core/column_text.hpp"

#include <fmt/core.h>
#include <algorithm>
#include <cmath>

#include "imukit/core/error.hpp"
#include "imukit/core/text_parse.hpp"

namespace imukit {
namespace {

constexpr std::array<std::string_view, kColumnCount> kNames = {
    "t",  "ax", "ay", "az", "gx", "gy", "gz", "mx", "my",
    "mz", "qw", "qx", "qy", "qz", "px", "py", "pz", "temp"};

std::size_t index(Column c) { return static_cast<std::size_t>(c); }

int unit_digits(TimeUnit u) {
  switch (u) {
    case TimeUnit::s:
      return 9;
    case TimeUnit::ms:
      return 6;
    case TimeUnit::us:
      return 3;
    case TimeUnit::ns:
      return 0;
  }
  return 9;
}

// ns as a decimal number of the file's unit (10^digits ns), exactly: 1500000 ns in ms is "1.5".
std::string decimal_time(TimeNs t, int digits) {
  // The magnitude in unsigned arithmetic, which INT64_MIN survives.
  const uint64_t magnitude =
      t < 0 ? uint64_t{0} - static_cast<uint64_t>(t) : static_cast<uint64_t>(t);
  uint64_t scale = 1;
  for (int i = 0; i < digits; ++i) scale *= 10;
  std::string fraction = digits > 0 ? fmt::format("{:0{}}", magnitude % scale, digits) : "";
  while (!fraction.empty() && fraction.back() == '0') fraction.pop_back();
  return fmt::format("{}{}{}{}", t < 0 ? "-" : "", magnitude / scale, fraction.empty() ? "" : ".",
                     fraction);
}

const char* time_unit_name(TimeUnit u) {
  switch (u) {
    case TimeUnit::s:
      return "s";
    case TimeUnit::ms:
      return "ms";
    case TimeUnit::us:
      return "us";
    case TimeUnit::ns:
      return "ns";
  }
  return "s";
}

bool is_nan_token(std::string_view s) {
  if (s.size() != 3 && s.size() != 4) return false;
  if (s.size() == 4 && s[0] != '-' && s[0] != '+') return false;
  if (s.size() == 4) s.remove_prefix(1);
  return (s[0] == 'n' || s[0] == 'N') && (s[1] == 'a' || s[1] == 'A') &&
         (s[2] == 'n' || s[2] == 'N');
}

bool is_blank_line(std::string_view line) {
  for (char c : line) {
    if (c != ' ' && c != '\t' && c != '\r') return false;
  }
  return true;
}

// Why the columns `present` name a triad in part ("the accelerometer needs all three columns
// ax,ay,az"), or empty when every triad is whole or absent.
std::string partial_triad(const std::bitset<kColumnCount>& present) {
  constexpr std::array<std::pair<Column, const char*>, 3> kTriads = {
      {{Column::ax, "accelerometer"}, {Column::gx, "gyroscope"}, {Column::mx, "magnetometer"}}};
  for (const auto& [x, what] : kTriads) {
    const std::size_t first = index(x);
    const int n = int(present[first]) + int(present[first + 1]) + int(present[first + 2]);
    if (n != 0 && n != 3) {
      return fmt::format("the {} needs all three columns {},{},{}", what, kNames[first],
                         kNames[first + 1], kNames[first + 2]);
    }
  }
  return {};
}

ColumnTable read_table(LineReader& reader, const ColumnSpec& spec,
                       const HeaderCheck& check_header) {
  if (spec.columns.empty())
    throw Error("column map is empty: name the file's columns with --columns");
  ColumnTable table;
  table.source = reader.source_name();
  const int digits = unit_digits(spec.time_unit);
  // Which file columns are parsed, and where their values go.
  std::vector<std::vector<double>*> targets(spec.columns.size(), nullptr);
  for (std::size_t i = 0; i < spec.columns.size(); ++i) {
    if (spec.columns[i] && *spec.columns[i] != Column::t) {
      targets[i] = &table.values[index(*spec.columns[i])];
    }
    if (spec.columns[i]) table.present.set(index(*spec.columns[i]));
  }

  std::vector<Field> fields;
  bool first_row = true;
  int64_t next_line = 0;  // where a data row follows the one before (ColumnTable::line_jumps)
  while (auto line = reader.next()) {
    if (is_blank_line(*line)) continue;
    // A UTF-8 byte-order mark (spreadsheets' "CSV UTF-8" exports) before the first row would turn
    // its first number into text, and the row into a header.
    if (first_row && line->starts_with("\xEF\xBB\xBF")) line->remove_prefix(3);
    split_fields(*line, fields);
    const auto where = [&](int64_t column) {
      return InputLocation{table.source, reader.line_number(), column, {}};
    };
    if (first_row) {
      first_row = false;
      table.first_row_line = next_line = reader.line_number();
      // A header by its first field that the map reads (a skipped first column of text, such as
      // a date, made every first data row a header: found in review, 2026-11-27).
      const Field* first_mapped = fields.empty() ? nullptr : &fields.front();
      for (std::size_t i = 0; i < std::min(fields.size(), spec.columns.size()); ++i) {
        if (spec.columns[i]) {
          first_mapped = &fields[i];
          break;
        }
      }
      // An empty field is a gap in data (or an error), not a name.
      const bool header = first_mapped != nullptr && !first_mapped->text.empty() &&
                          !parse_double(first_mapped->text) && !is_nan_token(first_mapped->text);
      if (header) {
        for (const Field& f : fields) {
          table.header.emplace_back(f.text);
          table.header_columns.push_back(f.column);
        }
      }
      if (check_header) check_header(table);
      if (header) continue;
    }
    if (reader.line_number() != next_line)
      table.line_jumps.emplace_back(table.rows, reader.line_number());
    next_line = reader.line_number() + 1;
    if (fields.size() < spec.columns.size() ||
        (fields.size() > spec.columns.size() && !spec.ignore_extra)) {
      throw Error(where(1), fmt::format("expected {} columns ({}), found {}{}", spec.columns.size(),
                                        spec.to_string(), fields.size(),
                                        fields.size() > spec.columns.size()
                                            ? "; skip extra columns with _ or end the map with _*"
                                            : ""));
    }
    for (std::size_t i = 0; i < spec.columns.size(); ++i) {
      if (!spec.columns[i]) continue;
      const Column name = *spec.columns[i];
      const Field& f = fields[i];
      const auto describe = [&] { return fmt::format("column {} ({})", i + 1, column_name(name)); };
      if (name == Column::t) {
        const auto t = parse_scaled_integer(f.text, digits);
        if (!t) {
          throw Error(where(f.column),
                      fmt::format("{}: {} is not a finite decimal time that fits in int64 ns",
                                  describe(), quote_excerpt(f.text, 24)));
        }
        if (spec.integer_time &&
            f.text.find_first_not_of("0123456789", f.text.starts_with('-') ? 1 : 0) !=
                std::string_view::npos) {
          throw Error(
              where(f.column),
              fmt::format("{}: {} is not an integer number of {} (this format's times "
                          "are written as integers)",
                          describe(), quote_excerpt(f.text, 24), time_unit_name(spec.time_unit)));
        }
        if (!table.t.empty() && *t < table.t.back()) {
          throw Error(
              where(f.column),
              fmt::format("{}: time goes backwards ({} after {} on the row before, in {})",
                          describe(), quote_excerpt(f.text, 24),
                          decimal_time(table.t.back(), digits), time_unit_name(spec.time_unit)));
        }
        table.t.push_back(*t);
        continue;
      }
      double value = 0.0;
      if (f.text.empty() || is_nan_token(f.text)) {
        if (!spec.gappy[index(name)]) {
          throw Error(where(f.column),
                      fmt::format("{}: {} is not allowed here (declare the column with --gaps {} "
                                  "if samples may be missing)",
                                  describe(), f.text.empty() ? "an empty field" : "NaN",
                                  column_name(name)));
        }
        value = std::nan("");
      } else {
        const auto parsed = parse_double(f.text);
        if (!parsed) {
          throw Error(where(f.column),
                      fmt::format("{}: {} is not a number", describe(), quote_excerpt(f.text, 24)));
        }
        if (std::isinf(*parsed)) {
          throw Error(where(f.column),
                      fmt::format("{}: infinite value {}", describe(), quote_excerpt(f.text, 24)));
        }
        // NaN spelled with a payload ("nan(0x1)", MSVC's "-nan(ind)") is NaN like "nan".
        if (std::isnan(*parsed) && !spec.gappy[index(name)]) {
          throw Error(where(f.column),
                      fmt::format("{}: NaN ({}) is not allowed here (declare the column with "
                                  "--gaps {} if samples may be missing)",
                                  describe(), quote_excerpt(f.text, 24), column_name(name)));
        }
        value = *parsed;
      }
      targets[i]->push_back(value);
    }
    ++table.rows;
  }
  return table;
}

}  // namespace

int64_t ColumnTable::line_of(std::size_t row) const {
  // The last jump at or before the row; rows after it follow line by line.
  auto it = std::upper_bound(line_jumps.begin(), line_jumps.end(), row,
                             [](std::size_t r, const auto& jump) { return r < jump.first; });
  if (it == line_jumps.begin()) return first_row_line + static_cast<int64_t>(row);
  --it;
  return it->second + static_cast<int64_t>(row - it->first);
}

std::string_view column_name(Column c) { return kNames[index(c)]; }

std::optional<Column> column_from_name(std::string_view name) {
  for (std::size_t i = 0; i < kNames.size(); ++i) {
    if (kNames[i] == name) return static_cast<Column>(i);
  }
  return std::nullopt;
}

TimeUnit parse_time_unit(std::string_view text) {
  if (text == "s") return TimeUnit::s;
  if (text == "ms") return TimeUnit::ms;
  if (text == "us" || text == "\xC2\xB5s") return TimeUnit::us;
  if (text == "ns") return TimeUnit::ns;
  throw Error(fmt::format("time unit '{}' is not one of s, ms, us, ns", text));
}

ColumnSpec ColumnSpec::parse(std::string_view columns, std::string_view gaps, TimeUnit time_unit) {
  ColumnSpec spec;
  spec.time_unit = time_unit;
  std::vector<Field> tokens;
  split_fields(columns, tokens);
  std::bitset<kColumnCount> seen;
  for (std::size_t k = 0; k < tokens.size(); ++k) {
    const std::string_view token = tokens[k].text;
    const auto bad = [&](const std::string& why) {
      return Error(fmt::format("--columns '{}': token {} '{}': {}", columns, k + 1, token, why));
    };
    if (token.empty()) throw bad("empty name");
    if (token == "_") {
      spec.columns.emplace_back();
    } else if (token == "_*") {
      if (k + 1 != tokens.size()) throw bad("_* must be the last token");
      spec.ignore_extra = true;
    } else if (token.front() == '_') {
      const auto n = parse_scaled_integer(token.substr(1), 0);
      if (!n || *n < 1 || *n > 100000 || token.find_first_of(".eE") != std::string_view::npos) {
        throw bad("expected _, _N (skip N columns) or _*");
      }
      spec.columns.insert(spec.columns.end(), static_cast<std::size_t>(*n), std::nullopt);
    } else {
      const auto c = column_from_name(token);
      if (!c) {
        throw bad(
            "unknown column name (use t, ax ay az, gx gy gz, mx my mz, qw qx qy qz, "
            "px py pz, temp, or _ to skip)");
      }
      if (seen[index(*c)]) throw bad("named twice");
      seen.set(index(*c));
      spec.columns.emplace_back(*c);
    }
  }
  if (spec.columns.empty()) throw Error(fmt::format("--columns '{}' names no column", columns));
  std::vector<Field> gap_tokens;
  split_fields(gaps, gap_tokens);
  for (const Field& g : gap_tokens) {
    if (g.text.empty()) continue;
    const auto c = column_from_name(g.text);
    if (!c) throw Error(fmt::format("--gaps '{}': '{}' is not a column name", gaps, g.text));
    if (*c == Column::t)
      throw Error(fmt::format("--gaps '{}': the time column cannot have gaps", gaps));
    if (!seen[index(*c)]) {
      throw Error(fmt::format("--gaps '{}': '{}' is not in --columns '{}'", gaps, g.text, columns));
    }
    spec.gappy.set(index(*c));
  }
  return spec;
}

bool ColumnSpec::has(Column c) const {
  for (const auto& col : columns) {
    if (col == c) return true;
  }
  return false;
}

void ColumnSpec::require_whole_triads() const {
  std::bitset<kColumnCount> present;
  for (const auto& col : columns) {
    if (col) present.set(index(*col));
  }
  if (const std::string why = partial_triad(present); !why.empty())
    throw Error(fmt::format("--columns '{}': {}", to_string(), why));
}

std::string ColumnSpec::to_string() const {
  std::string out;
  std::size_t skipped = 0;
  const auto flush_skips = [&] {
    if (skipped == 0) return;
    if (!out.empty()) out += ',';
    out += skipped == 1 ? std::string("_") : fmt::format("_{}", skipped);
    skipped = 0;
  };
  for (const auto& col : columns) {
    if (!col) {
      ++skipped;
      continue;
    }
    flush_skips();
    if (!out.empty()) out += ',';
    out += column_name(*col);
  }
  flush_skips();
  if (ignore_extra) out += out.empty() ? "_*" : ",_*";
  return out;
}

ColumnTable read_column_text(const std::string& path, const ColumnSpec& spec,
                             const HeaderCheck& check_header) {
  LineReader reader(path);
  return read_table(reader, spec, check_header);
}

ColumnTable parse_column_text(std::string_view text, const std::string& source_name,
                              const ColumnSpec& spec, const HeaderCheck& check_header) {
  LineReader reader(text, source_name);
  return read_table(reader, spec, check_header);
}

ImuSeries to_imu_series(const ColumnTable& table, const ChannelScale& scale) {
  if (!table.has(Column::t)) {
    throw Error(InputLocation{table.source, {}, {}, {}},
                "no time column: name one with t in --columns");
  }
  if (const std::string why = partial_triad(table.present); !why.empty())
    throw Error(InputLocation{table.source, {}, {}, {}}, why);
  const auto triad = [&](Column x, double factor, Eigen::Matrix3Xd& out) {
    const std::size_t first = index(x);
    if (!table.has(x)) return;
    out.resize(3, static_cast<Eigen::Index>(table.rows));
    for (std::size_t axis = 0; axis < 3; ++axis) {
      const std::vector<double>& v = table.values[first + axis];
      for (std::size_t i = 0; i < table.rows; ++i) {
        const double si = v[i] * factor;
        // A finite value that its unit turns into infinity (1e308 g): found in review, passed.
        if (std::isinf(si) && std::isfinite(v[i])) {
          throw Error(InputLocation{table.source, table.line_of(i), {}, {}},
                      fmt::format("{} = {} times {:g} (its unit in SI) is beyond a double",
                                  kNames[first + axis], v[i], factor));
        }
        out(static_cast<Eigen::Index>(axis), static_cast<Eigen::Index>(i)) = si;
      }
    }
  };
  ImuSeries series;
  series.t = table.t;
  triad(Column::ax, scale.accel, series.accel);
  triad(Column::gx, scale.gyro, series.gyro);
  triad(Column::mx, scale.mag, series.mag);
  if (table.has(Column::temp)) {
    series.temperature_c = Eigen::Map<const Eigen::VectorXd>(table[Column::temp].data(),
                                                             static_cast<Eigen::Index>(table.rows));
  }
  return series;
}

}  // namespace imukit
