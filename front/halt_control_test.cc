#include "front/halt_control.h"

#include <gtest/gtest.h>

namespace rumi {
namespace {

TEST(HaltControl, HaltsUntilTheFinishedSubmapIsInTheMap) {
  HaltControl h(10.0);
  EXPECT_FALSE(h.Update(-1, 0, -1, 0, 0.0));
  EXPECT_TRUE(h.Update(3, 900, 2, 500, 1.0));   // submap 3 finished, the map holds up to 2
  EXPECT_TRUE(h.Update(-1, 0, 2, 500, 2.0));    // still merging
  EXPECT_FALSE(h.Update(-1, 0, 3, 900, 4.5));   // merged: walk
  EXPECT_EQ(h.stats().halts, 1);
  EXPECT_EQ(h.stats().resumed_on_merge, 1);
  EXPECT_DOUBLE_EQ(h.stats().last_halt_s, 3.5);
}

TEST(HaltControl, ASnapshotOfTheSubmapIsNotItsMerge) {
  HaltControl h(10.0);
  // The manager holds a resent snapshot of submap 3 (frames up to 700), not
  // the finished one (up to 900).
  EXPECT_TRUE(h.Update(3, 900, 3, 700, 0.0));
  EXPECT_TRUE(h.Update(-1, 0, 3, 700, 1.0));
  EXPECT_FALSE(h.Update(-1, 0, 3, 900, 2.0));
}

TEST(HaltControl, AMergeThatNeverComesEndsTheHaltAfterTheLimit) {
  HaltControl h(5.0);
  EXPECT_TRUE(h.Update(0, 10, -1, 0, 0.0));
  EXPECT_TRUE(h.Update(-1, 0, -1, 0, 4.9));
  EXPECT_FALSE(h.Update(-1, 0, -1, 0, 5.0));
  EXPECT_EQ(h.stats().resumed_on_timeout, 1);
}

TEST(HaltControl, AnAlreadyMergedSubmapDoesNotHalt) {
  HaltControl h(5.0);
  EXPECT_FALSE(h.Update(4, 10, 4, 10, 0.0));  // a fast manager: already there
  EXPECT_EQ(h.stats().halts, 0);
}

TEST(HaltControl, ASecondFinishWhileHaltedWaitsForTheNewerOne) {
  HaltControl h(10.0);
  h.Update(1, 10, 0, 5, 0.0);
  EXPECT_TRUE(h.Update(2, 20, 0, 5, 1.0));
  EXPECT_TRUE(h.Update(-1, 0, 1, 10, 2.0));  // 1 merged, 2 not yet
  EXPECT_FALSE(h.Update(-1, 0, 2, 20, 3.0));
  EXPECT_EQ(h.stats().halts, 1);
}

}  // namespace
}  // namespace rumi
