// The attempt policy's decisions on canned attempts (no COLMAP).
#include "back/attempt_policy.h"

#include <gtest/gtest.h>

#include "back/model_to_submap.h"

namespace rumi {
namespace {

constexpr Timestamp kT0 = 1000000000LL, kDt = 100000000LL;
Timestamp T(int i) { return kT0 + kDt * i; }

// A window of n frames, frames `blank` blank; the layout as LayOutWindow
// makes it for them (stretches of at least 3 blank frames).
struct Canned {
  ImageWindow window;
  WindowLayout layout;
};
Canned MakeWindow(int n, const std::vector<int>& blank = {}, const std::vector<Timestamp>& joined_at = {}) {
  Canned c;
  for (int i = 0; i < n; ++i) {
    WindowFrame f;
    f.timestamp = T(i);
    c.window.frames.push_back(f);
  }
  c.window.joined_at = joined_at;
  c.layout.blank.assign(n, false);
  for (int i : blank) c.layout.blank[i] = true, ++c.layout.num_blank;
  c.layout.side.assign(n, 0);
  for (int i = 0; i < n;) {  // runs of >= 3 blank frames
    int j = i;
    while (j < n && c.layout.blank[j]) ++j;
    if (j - i >= 3) c.layout.stretches.push_back({T(i), T(j - 1)});
    i = std::max(j, i + 1);
  }
  for (int i = 0; i < n; ++i)
    for (const auto& st : c.layout.stretches) c.layout.side[i] += T(i) > st.second;
  c.layout.part_bounds = joined_at;
  for (const auto& st : c.layout.stretches) c.layout.part_bounds.push_back(st.second + 1);
  std::sort(c.layout.part_bounds.begin(), c.layout.part_bounds.end());
  return c;
}

BuiltModel Model(const std::vector<int>& frames) {
  BuiltModel b;
  for (int i : frames) {
    Keyframe k;
    k.id = i;
    k.timestamp = T(i);
    b.submap.keyframes.push_back(k);
  }
  b.stats.registered_images = int(frames.size());
  return b;
}

ColmapAttempt Attempt(std::vector<std::vector<int>> models, const std::string& name = "first attempt") {
  ColmapAttempt a;
  a.name = name;
  for (const auto& m : models) a.built.push_back(Model(m));
  a.models = a.built.size();
  return a;
}

std::vector<int> Range(int from, int to) {
  std::vector<int> r;
  for (int i = from; i < to; ++i) r.push_back(i);
  return r;
}

TEST(AttemptPolicy, AWindowIsShortWhenItsLargestModelMissesTooMany) {
  const Canned c = MakeWindow(10);
  EXPECT_FALSE(ShortOfFrames(c.window, c.layout, Attempt({Range(0, 9)}), 0.9));
  EXPECT_TRUE(ShortOfFrames(c.window, c.layout, Attempt({Range(0, 8)}), 0.9));
  EXPECT_TRUE(ShortOfFrames(c.window, c.layout, Attempt({Range(0, 5), Range(5, 10)}), 0.9));
  EXPECT_TRUE(ShortOfFrames(c.window, c.layout, Attempt({}), 0.9));
}

TEST(AttemptPolicy, BlankFramesAndJoinedPartsCountOnTheirOwn) {
  // Frames 4-6 blank: two sides of 4 and 3 frames, each its own model.
  const Canned blank = MakeWindow(10, {4, 5, 6});
  EXPECT_FALSE(ShortOfFrames(blank.window, blank.layout, Attempt({Range(0, 4), {7, 8, 9}}), 0.9));
  EXPECT_TRUE(ShortOfFrames(blank.window, blank.layout, Attempt({Range(0, 4), {7, 8}}), 0.9));
  // Two joined windows, one model each: not short; one part missing: short.
  const Canned joined = MakeWindow(10, {}, {T(5)});
  EXPECT_FALSE(ShortOfFrames(joined.window, joined.layout, Attempt({Range(0, 5), Range(5, 10)}), 0.9));
  EXPECT_TRUE(ShortOfFrames(joined.window, joined.layout, Attempt({Range(0, 5)}), 0.9));
}

TEST(AttemptPolicy, LeftOutFramesAreThoseOutsideTheBestModelOfTheirPart) {
  const Canned c = MakeWindow(10, {9});
  const ColmapAttempt a = Attempt({Range(0, 6), {7, 8}});  // 6 left out; 7, 8 in a smaller model
  std::vector<std::string> want;
  for (int i : {6, 7, 8}) want.push_back(ColmapImageName(T(i)));
  EXPECT_EQ(LeftOutFrames(c.window, c.layout, a, 0), want);
  // With a margin, the neighbours too; never the blank frame 9.
  want.insert(want.begin(), ColmapImageName(T(5)));
  EXPECT_EQ(LeftOutFrames(c.window, c.layout, a, 1), want);
}

TEST(AttemptPolicy, TheRetryGoesFirstWhenAQuarterLackFeaturesOrLinks) {
  const std::vector<std::string> missing = {"a", "b", "c", "d", "e", "f", "g", "h"};
  std::unordered_map<std::string, int> features;
  for (const auto& m : missing) features[m] = 500;
  features["kept"] = 500;
  std::vector<std::pair<std::string, std::string>> verified;
  for (const auto& m : missing) verified.push_back({m, "kept"});
  LeftOutCauses c = ClassifyLeftOut(missing, features, verified, 100);
  EXPECT_EQ(c.poor, 0);
  EXPECT_EQ(c.unlinked, 0);
  EXPECT_FALSE(RetryGoesFirst(c, missing.size()));
  // One poor (20 features), one without a row: 2 of 8, a quarter.
  features["a"] = 20;
  features.erase("b");
  c = ClassifyLeftOut(missing, features, verified, 100);
  EXPECT_EQ(c.poor, 2);
  EXPECT_TRUE(RetryGoesFirst(c, missing.size()));
  // A pair between two frames left out links neither of them to the model.
  features["a"] = 500;
  features["b"] = 500;
  verified = {{"a", "b"}, {"c", "kept"}, {"kept", "d"}, {"e", "kept"}, {"f", "kept"}, {"g", "kept"}, {"h", "kept"}};
  c = ClassifyLeftOut(missing, features, verified, 100);
  EXPECT_EQ(c.poor, 0);
  EXPECT_EQ(c.unlinked, 2);
  EXPECT_TRUE(RetryGoesFirst(c, missing.size()));
  verified.push_back({"kept", "a"});
  EXPECT_FALSE(RetryGoesFirst(ClassifyLeftOut(missing, features, verified, 100), missing.size()));
}

TEST(AttemptPolicy, ModelsAreCutAtBlankStretches) {
  const Canned c = MakeWindow(12, {4, 5, 6});
  std::vector<std::string> warnings;
  std::vector<BuiltModel> cut =
      CutModels({Model({0, 1, 2, 3, 7, 8, 9}), Model({9, 10, 11})}, c.layout.stretches, 3, 2, &warnings);
  ASSERT_EQ(cut.size(), 3u);
  EXPECT_EQ(cut[0].stats.registered_images, 4);
  EXPECT_EQ(cut[1].stats.registered_images, 3);
  EXPECT_EQ(cut[2].stats.registered_images, 3);  // not crossing: as it was
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_EQ(warnings[0], "a model of 7 frames cut at a blank stretch (the camera saw nothing): 4 + 3 frames kept");
  warnings.clear();
  cut = CutModels({Model({0, 1, 7, 8})}, c.layout.stretches, 3, 2, &warnings);
  EXPECT_TRUE(cut.empty());
  EXPECT_EQ(warnings[0], "a model of 4 frames cut at a blank stretch (the camera saw nothing): no side kept");
}

TEST(AttemptPolicy, EachSideKeepsTheAttemptThatRegisteredMostOfIt) {
  const Canned c = MakeWindow(12, {4, 5, 6});
  // The first attempt holds side 1 best, the fill (adopted: larger overall) side 2.
  const ColmapAttempt first = Attempt({Range(0, 4), {7, 8, 9}});
  ColmapAttempt fill = Attempt({{1, 2, 3, 7, 8, 9, 10, 11}}, "fill");
  std::vector<std::string> warnings;
  KeepBestSides({first, fill}, c.layout.stretches, 3, 2, &fill, &warnings);
  ASSERT_EQ(fill.built.size(), 2u);
  EXPECT_EQ(fill.built[0].stats.registered_images, 5);  // side 2, the fill's
  EXPECT_EQ(fill.built[0].submap.keyframes.front().timestamp, T(7));
  EXPECT_EQ(fill.built[1].stats.registered_images, 4);  // side 1, the first attempt's
  EXPECT_EQ(fill.built[1].submap.keyframes.front().timestamp, T(0));
  ASSERT_EQ(warnings.size(), 2u);
  EXPECT_EQ(warnings[0], "a model of 8 frames cut at a blank stretch (the camera saw nothing): 3 + 5 frames kept");
  EXPECT_EQ(warnings[1], "side 1 of the blank stretches: the first attempt's model of 4 frames kept");
}

}  // namespace
}  // namespace rumi
