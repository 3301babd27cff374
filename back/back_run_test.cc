// RunBack in-process, under rumid's rules (spool, wait for producers forever).
#include "back/back_run.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <thread>

#include "common/process/exit_codes.h"

namespace rumi {
namespace {
namespace fs = std::filesystem;

TEST(BackRun, UnderRumidTheSourceEndedAndNoChannelLeftEndsTheBack) {
  // A back restarted after the front had closed and removed a drained
  // window channel: rumid's SIGUSR1 (finish) must end it, not leave it
  // waiting forever for a front that is done.
  const fs::path dir = fs::temp_directory_path() / ("rumi_back_run_test_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  BackRunOptions o;
  o.work_dir = dir.string();
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
  const auto t0 = std::chrono::steady_clock::now();
  std::thread guard([&] {  // a back that never ends is stopped, and fails below
    while (!stop && std::chrono::steady_clock::now() - t0 < std::chrono::seconds(30))
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    stop = true;
  });
  back.join();
  const bool ended_by_itself = !stop;
  stop = true;
  guard.join();
  EXPECT_TRUE(ended_by_itself);
  EXPECT_EQ(code, kExitDone);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace rumi
