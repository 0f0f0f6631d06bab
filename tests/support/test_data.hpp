// Where tests find the real recordings of ../shared/data, and a temporary folder per test.
#pragma once

#include <filesystem>
#include <optional>
#include <string>

namespace imukit::testing {

// $IMUKIT_DATA_DIR, else the shared/data folder beside the checkout. Empty when the folder does
// not exist; use IMUKIT_REQUIRE_DATA to skip (or fail under CI=true) in that case.
std::optional<std::filesystem::path> data_dir();

// True when running under CI (CI=true), where missing data is an error, not a skip.
bool running_in_ci();

// True when $IMUKIT_TEST_QUICK is set (non-empty, not "0"): the sanitizer pass of scripts/test.sh,
// where code runs several times slower. Statistical tests then use fewer seeds (their thresholds in
// proportion) and long comparisons leave out the part other tests already run; the release pass
// keeps the full statistics and the figures the docs quote.
bool quick_mode();

// `full` in the release pass, `quick` in quick mode.
template <typename T>
T quick_or(T quick, T full) {
  return quick_mode() ? quick : full;
}

// The whole content of a file, bytes as they are (empty if it cannot be read).
std::string read_file(const std::filesystem::path& path);

// A fresh empty folder under the system's temp dir, removed by the destructor.
class TempDir {
 public:
  TempDir();
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path operator/(const std::string& name) const { return path_ / name; }

 private:
  std::filesystem::path path_;
};

}  // namespace imukit::testing

// Declares `const std::filesystem::path var` as the data folder, or ends the test: skipped with a
// visible message locally, failed under CI.
#define IMUKIT_REQUIRE_DATA(var)                                                     \
  const auto var##_opt = ::imukit::testing::data_dir();                              \
  if (!var##_opt) {                                                                  \
    if (::imukit::testing::running_in_ci()) {                                        \
      FAIL() << "test data folder missing (set IMUKIT_DATA_DIR); required under CI"; \
    }                                                                                \
    GTEST_SKIP() << "test data folder missing: set IMUKIT_DATA_DIR to shared/data";  \
  }                                                                                  \
  const std::filesystem::path var = *var##_opt
