// The web view against rumid (docs/view.md), in a real browser: rumid runs
// a generated sequence with a loss (scripts/soak.sh's looped `dark` walk: a
// near-black stretch loses the front, the sampler ships the window, the
// back rebuilds it with COLMAP and the manager joins the front submaps
// through it) and headless Chromium loads the page rumid serves. The page
// loads with no script error, its pose trail grows between two loads, and
// once the back's submap is merged the page shows the components and merges
// of `rumi status --json` taken at the same state, and the back submap in
// the main map; while the back builds, the page says which window and at
// what stage. The front is paused (SIGSTOP) once it sent a window, and
// walks on to the next window only if that one brought no merge: the back
// has the cores to itself, and nothing changes the map after its merge.
// Every wait is a bounded poll for a condition (a loaded 2-core CI): no
// sleep decides anything.
#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <regex>
#include <string>
#include <tuple>

#include "common/testing/headless_chromium.h"
#include "common/testing/require.h"
#include "common/testing/temp_dir.h"
#include "ipc/segments.h"
#include "tests/rumi_cli_util.h"
// Last: it pulls in <resolv.h>, whose _res macro breaks Eigen included after it.
#include <httplib.h>

namespace rumi {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using test::ElementText;
using test::Slurp;
using test::SlurpTail;

// "main map: 3 front, 1 back" in the page's legend: the back submaps of component 0.
int MainMapBackSubmaps(const std::string& dom) {
  static const std::regex re("main map: [0-9]+ front, ([0-9]+) back");
  std::smatch m;
  return std::regex_search(dom, m, re) ? std::stoi(m[1].str()) : -1;
}

int Number(const std::string& text) {
  try {
    return std::stoi(text);
  } catch (const std::exception&) {
    return -1;
  }
}

TEST(RumidView, ThePageFollowsTheSessionThroughTheBacksMerge) {
  const std::string chromium = test::FindChromium();
  RUMI_REQUIRE(!chromium.empty(), "no chromium to run the page in (apt-get install chromium)");
  TempDir tmp;
  const fs::path dir = tmp.Create();
  // 10 s at 640x480 with a near-black stretch (scripts/soak.sh's), looped.
  const fs::path seq = dir / "dark";
  ASSERT_EQ(test::RunRumiLogged("synth " + seq.string() + " --scenario dark --seed 2 --frames 300 --dark-gain 0.02",
                                dir / "synth.log"),
            0)
      << Slurp(dir / "synth.log");
  const fs::path state = dir / "state";
  const fs::path cfg = dir / "rumid.yaml";
  std::ofstream(cfg) << Slurp(seq / "camera.yaml") << "log_level: info\n"
                     << "source: {kind: dataset, dataset: tum, path: " << seq.string()
                     << ", odometry: " << (seq / "odometry.txt").string() << ", loop: true}\n"
                     // The sequential matcher: the back takes ~1 min per window here, not 4.
                     << "back: {matcher: sequential, max_num_features: 1024}\n"
                     // The front paused below is not a stalled one.
                     << "daemon: {child_output: files, state_dir: " << state.string()
                     << ", status_interval_s: 0.2, front_stall_s: 3600}\n"
                     << "dds: {enabled: true}\nview: {port: 0}\n";
  const std::string instance = "view" + std::to_string(::getpid() % 100000);
  const fs::path log = dir / "rumid.log";
  const pid_t pid = test::Start({test::BinPath("rumid"), "--config", cfg.string(), "--instance", instance}, log.string());
  ASSERT_GT(pid, 0);
  pid_t front = -1;  // paused below
  struct StopOnReturn {  // an ASSERT that returns early stops rumid and its children
    std::function<void()> f;
    ~StopOnReturn() { f(); }
  } stop{[&] {
    if (front > 0) ::kill(front, SIGCONT);
    test::Stop(pid, 30, std::chrono::milliseconds(100));
    RemoveInstanceSegments(instance, /*force=*/true);
  }};
  auto why = [&] {
    return "\nstatus: " + test::ReadStatus(state).dump(1) + "\nrumid: " + SlurpTail(log) +
           "\nback: " + SlurpTail(state / "logs" / "rumi-back.log") +
           "\nmanager: " + SlurpTail(state / "logs" / "rumi-manager.log");
  };

  std::string view;
  ASSERT_TRUE(test::WaitFor([&] { return !(view = test::ReadStatus(state).value("view", "")).empty(); }, 120,
                            std::chrono::milliseconds(100)))
      << why();
  httplib::Client web(view.substr(0, view.size() - 1));
  web.set_read_timeout(30, 0);
  auto api = [&](const std::string& path) {
    const auto r = web.Get(path);
    return r && r->status == 200 ? nlohmann::json::parse(r->body, nullptr, false) : nlohmann::json();
  };
  // The still page (?live=0: what the view holds when it loads), loaded
  // whole with no script error.
  const std::string headless = test::HeadlessChromium(chromium, dir / "profile");
  const fs::path chromium_log = dir / "chromium.log";
  auto load = [&] {
    const test::CommandResult r = test::DumpDom(headless, view + "?live=0", chromium_log);
    EXPECT_EQ(r.code, 0) << SlurpTail(chromium_log);
    EXPECT_EQ(ElementText(r.out, "loaded"), "yes") << r.out.substr(0, 3000);
    EXPECT_EQ(ElementText(r.out, "errors"), "") << "script errors on the page";
    EXPECT_EQ(Slurp(chromium_log).find("Uncaught"), std::string::npos) << SlurpTail(chromium_log);
    return r.out;
  };
  auto trail = [&] {
    const nlohmann::json s = api("/api/state");
    return s.is_object() ? static_cast<int>(s["trail"].size()) : 0;
  };

  // 1. The first live poses in the main map's frame, drawn as the trail;
  // the back has not rebuilt anything yet.
  ASSERT_TRUE(test::WaitFor([&] { return trail() >= 5; }, 300, std::chrono::milliseconds(200))) << why();
  const int back_before =
      test::ReadStatus(state).value("manager", nlohmann::json::object()).value("submaps_back", 0);
  const std::string first = load();
  const int trail_first = Number(ElementText(first, "drawn-trail"));
  EXPECT_GE(trail_first, 5);
  EXPECT_LT(trail_first, 600) << "the view keeps the last 600 poses: growth would not show";
  EXPECT_EQ(back_before, 0) << "the back rebuilt the loss before the first poses?" << why();
  EXPECT_EQ(MainMapBackSubmaps(first), 0) << first;

  // 2. The trail grew: the page loaded again draws more of it.
  ASSERT_TRUE(test::WaitFor([&] { return trail() > trail_first; }, 600, std::chrono::milliseconds(200))) << why();
  const std::string second = load();
  EXPECT_GT(Number(ElementText(second, "drawn-trail")), trail_first);

  // 3. The front pauses (SIGSTOP, with daemon.front_stall_s 3600 so that
  // rumid waits) once it sent a window: the back (nice 19) has the cores for
  // COLMAP, and no new window comes. While the back builds it, the page
  // (loaded between two statuses that say the same window is at work) names
  // that window. A window that brought no back submap merged (the frames a
  // loaded front loses differ from run to run: COLMAP may not rebuild them,
  // the manager may refuse the merge; one CI run waited 900 s for the first
  // window's) lets the front walk on to the next pass's loss and window.
  auto section = [&](const char* name) { return test::ReadStatus(state).value(name, nlohmann::json::object()); };
  auto merged = [&] {
    const nlohmann::json m = section("manager");
    return m.value("submaps_back", 0) >= 1 && m.value("merges", 0) >= 1;
  };
  auto at_work = [](const nlohmann::json& back) {
    return back.contains("building") ? back["building"].value("window", int64_t{-1}) : int64_t{-1};
  };
  auto done_windows = [&] {  // built, failed or dropped by the back
    const nlohmann::json b = section("back");
    return b.value("built", 0) + b.value("failed", 0) + b.value("dropped", 0);
  };
  front = test::StatusChild(test::ReadStatus(state), "rumi-front").value("pid", -1);
  ASSERT_GT(front, 0) << why();
  std::string during;
  int64_t window = -1;
  for (int pass = 0; pass < 3 && !merged(); ++pass) {
    const int sent = section("front").value("windows_sent", 0), done = done_windows();
    if (pass > 0) {
      ASSERT_EQ(::kill(front, SIGCONT), 0);
    }
    ASSERT_TRUE(test::WaitFor([&] { return section("front").value("windows_sent", 0) > sent; }, 300,
                              std::chrono::milliseconds(100)))
        << why();
    ASSERT_EQ(::kill(front, SIGSTOP), 0);
    // The page while the back builds (once is enough).
    while (during.empty() && test::WaitFor([&] { return at_work(section("back")) >= 0 || done_windows() > done; },
                                           900, std::chrono::milliseconds(100))) {
      window = at_work(section("back"));
      if (window < 0) break;  // built already
      const bool served = test::WaitFor(
          [&] {
            const nlohmann::json st = api("/api/state");
            return st.is_object() && at_work(st["status"].value("back", nlohmann::json::object())) == window;
          },
          30, std::chrono::milliseconds(200));
      if (!served) continue;
      during = load();
      if (at_work(section("back")) != window) during.clear();
    }
    // Built (or failed), and the manager's rebuild after it had its chance.
    ASSERT_TRUE(test::WaitFor([&] { return done_windows() > done && at_work(section("back")) < 0; }, 900,
                              std::chrono::milliseconds(200)))
        << why();
    test::WaitFor(merged, 60, std::chrono::milliseconds(200));  // else: the next pass
  }
  ASSERT_FALSE(during.empty()) << "the page never loaded while the back built a window" << why();
  EXPECT_EQ(ElementText(during, "back-building").rfind("the back builds window " + std::to_string(window) + ": ", 0),
            0u)
      << ElementText(during, "back-building");
  ASSERT_TRUE(merged()) << "no back submap merged after 3 windows" << why();

  // 4. The page against `rumi status --json` at one state: the view caught
  // up with the manager (its map's components, the status it serves), the
  // page loaded, and neither changed since (a rebuild still under way: again).
  auto status = [&] {
    EXPECT_EQ(test::RunRumiLogged("status --json --state-dir " + state.string(), dir / "status.json.txt"), 0);
    const nlohmann::json s = nlohmann::json::parse(Slurp(dir / "status.json.txt"), nullptr, false);
    return s.is_object() ? s.value("manager", nlohmann::json::object()) : nlohmann::json::object();
  };
  auto counts = [](const nlohmann::json& m) {
    return std::make_tuple(m.value("components", -1), m.value("merges", -1), m.value("submaps_back", -1),
                           m.value("submaps_front", -1));
  };
  std::string page;
  nlohmann::json manager;
  int tries = 0;
  const auto t0 = Clock::now();
  while (test::SecondsSince(t0) < 600) {
    ++tries;
    manager = status();
    auto caught_up = [&] {
      const nlohmann::json m = api("/api/map"), s = api("/api/state");
      return m.is_object() && s.is_object() && m["counts"].value("components", -2) == manager.value("components", -1) &&
             s["status"].value("manager", nlohmann::json::object()).value("merges", -2) == manager.value("merges", -1);
    };
    if (!test::WaitFor(caught_up, 30, std::chrono::milliseconds(200))) continue;
    page = load();
    if (counts(status()) == counts(manager) && caught_up()) break;
    page.clear();
  }
  ASSERT_FALSE(page.empty()) << "the session never stood still for a page load (" << tries << " tries)" << why();
  std::printf("compared after %d tries: %s\n", tries, manager.dump().c_str());
  EXPECT_EQ(ElementText(page, "count-components"), std::to_string(manager.value("components", -1)));
  EXPECT_EQ(ElementText(page, "count-merges"), std::to_string(manager.value("merges", -1)));
  EXPECT_GE(MainMapBackSubmaps(page), 1) << "the back submap, joined, in the main map";
  EXPECT_GE(Number(ElementText(page, "windows-count")), 1);
  EXPECT_GE(Number(ElementText(page, "timeline-count")), 3);  // initialising, tracking, lost at least
  EXPECT_EQ(ElementText(page, "drawn-grid"), "yes");
}

}  // namespace
}  // namespace rumi
