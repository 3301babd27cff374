#include "apps/daemon/state_dir.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>

#include "common/testing/temp_dir.h"

namespace rumi {
namespace {

namespace fs = std::filesystem;

// Sets $STATE_DIRECTORY for its lifetime (nullptr: unset), then restores it.
class StateDirectoryEnv {
 public:
  explicit StateDirectoryEnv(const char* value) {
    if (const char* v = std::getenv("STATE_DIRECTORY")) old_ = v;
    if (value) ::setenv("STATE_DIRECTORY", value, 1);
    else ::unsetenv("STATE_DIRECTORY");
  }
  ~StateDirectoryEnv() {
    if (old_) ::setenv("STATE_DIRECTORY", old_->c_str(), 1);
    else ::unsetenv("STATE_DIRECTORY");
  }

 private:
  std::optional<std::string> old_;
};

TEST(StateDir, TheCommandLineThenTheConfigThenSystemdThenVarLib) {
  {
    const StateDirectoryEnv env("/var/lib/rumi/robot1:/var/lib/other");
    EXPECT_EQ(ResolveStateDir("/cli", "/config", "robot1"), "/cli");
    EXPECT_EQ(ResolveStateDir("", "/config", "robot1"), "/config");
    EXPECT_EQ(ResolveStateDir("", "", "robot1"), "/var/lib/rumi/robot1");  // the first of systemd's list
  }
  {
    const StateDirectoryEnv env("/srv/rumi");
    EXPECT_EQ(ResolveStateDir("", "", "x"), "/srv/rumi");
  }
  const StateDirectoryEnv env(nullptr);
  EXPECT_EQ(ResolveStateDir("", "", "robot2"), "/var/lib/rumi/robot2");
  EXPECT_EQ(InstanceLockPath("robot2"), "/dev/shm/.rumid_robot2.lock");
}

TEST(StateDir, GenerationsCountUpAcrossRuns) {
  const TempDir tmp;
  const StateDirLayout layout{tmp.Create().string()};
  std::string why;
  EXPECT_EQ(NextGeneration(layout, &why), 0) << why;
  EXPECT_EQ(NextGeneration(layout, &why), 1) << why;
  EXPECT_EQ(NextGeneration(layout, &why), 2) << why;
  std::ifstream in(layout.Generation());
  long g = -1;
  in >> g;
  EXPECT_EQ(g, 2);
  // A file that does not hold a number starts again at 0.
  std::ofstream(layout.Generation()) << "garbage\n";
  EXPECT_EQ(NextGeneration(layout, &why), 0) << why;
  // A folder that is not there: -1 and why.
  const StateDirLayout missing{(tmp.path() / "missing" / "state").string()};
  why.clear();
  EXPECT_EQ(NextGeneration(missing, &why), -1);
  EXPECT_FALSE(why.empty());
}

TEST(StateDir, OneLockHolderAtATime) {
  const TempDir tmp;
  const StateDirLayout layout{tmp.Create().string()};
  std::string why;
  {
    StateDirLock first;
    ASSERT_TRUE(first.Acquire(layout, &why)) << why;
    EXPECT_TRUE(first.StillHeld());
    StateDirLock second;
    EXPECT_FALSE(second.Acquire(layout, &why));
    EXPECT_EQ(why, "another rumid (pid " + std::to_string(::getpid()) + ") runs on " + layout.root) << why;
  }
  StateDirLock after;  // the first one's went with it
  EXPECT_TRUE(after.Acquire(layout, &why)) << why;
  // A lock whose file was removed guards nothing.
  fs::remove(layout.Lock());
  EXPECT_FALSE(after.StillHeld());
}

}  // namespace
}  // namespace rumi
