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
    EXPECT_NE(std::string(e.what()).find("test.yaml: key 'manager.robust_loss'"), std::string::npos) << e.what();
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

// The YAML reader and Check() come from one declaration: a value the reader
// refuses is one Check() refuses, with the same range (they used to differ,
// e.g. match_radius_px 1e-4 passed Check but not the reader, min_inlier_ratio
// 0.995 the reverse).
TEST(ManagerOptions, ReaderAndCheckAgree) {
  for (const std::string yaml : {"match_radius_px: 0.0001", "match_radius_px: 0", "min_inlier_ratio: 0.995",
                                 "min_inlier_ratio: 1", "pair_ratio: 1.0", "pair_ratio: 0.0001",
                                 "front_search_px: 50", "front_search_px: 50.5", "culling_redundant_ratio: 1"}) {
    SCOPED_TRACE(yaml);
    const auto key = yaml.substr(0, yaml.find(':'));
    const double v = std::stod(yaml.substr(yaml.find(':') + 1));
    ManagerOptions set;
    if (key == "match_radius_px") set.match_radius_px = v;
    if (key == "min_inlier_ratio") set.min_inlier_ratio = v;
    if (key == "pair_ratio") set.pair_ratio = v;
    if (key == "front_search_px") set.front_search_px = v;
    if (key == "culling_redundant_ratio") set.culling_redundant_ratio = v;
    std::string why;
    const bool check_ok = set.Check(&why);
    bool read_ok = true;
    std::string error;
    try {
      auto root = LoadConfigString("manager:\n  " + yaml + "\n", "t.yaml");
      auto s = root.Child("manager");
      ManagerOptions o;
      ReadOptions(s, &o);
    } catch (const ConfigError& e) {
      read_ok = false;
      error = e.what();
    }
    EXPECT_EQ(check_ok, read_ok) << why << " | " << error;
    if (!check_ok) {
      EXPECT_NE(error.find(why.substr(why.find(" is outside"))), std::string::npos) << error;
    }
  }
}

}  // namespace
}  // namespace rumi
