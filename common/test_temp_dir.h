#pragma once
// For tests only: a fresh folder under $TMPDIR (not created: a test may ask
// that what it checks creates it), removed with everything in it at the end.
#include <unistd.h>

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
    std::error_code ec;  // a folder that will not go must not end the test run
    std::filesystem::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::filesystem::path& path() const { return path_; }
  std::string str() const { return path_.string(); }
  std::string operator/(const std::string& f) const { return (path_ / f).string(); }

 private:
  std::filesystem::path path_;
};

}  // namespace rumi
