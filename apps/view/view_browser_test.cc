// The page in a real browser: headless Chromium (Debian's `chromium`,
// installed by scripts/setup.sh; under CI a missing browser fails the test)
// loads the view of a saved session folder served by `rumi view`'s
// ViewSession, runs its JavaScript, and the DOM it leaves must say what the
// map file holds: the counts the page wrote, the cells and keyframes it
// drew, the grid under them, the timeline, the daemon's children, and no
// script error.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iomanip>
#include <thread>

#include "apps/view/view_session.h"
#include "common/testing/headless_chromium.h"
#include "common/testing/process.h"
#include "common/testing/require.h"
#include "common/testing/temp_dir.h"
#include "manager/grid/grid_file.h"
#include "manager/map_file.h"
#include "manager/map_snapshot_of.h"
#include "manager/testing/synthetic_submaps.h"

namespace rumi {
namespace {

namespace fs = std::filesystem;

SyntheticScene Scene() {
  SyntheticSceneOptions so;
  so.num_frames = 120;
  so.num_points = 1500;
  return MakeSyntheticScene(so);
}

// The map: two front submaps joined by the back submap that rebuilt the
// loss between them, a third front submap not joined (its own component);
// grown: one more front submap joined to the main map (a map update).
void WriteMap(const fs::path& dir, bool grown) {
  fs::create_directories(dir / "front");
  const SyntheticScene scene = Scene();
  GlobalMap map;
  auto add = [&](SubmapSource source, int64_t id, int first, int last) {
    SyntheticSubmapOptions o;
    o.id = id;
    o.source = source;
    o.first_frame = first;
    o.last_frame = last;
    o.keyframe_step = 3;
    o.S_lw = Sim3();
    const int i = map.AddSubmap(MakeSyntheticSubmap(scene, o).submap);
    EXPECT_GE(i, 0);
    return i;
  };
  const int a = add(SubmapSource::kFront, 1, 0, 44);
  const int back = add(SubmapSource::kBack, 101, 36, 66);
  const int b = add(SubmapSource::kFront, 2, 58, 90);
  add(SubmapSource::kFront, 3, 96, 119);  // after a second loss, never joined
  map.Union(a, back);
  map.Union(back, b);
  if (grown) map.Union(b, add(SubmapSource::kFront, 4, 70, 95));
  std::string why;
  ASSERT_TRUE(SaveGlobalMap(map, (dir / "map.rumi").string(), &why)) << why;
}

// A session as rumid leaves it: the map, the grid, status.json,
// front_frames.txt and front_samples.txt.
void WriteSession(const fs::path& dir) {
  WriteMap(dir, false);
  std::string why;

  MapServerGrid g;
  g.image = "grid.pgm";
  g.resolution = 0.1;
  g.origin = Eigen::Vector3d(-2, -2, 0);
  g.width = 140;
  g.height = 60;
  g.pixels.assign(size_t(g.width * g.height), kPgmUnknown);
  for (int r = 10; r < 50; ++r)
    for (int c = 10; c < 130; ++c) g.pixels[size_t(r * g.width + c)] = (r == 10 || r == 49) ? kPgmOccupied : kPgmFree;
  // The grid frame: the global frame turned so that its z (ahead) is y.
  ASSERT_TRUE(WriteMapServerGrid(g, (dir / "grid.pgm").string(), (dir / "grid.yaml").string(),
                                 {"rumi_map_to_grid: {s: 1.0, q_xyzw: [0.7071067811865476, 0.0, 0.0, "
                                  "0.7071067811865476], t: [0.0, 0.0, 0.0]}"},
                                 &why))
      << why;
  std::ofstream(dir / "status.json") << nlohmann::json(
      {{"instance", "browser"},
       {"state", "stopped"},
       {"summary", "stopped: 3 front submaps, 1 back"},
       {"children",
        {{{"name", "rumi-front"}, {"state", "exited"}, {"restarts", 1}},
         {{"name", "rumi-back"}, {"state", "exited"}, {"restarts", 0}},
         {{"name", "rumi-manager"}, {"state", "exited"}, {"restarts", 0}}}},
       {"back",
        {{"queue", 1},
         {"windows_built", 1},
         {"building", {{"window", 7}, {"stage", "mapper"}, {"elapsed_s", 12.4}, {"frames", 36}}}}},
       {"rings", {{{"name", "rumi_browser_windows"}, {"dropped", 2}}}}});
  const SyntheticScene scene = Scene();
  std::ofstream(dir / "manager_stats.json")
      << nlohmann::json({{"merges", 2}, {"loop_closures", 0}, {"components", 2}, {"last_save", "at the stop"}});
  // One window for the first loss: S1 before it, S2 through it, S3 after.
  std::ofstream samples(dir / "front" / "front_samples.txt");
  for (int i = 30; i < 66; ++i)
    samples << std::fixed << std::setprecision(9) << NsToSeconds(scene.timestamps[size_t(i)]) << " "
            << (i < 45 ? "S1" : i < 58 ? "S2" : "S3") << " 7\n";
  std::ofstream frames(dir / "front" / "front_frames.txt");
  for (int i = 0; i < 120; ++i) {
    const bool lost = (i > 44 && i < 58) || (i > 90 && i < 96);
    frames << std::fixed << std::setprecision(9) << NsToSeconds(scene.timestamps[size_t(i)]) << " " << (lost ? "lost" : "tracking") << " "
           << (i < 50 ? 1 : i < 93 ? 2 : 3) << "\n";
  }
}

TEST(ViewBrowser, ThePageShowsWhatTheMapFileHolds) {
  const std::string chromium = test::FindChromium();
  RUMI_REQUIRE(!chromium.empty(), "no chromium to run the page in (apt-get install chromium)");
  TempDir tmp;
  const fs::path dir = tmp.Create() / "state";
  WriteSession(dir);
  if (HasFatalFailure()) return;

  ViewSessionOptions o;
  o.view.port = 0;
  o.state_dir = dir.string();
  std::string why;
  auto session = ViewSession::Start(o, &why);
  ASSERT_TRUE(session) << why;

  // The DOM is dumped once the virtual time budget is spent; virtual time
  // stands still while a request is open, so the page's live stream holds
  // it until the test ends the stream below.
  const std::string log = (tmp.path() / "chromium.log").string();
  const std::string base = test::HeadlessChromium(chromium, tmp.path() / "profile");
  test::CommandResult r;
  std::thread browser([&] { r = test::DumpDom(base, session->Address(), log, 300); });
  // The page loaded the session and follows the live stream.
  const bool following = test::WaitFor([&] { return session->hub().counters().clients >= 1; }, 240);
  // Live: front_frames.txt grows (5 frames lost, 5 tracked): the page gets
  // the timeline's change (keep 5, add lost, tracking, end), once the feed
  // read it...
  const SyntheticScene scene = Scene();
  {
    std::ofstream frames(dir / "front" / "front_frames.txt", std::ios::app);
    for (int i = 1; i <= 10; ++i)
      frames << std::fixed << std::setprecision(9) << NsToSeconds(scene.timestamps.back() + i * 33'000'000LL) << " "
             << (i <= 5 ? "lost" : "tracking") << " 4\n";
  }
  const bool grown = test::WaitFor(
      [&] { return nlohmann::json::parse(session->hub().TimelineJson())["timeline"].size() == 8; }, 60);
  // ...then the pose moves (20 poses tracked, then 10 lost) and the map
  // grows (the manager saved again: one more front submap joined).
  for (int i = 0; i < 30; ++i) {
    LivePose p;
    p.timestamp = scene.timestamps.back() + 1'000'000'000LL + i * 100'000'000LL;
    p.state = i < 20 ? 1 : 3;
    p.in_global = true;
    p.T_wc = scene.T_wc[size_t(60 + i)];
    session->hub().AddPose(p);
  }
  // The manager's events over DDS, as DdsFeed hands them over.
  session->hub().AddEvents({{"merged", "back#101", "front#1", Sim3(), "inliers 80"},
                            {"loop", "front#2", "front#1", Sim3(), "keyframe 60 -> 4"}});
  WriteMap(dir, true);
  const bool updated = test::WaitFor([&] { return session->hub().counters().map_updates >= 2; }, 60);
  // The stream ends after what it holds; the page's EventSource is refused
  // from then on and stops asking: the page goes idle, the budget runs out.
  session->hub().CloseAll();
  browser.join();
  ASSERT_TRUE(following) << "the page never opened its live stream; chromium's log:\n" << test::Slurp(log);
  ASSERT_TRUE(updated);
  ASSERT_TRUE(grown) << session->hub().TimelineJson();
  ASSERT_EQ(r.code, 0) << "chromium failed; its log:\n" << test::Slurp(log);
  const std::string& dom = r.out;
  ASSERT_EQ(test::ElementText(dom, "loaded"), "yes") << dom.substr(0, 4000) << "\n" << test::Slurp(log);
  EXPECT_EQ(test::ElementText(dom, "errors"), "") << "script errors on the page";
  EXPECT_EQ(test::Slurp(log).find("Uncaught"), std::string::npos) << test::Slurp(log);

  // What the page must say: the grown map file as the manager would serve it.
  GlobalMap map;
  ASSERT_TRUE(LoadGlobalMap((dir / "map.rumi").string(), &map, &why)) << why;
  MapSnapshot expect;
  FillMapSnapshot(map, &expect);
  ASSERT_EQ(expect.submaps.size(), 5u);
  EXPECT_EQ(test::ElementText(dom, "count-points"), std::to_string(expect.points.size()));
  EXPECT_EQ(test::ElementText(dom, "count-keyframes"), std::to_string(expect.keyframes.size()));
  EXPECT_EQ(test::ElementText(dom, "count-submaps"), "5");
  EXPECT_EQ(test::ElementText(dom, "count-components"), "2");  // the unjoined front submap is a component of its own
  EXPECT_EQ(test::ElementText(dom, "count-links"), "2");       // the back submap joined two front submaps
  EXPECT_EQ(test::ElementText(dom, "drawn-keyframes"), std::to_string(expect.keyframes.size()));
  EXPECT_GT(std::stoi(test::ElementText(dom, "drawn-cells")), 100);
  EXPECT_EQ(test::ElementText(dom, "drawn-grid"), "yes");
  EXPECT_EQ(test::ElementText(dom, "frame"), "grid");
  EXPECT_EQ(test::ElementText(dom, "drawn-trail"), "30");  // every live pose (15 Hz at most: they are 10 Hz)
  // tracking, lost, tracking, lost, tracking, end from front_frames.txt as
  // the page loaded it; lost, tracking, end as it grew (a delta); then
  // tracking, lost live.
  EXPECT_EQ(test::ElementText(dom, "timeline-count"), "10");
  EXPECT_EQ(test::ElementText(dom, "windows-count"), "1");
  // The window the back builds (status.json's back.building), the one sent on the timeline.
  EXPECT_EQ(test::ElementText(dom, "back-building"), "the back builds window 7: mapper, 12 s (36 frames)");
  EXPECT_EQ(test::ElementText(dom, "live"), "offline");
  EXPECT_EQ(test::ElementText(dom, "count-merges"), "1");
  EXPECT_EQ(test::ElementText(dom, "count-loops"), "1");
  EXPECT_NE(dom.find("loop front#2 → front#1 (keyframe 60 -&gt; 4)"), std::string::npos);
  EXPECT_NE(dom.find("component 1 (not joined)"), std::string::npos);
  EXPECT_NE(dom.find("<td>rumi-front</td><td>exited</td><td>1</td>"), std::string::npos);
  EXPECT_EQ(test::ElementText(dom, "instance"), "browser");
  session.reset();

  // The saved session alone, still (?live=0: nothing left open), as `rumi
  // view` shows it: no events, so the merges are the last save's count.
  session = ViewSession::Start(o, &why);
  ASSERT_TRUE(session) << why;
  const test::CommandResult still = test::DumpDom(base, session->Address() + "?live=0", log);
  ASSERT_EQ(still.code, 0) << test::Slurp(log);
  EXPECT_EQ(test::ElementText(still.out, "loaded"), "yes");
  EXPECT_EQ(test::ElementText(still.out, "errors"), "");
  EXPECT_EQ(test::ElementText(still.out, "count-merges"), "2");
  EXPECT_EQ(test::ElementText(still.out, "count-submaps"), "5");
  EXPECT_NE(still.out.find("map at its last save"), std::string::npos);
  // The same page as a picture (the docs' come this way from a demo session).
  // The same page as a picture (docs/view.md's come from a demo session).
  const fs::path png = tmp.path() / "view.png";
  const test::CommandResult shot = test::RunCommand("timeout 180 " + base + "--window-size=1400,1000 --screenshot=" +
                                                    png.string() + " " + session->Address() + "?live=0 2>>" + log);
  EXPECT_EQ(shot.code, 0) << test::Slurp(log);
  EXPECT_GT(fs::exists(png) ? fs::file_size(png) : 0, 20000u) << "a screenshot with a drawn map";
}

}  // namespace
}  // namespace rumi
