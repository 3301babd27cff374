#include "manager/manager_options.h"

#include <gtest/gtest.h>

namespace rumi {
namespace {

TEST(ManagerOptions, DefaultsFollowThePaper) {
  const ManagerOptions o;
  EXPECT_TRUE(o.Check());
  EXPECT_EQ(o.pairing_max_dt_ns, 100000);  // 1e-4 s
  EXPECT_EQ(o.match_radius_px, 3.0);
  EXPECT_EQ(o.min_inlier_ratio, 0.1);
  EXPECT_EQ(o.culling_redundant_ratio, 0.9);
  EXPECT_EQ(o.culling_min_observers, 3);
  EXPECT_EQ(o.culling_octave_tolerance, 1);   // ORB-SLAM's KeyFrameCulling
  EXPECT_EQ(o.front_search_px, 3.0);          // ORB-SLAM's Fuse radius ...
  EXPECT_EQ(o.front_search_max_hamming, 50);  // ... and TH_LOW
  EXPECT_TRUE(o.pair_tracked_frames);
  EXPECT_EQ(o.pair_ratio, 0.7);
}

TEST(ManagerOptions, ReadsSection) {
  auto root = LoadConfigString("manager:\n  search_n: 5\n  robust_loss: cauchy\n  match_radius_px: 2.5\n"
                               "  pairing_max_dt_ns: 50000\n  pair_tracked_frames: false\n"
                               "  pair_neighbour_keyframes: 2\n  pair_ratio: 0.8\n");
  auto s = root.Child("manager");
  ManagerOptions o;
  ReadOptions(s, &o);
  root.Finish();
  EXPECT_EQ(o.search_n, 5);
  EXPECT_EQ(o.robust_loss, "cauchy");
  EXPECT_EQ(o.match_radius_px, 2.5);
  EXPECT_EQ(o.pairing_max_dt_ns, 50000);
  EXPECT_FALSE(o.pair_tracked_frames);
  EXPECT_EQ(o.pair_neighbour_keyframes, 2);
  EXPECT_EQ(o.pair_ratio, 0.8);
}

TEST(ManagerOptions, RejectsBadValues) {
  ManagerOptions o;
  auto bad = [&](const std::string& yaml) {
    auto root = LoadConfigString("manager:\n  " + yaml + "\n", "test.yaml");
    auto s = root.Child("manager");
    ReadOptions(s, &o);
    root.Finish();
  };
  try {
    bad("robust_loss: l2");
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("test.yaml: section 'manager': robust_loss"), std::string::npos) << e.what();
  }
  EXPECT_THROW(bad("min_inlier_ratio: 1.5"), ConfigError);
  EXPECT_THROW(bad("search_n: many"), ConfigError);
  EXPECT_THROW(bad("pair_tracked_frames: maybe"), ConfigError);
  EXPECT_THROW(bad("pair_ratio: 0"), ConfigError);
  EXPECT_THROW(bad("pair_neighbour_keyframes: 0"), ConfigError);
  EXPECT_THROW(bad("serch_n: 3"), ConfigError);  // typo: unknown key
  EXPECT_THROW(bad("front_search_px: -1"), ConfigError);
  EXPECT_THROW(bad("front_search_max_hamming: 300"), ConfigError);
  EXPECT_THROW(bad("culling_octave_tolerance: -1"), ConfigError);
  try {
    bad("match_radius_px: -1");
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("manager.match_radius_px"), std::string::npos) << e.what();
  }
  o = ManagerOptions();
  o.culling_min_observers = 0;
  std::string why;
  EXPECT_FALSE(o.Check(&why));
  EXPECT_NE(why.find("culling_min_observers"), std::string::npos);
}

}  // namespace
}  // namespace rumi
