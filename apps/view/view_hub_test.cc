#include "apps/view/view_hub.h"

#include <gtest/gtest.h>

namespace rumi {
namespace {

// The next message of a stream: its event name and its data.
std::pair<std::string, nlohmann::json> Next(ClientQueue* q) {
  std::string m;
  if (!q->Pop(std::chrono::milliseconds(0), &m)) return {"<none>", nullptr};
  const size_t data = m.find("\ndata: ");
  return {m.substr(7, data - 7), nlohmann::json::parse(m.substr(data + 7))};
}

std::vector<FrontFrameLine> Frames(const std::vector<TrackingState>& states) {
  std::vector<FrontFrameLine> frames;
  for (size_t i = 0; i < states.size(); ++i) {
    FrontFrameLine f;
    f.t = static_cast<Timestamp>(i) * 100'000'000;
    f.state = states[i];
    frames.push_back(f);
  }
  return frames;
}

// What view.js does with a timeline message (applyTimeline).
void Apply(const nlohmann::json& d, nlohmann::json* timeline, int64_t* seq) {
  ASSERT_EQ(d["base"].get<int64_t>(), *seq);
  nlohmann::json next = nlohmann::json::array();
  for (size_t i = 0; i < d["keep"].get<size_t>(); ++i) next.push_back((*timeline)[i]);
  for (const auto& e : d["add"]) next.push_back(e);
  *timeline = next;
  *seq = d["seq"];
}

TEST(TimelineDelta, KeepsTheCommonStartAndSendsTheRest) {
  const nlohmann::json a = {{0.0, "tracking"}, {1.0, "lost"}, {2.0, "end"}};
  const nlohmann::json b = {{0.0, "tracking"}, {1.0, "lost"}, {3.0, "tracking"}, {4.0, "end"}};
  const nlohmann::json d = TimelineDelta(a, b);
  EXPECT_EQ(d["keep"], 2);
  EXPECT_EQ(d["add"], nlohmann::json({{3.0, "tracking"}, {4.0, "end"}}));
  EXPECT_EQ(TimelineDelta(b, a)["keep"], 2);  // a shorter one (the file written anew)
  EXPECT_EQ(TimelineDelta(nlohmann::json::array(), a)["add"], a);
}

TEST(ViewHub, TheTimelineGoesOutAsItsChangesAndTheirSumIsTheTimeline) {
  ViewHub hub{ViewOptions()};
  std::string why;
  const auto q = hub.Subscribe(&why);
  ASSERT_TRUE(q) << why;
  // A page that opened now: the state's timeline and its seq.
  const nlohmann::json state = nlohmann::json::parse(hub.StateJson());
  nlohmann::json page = state["timeline"];
  int64_t seq = state["timeline_seq"];
  using S = TrackingState;
  std::vector<S> states = {S::kInitializing, S::kTracking, S::kTracking};
  for (int grow = 0; grow < 40; ++grow) {  // front_frames.txt grows: a loss every 10 frames
    for (int i = 0; i < 5; ++i) states.push_back(grow % 2 ? S::kLost : S::kTracking);
    hub.SetFrames(Frames(states));
    hub.SetFrames(Frames(states));  // read again, unchanged: nothing sent
    const auto [event, d] = Next(q.get());
    ASSERT_EQ(event, "timeline");
    EXPECT_EQ(Next(q.get()).first, "<none>");
    Apply(d, &page, &seq);
    ASSERT_FALSE(HasFatalFailure());
    if (grow > 0) {
      EXPECT_LE(d["add"].size(), 2u);  // the new state and the end, not the whole timeline again
    }
  }
  const nlohmann::json whole = nlohmann::json::parse(hub.TimelineJson());
  EXPECT_EQ(page, whole["timeline"]);
  EXPECT_EQ(seq, whole["seq"]);
  EXPECT_EQ(page.size(), 42u);  // initialising, tracking, 39 changes of state, the end

  // A live pose that changes the state moves the seq on, as view.js does
  // with its copy; a page that missed it is no longer the next delta's base.
  LivePose p;
  p.timestamp = 10'000'000'000;
  p.state = 3;
  hub.AddPose(p);
  EXPECT_EQ(Next(q.get()).first, "pose");
  states.push_back(S::kTracking);
  hub.SetFrames(Frames(states));
  EXPECT_NE(Next(q.get()).second["base"], seq);
}

TEST(ViewHub, TheManagerStatsReportsStayOutOfTheStream) {
  ViewHub hub{ViewOptions()};
  std::string why;
  const auto q = hub.Subscribe(&why);
  ASSERT_TRUE(q) << why;
  nlohmann::json stats = {{"merges", 40},       {"loop_closures", 3}, {"components", 1},
                          {"last_save", "now"}, {"baked", true},     {"loop_seconds", {{"mean", 0.2}}}};
  for (int i = 0; i < 400; ++i)  // a long session's reports: 150 KB and growing
    stats["merge_reports"].push_back({{"submap", "front#" + std::to_string(i)}, {"filler", std::string(300, 'x')}});
  hub.SetManagerStats(stats);
  const auto [event, summary] = Next(q.get());
  EXPECT_EQ(event, "manager_stats");
  EXPECT_EQ(summary, nlohmann::json({{"merges", 40},
                                     {"loop_closures", 3},
                                     {"components", 1},
                                     {"last_save", "now"},
                                     {"baked", true}}));
  EXPECT_EQ(nlohmann::json::parse(hub.StateJson())["manager_stats"], summary);
  EXPECT_EQ(nlohmann::json::parse(hub.ManagerStatsJson()), stats);  // whole, when asked
}

}  // namespace
}  // namespace rumi
