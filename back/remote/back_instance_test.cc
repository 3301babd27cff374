// RunBackInstance's checks of its options, before any channel is opened.
#include "back/remote/back_instance.h"

#include <gtest/gtest.h>

#include "common/process/exit_codes.h"

namespace rumi {
namespace {

TEST(BackInstance, ABadInstanceOrNoWorkFolderIsBadInput) {
  BackRunOptions run;
  run.work_dir = "/nonexistent/work";
  run.ipc.instance = "no spaces/allowed";
  const std::atomic<bool> stop{true};
  EXPECT_EQ(RunBackInstance(run, DdsOptions{}, &stop), kExitBadInput);
  run.ipc.instance = "back_instance_test";
  run.work_dir.clear();
  EXPECT_EQ(RunBackInstance(run, DdsOptions{}, &stop), kExitBadInput);
}

}  // namespace
}  // namespace rumi
