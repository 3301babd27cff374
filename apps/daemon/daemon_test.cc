// RunDaemon in-process: what it refuses before it starts a child (the
// session itself, rumid with its children, is tests/rumid_test.cc).
#include "apps/daemon/daemon.h"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <fstream>

#include "apps/daemon/state_dir.h"
#include "common/process/exit_codes.h"
#include "common/testing/temp_dir.h"

namespace rumi {
namespace {

namespace fs = std::filesystem;

class DaemonRefuses : public ::testing::Test {
 protected:
  void SetUp() override { fs::create_directories(tmp_.path() / "bin"); }
  void TearDown() override { fs::remove(InstanceLockPath(instance_)); }

  // A dataset session in a fresh state folder, its executables in an empty
  // folder: every test breaks one rule before the check of the executables
  // (the last before the children start) or breaks that one.
  DaemonRunOptions Options() const {
    DaemonRunOptions o;
    o.config.source.kind = "dataset";
    o.config.source.path = (tmp_.path() / "sequence").string();
    o.instance = instance_;
    o.state_dir = (tmp_.path() / "state").string();
    o.bin_dir = (tmp_.path() / "bin").string();
    return o;
  }
  static int Run(const DaemonRunOptions& o) {
    std::atomic<bool> stop{false};
    return RunDaemon(o, &stop, nullptr);
  }

  TempDir tmp_;
  const std::string instance_ = "daemontest" + std::to_string(::getpid());
};

TEST_F(DaemonRefuses, AStateFolderAnotherRumidHolds) {
  const DaemonRunOptions o = Options();
  StateDirLock other;
  fs::create_directories(o.state_dir);
  std::string why;
  ASSERT_TRUE(other.Acquire(StateDirLayout{o.state_dir}, &why)) << why;
  EXPECT_EQ(Run(o), kExitBadInput);
  // The layout was made before the lock was asked for.
  for (const char* d : {"front", "back", "logs"}) EXPECT_TRUE(fs::is_directory(fs::path(o.state_dir) / d)) << d;
}

TEST_F(DaemonRefuses, AnInstanceAnotherRumidRunsElsewhere) {
  const DaemonRunOptions o = Options();
  StateDirLock other;
  std::string why;
  ASSERT_TRUE(other.Acquire(InstanceLockPath(o.instance), "instance '" + o.instance + "'", &why)) << why;
  EXPECT_EQ(Run(o), kExitBadInput);
  // Its state folder's lock went with the refusal.
  StateDirLock again;
  EXPECT_TRUE(again.Acquire(StateDirLayout{o.state_dir}, &why)) << why;
}

TEST_F(DaemonRefuses, ADatasetWithoutItsPath) {
  DaemonRunOptions o = Options();
  o.config.source.path.clear();
  EXPECT_EQ(Run(o), kExitBadInput);
  // Both locks went with the refusal: the same session may start again.
  std::string why;
  StateDirLock state, instance;
  EXPECT_TRUE(state.Acquire(StateDirLayout{o.state_dir}, &why)) << why;
  EXPECT_TRUE(instance.Acquire(InstanceLockPath(o.instance), "instance", &why)) << why;
}

TEST_F(DaemonRefuses, ACaptureWithoutTheCamerasCalibration) {
  DaemonRunOptions o = Options();
  o.config.source.kind = "capture";
  o.config.source.path = "/dev/video0";
  o.config.has_camera = false;
  EXPECT_EQ(Run(o), kExitBadInput);
}

TEST_F(DaemonRefuses, ChildExecutablesThatAreMissingOrNotExecutable) {
  const DaemonRunOptions o = Options();
  EXPECT_EQ(Run(o), kExitBadInput);  // an empty bin folder
  for (const char* bin : {"rumi-front", "rumi-back", "rumi-manager"})
    std::ofstream(fs::path(o.bin_dir) / bin) << "#!/bin/sh\nexit 0\n";  // not executable (0644)
  EXPECT_EQ(Run(o), kExitBadInput);
}

TEST_F(DaemonRefuses, AStateFolderThatCannotBeMadeIsAnError) {
  DaemonRunOptions o = Options();
  std::ofstream(tmp_.path() / "file") << "a file, not a folder\n";
  o.state_dir = (tmp_.path() / "file" / "state").string();
  EXPECT_EQ(Run(o), kExitError);
}

}  // namespace
}  // namespace rumi
