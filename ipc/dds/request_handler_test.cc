#include "ipc/dds/request_handler.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace rumi {
namespace {

rumi_dds_Request Make(int32_t kind) {
  rumi_dds_Request r{};
  r.version = kDdsProtocolVersion;
  r.kind = kind;
  r.submap = const_cast<char*>("");
  return r;
}

MapSnapshot Snapshot(int points) {
  MapSnapshot s;
  s.seq = 3;
  for (int i = 0; i < points; ++i) s.points.emplace_back(float(i % 100), float(i / 100), 0.f);
  for (int i = 0; i < 50; ++i) s.trajectory.push_back({int64_t(i) * 1000000000, false, Se3()});
  s.keyframes.push_back({0, 0, "front#0", 0, Se3()});
  s.submaps.push_back({"front#0", 0, 1, points, 0, 0, Sim3()});
  s.submaps.push_back({"back#0", 0, 1, 0, 0, 0, Sim3()});
  return s;
}

TEST(RequestHandlerTest, MalformedRequestsAreNamed) {
  const DdsOptions o;
  rumi_dds_Request r = Make(rumi_dds_KIND_POINTS);
  EXPECT_EQ(RequestProblem(r, o), "");
  r.box_min[1] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(RequestProblem(r, o).find("NaN"), std::string::npos);
  r = Make(rumi_dds_KIND_POINTS);
  r.box_min[0] = 2;
  r.box_max[0] = 1;
  EXPECT_NE(RequestProblem(r, o).find("box_min[0]"), std::string::npos);
  r = Make(rumi_dds_KIND_POINTS);
  r.page_size = -3;
  EXPECT_NE(RequestProblem(r, o).find("page_size -3"), std::string::npos);
  r.page_size = int64_t(o.max_page_points) + 1;
  EXPECT_NE(RequestProblem(r, o).find("cap"), std::string::npos);
  r = Make(rumi_dds_KIND_POINTS);
  r.page = -1;
  EXPECT_NE(RequestProblem(r, o).find("page -1"), std::string::npos);
  r = Make(42);
  EXPECT_NE(RequestProblem(r, o).find("kind 42"), std::string::npos);
  r = Make(rumi_dds_KIND_STATUS);
  r.version = 7;
  EXPECT_NE(RequestProblem(r, o).find("version 7"), std::string::npos);
  EXPECT_EQ(PlanReply(r, nullptr, o).code, rumi_dds_CODE_BAD_VERSION);
  r = Make(rumi_dds_KIND_TRAJECTORY);
  r.from_ns = 10;
  r.to_ns = 5;
  EXPECT_NE(RequestProblem(r, o).find("after"), std::string::npos);
}

TEST(RequestHandlerTest, NothingBuiltYetAnswersStatusOnly) {
  const DdsOptions o;
  EXPECT_EQ(PlanReply(Make(rumi_dds_KIND_STATUS), nullptr, o).code, rumi_dds_CODE_OK);
  const ReplyPlan p = PlanReply(Make(rumi_dds_KIND_POINTS), nullptr, o);
  EXPECT_EQ(p.code, rumi_dds_CODE_UNAVAILABLE);
  EXPECT_EQ(p.chunks(), 1u);  // the error goes out as one chunk
  const MapSnapshot s = Snapshot(10);
  EXPECT_EQ(PlanReply(Make(rumi_dds_KIND_GRID), &s, o).code, rumi_dds_CODE_UNAVAILABLE);
}

TEST(RequestHandlerTest, PointsArePagedFilteredAndChunked) {
  DdsOptions o;
  o.chunk_bytes = 64 << 10;
  const MapSnapshot s = Snapshot(25000);  // x in [0, 99], y in [0, 249]
  rumi_dds_Request r = Make(rumi_dds_KIND_POINTS);
  r.page_size = 10000;
  ReplyPlan p = PlanReply(r, &s, o);
  ASSERT_EQ(p.code, rumi_dds_CODE_OK) << p.error;
  EXPECT_EQ(p.total, 25000);
  EXPECT_EQ(p.pages, 3);
  EXPECT_EQ(p.points.size(), 10000u);
  ASSERT_GT(p.chunks(), 1u);
  for (size_t k = 0; k < p.chunks(); ++k) {
    EXPECT_LT(p.bounds[k], p.bounds[k + 1]);
    EXPECT_LE((p.bounds[k + 1] - p.bounds[k]) * 12 + 4096, size_t(o.chunk_bytes));
  }
  EXPECT_EQ(p.bounds.back(), 10000u);
  r.page = 2;
  p = PlanReply(r, &s, o);
  EXPECT_EQ(p.points.size(), 5000u);
  EXPECT_EQ(p.points.front().y(), 200.f);
  r.page = 3;
  EXPECT_EQ(PlanReply(r, &s, o).code, rumi_dds_CODE_NOT_FOUND);
  r = Make(rumi_dds_KIND_POINTS);
  r.box_min[0] = 10, r.box_min[1] = 0, r.box_min[2] = -1;
  r.box_max[0] = 19, r.box_max[1] = 9, r.box_max[2] = 1;
  p = PlanReply(r, &s, o);
  EXPECT_EQ(p.total, 100);
  for (const auto& x : p.points) EXPECT_TRUE(x.x() >= 10 && x.x() <= 19 && x.y() <= 9);
}

TEST(RequestHandlerTest, TrajectoryRangeSubmapAndGrid) {
  DdsOptions o;
  o.chunk_bytes = 1 << 20;
  MapSnapshot s = Snapshot(10);
  rumi_dds_Request r = Make(rumi_dds_KIND_TRAJECTORY);
  r.from_ns = 10000000000;
  r.to_ns = 19000000000;
  EXPECT_EQ(PlanReply(r, &s, o).poses.size(), 10u);
  r = Make(rumi_dds_KIND_SUBMAP);
  EXPECT_EQ(PlanReply(r, &s, o).submaps.size(), 2u);
  r.submap = const_cast<char*>("back#0");
  EXPECT_EQ(PlanReply(r, &s, o).submaps.size(), 1u);
  r.submap = const_cast<char*>("front#9");
  const ReplyPlan miss = PlanReply(r, &s, o);
  EXPECT_EQ(miss.code, rumi_dds_CODE_NOT_FOUND);
  EXPECT_NE(miss.error.find("front#9"), std::string::npos);
  s.grid.ok = true;
  s.grid.cells.width = 3000;
  s.grid.cells.height = 1000;
  s.grid.cells.pixels.assign(3000000, kPgmUnknown);
  s.grid.yaml = "image: grid.pgm\n";
  const ReplyPlan g = PlanReply(Make(rumi_dds_KIND_GRID), &s, o);
  ASSERT_EQ(g.code, rumi_dds_CODE_OK);
  EXPECT_EQ(g.chunks(), 3u);  // 3 MB in chunks below 1 MiB
  EXPECT_EQ(g.bounds.back(), 3000000u);
}

}  // namespace
}  // namespace rumi
