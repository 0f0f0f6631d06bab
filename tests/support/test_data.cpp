#include "support/test_data.hpp"

#include <unistd.h>
#include <atomic>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string_view>

namespace imukit::testing {

std::optional<std::filesystem::path> data_dir() {
  const char* env = std::getenv("IMUKIT_DATA_DIR");
  std::filesystem::path dir = (env && *env) ? env : IMUKIT_DEFAULT_DATA_DIR;
  std::error_code ec;
  if (!std::filesystem::is_directory(dir, ec)) return std::nullopt;
  return std::filesystem::weakly_canonical(dir, ec);
}

bool running_in_ci() {
  const char* ci = std::getenv("CI");
  return ci && (std::string_view(ci) == "true" || std::string_view(ci) == "1");
}

bool quick_mode() {
  const char* quick = std::getenv("IMUKIT_TEST_QUICK");
  return quick && *quick && std::string_view(quick) != "0";
}

std::string read_file(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

TempDir::TempDir() {
  static std::atomic<int> counter{0};
  path_ = std::filesystem::temp_directory_path() /
          ("imukit-test-" + std::to_string(::getpid()) + "-" + std::to_string(counter++));
  std::filesystem::remove_all(path_);
  std::filesystem::create_directories(path_);
}

TempDir::~TempDir() {
  std::error_code ec;
  std::filesystem::remove_all(path_, ec);
}

}  // namespace imukit::testing
