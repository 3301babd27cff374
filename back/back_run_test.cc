// RunBack in-process, under rumid's rules (spool, wait for producers forever).
#include "back/back_run.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <thread>

#include "common/process/exit_codes.h"
#include "common/testing/process.h"
#include "common/testing/temp_dir.h"

namespace rumi {
namespace {
namespace fs = std::filesystem;

TEST(BackRun, UnderRumidTheSourceEndedAndNoChannelLeftEndsTheBack) {
  // A back restarted after the front had closed and removed a drained
  // window channel: rumid's SIGUSR1 (finish) must end it, not leave it
  // waiting forever for a front that is done.
  const TempDir dir;
  BackRunOptions o;
  o.work_dir = dir.str();
  o.ipc.instance = "backfin_" + std::to_string(::getpid());
  o.spool = true;
  o.producer_death_ends = false;
  o.back.wait_for_producer_s = 0;    // as under rumid: a front may be restarting
  o.back.wait_for_consumer_s = 0.5;  // no manager in this test
  std::atomic<bool> finish{false}, stop{false};
  o.finish = &finish;
  int code = -1;
  std::thread back([&] { code = RunBack(o, &stop); });
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  finish = true;
  EXPECT_TRUE(test::JoinWithin(&back, &stop, 30));  // a back that never ends is stopped, and fails
  EXPECT_EQ(code, kExitDone);
}

}  // namespace
}  // namespace rumi
