#include "manager/map_snapshot_of.h"

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

namespace rumi {
namespace {

// The status topic's JSON under rumid: the front's link statistics as
// LinkStats::ToJson writes them (with the front's gyro figures) become the
// typed fields.
TEST(LinkFromStatusJson, ReadsTheFrontsLinkStatistics) {
  const nlohmann::json link = {
      {"robot_heard", true},     {"robot_halted", false},   {"robot_failsafe", true},
      {"robot_rssi_dbm", -61},   {"frames_delivered", 812}, {"frames_dropped", 7},
      {"frames_overflow", 2},    {"fragments_recovered", 95}, {"imu_samples", 2400},
      {"imu_gaps", 3},
      {"latency_ms", {{"p50", 61.5}, {"p95", 140.0}, {"max", 410.0}}},
      {"clock", {{"synced", true}, {"offset_ms", -2500.4}, {"drift_ppm", 20.1}}},
      {"rate_control", {{"asked_fps", 12.0}, {"cuts", 1}, {"raises", 0}}},
      {"gyro", {{"predicted", 700}, {"bridged", 2}, {"bias_updates", 500}, {"disabled", false}}}};
  const nlohmann::json j = {{"manager", {{"state", "running"}}},
                            {"daemon", {{"front", {{"frames", 820}, {"link", link}}}}}};
  const SnapshotLink l = LinkFromStatusJson(j.dump());
  EXPECT_TRUE(l.present);
  EXPECT_TRUE(l.robot_heard);
  EXPECT_FALSE(l.robot_halted);
  EXPECT_TRUE(l.robot_failsafe);
  EXPECT_EQ(l.rssi_dbm, -61);
  EXPECT_EQ(l.frames_delivered, 812);
  EXPECT_EQ(l.frames_dropped, 9) << "dropped at the deadline + the front too slow";
  EXPECT_EQ(l.fragments_recovered, 95);
  EXPECT_DOUBLE_EQ(l.latency_p50_ms, 61.5);
  EXPECT_DOUBLE_EQ(l.latency_p95_ms, 140.0);
  EXPECT_DOUBLE_EQ(l.latency_max_ms, 410.0);
  EXPECT_TRUE(l.clock_synced);
  EXPECT_DOUBLE_EQ(l.clock_offset_ms, -2500.4);
  EXPECT_DOUBLE_EQ(l.asked_fps, 12.0);
  EXPECT_EQ(l.imu_samples, 2400);
  EXPECT_EQ(l.imu_gaps, 3);
  EXPECT_EQ(l.gyro_predicted, 700);
  EXPECT_EQ(l.gyro_bridged, 2);
}

TEST(LinkFromStatusJson, NoLinkOrGarbageIsNotPresent) {
  EXPECT_FALSE(LinkFromStatusJson("").present);
  EXPECT_FALSE(LinkFromStatusJson("not json{").present);
  EXPECT_FALSE(LinkFromStatusJson(R"({"manager": {}})").present) << "not under rumid";
  EXPECT_FALSE(LinkFromStatusJson(R"({"daemon": {"front": {"source": "dataset"}}})").present) << "another source";
  EXPECT_FALSE(LinkFromStatusJson(R"({"daemon": {"front": "x"}})").present);
  // Values of the wrong type read as defaults; the rest still comes through.
  const SnapshotLink l = LinkFromStatusJson(
      R"({"daemon": {"front": {"link": {"frames_delivered": "many", "latency_ms": 5, "clock": {"synced": 1},)"
      R"( "frames_dropped": 4}}}})");
  EXPECT_TRUE(l.present);
  EXPECT_EQ(l.frames_delivered, 0);
  EXPECT_EQ(l.latency_p50_ms, 0);
  EXPECT_FALSE(l.clock_synced);
  EXPECT_EQ(l.frames_dropped, 4);
}

}  // namespace
}  // namespace rumi
