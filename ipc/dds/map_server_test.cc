// The map over DDS between participants (the same code paths as between
// processes; map_server_process_test runs rumi-manager and rumi query).
#include "ipc/dds/map_server.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <thread>

#include "ipc/dds/map_client.h"
#include "ipc/dds/request_handler.h"
#include "ros2_msgs.h"

namespace rumi {
namespace {

std::string UniqueInstance() {
  static int n = 0;
  return "t" + std::to_string(getpid()) + "_" + std::to_string(n++);
}

std::shared_ptr<MapSnapshot> MakeSnapshot(int points) {
  auto s = std::make_shared<MapSnapshot>();
  s->seq = 7;
  s->status.instance = "x";
  s->status.state = "running";
  s->status.rebuilds = 7;
  s->status.submaps_front = 2;
  s->status.json = "{\"process\":\"manager\"}";
  s->status.link.present = true;
  s->status.link.robot_halted = true;
  s->status.link.frames_delivered = 1234;
  s->status.link.latency_p95_ms = 87.5;
  s->status.link.clock_offset_ms = -2500.25;
  s->status.link.gyro_bridged = 3;
  for (int i = 0; i < points; ++i) s->points.emplace_back(0.01f * (i % 1000), 0.01f * (i / 1000), 0.5f);
  for (int i = 0; i < 400; ++i) {
    const Se3 T(Eigen::Quaterniond(Eigen::AngleAxisd(0.01 * i, Eigen::Vector3d::UnitZ())),
                Eigen::Vector3d(0.1 * i, 0, 1));
    s->trajectory.push_back({int64_t(i) * 33333333, i % 7 == 0, T});
    if (i % 10 == 0) s->keyframes.push_back({i / 10, int64_t(i) * 33333333, "front#0", 0, T});
  }
  s->submaps.push_back({"front#0", 0, 40, points, 0, 399 * 33333333ll, Sim3()});
  s->submaps.push_back({"back#1", 0, 12, 0, 0, 0, Sim3(2.0, Eigen::Quaterniond::Identity(), Eigen::Vector3d(1, 2, 3))});
  s->grid.ok = true;
  MapServerGrid& g = s->grid.cells;
  g.width = 1500;
  g.height = 1000;
  g.resolution = 0.05;
  g.origin = Eigen::Vector3d(-10, -5, 0);
  g.pixels.resize(size_t(g.width) * g.height);
  for (size_t i = 0; i < g.pixels.size(); ++i) g.pixels[i] = i % 3 == 0 ? kPgmFree : i % 3 == 1 ? kPgmOccupied : kPgmUnknown;
  s->grid.yaml = "image: grid.pgm\nresolution: 0.05\n";
  s->events.push_back({"merged", "back#1", "front#0", Sim3(), "inliers 100"});
  return s;
}

class MapServerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    o_.chunk_bytes = 256 << 10;  // many chunks for the big replies
    instance_ = UniqueInstance();
  }
  DdsOptions o_;
  std::string instance_;
};

TEST_F(MapServerTest, NoServerIsATimeOutNamingWhatWasLookedFor) {
  std::string why;
  const auto start = std::chrono::steady_clock::now();
  EXPECT_EQ(MapClient::Connect(o_, instance_, 1.0, &why), nullptr);
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(30));
  EXPECT_NE(why.find("'" + instance_ + "'"), std::string::npos) << why;
  EXPECT_NE(why.find("domain 0"), std::string::npos) << why;
}

TEST_F(MapServerTest, AnswersEveryKindFromTheSnapshot) {
  std::string why;
  auto server = MapServer::Start(o_, instance_, &why);
  ASSERT_TRUE(server) << why;
  auto client = MapClient::Connect(o_, instance_, 20.0, &why);
  ASSERT_TRUE(client) << why;
  MapReply r;
  // Before any map: status answers "starting", the rest is unavailable.
  rumi_dds_Request q{};
  q.submap = const_cast<char*>("");
  q.kind = rumi_dds_KIND_STATUS;
  ASSERT_TRUE(client->Call(q, 20.0, &r, &why)) << why;
  EXPECT_EQ(r.code, rumi_dds_CODE_OK);
  EXPECT_EQ(r.status.state, "starting");
  q.kind = rumi_dds_KIND_KEYFRAMES;
  ASSERT_TRUE(client->Call(q, 20.0, &r, &why)) << why;
  EXPECT_EQ(r.code, rumi_dds_CODE_UNAVAILABLE);

  const auto snap = MakeSnapshot(150000);
  server->Publish(snap);
  q.kind = rumi_dds_KIND_STATUS;
  ASSERT_TRUE(client->Call(q, 20.0, &r, &why)) << why;
  EXPECT_EQ(r.status.state, "running");
  EXPECT_EQ(r.status.rebuilds, 7);
  EXPECT_EQ(r.status.json, snap->status.json);
  // The robot link's typed fields.
  EXPECT_TRUE(r.status.link.present);
  EXPECT_TRUE(r.status.link.robot_halted);
  EXPECT_FALSE(r.status.link.robot_failsafe);
  EXPECT_EQ(r.status.link.frames_delivered, 1234);
  EXPECT_DOUBLE_EQ(r.status.link.latency_p95_ms, 87.5);
  EXPECT_DOUBLE_EQ(r.status.link.clock_offset_ms, -2500.25);
  EXPECT_EQ(r.status.link.gyro_bridged, 3);
  EXPECT_EQ(r.map_seq, 7);

  q.kind = rumi_dds_KIND_POINTS;
  q.page_size = 100000;
  ASSERT_TRUE(client->Call(q, 20.0, &r, &why)) << why;
  ASSERT_EQ(r.code, rumi_dds_CODE_OK) << r.error;
  EXPECT_EQ(r.total, 150000);
  EXPECT_EQ(r.pages, 2);
  ASSERT_EQ(r.points.size(), 100000u);  // 1.2 MB in 256 KiB chunks, in order
  for (size_t i = 0; i < r.points.size(); i += 997) EXPECT_EQ(r.points[i], snap->points[i]);
  q.page = 1;
  ASSERT_TRUE(client->Call(q, 20.0, &r, &why)) << why;
  ASSERT_EQ(r.points.size(), 50000u);
  EXPECT_EQ(r.points.back(), snap->points.back());
  q.page = 0;
  q.page_size = 0;

  q.kind = rumi_dds_KIND_TRAJECTORY;
  ASSERT_TRUE(client->Call(q, 20.0, &r, &why)) << why;
  ASSERT_EQ(r.poses.size(), 400u);
  EXPECT_EQ(r.poses[123].timestamp, snap->trajectory[123].timestamp);
  EXPECT_EQ(r.poses[7].from_back, true);
  EXPECT_LT((r.poses[321].T_wc.translation() - snap->trajectory[321].T_wc.translation()).norm(), 1e-12);
  EXPECT_LT(r.poses[321].T_wc.rotation().angularDistance(snap->trajectory[321].T_wc.rotation()), 1e-12);

  q.kind = rumi_dds_KIND_KEYFRAMES;
  ASSERT_TRUE(client->Call(q, 20.0, &r, &why)) << why;
  ASSERT_EQ(r.keyframes.size(), 40u);
  EXPECT_EQ(r.keyframes[5].submap, "front#0");
  EXPECT_EQ(r.keyframes[5].id, 5);

  q.kind = rumi_dds_KIND_SUBMAP;
  q.submap = const_cast<char*>("back#1");
  ASSERT_TRUE(client->Call(q, 20.0, &r, &why)) << why;
  ASSERT_EQ(r.submaps.size(), 1u);
  EXPECT_EQ(r.submaps[0].keyframes, 12);
  EXPECT_DOUBLE_EQ(r.submaps[0].S_gl.scale(), 2.0);
  EXPECT_EQ(r.submaps[0].S_gl.translation(), Eigen::Vector3d(1, 2, 3));
  q.submap = const_cast<char*>("");

  q.kind = rumi_dds_KIND_GRID;
  ASSERT_TRUE(client->Call(q, 20.0, &r, &why)) << why;
  ASSERT_EQ(r.code, rumi_dds_CODE_OK) << r.error;
  ASSERT_TRUE(r.grid.ok);
  EXPECT_EQ(r.grid.cells.width, 1500);
  EXPECT_EQ(r.grid.cells.height, 1000);
  EXPECT_EQ(r.grid.cells.origin, snap->grid.cells.origin);
  EXPECT_EQ(r.grid.cells.pixels, snap->grid.cells.pixels);  // 1.5 MB over 6 chunks
  EXPECT_EQ(r.grid.yaml, snap->grid.yaml);

  // Late joiner: the last status is there without asking.
  auto late = MapClient::Connect(o_, instance_, 20.0, &why);
  ASSERT_TRUE(late) << why;
  SnapshotStatus st;
  ASSERT_TRUE(late->LatestStatus(20.0, &st, &why)) << why;
  EXPECT_EQ(st.state, "running");
  const MapServerCounters c = server->counters();
  EXPECT_GE(c.replies, 9);
  EXPECT_EQ(c.write_failures, 0);
}

TEST_F(MapServerTest, MalformedRequestsGetErrorsAndTheServerStaysUp) {
  std::string why;
  auto server = MapServer::Start(o_, instance_, &why);
  ASSERT_TRUE(server) << why;
  server->Publish(MakeSnapshot(1000));
  auto client = MapClient::Connect(o_, instance_, 20.0, &why);
  ASSERT_TRUE(client) << why;
  rumi_dds_Request q{};
  q.client_id = client->client_id();
  q.version = kDdsProtocolVersion;
  q.submap = const_cast<char*>("");
  q.kind = rumi_dds_KIND_POINTS;
  q.request_id = 1001;
  q.box_max[2] = std::numeric_limits<double>::quiet_NaN();
  MapReply r;
  ASSERT_TRUE(client->CallRaw(q, 20.0, &r, &why)) << why;
  EXPECT_EQ(r.code, rumi_dds_CODE_BAD_REQUEST);
  EXPECT_NE(r.error.find("NaN"), std::string::npos) << r.error;
  q.box_max[2] = 0;
  q.page_size = -5;
  q.request_id = 1002;
  ASSERT_TRUE(client->CallRaw(q, 20.0, &r, &why)) << why;
  EXPECT_NE(r.error.find("page_size -5"), std::string::npos) << r.error;
  q.page_size = 1ll << 40;
  q.request_id = 1003;
  ASSERT_TRUE(client->CallRaw(q, 20.0, &r, &why)) << why;
  EXPECT_NE(r.error.find("cap"), std::string::npos) << r.error;
  q.page_size = 0;
  q.version = 99;
  q.request_id = 1004;
  ASSERT_TRUE(client->CallRaw(q, 20.0, &r, &why)) << why;
  EXPECT_EQ(r.code, rumi_dds_CODE_BAD_VERSION);
  q.version = kDdsProtocolVersion;
  q.kind = -7;
  q.request_id = 1005;
  ASSERT_TRUE(client->CallRaw(q, 20.0, &r, &why)) << why;
  EXPECT_NE(r.error.find("kind -7"), std::string::npos) << r.error;
  q.kind = rumi_dds_KIND_SUBMAP;
  q.submap = const_cast<char*>("front#99");
  q.request_id = 1006;
  ASSERT_TRUE(client->CallRaw(q, 20.0, &r, &why)) << why;
  EXPECT_EQ(r.code, rumi_dds_CODE_NOT_FOUND);
  // Still serving.
  q.kind = rumi_dds_KIND_POINTS;
  q.request_id = 1007;
  ASSERT_TRUE(client->CallRaw(q, 20.0, &r, &why)) << why;
  EXPECT_EQ(r.code, rumi_dds_CODE_OK);
  EXPECT_EQ(r.points.size(), 1000u);
  EXPECT_EQ(server->counters().bad_requests, 6);
}

TEST_F(MapServerTest, AVanishedClientDoesNotStallTheServer) {
  std::string why;
  auto server = MapServer::Start(o_, instance_, &why);
  ASSERT_TRUE(server) << why;
  server->Publish(MakeSnapshot(200000));
  {
    auto gone = MapClient::Connect(o_, instance_, 20.0, &why);
    ASSERT_TRUE(gone) << why;
    rumi_dds_Request q{};
    q.submap = const_cast<char*>("");
    q.kind = rumi_dds_KIND_POINTS;
    MapReply r;
    gone->Call(q, 0.001, &r, &why);  // sends, leaves before the reply
  }
  auto client = MapClient::Connect(o_, instance_, 20.0, &why);
  ASSERT_TRUE(client) << why;
  rumi_dds_Request q{};
  q.submap = const_cast<char*>("");
  q.kind = rumi_dds_KIND_STATUS;
  MapReply r;
  ASSERT_TRUE(client->Call(q, 30.0, &r, &why)) << why;
  EXPECT_EQ(r.code, rumi_dds_CODE_OK);
  server->Publish(MakeSnapshot(10));  // and the manager's hand-over still goes through
}

TEST_F(MapServerTest, PoseStreamReachesAFollower) {
  std::string why;
  auto server = MapServer::Start(o_, instance_, &why);
  ASSERT_TRUE(server) << why;
  auto client = MapClient::Connect(o_, instance_, 20.0, &why);
  ASSERT_TRUE(client) << why;
  std::atomic<bool> done{false};
  std::thread writer([&] {
    for (int i = 0; i < 2000 && !done; ++i) {  // best effort: keep sending until seen
      LivePose p;
      p.timestamp = 1000 + i;
      p.state = 1;
      p.submap = "front#2";
      p.T_wc = Se3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(1, 2, 3));
      server->PublishPose(p);
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
  });
  LivePose got;
  const bool any = client->FollowPose(20.0, [&](const LivePose& p) {
    got = p;
    return false;
  });
  done = true;
  writer.join();
  ASSERT_TRUE(any);
  EXPECT_GE(got.timestamp, 1000);
  EXPECT_EQ(got.submap, "front#2");
  EXPECT_EQ(got.state, 1);
  EXPECT_EQ(got.T_wc.translation(), Eigen::Vector3d(1, 2, 3));
}

// A ROS 2 tool on rmw_cyclonedds reads rt/<prefix>/map as
// nav_msgs::msg::dds_::OccupancyGrid_ and so on: read them with those types.
template <typename T>
bool ReadOne(dds_entity_t pp, const dds_topic_descriptor_t* desc, const std::string& name,
             const std::function<void(const T&)>& check) {
  std::string why;
  const dds_entity_t topic = CreateTopic(pp, desc, name, &why);
  const dds_entity_t reader = CreateReader(pp, topic, DdsQosKind::kState, &why);
  EXPECT_GT(reader, 0) << why;
  EXPECT_STREQ(desc->m_typename, desc->m_typename);
  for (int i = 0; i < 4000; ++i) {
    void* samples[1] = {nullptr};
    dds_sample_info_t info[1];
    const dds_return_t n = dds_take(reader, samples, info, 1, 1);
    if (n > 0 && info[0].valid_data) {
      check(*static_cast<const T*>(samples[0]));
      dds_return_loan(reader, samples, n);
      return true;
    }
    if (n > 0) dds_return_loan(reader, samples, n);
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return false;
}

TEST_F(MapServerTest, Ros2ShapedTopicsRoundTrip) {
  EXPECT_STREQ(nav_msgs_msg_dds__OccupancyGrid__desc.m_typename, "nav_msgs::msg::dds_::OccupancyGrid_");
  EXPECT_STREQ(nav_msgs_msg_dds__Path__desc.m_typename, "nav_msgs::msg::dds_::Path_");
  EXPECT_STREQ(sensor_msgs_msg_dds__PointCloud2__desc.m_typename, "sensor_msgs::msg::dds_::PointCloud2_");
  EXPECT_STREQ(geometry_msgs_msg_dds__PoseStamped__desc.m_typename, "geometry_msgs::msg::dds_::PoseStamped_");
  o_.ros2_compat = true;
  std::string why;
  auto server = MapServer::Start(o_, instance_, &why);
  ASSERT_TRUE(server) << why;
  auto snap = MakeSnapshot(5000);
  // The grid frame: scale 2, shifted, so the ROS topics are in it.
  snap->grid.S_gm = Sim3(2.0, Eigen::Quaterniond::Identity(), Eigen::Vector3d(0, 0, 1));
  server->Publish(snap);
  const DdsTopics t = TopicsFor(o_, instance_);
  DdsEntity pp(CreateParticipant(o_, &why));
  ASSERT_TRUE(pp.ok()) << why;
  EXPECT_TRUE(ReadOne<nav_msgs_msg_dds__OccupancyGrid_>(
      pp.get(), &nav_msgs_msg_dds__OccupancyGrid__desc, t.ros_map, [&](const nav_msgs_msg_dds__OccupancyGrid_& m) {
        EXPECT_STREQ(m.header_.frame_id_, "map");
        EXPECT_EQ(m.info_.width_, 1500u);
        EXPECT_EQ(m.info_.height_, 1000u);
        EXPECT_FLOAT_EQ(m.info_.resolution_, 0.05f);
        EXPECT_DOUBLE_EQ(m.info_.origin_.position_.x_, -10);
        ASSERT_EQ(m.data_._length, 1500u * 1000u);
        // ROS row 0 is the bottom row, the PGM's last.
        const MapServerGrid& g = snap->grid.cells;
        for (int row : {0, 1, 499, 999})
          for (int col : {0, 1, 2, 1499}) {
            const uint8_t v = g.pixels[size_t(g.height - 1 - row) * g.width + col];
            const int8_t want = v == kPgmFree ? 0 : v == kPgmOccupied ? 100 : -1;
            EXPECT_EQ(m.data_._buffer[size_t(row) * g.width + col], want) << row << "," << col;
          }
      }));
  EXPECT_TRUE(ReadOne<nav_msgs_msg_dds__Path_>(pp.get(), &nav_msgs_msg_dds__Path__desc, t.ros_path,
                                                [&](const nav_msgs_msg_dds__Path_& p) {
                                                  ASSERT_EQ(p.poses_._length, 400u);
                                                  // x = 0.1 i, scaled by 2; z = 1 * 2 + 1
                                                  EXPECT_NEAR(p.poses_._buffer[10].pose_.position_.x_, 2.0, 1e-9);
                                                  EXPECT_NEAR(p.poses_._buffer[10].pose_.position_.z_, 3.0, 1e-9);
                                                }));
  EXPECT_TRUE(ReadOne<sensor_msgs_msg_dds__PointCloud2_>(
      pp.get(), &sensor_msgs_msg_dds__PointCloud2__desc, t.ros_points,
      [&](const sensor_msgs_msg_dds__PointCloud2_& c) {
        ASSERT_EQ(c.width_, 5000u);
        ASSERT_EQ(c.fields_._length, 3u);
        EXPECT_STREQ(c.fields_._buffer[2].name_, "z");
        EXPECT_EQ(c.fields_._buffer[2].offset_, 8u);
        EXPECT_EQ(c.fields_._buffer[2].datatype_, 7);
        EXPECT_EQ(c.point_step_, 12u);
        ASSERT_EQ(c.data_._length, 5000u * 12u);
        float xyz[3];
        std::memcpy(xyz, c.data_._buffer + 1234 * 12, 12);
        const Eigen::Vector3f want = (snap->grid.S_gm * snap->points[1234].cast<double>()).cast<float>();
        EXPECT_FLOAT_EQ(xyz[0], want.x());
        EXPECT_FLOAT_EQ(xyz[2], want.z());
      }));
}

}  // namespace
}  // namespace rumi
