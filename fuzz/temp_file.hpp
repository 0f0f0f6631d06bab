// Shared by the fuzzers whose code under test reads files by name (recovery rewrites a file into
// another; the label reader opens a path): the input goes to a file in a folder of this process's
// own, removed at exit.
#pragma once

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

namespace imukit::fuzz {

class TempFolder {
 public:
  TempFolder() {
    const char* base = std::getenv("TMPDIR");
    std::string pattern = std::string(base && *base ? base : "/tmp") + "/imukit-fuzz-XXXXXX";
    if (!::mkdtemp(pattern.data())) std::abort();
    path_ = pattern;
  }
  ~TempFolder() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  TempFolder(const TempFolder&) = delete;
  TempFolder& operator=(const TempFolder&) = delete;

  std::string file(const std::string& name) const { return (path_ / name).string(); }
  // Writes the bytes to `name` in the folder and returns its path.
  std::string write(const std::string& name, const uint8_t* data, std::size_t size) const {
    const std::string path = file(name);
    std::FILE* f = std::fopen(path.c_str(), "wb");
    if (!f || (size > 0 && std::fwrite(data, 1, size, f) != size) || std::fclose(f) != 0)
      std::abort();
    return path;
  }

 private:
  std::filesystem::path path_;
};

inline const TempFolder& temp_folder() {
  static const TempFolder folder;
  return folder;
}

}  // namespace imukit::fuzz
