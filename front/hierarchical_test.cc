#include "front/hierarchical.h"

#include <gtest/gtest.h>

namespace rumi {
namespace {

HierarchicalOptions Opts() {
  HierarchicalOptions o;
  o.eta = 3.0;
  o.lambda = 10;
  o.stall_threshold = 8;
  o.sparse_frames = 3;
  o.resume_frames = 4;
  return o;
}

TEST(Hierarchical, StaysFineWhileDenseAndGrowing) {
  HierarchicalState h(Opts());
  for (int i = 0; i < 100; ++i) {
    // The submap grows every third frame: 6-7 unchanged of 10 < 8.
    EXPECT_EQ(h.Update(10.0, i % 3 == 0, true), MappingGrain::kFine) << i;
    EXPECT_FALSE(h.halt());
    EXPECT_LE(h.stall_count(), 7);
  }
}

TEST(Hierarchical, SparseFeaturesEnterCoarseAfterSparseFrames) {
  HierarchicalState h(Opts());
  h.Update(10.0, true, true);
  EXPECT_EQ(h.Update(2.0, false, true), MappingGrain::kFine);
  EXPECT_EQ(h.Update(2.0, false, true), MappingGrain::kFine);
  EXPECT_EQ(h.Update(2.0, false, true), MappingGrain::kCoarse);  // third sparse frame
  EXPECT_TRUE(h.entered_coarse());
  EXPECT_TRUE(h.halt());
  EXPECT_EQ(h.Update(2.0, false, true), MappingGrain::kCoarse);
  EXPECT_FALSE(h.entered_coarse());  // reported once
  // A dense frame interrupted by a sparse one does not resume.
  for (int i = 0; i < 3; ++i) EXPECT_EQ(h.Update(5.0, false, false), MappingGrain::kCoarse);
  EXPECT_EQ(h.Update(1.0, false, false), MappingGrain::kCoarse);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(h.Update(5.0, false, false), MappingGrain::kCoarse);
  EXPECT_EQ(h.Update(5.0, false, false), MappingGrain::kFine);  // 4th consecutive dense frame
  EXPECT_TRUE(h.left_coarse());
  EXPECT_FALSE(h.halt());
}

TEST(Hierarchical, DensityAtEtaIsFine) {
  HierarchicalState h(Opts());
  for (int i = 0; i < 20; ++i) EXPECT_EQ(h.Update(3.0, true, true), MappingGrain::kFine);
  for (int i = 0; i < 2; ++i) EXPECT_EQ(h.Update(2.999, true, true), MappingGrain::kFine);
  EXPECT_EQ(h.Update(2.999, true, true), MappingGrain::kCoarse);
}

TEST(Hierarchical, StallCounterOverWindowEntersCoarse) {
  HierarchicalState h(Opts());
  // Dense but the submap stops growing: C_t counts unchanged steps.
  for (int i = 0; i < 7; ++i) EXPECT_EQ(h.Update(10.0, false, true), MappingGrain::kFine);
  EXPECT_EQ(h.stall_count(), 7);
  EXPECT_EQ(h.Update(10.0, true, true), MappingGrain::kFine);
  EXPECT_EQ(h.Update(10.0, false, true), MappingGrain::kFine);  // window 9 < lambda
  EXPECT_EQ(h.stall_count(), 8);
  EXPECT_EQ(h.Update(10.0, false, true), MappingGrain::kCoarse);  // window full, C_t = 9 >= 8
  EXPECT_TRUE(h.entered_coarse());
  EXPECT_EQ(h.stall_count(), 0);  // reset for the next submap
}

TEST(Hierarchical, WindowSlides) {
  HierarchicalState h(Opts());
  // Alternate 7 unchanged / 3 changed: C_t never exceeds 7 in any window of 10.
  for (int i = 0; i < 200; ++i) {
    const bool changed = (i % 10) >= 7;
    EXPECT_EQ(h.Update(10.0, changed, true), MappingGrain::kFine) << i;
  }
}

TEST(Hierarchical, NoStallCountedWhileNotBuilding) {
  HierarchicalState h(Opts());
  for (int i = 0; i < 100; ++i) EXPECT_EQ(h.Update(10.0, false, false), MappingGrain::kFine);
  EXPECT_EQ(h.stall_count(), 0);
}

TEST(Hierarchical, ResetGoesBackToFine) {
  HierarchicalState h(Opts());
  for (int i = 0; i < 3; ++i) h.Update(0.0, false, true);
  ASSERT_EQ(h.state(), MappingGrain::kCoarse);
  h.Reset();
  EXPECT_EQ(h.state(), MappingGrain::kFine);
  EXPECT_STREQ(ToString(h.state()), "fine");
}

TEST(Hierarchical, OptionsCheckAndRead) {
  HierarchicalOptions o;
  EXPECT_TRUE(o.Check());
  o.stall_threshold = o.lambda + 1;
  std::string why;
  EXPECT_FALSE(o.Check(&why));
  EXPECT_NE(why.find("stall_threshold"), std::string::npos);

  ConfigSection s = LoadConfigString("eta: 1.5\nlambda: 20\nstall_threshold: 15\n", "t.yaml");
  HierarchicalOptions r;
  ReadOptions(s, &r);
  EXPECT_DOUBLE_EQ(r.eta, 1.5);
  EXPECT_EQ(r.lambda, 20);
  EXPECT_EQ(r.stall_threshold, 15);
  EXPECT_NO_THROW(s.Finish());

  ConfigSection bad = LoadConfigString("lambda: 5\nstall_threshold: 6\n", "bad.yaml");
  HierarchicalOptions b;
  EXPECT_THROW(ReadOptions(bad, &b), ConfigError);
  ConfigSection typo = LoadConfigString("lamda: 5\n", "typo.yaml");
  HierarchicalOptions c;
  ReadOptions(typo, &c);
  EXPECT_THROW(typo.Finish(), ConfigError);
  ConfigSection wrong = LoadConfigString("eta: abc\n", "w.yaml");
  EXPECT_THROW(ReadOptions(wrong, &c), ConfigError);
}

}  // namespace
}  // namespace rumi
