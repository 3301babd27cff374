#include "manager/manager_run.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <thread>

#include "common/testing/process.h"
#include "manager/testing/test_scenario.h"

namespace rumi {
namespace {
namespace fs = std::filesystem;
using testing::ExpectMatchesTruth;
using testing::ReadJson;
using testing::ReadTum;
using testing::TempDir;

TEST(ManagerRun, RebuildsTakeAtMostTheirDutyShare) {
  ManagerLoopOptions run;  // 1 s interval, duty 0.5
  // Quick rebuilds: the interval decides.
  EXPECT_FALSE(RebuildDue(run, 0.9, 0.2));
  EXPECT_TRUE(RebuildDue(run, 1.0, 0.2));
  // A 10 s rebuild (a long session's map) is followed by 10 s without one.
  EXPECT_FALSE(RebuildDue(run, 9.9, 10.0));
  EXPECT_TRUE(RebuildDue(run, 10.0, 10.0));
  run.rebuild_max_duty = 0.2;  // 10 s of work, then 40 s of rest
  EXPECT_FALSE(RebuildDue(run, 39.0, 10.0));
  EXPECT_TRUE(RebuildDue(run, 40.0, 10.0));
  run.rebuild_max_duty = 1.0;  // no bound beyond the interval
  EXPECT_TRUE(RebuildDue(run, 1.0, 10.0));
  run.rebuild_max_duty = 0;  // clamped to 0.001, not a division by zero
  EXPECT_FALSE(RebuildDue(run, 9000.0, 10.0));
  EXPECT_TRUE(RebuildDue(run, 9991.0, 10.0));
  EXPECT_TRUE(RebuildDue(run, 1.0, 0.0));
}

TEST(ManagerRun, MapSaveDueHonoursIntervalAndDuty) {
  ManagerLoopOptions run;
  run.map_save_interval_s = 30;
  run.map_save_max_duty = 0.1;
  EXPECT_FALSE(MapSaveDue(run, 29.9, 0.5));
  EXPECT_TRUE(MapSaveDue(run, 30.0, 0.5));
  // 15 s to write a long session's files: 135 s before the next write.
  EXPECT_FALSE(MapSaveDue(run, 134.0, 15.0));
  EXPECT_TRUE(MapSaveDue(run, 135.0, 15.0));
  run.map_save_interval_s = 0;  // every rebuild writes them (small maps)
  EXPECT_TRUE(MapSaveDue(run, 0.0, 0.0));
}

TEST(ManagerRun, LoopEndsWhenNoProducerAppearsOrOnStop) {
  TempDir dir;
  std::string why;
  ManagerRunOptions run;
  run.service.out_dir = dir.str();
  ManagerService svc(run.service);
  ASSERT_TRUE(svc.Start(&why)) << why;
  run.ipc.instance = "mgrsvc_" + std::to_string(::getpid());
  run.loop.wait_for_producers_s = 0.2;
  EXPECT_EQ(RunManagerLoop(run, &svc, nullptr), ManagerExit::kNoProducer);
  // Outputs exist even for an empty map.
  EXPECT_TRUE(fs::exists(dir / "map.rumi"));
  EXPECT_TRUE(fs::exists(dir / "merged.txt"));
  EXPECT_EQ(ReadJson(dir / "manager_stats.json")["components"], 0);

  run.loop.wait_for_producers_s = 0;  // forever, but stopped
  std::atomic<bool> stop{false};
  std::thread t([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    stop = true;
  });
  EXPECT_EQ(RunManagerLoop(run, &svc, &stop), ManagerExit::kStopped);
  t.join();
}

TEST(ManagerRun, AStopUnderRumidLeavesSlowMapSavesToTheJournal) {
  // The map file takes longer to write than a stop may (stop_rebuild_max_s
  // 0 here): the stop writes the small outputs only, the journal keeps the
  // submap that arrived since the last whole save, and a restart has it.
  const auto s = testing::MakeScenario();
  TempDir dir;
  std::string why;
  ManagerRunOptions run;
  run.service.out_dir = dir.str();
  run.service.journal = true;
  run.ipc.instance = "mgrstop_" + std::to_string(::getpid());
  run.loop.stop_rebuild_max_s = 0;
  {
    ManagerService svc(run.service);
    ASSERT_TRUE(svc.Start(&why)) << why;
    svc.AddSubmap(s.front_a.submap);
    ASSERT_TRUE(svc.Rebuild(&why)) << why;  // a whole save
    ASSERT_GT(svc.stats().last_map_save_seconds, 0);
    svc.AddSubmap(s.back.submap);
    std::atomic<bool> stop{true};
    EXPECT_EQ(RunManagerLoop(run, &svc, &stop), ManagerExit::kStopped);
    EXPECT_EQ(svc.stats().map_saves, 1);
  }
  EXPECT_TRUE(fs::exists(fs::path(run.service.JournalDir()) / "back_1.rsub"));
  ManagerService again(run.service);
  ASSERT_TRUE(again.Start(&why)) << why;
  EXPECT_EQ(again.stats().journal_reloaded, 1);
  EXPECT_TRUE(again.dirty());
  ASSERT_TRUE(again.Rebuild(&why)) << why;
  EXPECT_EQ(again.stats().merges, 1);
}

TEST(ManagerRun, UnderRumidTheSourceEndedAndNoChannelLeftEndsTheLoop) {
  // A manager restarted after the front and the back closed and removed
  // their channels: rumid's SIGUSR1 (finish) must end it, not leave it
  // waiting forever for producers that are done (wait_for_producers_s 0).
  TempDir dir;
  std::string why;
  ManagerRunOptions run;
  run.service.out_dir = dir.str();
  ManagerService svc(run.service);
  ASSERT_TRUE(svc.Start(&why)) << why;
  run.ipc.instance = "mgrfin_" + std::to_string(::getpid());
  run.loop.wait_for_producers_s = 0;  // as under rumid: a producer may be restarting
  std::atomic<bool> finish{false}, stop{false};
  run.finish = &finish;
  ManagerExit result = ManagerExit::kError;
  std::thread loop([&] { result = RunManagerLoop(run, &svc, &stop); });
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  finish = true;
  EXPECT_TRUE(test::JoinWithin(&loop, &stop, 30));  // a loop that never ends is stopped, and fails
  EXPECT_EQ(result, ManagerExit::kProducersDone);
}

TEST(ManagerRun, LoopConsumesInProcessProducers) {
  const auto s = testing::MakeScenario();
  TempDir dir;
  std::string why;
  ManagerRunOptions run;
  run.service.out_dir = dir.str();
  ManagerService svc(run.service);
  ASSERT_TRUE(svc.Start(&why)) << why;
  run.ipc.instance = "mgrloop_" + std::to_string(::getpid());
  run.ipc.submap_slot_bytes = 4 << 20;
  run.loop.rebuild_interval_s = 0;
  run.loop.wait_for_producers_s = 10;  // bounded if something goes wrong
  ManagerExit result = ManagerExit::kError;
  std::thread loop([&] { result = RunManagerLoop(run, &svc, nullptr); });
  {
    SubmapSender front(run.ipc, SubmapSource::kFront);
    SubmapSender back(run.ipc, SubmapSource::kBack);
    // Close only after the consumer attached: a closed segment is not attached to.
    for (int i = 0; i < 500 && !(front.ring().Stats().consumer_alive && back.ring().Stats().consumer_alive); ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    EXPECT_EQ(front.Send(s.front_a.submap), PushStatus::kOk);
    EXPECT_EQ(back.Send(s.back.submap), PushStatus::kOk);
    EXPECT_EQ(front.Send(s.front_b.submap), PushStatus::kOk);
  }  // both close
  loop.join();
  EXPECT_EQ(result, ManagerExit::kProducersDone);
  EXPECT_EQ(svc.stats().merges, 2);
  EXPECT_EQ(svc.stats().trajectory_frames, 111);
  ExpectMatchesTruth(s, ReadTum(dir / "merged.txt"), 0, 110);
}

}  // namespace
}  // namespace rumi
