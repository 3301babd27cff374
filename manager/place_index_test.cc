#include "manager/place_index.h"

#include <gtest/gtest.h>

#include <random>

#include "manager/testing/synthetic_places.h"

namespace rumi {
namespace {

TEST(PlaceIndex, FindsTheSamePlaceAmongMany) {
  // 60 places of 400 corners each; 4 views of each place are indexed, a
  // fifth view is the query: it must rank a view of its own place first.
  const SyntheticPlaces places(60, 400, /*seed=*/3);
  PlaceIndexOptions o;
  o.min_train_descriptors = 1 << 30;  // trained by TrainNow below
  PlaceIndex index(o);
  for (int p = 0; p < 60; ++p)
    for (int v = 0; v < 4; ++v) index.Add(p * 10 + v, places.View(p, v, /*flips=*/16));
  EXPECT_FALSE(index.ready());
  EXPECT_TRUE(index.Query(BowVector{{0, 1.0f}}, 5).empty());
  index.TrainNow();
  ASSERT_TRUE(index.ready());
  EXPECT_GT(index.vocabulary().num_words(), 1000);
  int right = 0;
  for (int p = 0; p < 60; ++p) {
    const BowVector q = index.vocabulary().Transform(places.View(p, 9, 16));
    const auto m = index.Query(q, 4);
    ASSERT_FALSE(m.empty());
    right += m[0].key / 10 == p;
    // The runner-up places score well below the views of the same place.
    for (const auto& x : m) {
      if (x.key / 10 != p) {
        EXPECT_LT(x.score, 0.6 * m[0].score);
      }
    }
  }
  EXPECT_EQ(right, 60);
}

TEST(PlaceIndex, TrainsByItselfAndIndexesWhatCameBefore) {
  const SyntheticPlaces places(20, 400, 5);
  PlaceIndexOptions o;
  o.min_train_descriptors = 3300;  // after 10 views of ~340 descriptors
  PlaceIndex index(o);
  for (int p = 0; p < 20; ++p) {
    index.Add(p, places.View(p, 0, 16));
    EXPECT_EQ(index.ready(), p >= 9) << p;
  }
  // Those added before the training and after it are indexed alike: each
  // one's own bag of words finds it first, with the full score.
  for (int p = 0; p < 20; ++p) {
    ASSERT_FALSE(index.Bow(p).empty());
    const auto m = index.Query(index.Bow(p), 1);
    ASSERT_EQ(m.size(), 1u);
    EXPECT_EQ(m[0].key, p);
    EXPECT_NEAR(m[0].score, 1.0, 1e-4);
  }
  // A key added again is left as it was; skip removes candidates.
  const BowVector before = index.Bow(3);
  index.Add(3, places.View(7, 0, 16));
  EXPECT_EQ(index.Bow(3), before);
  EXPECT_EQ(index.size(), 20u);
  const auto m = index.Query(index.Bow(3), 5, [](int64_t k) { return k == 3; });
  for (const auto& x : m) EXPECT_NE(x.key, 3);
}

TEST(PlaceIndex, RemovedKeyframesAreNotFoundAndTheIndexShrinks) {
  const SyntheticPlaces places(40, 400, 13);
  PlaceIndexOptions o;
  o.min_train_descriptors = 1 << 30;
  PlaceIndex index(o);
  for (int p = 0; p < 40; ++p)
    for (int v = 0; v < 2; ++v) index.Add(p * 10 + v, places.View(p, v, 16));
  index.TrainNow();
  ASSERT_EQ(index.size(), 80u);
  // The first view of every place goes, then the second of the first 30
  // (more removed than left: the postings are compacted).
  index.RemoveUnless([](int64_t k) { return k % 10 != 0; });
  EXPECT_EQ(index.size(), 40u);
  EXPECT_FALSE(index.Contains(0));
  EXPECT_TRUE(index.Bow(0).empty());
  for (int p = 0; p < 40; ++p) {
    const auto m = index.Query(index.vocabulary().Transform(places.View(p, 5, 16)), 3);
    ASSERT_FALSE(m.empty());
    EXPECT_EQ(m[0].key, p * 10 + 1);
    for (const auto& x : m) EXPECT_NE(x.key % 10, 0);
  }
  for (int p = 0; p < 30; ++p) index.Remove(p * 10 + 1);
  index.Remove(12345);  // not there: nothing happens
  EXPECT_EQ(index.size(), 10u);
  for (int p = 0; p < 40; ++p) {
    const auto m = index.Query(index.vocabulary().Transform(places.View(p, 5, 16)), 1);
    if (p >= 30) {
      ASSERT_EQ(m.size(), 1u);
      EXPECT_EQ(m[0].key, p * 10 + 1);
    } else {
      for (const auto& x : m) EXPECT_GE(x.key, 301);
    }
  }
  // A removed key may come back.
  index.Add(11, places.View(1, 1, 16));
  EXPECT_EQ(index.Query(index.Bow(11), 1)[0].key, 11);
}

TEST(PlaceIndex, ScoresAreNormalisedAndDeterministic) {
  const SyntheticPlaces places(10, 300, 7);
  PlaceIndexOptions o;
  o.min_train_descriptors = 1 << 30;
  PlaceIndex a(o), b(o);
  for (int p = 0; p < 10; ++p) a.Add(p, places.View(p, 0, 16)), b.Add(p, places.View(p, 0, 16));
  a.TrainNow();
  b.TrainNow();
  for (int p = 0; p < 10; ++p) {
    EXPECT_EQ(a.Bow(p), b.Bow(p));
    EXPECT_NEAR(BowScore(a.Bow(p), a.Bow(p)), 1.0, 1e-5);
    double sum = 0;
    for (const auto& [w, x] : a.Bow(p)) {
      sum += x;
      EXPECT_GT(x, 0);
    }
    EXPECT_NEAR(sum, 1.0, 1e-5);
    EXPECT_NEAR(a.Query(a.Bow(p), 1)[0].score, 1.0, 1e-4);
  }
  EXPECT_LT(BowScore(a.Bow(0), a.Bow(1)), 0.5);
  EXPECT_TRUE(KeyframeDescriptors(Keyframe{}).empty());
}

}  // namespace
}  // namespace rumi
