#pragma once
// For tests only: a fresh folder under $TMPDIR (not created: a test may ask
// that what it checks creates it), removed with everything in it at the end,
// unless RUMI_KEEP_TEST_DIR is set or Keep() was called (debugging: the logs
// stay).
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <string>

namespace rumi {

class TempDir {
 public:
  TempDir() {
    static int n = 0;  // NOLINT: test code
    path_ = std::filesystem::temp_directory_path() /
            ("rumi_test_" + std::to_string(::getpid()) + "_" + std::to_string(n++));
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  ~TempDir() {
    if (keep_ || std::getenv("RUMI_KEEP_TEST_DIR")) return;
    std::error_code ec;  // a folder that will not go must not end the test run
    std::filesystem::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::filesystem::path& path() const { return path_; }
  std::string str() const { return path_.string(); }
  std::string operator/(const std::string& f) const { return (path_ / f).string(); }
  // Creates the folder; its path.
  const std::filesystem::path& Create() const {
    std::filesystem::create_directories(path_);
    return path_;
  }
  void Keep() { keep_ = true; }

 private:
  std::filesystem::path path_;
  bool keep_ = false;
};

}  // namespace rumi
