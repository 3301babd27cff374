#include "manager/manager_service.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <cmath>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

#include "common/timestamp.h"
#include "manager/map_file.h"
#include "manager/testing/synthetic_walk.h"
#include "manager/testing/test_scenario.h"

namespace rumi {
namespace {
namespace fs = std::filesystem;
using testing::ExpectMatchesTruth;
using testing::ReadJson;
using testing::ReadTum;
using testing::TempDir;
using testing::TumRow;

// Front B of the scenario cut at `last_frame`: the same submap while it grows.
Submap PartialFrontB(const testing::Scenario& s, uint32_t seed, int last_frame) {
  SyntheticSubmapOptions c;
  c.id = 2;
  c.source = SubmapSource::kFront;
  c.first_frame = 70;
  c.last_frame = last_frame;
  c.keyframe_step = 2;
  c.S_lw = s.S_fbw;
  c.max_octave = 3;
  c.pose_noise_m = 0.01;
  c.pose_noise_rad = 0.002;
  c.point_id_offset = 3000000;
  c.seed = seed * 11 + 6;
  return MakeSyntheticSubmap(s.scene, c).submap;
}

ManagerServiceOptions Options(const TempDir& dir) {
  ManagerServiceOptions o;
  o.out_dir = dir.str();
  return o;
}

TEST(ManagerService, FrontABackFrontBMergeIntoOneTrajectory) {
  const auto s = testing::MakeScenario();
  TempDir dir;
  ManagerService svc(Options(dir));
  std::string why;
  ASSERT_TRUE(svc.Start(&why)) << why;
  EXPECT_FALSE(svc.dirty());

  svc.AddSubmap(s.front_a.submap);
  EXPECT_TRUE(svc.dirty());
  ASSERT_TRUE(svc.Rebuild(&why)) << why;
  EXPECT_FALSE(svc.dirty());
  EXPECT_EQ(svc.stats().merges, 0);
  EXPECT_EQ(svc.stats().components, 1);
  EXPECT_EQ(ReadTum(dir / "merged.txt").size(), 41u);  // front A: frames 0-40 tracked

  svc.AddSubmap(s.back.submap);
  ASSERT_TRUE(svc.Rebuild(&why)) << why;
  EXPECT_EQ(svc.stats().merges, 1);
  EXPECT_EQ(svc.stats().components, 1);
  // A (0-40) + back (30-80): frames 0-80.
  EXPECT_EQ(ReadTum(dir / "merged.txt").size(), 81u);

  svc.AddSubmap(s.front_b.submap);
  ASSERT_TRUE(svc.Rebuild(&why)) << why;
  const ManagerStats& st = svc.stats();
  EXPECT_EQ(st.merges, 2);
  EXPECT_EQ(st.components, 1);
  EXPECT_EQ(st.submaps_front, 2);
  EXPECT_EQ(st.submaps_back, 1);
  EXPECT_EQ(st.messages_front, 2);
  EXPECT_EQ(st.messages_back, 1);
  EXPECT_EQ(st.resends, 0);
  EXPECT_EQ(st.rebuilds, 3);
  EXPECT_EQ(st.saved_frames, 21 + 51 + 21);  // keyframes before culling
  EXPECT_LT(st.saved_frames_postculled, st.saved_frames);  // the back duplicates the fronts
  EXPECT_GE(st.saved_frames_postculled, 3);
  EXPECT_EQ(st.trajectory_frames, 111);

  // Every frame 0-110, matching the truth after one Sim(3): the culled
  // keyframes left their poses.
  const auto rows = ReadTum(dir / "merged.txt");
  ExpectMatchesTruth(s, rows, 0, 110);
  EXPECT_EQ(ReadTum(dir / "merged_0.txt").size(), 111u);
  EXPECT_FALSE(fs::exists(dir / "merged_1.txt"));

  const nlohmann::json j = ReadJson(dir / "manager_stats.json");
  EXPECT_EQ(j["merges"], 2);
  EXPECT_EQ(j["saved_frames"], 93);
  EXPECT_EQ(j["saved_frames_postculled"], st.saved_frames_postculled);
  EXPECT_EQ(j["submaps_front"], 2);
  EXPECT_EQ(j["submaps_back"], 1);
  EXPECT_EQ(j["components"], 1);
  ASSERT_TRUE(j["merge_reports"].is_array());
  int merged = 0;
  for (const auto& r : j["merge_reports"]) merged += r["merged"].get<bool>() ? 1 : 0;
  EXPECT_EQ(merged, 2);
  ASSERT_EQ(j["component_list"].size(), 1u);
  EXPECT_EQ(j["component_list"][0]["submaps"].size(), 3u);

  // The map file holds the culled, merged map.
  GlobalMap loaded;
  ASSERT_TRUE(LoadGlobalMap(dir / "map.rumi", &loaded, &why)) << why;
  EXPECT_EQ(loaded.size(), 3u);
  int kfs = 0;
  for (size_t i = 0; i < loaded.size(); ++i) kfs += int(loaded.submap(int(i)).keyframes.size());
  EXPECT_EQ(kfs, st.saved_frames_postculled);

  // A second service on the same folder reloads it and writes the same trajectory.
  ManagerService again(Options(dir));
  ASSERT_TRUE(again.Start(&why)) << why;
  EXPECT_EQ(again.map().size(), 3u);
  EXPECT_EQ(again.stats().base_submaps, 3);
  EXPECT_EQ(again.stats().merges, 2);
  EXPECT_EQ(again.stats().components, 1);
  EXPECT_EQ(again.stats().saved_frames, 93);
  EXPECT_EQ(again.stats().saved_frames_postculled, st.saved_frames_postculled);
  EXPECT_FALSE(again.dirty());
  fs::remove(dir / "merged.txt");
  ASSERT_TRUE(again.WriteOutputs(&why)) << why;
  const auto rows2 = ReadTum(dir / "merged.txt");
  ASSERT_EQ(rows2.size(), rows.size());
  for (size_t i = 0; i < rows.size(); ++i) {
    EXPECT_EQ(rows2[i].t, rows[i].t);
    EXPECT_LT((rows2[i].p - rows[i].p).norm(), 1e-9);
  }
  EXPECT_FALSE(fs::exists(dir / "map.rumi.bad"));
  EXPECT_TRUE(fs::exists(dir / "map.rumi.raw"));
}

TEST(ManagerService, UnmergedSubmapsGetOneTrajectoryEach) {
  const auto s = testing::MakeScenario();
  TempDir dir;
  ManagerService svc(Options(dir));
  std::string why;
  ASSERT_TRUE(svc.Start(&why)) << why;
  svc.AddSubmap(s.front_a.submap);
  svc.AddSubmap(s.front_b.submap);  // no back: nothing links them
  ASSERT_TRUE(svc.Rebuild(&why)) << why;
  EXPECT_EQ(svc.stats().components, 2);
  EXPECT_EQ(svc.stats().merges, 0);
  EXPECT_EQ(ReadTum(dir / "merged_0.txt").size(), 41u);
  EXPECT_EQ(ReadTum(dir / "merged_1.txt").size(), 41u);
  const auto a = ReadTum(dir / "merged_0.txt"), b = ReadTum(dir / "merged_1.txt");
  // Equal frame and keyframe counts: the lower map index (front A) comes first, as in merged.txt.
  EXPECT_EQ(a.front().t, s.scene.timestamps[0]);
  EXPECT_EQ(b.front().t, s.scene.timestamps[70]);
  EXPECT_EQ(ReadTum(dir / "merged.txt").front().t, a.front().t);
  // The back joins them into one: the stale merged_1.txt goes.
  svc.AddSubmap(s.back.submap);
  ASSERT_TRUE(svc.Rebuild(&why)) << why;
  EXPECT_EQ(svc.stats().components, 1);
  EXPECT_EQ(ReadTum(dir / "merged_0.txt").size(), 111u);
  EXPECT_FALSE(fs::exists(dir / "merged_1.txt"));
}

// The loss-to-merge times of `rumi eval run` need when each back submap
// arrived and when it first shared a component with a front submap.
TEST(ManagerService, BackSubmapTimesSayWhenABackSubmapJoinedAFront) {
  const auto s = testing::MakeScenario();
  TempDir dir;
  ManagerService svc(Options(dir));
  std::string why;
  ASSERT_TRUE(svc.Start(&why)) << why;
  const Timestamp before = WallNowNs();
  svc.AddSubmap(s.back.submap);
  ASSERT_TRUE(svc.Rebuild(&why)) << why;  // alone: a component without a front
  ASSERT_EQ(svc.stats().back_times.count(s.back.submap.id), 1u);
  const ManagerStats::BackTimes t0 = svc.stats().back_times.at(s.back.submap.id);
  EXPECT_GE(t0.received, before);
  EXPECT_EQ(t0.joined, 0);
  nlohmann::json j = ReadJson(dir / "manager_stats.json");
  ASSERT_EQ(j["back_submap_times"].size(), 1u);
  EXPECT_EQ(j["back_submap_times"][0]["id"], s.back.submap.id);
  EXPECT_TRUE(j["back_submap_times"][0]["joined_wall_s"].is_null());

  svc.AddSubmap(s.front_a.submap);
  ASSERT_TRUE(svc.Rebuild(&why)) << why;
  ASSERT_EQ(svc.stats().merges, 1);
  const ManagerStats::BackTimes t1 = svc.stats().back_times.at(s.back.submap.id);
  EXPECT_EQ(t1.received, t0.received);  // the first arrival counts
  EXPECT_GE(t1.joined, t1.received);
  svc.AddSubmap(s.front_b.submap);  // a later rebuild keeps the first join
  ASSERT_TRUE(svc.Rebuild(&why)) << why;
  EXPECT_EQ(svc.stats().back_times.at(s.back.submap.id).joined, t1.joined);
  j = ReadJson(dir / "manager_stats.json");
  EXPECT_NEAR(j["back_submap_times"][0]["joined_wall_s"].get<double>(), NsToSeconds(t1.joined), 1e-6);
}

// No back submap, but front C (frames 44-80) looks at what front A (0-40)
// mapped: the place merge joins them, and a pair it rejected is not matched
// again on the next rebuild while neither submap changes.
TEST(ManagerService, FrontSubmapsOfOnePlaceArePlaceMerged) {
  auto s = testing::MakeScenario();
  SyntheticSubmapOptions c;
  c.id = 7;
  c.first_frame = 44;
  c.last_frame = 80;
  c.keyframe_step = 2;
  c.S_lw = RandomSim3(77);
  c.max_octave = 3;
  c.point_id_offset = 7000000;
  c.seed = 78;
  SyntheticSubmap front_c = MakeSyntheticSubmap(s.scene, c);
  AttachPointDescriptors(&s.front_a, s.scene.points.size(), 5, 20, 1);
  AttachPointDescriptors(&front_c, s.scene.points.size(), 5, 20, 2);
  SyntheticSubmap stranger = front_c;  // the same geometry, another scene's descriptors
  stranger.submap.id = 8;
  AttachPointDescriptors(&stranger, s.scene.points.size(), 6, 20, 3);

  TempDir dir;
  ManagerService svc(Options(dir));
  std::string why;
  ASSERT_TRUE(svc.Start(&why)) << why;
  svc.AddSubmap(s.front_a.submap);
  svc.AddSubmap(stranger.submap);
  ASSERT_TRUE(svc.Rebuild(&why)) << why;
  EXPECT_EQ(svc.stats().components, 2);
  EXPECT_EQ(svc.stats().merge_attempts, 1);  // A <-> stranger, rejected
  ASSERT_TRUE(svc.Rebuild(&why)) << why;
  EXPECT_EQ(svc.stats().merge_attempts, 0);  // remembered

  svc.AddSubmap(front_c.submap);
  ASSERT_TRUE(svc.Rebuild(&why)) << why;
  EXPECT_EQ(svc.stats().merges, 1);
  EXPECT_EQ(svc.stats().components, 2);  // A + C, and the stranger alone
  const auto merged = ReadTum(dir / "merged.txt");
  EXPECT_EQ(merged.size(), 41u + 37u);  // frames 0-40 and 44-80
  EXPECT_EQ(merged.front().t, s.scene.timestamps[0]);
  EXPECT_EQ(merged.back().t, s.scene.timestamps[80]);
}

TEST(ManagerService, FrontSubmapsWithOdometryAreJoinedUntilTheBackArrives) {
  auto s = testing::MakeScenario();
  const Se3 T_ow(Eigen::Quaterniond(Eigen::AngleAxisd(-1.1, Eigen::Vector3d::UnitZ())), Eigen::Vector3d(1, 2, 0));
  AttachSyntheticOdometry(s.scene, T_ow, 0.01, 0.005, 1, &s.front_a.submap);
  AttachSyntheticOdometry(s.scene, T_ow, 0.01, 0.005, 2, &s.front_b.submap);
  TempDir dir;
  ManagerService svc(Options(dir));
  std::string why;
  ASSERT_TRUE(svc.Start(&why)) << why;
  svc.AddSubmap(s.front_a.submap);
  svc.AddSubmap(s.front_b.submap);
  ASSERT_TRUE(svc.Rebuild(&why)) << why;
  EXPECT_EQ(svc.stats().merges, 1);  // frames 0-40 and 70-110 share nothing but the pose source
  ASSERT_EQ(svc.stats().reports.size(), 2u);  // the place merge refuses, the odometry merge joins
  EXPECT_EQ(svc.stats().reports[1].init_method, "odometry");
  EXPECT_TRUE(svc.stats().reports[1].merged);
  const auto rows = ReadTum(dir / "merged.txt");
  ASSERT_EQ(rows.size(), 41u + 41u);
  std::vector<Eigen::Vector3d> est, truth;
  for (const TumRow& r : rows) {
    const auto it = std::find(s.scene.timestamps.begin(), s.scene.timestamps.end(), r.t);
    ASSERT_NE(it, s.scene.timestamps.end());
    est.push_back(r.p);
    truth.push_back(s.scene.T_wc[it - s.scene.timestamps.begin()].translation());
  }
  const UmeyamaResult u = UmeyamaAlign(est, truth, true);
  ASSERT_TRUE(u.ok);
  EXPECT_LT(u.rmse, 0.06);  // 1 cm pose noise, 1 % odometry bias over ~11 m

  // The back arrives: image evidence joins everything, the odometry merge has nothing left to do.
  svc.AddSubmap(s.back.submap);
  ASSERT_TRUE(svc.Rebuild(&why)) << why;
  EXPECT_EQ(svc.stats().merges, 2);
  EXPECT_EQ(svc.stats().components, 1);
  for (const MergeReport& r : svc.stats().reports) EXPECT_NE(r.init_method, "odometry") << ToString(r.front);
}

TEST(ManagerService, ResentFrontSubmapReplacesTheEarlierVersion) {
  const uint32_t seed = 3;
  const auto s = testing::MakeScenario(seed);
  TempDir dir;
  ManagerService svc(Options(dir));
  std::string why;
  ASSERT_TRUE(svc.Start(&why)) << why;
  svc.AddSubmap(s.front_a.submap);
  svc.AddSubmap(s.back.submap);
  svc.AddSubmap(PartialFrontB(s, seed, 85));  // B while it grows
  ASSERT_TRUE(svc.Rebuild(&why)) << why;
  EXPECT_EQ(svc.stats().merges, 2);
  ExpectMatchesTruth(s, ReadTum(dir / "merged.txt"), 0, 85);

  EXPECT_EQ(svc.stats().merges_replayed, 0);

  svc.AddSubmap(s.front_b.submap);  // B finished: same id, re-merged
  EXPECT_TRUE(svc.dirty());
  ASSERT_TRUE(svc.Rebuild(&why)) << why;
  // A <-> back is replayed (neither changed), B <-> back computed again.
  EXPECT_EQ(svc.stats().merges_replayed, 1);
  EXPECT_EQ(svc.stats().resends, 1);
  EXPECT_EQ(svc.stats().messages_front, 3);
  EXPECT_EQ(svc.stats().submaps_front, 2);  // replaced, not added
  EXPECT_EQ(svc.stats().merges, 2);
  EXPECT_EQ(svc.stats().saved_frames, 93);
  ExpectMatchesTruth(s, ReadTum(dir / "merged.txt"), 0, 110);
  const int b = svc.map().Find({SubmapSource::kFront, 2});
  ASSERT_GE(b, 0);
  EXPECT_EQ(svc.map().submap(b).frames.back().timestamp, s.scene.timestamps[110]);
  // Nothing new: both replayed, from the fingerprints hashed when received.
  ASSERT_TRUE(svc.Rebuild(&why)) << why;
  EXPECT_EQ(svc.stats().merges_replayed, 2);
  ExpectMatchesTruth(s, ReadTum(dir / "merged.txt"), 0, 110);
}

TEST(ManagerService, ReloadedMapTakesNewSubmapsAndResends) {
  const auto s = testing::MakeScenario();
  TempDir dir;
  std::string why;
  {
    ManagerService svc(Options(dir));
    ASSERT_TRUE(svc.Start(&why)) << why;
    svc.AddSubmap(s.front_a.submap);
    svc.AddSubmap(s.back.submap);
    ASSERT_TRUE(svc.Rebuild(&why)) << why;
    EXPECT_EQ(svc.stats().merges, 1);
  }
  ManagerService svc(Options(dir));
  ASSERT_TRUE(svc.Start(&why)) << why;
  EXPECT_EQ(svc.stats().base_submaps, 2);
  // Front A again (a restarted front) replaces the reloaded copy; B is new.
  svc.AddSubmap(s.front_a.submap);
  svc.AddSubmap(s.front_b.submap);
  ASSERT_TRUE(svc.Rebuild(&why)) << why;
  EXPECT_EQ(svc.map().size(), 3u);
  EXPECT_EQ(svc.stats().submaps_front, 2);
  EXPECT_EQ(svc.stats().submaps_back, 1);
  EXPECT_EQ(svc.stats().components, 1);
  EXPECT_EQ(svc.stats().merges, 2);
  EXPECT_EQ(svc.stats().trajectory_frames, 111);
}

// The incremental manager: settled submaps leave the raw set for the base in
// their merged, culled form; what arrives later still merges with them, and
// a restart finds them in the map file.
TEST(ManagerService, SettledSubmapsAreBakedIntoTheBase) {
  const auto s = testing::MakeScenario();
  TempDir dir;
  std::string why;
  const auto raw_submaps = [&] {
    GlobalMap raw;
    EXPECT_TRUE(LoadGlobalMap(dir / "map.rumi.raw", &raw, &why)) << why;
    return raw.size();
  };
  {
    ManagerService svc(Options(dir));
    ASSERT_TRUE(svc.Start(&why)) << why;
    svc.AddSubmap(s.front_a.submap);
    svc.AddSubmap(s.back.submap);
    EXPECT_EQ(svc.BakeSettled(1e-3), 0);  // not rebuilt yet
    ASSERT_TRUE(svc.Rebuild(&why, nullptr, {}, /*map_files=*/false)) << why;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    EXPECT_EQ(svc.BakeSettled(1e-3), 0);  // not in the map file yet
    ASSERT_TRUE(svc.WriteOutputs(&why)) << why;
    EXPECT_EQ(svc.BakeSettled(0), 0);     // off
    EXPECT_EQ(svc.BakeSettled(3600), 0);  // not old enough
    // Front A is the newest front submap (it may still grow): only the back goes.
    EXPECT_EQ(svc.BakeSettled(1e-3), 1);
    EXPECT_EQ(svc.stats().baked, 1);
    EXPECT_TRUE(svc.map_files_pending());  // the raw file still holds it
    ASSERT_TRUE(svc.WriteOutputs(&why)) << why;
    EXPECT_EQ(raw_submaps(), 1u);
    {  // the baked back submap is still there as received (the merge audit's need)
      GlobalMap all;
      ASSERT_TRUE(LoadRawSubmaps(dir / "map.rumi.raw", &all, &why)) << why;
      ASSERT_EQ(all.size(), 2u);
      const int back = all.Find({SubmapSource::kBack, s.back.submap.id});
      ASSERT_GE(back, 0);
      EXPECT_EQ(all.submap(back).keyframes.size(), s.back.submap.keyframes.size());
      EXPECT_EQ(all.submap(back).points.size(), s.back.submap.points.size());
    }

    svc.AddSubmap(s.front_b.submap);
    ASSERT_TRUE(svc.Rebuild(&why)) << why;
    EXPECT_EQ(svc.stats().merges, 2);  // B merges with the baked back submap
    EXPECT_EQ(svc.stats().components, 1);
    EXPECT_EQ(svc.stats().trajectory_frames, 111);
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    EXPECT_EQ(svc.BakeSettled(1e-3), 1);  // A, no longer the newest
    ASSERT_TRUE(svc.WriteOutputs(&why)) << why;
    EXPECT_EQ(raw_submaps(), 1u);  // B
    GlobalMap all;
    ASSERT_TRUE(LoadRawSubmaps(dir / "map.rumi.raw", &all, &why)) << why;
    EXPECT_EQ(all.size(), 3u);  // B raw, A and the back baked
    ASSERT_TRUE(svc.Rebuild(&why)) << why;  // from the base alone: the same map
    EXPECT_EQ(svc.map().size(), 3u);
    EXPECT_EQ(svc.stats().components, 1);
    EXPECT_EQ(svc.stats().trajectory_frames, 111);
  }
  // A restart: the base from the map file, B from the raw file.
  ManagerService svc(Options(dir));
  ASSERT_TRUE(svc.Start(&why)) << why;
  EXPECT_EQ(svc.stats().base_submaps, 3);
  svc.AddSubmap(s.front_b.submap);  // resent by a restarted front
  ASSERT_TRUE(svc.Rebuild(&why)) << why;
  EXPECT_EQ(svc.map().size(), 3u);
  EXPECT_EQ(svc.stats().components, 1);
  EXPECT_EQ(svc.stats().trajectory_frames, 111);
}

// A rebuild may leave the map file and the raw submaps for later (the
// loop's MapSaveDue): the trajectories are current, the big files catch up at
// the next whole save, and a restart in between loses nothing of the journal.
TEST(ManagerService, RebuildCanLeaveTheMapFilesForLater) {
  const auto s = testing::MakeScenario();
  TempDir dir;
  std::string why;
  ManagerServiceOptions o = Options(dir);
  o.journal = true;
  {
    ManagerService svc(o);
    ASSERT_TRUE(svc.Start(&why)) << why;
    svc.AddSubmap(s.front_a.submap);
    ASSERT_TRUE(svc.Rebuild(&why)) << why;  // whole
    EXPECT_FALSE(svc.map_files_pending());
    EXPECT_EQ(svc.stats().map_saves, 1);
    const auto map_size = fs::file_size(dir / "map.rumi");
    svc.AddSubmap(s.back.submap);
    svc.AddSubmap(s.front_b.submap);
    ASSERT_TRUE(svc.Rebuild(&why, nullptr, {}, /*map_files=*/false)) << why;
    EXPECT_TRUE(svc.map_files_pending());
    EXPECT_FALSE(svc.unsaved());
    EXPECT_EQ(svc.stats().map_saves, 1);
    EXPECT_EQ(fs::file_size(dir / "map.rumi"), map_size);  // untouched
    EXPECT_EQ(ReadTum(dir / "merged.txt").size(), 111u);   // current
    EXPECT_EQ(ReadJson(dir / "manager_stats.json")["merges"], 2);
    // Killed here: the journal still holds the two submaps.
  }
  {
    ManagerService svc(o);
    ASSERT_TRUE(svc.Start(&why)) << why;
    EXPECT_EQ(svc.stats().journal_reloaded, 2);
    ASSERT_TRUE(svc.Rebuild(&why, nullptr, {}, /*map_files=*/false)) << why;
    EXPECT_EQ(svc.stats().merges, 2);
    ASSERT_TRUE(svc.WriteOutputs(&why)) << why;  // the whole save
    EXPECT_FALSE(svc.map_files_pending());
    EXPECT_TRUE(fs::is_empty(o.JournalDir()));
  }
  GlobalMap saved;
  ASSERT_TRUE(LoadGlobalMap(dir / "map.rumi", &saved, &why)) << why;
  EXPECT_EQ(saved.size(), 3u);
}

// rumid's manager keeps a journal: what arrived after the last save
// survives a manager killed before the next one, and the restart merges it.
TEST(ManagerService, JournalKeepsWhatArrivedBetweenSavesAcrossAKill) {
  const auto s = testing::MakeScenario();
  TempDir dir;
  std::string why;
  ManagerServiceOptions o = Options(dir);
  o.journal = true;
  {
    ManagerService svc(o);
    ASSERT_TRUE(svc.Start(&why)) << why;
    svc.AddSubmap(s.front_a.submap);
    ASSERT_TRUE(svc.Rebuild(&why)) << why;  // saved: the journal is empty again
    EXPECT_TRUE(fs::is_empty(o.JournalDir()));
    svc.AddSubmap(s.back.submap);
    svc.AddSubmap(s.front_b.submap);
    // Killed here: no save after these two.
  }
  int entries = 0;
  for (const auto& e : fs::directory_iterator(o.JournalDir())) entries += e.path().extension() == ".rsub";
  EXPECT_EQ(entries, 2);
  ManagerService svc(o);
  ASSERT_TRUE(svc.Start(&why)) << why;
  EXPECT_EQ(svc.stats().journal_reloaded, 2);
  EXPECT_TRUE(svc.dirty());
  ASSERT_TRUE(svc.Rebuild(&why)) << why;
  EXPECT_EQ(svc.stats().merges, 2);
  EXPECT_EQ(svc.stats().trajectory_frames, 111);
  ExpectMatchesTruth(s, ReadTum(dir / "merged.txt"), 0, 110);
  // A corrupt entry is moved aside, not fatal.
  std::ofstream(o.JournalDir() + "/front_9.rsub") << "not a submap";
  ManagerService again(o);
  ASSERT_TRUE(again.Start(&why)) << why;
  EXPECT_TRUE(fs::exists(o.JournalDir() + "/front_9.rsub.bad"));
}

TEST(ManagerService, BadMapFileIsKeptAsideAndTheServiceStartsEmpty) {
  const auto s = testing::MakeScenario();
  TempDir dir;
  std::string why;
  fs::create_directories(dir.str());
  {
    std::ofstream out(dir / "map.rumi");
    out << "this is not a rumi map";
  }
  ManagerService svc(Options(dir));
  ASSERT_TRUE(svc.Start(&why)) << why;
  EXPECT_EQ(svc.map().size(), 0u);
  EXPECT_FALSE(fs::exists(dir / "map.rumi"));
  ASSERT_TRUE(fs::exists(dir / "map.rumi.bad"));
  EXPECT_EQ(fs::file_size(dir / "map.rumi.bad"), 22u);  // untouched
  svc.AddSubmap(s.front_a.submap);
  svc.AddSubmap(s.back.submap);
  ASSERT_TRUE(svc.Rebuild(&why)) << why;

  // A truncated good file: moved to .bad.1 (the first .bad stays).
  const auto size = fs::file_size(dir / "map.rumi");
  fs::resize_file(dir / "map.rumi", size / 2);
  ManagerService again(Options(dir));
  ASSERT_TRUE(again.Start(&why)) << why;
  EXPECT_EQ(again.map().size(), 0u);
  EXPECT_EQ(fs::file_size(dir / "map.rumi.bad"), 22u);
  ASSERT_TRUE(fs::exists(dir / "map.rumi.bad.1"));
  EXPECT_EQ(fs::file_size(dir / "map.rumi.bad.1"), size / 2);
  // The received submaps (map.rumi.raw) were intact: rebuilt from them.
  EXPECT_TRUE(again.dirty());
  ASSERT_TRUE(again.Rebuild(&why)) << why;
  EXPECT_EQ(again.map().size(), 2u);
  EXPECT_EQ(again.stats().merges, 1);
  EXPECT_EQ(again.stats().trajectory_frames, 81);

  // A bad raw file goes aside too; the (good) map file is still used.
  fs::resize_file(dir / "map.rumi.raw", 100);
  ManagerService third(Options(dir));
  ASSERT_TRUE(third.Start(&why)) << why;
  EXPECT_TRUE(fs::exists(dir / "map.rumi.raw.bad"));
  EXPECT_EQ(third.map().size(), 2u);
  EXPECT_EQ(third.stats().merges, 1);
  EXPECT_FALSE(third.dirty());
}

TEST(ManagerService, MapFileWithoutRawSubmapsIsKeptAsABase) {
  const auto s = testing::MakeScenario();
  TempDir dir;
  std::string why;
  {
    ManagerService svc(Options(dir));
    ASSERT_TRUE(svc.Start(&why)) << why;
    svc.AddSubmap(s.front_a.submap);
    svc.AddSubmap(s.back.submap);
    ASSERT_TRUE(svc.Rebuild(&why)) << why;
  }
  fs::remove(dir / "map.rumi.raw");  // e.g. a map from elsewhere given with --map
  ManagerService svc(Options(dir));
  ASSERT_TRUE(svc.Start(&why)) << why;
  EXPECT_FALSE(svc.dirty());
  EXPECT_EQ(svc.stats().merges, 1);
  svc.AddSubmap(s.front_b.submap);
  ASSERT_TRUE(svc.Rebuild(&why)) << why;
  // Nothing of the base is lost; its merge stays. (Whether B can still join
  // depends on the back keyframes that survived culling: not checked.)
  EXPECT_EQ(svc.map().size(), 3u);
  EXPECT_TRUE(svc.map().Connected(svc.map().Find({SubmapSource::kFront, 1}), svc.map().Find({SubmapSource::kBack, 1})));
  EXPECT_GE(svc.stats().merges, 1);
  EXPECT_GE(svc.stats().trajectory_frames, 81);
}

TEST(ManagerService, MapPathOptionAndUnwritableOutput) {
  const auto s = testing::MakeScenario();
  TempDir dir, other;
  fs::create_directories(other.str());
  ManagerServiceOptions o = Options(dir);
  o.map_path = other / "my.rumi";
  ManagerService svc(o);
  std::string why;
  ASSERT_TRUE(svc.Start(&why)) << why;
  svc.AddSubmap(s.front_a.submap);
  ASSERT_TRUE(svc.Rebuild(&why)) << why;
  EXPECT_TRUE(fs::exists(other / "my.rumi"));
  EXPECT_FALSE(fs::exists(dir / "map.rumi"));

  o.map_path = "/nonexistent-dir/x.rumi";
  ManagerService bad(o);
  ASSERT_TRUE(bad.Start(&why)) << why;
  bad.AddSubmap(s.front_a.submap);
  EXPECT_FALSE(bad.Rebuild(&why));
  EXPECT_NE(why.find("/nonexistent-dir/x.rumi"), std::string::npos) << why;
}

TEST(ManagerService, InconsistentSubmapsAreRefusedAndCounted) {
  const auto s = testing::MakeScenario();
  std::string why;
  EXPECT_TRUE(ValidateSubmap(s.front_a.submap, &why)) << why;
  EXPECT_TRUE(ValidateSubmap(s.back.submap, &why)) << why;
  std::vector<std::pair<std::string, Submap>> bad;
  Submap m = s.front_a.submap;
  m.keyframes[3].point_ids.pop_back();
  bad.push_back({"point ids", m});
  m = s.front_a.submap;
  m.points[5].position.x() = std::nan("");
  bad.push_back({"not finite", m});
  m = s.front_a.submap;
  m.keyframes[2].id = m.keyframes[1].id;
  bad.push_back({"duplicate", m});
  m = s.front_a.submap;
  m.keyframes[0].octaves.resize(2);
  bad.push_back({"octaves", m});
  m = s.front_a.submap;
  m.camera.fx = 0;
  bad.push_back({"camera", m});
  m = s.front_a.submap;
  m.source = SubmapSource::kMerged;
  bad.push_back({"source", m});
  m = s.front_a.submap;
  m.frames[4].T_wc.translation().y() = std::numeric_limits<double>::infinity();
  bad.push_back({"frame record", m});

  TempDir dir;
  ManagerService svc(Options(dir));
  ASSERT_TRUE(svc.Start(&why)) << why;
  for (const auto& [what, sub] : bad) {
    EXPECT_FALSE(ValidateSubmap(sub, &why)) << what;
    EXPECT_NE(why.find(what), std::string::npos) << what << ": " << why;
    EXPECT_FALSE(svc.AddSubmap(sub)) << what;
  }
  EXPECT_EQ(svc.stats().invalid_submaps, int64_t(bad.size()));
  EXPECT_FALSE(svc.dirty());
  EXPECT_TRUE(svc.AddSubmap(s.front_a.submap));
  EXPECT_TRUE(svc.dirty());
}

TEST(ManagerService, CopyWithoutKeepsComponentsAndFusedLinks) {
  const auto s = testing::MakeScenario();
  GlobalMap map;
  map.AddSubmap(s.front_a.submap);
  map.AddSubmap(s.back.submap);
  map.AddSubmap(s.front_b.submap);
  MergeAll(&map, ManagerOptions());
  ASSERT_TRUE(map.Connected(0, 2));
  ASSERT_FALSE(map.fused().empty());
  // Without the back, A and B still share the global frame: one component.
  const GlobalMap c = CopyWithout(map, {{SubmapSource::kBack, 1}});
  ASSERT_EQ(c.size(), 2u);
  EXPECT_TRUE(c.Connected(0, 1));
  EXPECT_EQ(c.ToGlobal(1).translation(), map.ToGlobal(2).translation());
  EXPECT_EQ(c.submap(1).id, 2);
  for (const auto& f : c.fused()) {  // every fused link involved the back
    ADD_FAILURE() << f.dup << " " << f.kept;
  }
  const GlobalMap all = CopyWithout(map, {});
  EXPECT_EQ(all.fused().size(), map.fused().size());
  EXPECT_TRUE(all.Connected(0, 2));
}


// merged.txt's positions against the walk's truth after a Sim(3) fit.
double MergedAte(const TempDir& dir, const Walk& w) {
  const std::vector<TumRow> rows = ReadTum(dir / "merged.txt");
  std::vector<Eigen::Vector3d> est, gt;
  for (size_t k = 0; k < rows.size() && k < w.T_wc_true.size(); ++k) {
    est.push_back(rows[k].p);
    gt.push_back(w.T_wc_true[k].translation());
  }
  return rows.size() == w.T_wc_true.size() ? UmeyamaAlign(est, gt, true).rmse : 1e9;
}

TEST(ManagerService, ALoopIsClosedAtEachRebuildTheSameWay) {
  const Walk w = MakeRoomWalk();
  TempDir off_dir, dir;
  std::string why;
  {
    ManagerServiceOptions o = Options(off_dir);
    o.manager.loop_closure = false;
    ManagerService off(o);
    ASSERT_TRUE(off.Start(&why)) << why;
    off.AddSubmap(w.submap);
    ASSERT_TRUE(off.Rebuild(&why)) << why;
    EXPECT_EQ(off.stats().loops.closed, 0);
  }
  ManagerService svc(Options(dir));
  ASSERT_TRUE(svc.Start(&why)) << why;
  svc.AddSubmap(w.submap);
  ASSERT_TRUE(svc.Rebuild(&why)) << why;
  EXPECT_GE(svc.stats().loops.closed, 1);
  const double before = MergedAte(off_dir, w), after = MergedAte(dir, w);
  EXPECT_LT(after, 0.5 * before) << before << " -> " << after;
  const nlohmann::json j = ReadJson(dir / "manager_stats.json");
  EXPECT_GE(j.at("loop_closures").get<int>(), 1);
  ASSERT_FALSE(j.at("loops").empty());
  EXPECT_EQ(j.at("loops")[0].at("query").get<std::string>(), "front#0");
  EXPECT_TRUE(j.at("last_rebuild_phases_s").contains("loops"));
  const std::vector<TumRow> first = ReadTum(dir / "merged.txt");
  // The submap sent again (a resend): the rebuild starts from it raw and
  // closes the same loops from the searches it kept, to the same map.
  svc.AddSubmap(w.submap);
  ASSERT_TRUE(svc.Rebuild(&why)) << why;
  EXPECT_EQ(svc.stats().loops.keyframes_queried, 0);
  EXPECT_EQ(svc.stats().loops.closed, j.at("loop_closures").get<int>());
  // The loops decided at the first rebuild go back in together, with one
  // solve instead of one each: the same map to the solver's tolerance
  // (micrometres in a room of 1 m).
  const std::vector<TumRow> second = ReadTum(dir / "merged.txt");
  ASSERT_EQ(second.size(), first.size());
  for (size_t k = 0; k < first.size(); ++k) EXPECT_LT((second[k].p - first[k].p).norm(), 1e-4);
  // A restarted manager: the map file holds the loop memory (raw poses,
  // searches), so its first rebuild closes the same loops without a search.
  ManagerService restarted(Options(dir));
  ASSERT_TRUE(restarted.Start(&why)) << why;
  EXPECT_FALSE(restarted.map().loops().empty());
  restarted.AddSubmap(w.submap);  // the front resends it
  ASSERT_TRUE(restarted.Rebuild(&why)) << why;
  EXPECT_EQ(restarted.stats().loops.keyframes_queried, 0);
  EXPECT_EQ(restarted.stats().loops.closed, j.at("loop_closures").get<int>());
  const std::vector<TumRow> third = ReadTum(dir / "merged.txt");
  ASSERT_EQ(third.size(), first.size());
  for (size_t k = 0; k < first.size(); ++k) EXPECT_LT((third[k].p - first[k].p).norm(), 1e-9);
}

}  // namespace
}  // namespace rumi
