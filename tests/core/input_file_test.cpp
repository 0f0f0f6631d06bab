#include "imukit/core/input_file.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "imukit/core/column_text.hpp"
#include "imukit/core/error.hpp"
#include "imukit/core/euroc_csv.hpp"
#include "imukit/core/npy.hpp"
#include "imukit/core/profile.hpp"
#include "support/test_data.hpp"

namespace imukit {
namespace {

// Runs `fn`, expects an IoError whose message contains every one of `parts`.
template <typename Fn>
void expect_io_error(Fn fn, std::initializer_list<std::string> parts) {
  try {
    fn();
    ADD_FAILURE() << "expected an imukit::IoError";
  } catch (const IoError& e) {
    for (const std::string& p : parts) {
      EXPECT_NE(std::string(e.what()).find(p), std::string::npos)
          << "message '" << e.what() << "' lacks '" << p << "'";
    }
  }
}

void write(const std::filesystem::path& p, const std::string& text) {
  std::ofstream(p, std::ios::binary) << text;
}

TEST(InputFile, ReadsARegularFileWhole) {
  testing::TempDir dir;
  const std::string text = std::string("a\0b\n", 4) + std::string(5000, 'x');
  write(dir / "f.bin", text);
  EXPECT_EQ(read_regular_file((dir / "f.bin").string(), 1 << 20, "test input"), text);
  EXPECT_EQ(read_regular_file((dir / "f.bin").string(), text.size(), "test input"), text);
}

TEST(OutputFile, AFailedWriteLeavesTheEarlierFileAndNoTemporary) {
  // Found in review: a failed `imukit convert` truncated the file it was to replace.
  testing::TempDir dir;
  const std::string path = (dir / "out.csv").string();
  write(path, "keep me\n");
  EXPECT_THROW(write_file_atomically(path,
                                     [](std::FILE* f) {
                                       std::fputs("half", f);
                                       throw Error("bad input found while writing");
                                     }),
               Error);
  ImuSeries accel_only = ImuSeries::with_channels(3, true, false);
  EXPECT_THROW(write_euroc_csv(path, accel_only.view()), Error);
  EXPECT_EQ(read_regular_file(path, 1 << 20, "test output"), "keep me\n");
  std::size_t files = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir.path()))
    files += e.is_regular_file();
  EXPECT_EQ(files, 1u);
  write_text_file(path, "new\n");
  EXPECT_EQ(read_regular_file(path, 1 << 20, "test output"), "new\n");
  // A symbolic link still points at its file, now replaced; a device is written in place, never
  // replaced by a file (renaming over /dev/stdout would).
  std::filesystem::create_symlink(path, dir / "link.csv");
  write_text_file((dir / "link.csv").string(), "through the link\n");
  EXPECT_TRUE(std::filesystem::is_symlink(dir / "link.csv"));
  EXPECT_EQ(read_regular_file(path, 1 << 20, "test output"), "through the link\n");
  // A FIFO stands for /dev/stdout and devices (a test must not risk a real device node).
  const std::string fifo = (dir / "fifo").string();
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  const int reader = ::open(fifo.c_str(), O_RDONLY | O_NONBLOCK);
  ASSERT_GE(reader, 0);
  write_text_file(fifo, "to the reader\n");
  char got[64] = {};
  EXPECT_EQ(::read(reader, got, sizeof got), 14);
  EXPECT_EQ(std::string(got), "to the reader\n");
  ::close(reader);
  EXPECT_TRUE(std::filesystem::is_fifo(fifo));
  // Found in review of the above: the file keeps its mode, other hard links see the new content,
  // a dangling link is written through (the link stays), and threads writing one path at once
  // never collide on a temporary (one name per process did: a third of 1200 writes failed).
  ::chmod(path.c_str(), 0600);
  write_text_file(path, "private\n");
  struct stat st {};
  ASSERT_EQ(::stat(path.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0600u);
  std::filesystem::create_hard_link(path, dir / "hard.csv");
  write_text_file((dir / "hard.csv").string(), "both names\n");
  EXPECT_EQ(read_regular_file(path, 1 << 20, "test output"), "both names\n");
  std::filesystem::create_symlink("later.csv", dir / "dangling.csv");
  write_text_file((dir / "dangling.csv").string(), "made through the link\n");
  EXPECT_TRUE(std::filesystem::is_symlink(dir / "dangling.csv"));
  EXPECT_EQ(read_regular_file((dir / "later.csv").string(), 1 << 20, "test output"),
            "made through the link\n");
  const std::string shared = (dir / "shared.json").string();
  std::vector<std::thread> writers;
  std::atomic<int> failures{0};
  for (int w = 0; w < 4; ++w) {
    writers.emplace_back([&, w] {
      for (int k = 0; k < 100; ++k) {
        try {
          write_text_file(shared, fmt::format("{{\"writer\": {}, \"k\": {}}}\n", w, k));
        } catch (const Error&) {
          ++failures;
        }
      }
    });
  }
  for (std::thread& t : writers) t.join();
  EXPECT_EQ(failures.load(), 0);
  EXPECT_EQ(read_regular_file(shared, 1 << 20, "test output").rfind("{\"writer\": ", 0), 0u);
  for (const auto& e : std::filesystem::directory_iterator(dir.path()))
    EXPECT_EQ(e.path().filename().string().rfind(".imukit-", 0), std::string::npos) << e.path();
  // A folder that does not exist: named, nothing created.
  expect_io_error([&] { write_text_file((dir / "no" / "x.csv").string(), "x"); },
                  {"no/x.csv", "cannot open for writing"});
}

TEST(InputFile, RefusesDevicesPipesAndFoldersWithoutReadingOrBlocking) {
  testing::TempDir dir;
  // /dev/zero never ends; a FIFO without a writer would block a plain open forever; a folder
  // opens on Linux and reads as an I/O error later. Each is refused by name, at once.
  expect_io_error([] { read_regular_file("/dev/zero", kMaxJsonBytes, "scene"); },
                  {"/dev/zero", "character device", "scene"});
  const auto fifo = dir / "fifo";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  expect_io_error([&] { read_regular_file(fifo.string(), kMaxJsonBytes, "policy"); },
                  {"fifo", "pipe (FIFO)"});
  expect_io_error([&] { (void)open_regular_file(dir.path().string(), "recording"); },
                  {"is a folder, not a file"});
  expect_io_error([&] { (void)open_regular_file((dir / "missing").string(), "recording"); },
                  {"missing", "cannot open for reading", "No such file"});
}

TEST(InputFile, EnforcesTheSizeLimitOfWholeFileReaders) {
  testing::TempDir dir;
  write(dir / "big.json", std::string(1000, ' '));
  expect_io_error([&] { read_regular_file((dir / "big.json").string(), 999, "device profile"); },
                  {"big.json", "1000 bytes is more than a device profile may hold (999 bytes)"});
}

TEST(InputFile, EveryReaderGoesThroughIt) {
  testing::TempDir dir;
  const auto fifo = dir / "fifo";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  for (const std::string& path : {std::string("/dev/zero"), fifo.string(), dir.path().string()}) {
    SCOPED_TRACE(path);
    EXPECT_THROW(read_profile(path), IoError);
    EXPECT_THROW(read_npy(path), IoError);
    EXPECT_THROW(read_column_text(path, ColumnSpec::parse("t,ax,ay,az")), IoError);
  }
  // The profile updater reads its output back first: a device or folder there is refused
  // before anything is written (it used to hang on -o /dev/stdout into a pipe).
  EXPECT_THROW(update_profile("/dev/zero", DeviceProfile{}), IoError);
  EXPECT_THROW(update_profile(fifo.string(), DeviceProfile{}), IoError);
  EXPECT_THROW(update_profile(dir.path().string(), DeviceProfile{}), IoError);
}

TEST(InputFile, TextLinesAreBoundedSoABinaryFileCannotFillMemory) {
  testing::TempDir dir;
  write(dir / "one_line.txt", std::string((std::size_t{16} << 20) + 10, '1'));
  try {
    read_column_text((dir / "one_line.txt").string(), ColumnSpec::parse("t,ax,ay,az"));
    ADD_FAILURE() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("one_line.txt:1: line longer than 16 MiB"),
              std::string::npos)
        << e.what();
  }
}

TEST(Messages, QuoteExcerptEscapesAndElides) {
  EXPECT_EQ(quote_excerpt("abc"), "'abc'");
  EXPECT_EQ(quote_excerpt(std::string("a\0b\n\x7f\xff", 6)), "'a\\x00b\\n\\x7F\\xFF'");
  EXPECT_EQ(quote_excerpt("it's"), "'it\\'s'");
  EXPECT_EQ(quote_excerpt("caf\xc3\xa9"), "'caf\xc3\xa9'");  // valid UTF-8 stays
  EXPECT_EQ(quote_excerpt("\xc3(", 8), "'\\xC3('");          // a broken sequence does not
  EXPECT_EQ(quote_excerpt("root:x:0:0:root:/root:/bin/bash", 10), "'root:x:0:0...' (31 bytes)");
  EXPECT_EQ(escape_unprintable("file \x1b[31mred\n"), "file \\x1B[31mred\\n");
}

}  // namespace
}  // namespace imukit
