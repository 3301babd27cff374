#include "ipc/dds/map_server.h"

#include <spdlog/spdlog.h>

#include <chrono>
#include <cstring>
#include <vector>

#include "common/timestamp.h"
#include "ipc/dds/request_handler.h"
#include "ros2_msgs.h"  // idlc, from ros2_msgs.idl
#include "rumi_map.h"

namespace rumi {
namespace {

// The generated C types hold char*: they point into strings that outlive the
// write (dds_write serialises before it returns).
char* C(const std::string& s) { return const_cast<char*>(s.c_str()); }

template <typename Seq, typename T>
void View(Seq* seq, std::vector<T>& v) {
  seq->_maximum = seq->_length = static_cast<uint32_t>(v.size());
  seq->_buffer = v.empty() ? nullptr : v.data();
  seq->_release = false;
}

void PoseTo(const Se3& T, double* t, double* q) {
  for (int i = 0; i < 3; ++i) t[i] = T.translation()[i];
  const Eigen::Quaterniond& r = T.rotation();
  q[0] = r.x(), q[1] = r.y(), q[2] = r.z(), q[3] = r.w();
}

void Sim3To(const Sim3& S, double* v) {
  v[0] = S.scale();
  const Eigen::Quaterniond& r = S.rotation();
  v[1] = r.x(), v[2] = r.y(), v[3] = r.z(), v[4] = r.w();
  for (int i = 0; i < 3; ++i) v[5 + i] = S.translation()[i];
}

// The grid topics carry the whole grid in one sample: only up to this size
// (a 100 x 100 m floor at 5 cm); a larger one is fetched in chunks.
constexpr size_t kMaxStreamedGridBytes = 4u << 20;

rumi_dds_Status ToDds(const SnapshotStatus& s) {
  rumi_dds_Status d{};
  CopyStatusFields(s, &d, C);
  d.version = kDdsProtocolVersion;
  return d;
}

builtin_interfaces_msg_dds__Time_ RosTime(int64_t ns) {
  builtin_interfaces_msg_dds__Time_ t;
  t.sec_ = static_cast<int32_t>(ns / 1000000000);
  t.nanosec_ = static_cast<uint32_t>(ns % 1000000000);
  return t;
}

geometry_msgs_msg_dds__Pose_ RosPose(const Se3& T) {
  geometry_msgs_msg_dds__Pose_ p;
  p.position_.x_ = T.translation().x();
  p.position_.y_ = T.translation().y();
  p.position_.z_ = T.translation().z();
  p.orientation_.x_ = T.rotation().x();
  p.orientation_.y_ = T.rotation().y();
  p.orientation_.z_ = T.rotation().z();
  p.orientation_.w_ = T.rotation().w();
  return p;
}

}  // namespace

MapServer::MapServer(const DdsOptions& o, std::string instance) : options_(o), instance_(std::move(instance)) {}

std::unique_ptr<MapServer> MapServer::Start(const DdsOptions& o, const std::string& instance, std::string* why) {
  std::unique_ptr<MapServer> s(new MapServer(o, instance));
  if (!s->Open(why)) return nullptr;
  s->thread_ = std::thread([p = s.get()] { p->Loop(); });
  return s;
}

MapServer::~MapServer() {
  stop_ = true;
  if (wake_ > 0) dds_set_guardcondition(wake_, true);
  if (thread_.joinable()) thread_.join();
  participant_.Reset();  // deletes every entity below it
}

bool MapServer::Open(std::string* why) {
  participant_ = DdsEntity(CreateParticipant(options_, why));
  if (!participant_.ok()) return false;
  const dds_entity_t pp = participant_.get();
  const DdsTopics t = TopicsFor(options_, instance_);
  const double block = options_.reply_block_s;
  auto writer = [&](const dds_topic_descriptor_t* d, const std::string& name, DdsQosKind k, dds_entity_t* w) {
    const dds_entity_t topic = CreateTopic(pp, d, name, why);
    if (topic < 0) return false;
    *w = CreateWriter(pp, topic, k, block, why);
    return *w > 0;
  };
  if (!writer(&rumi_dds_Status_desc, t.status, DdsQosKind::kState, &status_w_) ||
      !writer(&rumi_dds_PoseSample_desc, t.pose, DdsQosKind::kStream, &pose_w_) ||
      !writer(&rumi_dds_MapEvent_desc, t.events, DdsQosKind::kEvents, &events_w_) ||
      !writer(&rumi_dds_GridChunk_desc, t.prefix + "/grid", DdsQosKind::kState, &grid_w_) ||
      !writer(&rumi_dds_Reply_desc, t.reply, DdsQosKind::kRpc, &reply_w_))
    return false;
  if (options_.ros2_compat &&
      (!writer(&nav_msgs_msg_dds__OccupancyGrid__desc, t.ros_map, DdsQosKind::kState, &ros_map_w_) ||
       !writer(&nav_msgs_msg_dds__Path__desc, t.ros_path, DdsQosKind::kState, &ros_path_w_) ||
       !writer(&sensor_msgs_msg_dds__PointCloud2__desc, t.ros_points, DdsQosKind::kState, &ros_points_w_) ||
       !writer(&geometry_msgs_msg_dds__PoseStamped__desc, t.ros_pose, DdsQosKind::kStream, &ros_pose_w_)))
    return false;
  const dds_entity_t rt = CreateTopic(pp, &rumi_dds_Request_desc, t.request, why);
  if (rt < 0) return false;
  request_r_ = CreateReader(pp, rt, DdsQosKind::kRpc, why);
  if (request_r_ <= 0) return false;
  waitset_ = dds_create_waitset(pp);
  request_cond_ = dds_create_readcondition(request_r_, DDS_ANY_STATE);
  wake_ = dds_create_guardcondition(pp);
  if (waitset_ < 0 || request_cond_ < 0 || wake_ < 0 || dds_waitset_attach(waitset_, request_cond_, 0) < 0 ||
      dds_waitset_attach(waitset_, wake_, 1) < 0) {
    if (why) *why = "cannot create the DDS waitset";
    return false;
  }
  // Late joiners see a status before the first map.
  SnapshotStatus st;
  st.instance = instance_;
  st.state = "starting";
  st.stamp_ns = WallNowNs();
  const rumi_dds_Status d = ToDds(st);
  dds_write(status_w_, &d);
  spdlog::info("dds: serving instance {} on domain {} (interface '{}', topics {}/*{})", instance_, options_.domain_id,
               options_.interface, t.prefix, options_.ros2_compat ? ", ROS 2 topics on" : "");
  return true;
}

void MapServer::Publish(std::shared_ptr<const MapSnapshot> snapshot) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    status_ = snapshot->status;
    latest_ = std::move(snapshot);
    fresh_ = true;
  }
  dds_set_guardcondition(wake_, true);
}

void MapServer::PublishStatus(const SnapshotStatus& status) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    status_ = status;
    status_fresh_ = true;
  }
  dds_set_guardcondition(wake_, true);
}

void MapServer::PublishPose(const LivePose& in) {
  LivePose p = in;
  const bool posed = p.state == 1 || p.state == 2;
  std::shared_ptr<const MapSnapshot> snap;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    snap = latest_;
  }
  if (posed && !p.in_global && !p.submap.empty()) {
    // Into the global frame once the front submap is part of the main component.
    if (snap)
      for (const SnapshotSubmap& s : snap->submaps)
        if (s.key == p.submap && s.component == 0) {
          p.T_wc = s.S_gl.TransformPose(p.T_wc);
          p.in_global = true;
          break;
        }
  }
  rumi_dds_PoseSample d{};
  d.instance = C(instance_);
  d.version = kDdsProtocolVersion;
  d.stamp_ns = p.timestamp;
  d.state = p.state;
  d.submap = C(p.submap);
  d.in_global = p.in_global;
  PoseTo(p.T_wc, d.t, d.q);
  dds_write(pose_w_, &d);  // best effort: never blocks
  if (ros_pose_w_ > 0 && p.in_global) {
    geometry_msgs_msg_dds__PoseStamped_ r{};
    r.header_.stamp_ = RosTime(p.timestamp);
    // Only global poses (one in a submap's own frame would jump), in the
    // frame of the other ROS topics: the grid's when there is one.
    static const std::string map_frame = "map", rumi_frame = "rumi_map";
    const bool metric = snap && snap->grid.ok;
    r.header_.frame_id_ = C(metric ? map_frame : rumi_frame);
    r.pose_ = RosPose(metric ? snap->grid.S_gm.TransformPose(p.T_wc) : p.T_wc);
    dds_write(ros_pose_w_, &r);
  }
}

MapServerCounters MapServer::counters() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return counters_;
}

void MapServer::Loop() {
  while (!stop_) {
    dds_attach_t hits[2];
    dds_waitset_wait(waitset_, hits, 2, DDS_SECS(1));
    bool woken = false;
    dds_take_guardcondition(wake_, &woken);
    std::shared_ptr<const MapSnapshot> s;
    SnapshotStatus status;
    bool status_only = false;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (fresh_) s = latest_;
      status_only = status_fresh_ && !fresh_;
      if (status_only) status = status_;
      fresh_ = status_fresh_ = false;
    }
    if (status_only) {
      const rumi_dds_Status d = ToDds(status);
      dds_write(status_w_, &d);
    }
    if (s) {
      PublishState(*s);
      if (options_.ros2_compat) PublishRos(*s);
      std::lock_guard<std::mutex> lock(mutex_);
      ++counters_.snapshots;
    }
    // Requests, a few at a time so a flood cannot starve the state topics.
    for (int round = 0; round < 16 && !stop_; ++round) {
      void* samples[1] = {nullptr};
      dds_sample_info_t info[1];
      const dds_return_t n = dds_take(request_r_, samples, info, 1, 1);
      if (n <= 0) break;
      if (info[0].valid_data) Answer(*static_cast<const rumi_dds_Request*>(samples[0]));
      dds_return_loan(request_r_, samples, n);
    }
  }
}

void MapServer::PublishState(const MapSnapshot& s) {
  const rumi_dds_Status st = ToDds(s.status);
  dds_write(status_w_, &st);
  for (const SnapshotEvent& e : s.events) {
    rumi_dds_MapEvent d{};
    d.instance = C(instance_);
    d.version = kDdsProtocolVersion;
    d.seq = ++event_seq_;
    d.stamp_ns = s.status.stamp_ns;
    d.kind = C(e.kind);
    d.submap = C(e.submap);
    d.other = C(e.other);
    Sim3To(e.S, d.sim3);
    d.detail = C(e.detail);
    dds_write(events_w_, &d);
  }
  if (s.grid.ok && s.grid.cells.pixels.size() > kMaxStreamedGridBytes) {
    if (!big_grid_said_)
      spdlog::info("dds: the grid ({} cells) is above {} B: not streamed, answered to queries only",
                   s.grid.cells.pixels.size(), kMaxStreamedGridBytes);
    big_grid_said_ = true;
  } else if (s.grid.ok) {
    std::vector<uint8_t> cells = s.grid.cells.pixels;
    rumi_dds_GridChunk g{};
    g.resolution = s.grid.cells.resolution;
    for (int i = 0; i < 3; ++i) g.origin[i] = s.grid.cells.origin[i];
    g.width = s.grid.cells.width;
    g.height = s.grid.cells.height;
    g.offset = 0;
    View(&g.cells, cells);
    g.yaml = C(s.grid.yaml);
    const dds_return_t rc = dds_write(grid_w_, &g);
    if (rc < 0) spdlog::warn("dds: grid not published: {}", DdsError(rc));
  }
}

void MapServer::PublishRos(const MapSnapshot& s) {
  // With a grid the map frame is the grid's (metric, z up, frame "map");
  // without one, rumi's global frame ("rumi_map").
  const bool metric = s.grid.ok;
  const Sim3 S = metric ? s.grid.S_gm : Sim3();
  static const std::string map_frame = "map", rumi_frame = "rumi_map";
  std_msgs_msg_dds__Header_ h{};
  h.stamp_ = RosTime(s.status.stamp_ns);
  h.frame_id_ = C(metric ? map_frame : rumi_frame);
  if (metric && s.grid.cells.pixels.size() <= kMaxStreamedGridBytes) {
    const MapServerGrid& g = s.grid.cells;
    std::vector<int8_t> data(g.pixels.size());
    for (int row = 0; row < g.height; ++row)  // OccupancyGrid row 0 = bottom
      for (int col = 0; col < g.width; ++col) {
        const uint8_t v = g.pixels[static_cast<size_t>(g.height - 1 - row) * g.width + col];
        data[static_cast<size_t>(row) * g.width + col] = v == kPgmFree ? 0 : v == kPgmOccupied ? 100 : -1;
      }
    nav_msgs_msg_dds__OccupancyGrid_ m{};
    m.header_ = h;
    m.info_.map_load_time_ = h.stamp_;
    m.info_.resolution_ = static_cast<float>(g.resolution);
    m.info_.width_ = g.width;
    m.info_.height_ = g.height;
    const Eigen::Quaterniond yaw(Eigen::AngleAxisd(g.origin[2], Eigen::Vector3d::UnitZ()));
    m.info_.origin_ = RosPose(Se3(yaw, Eigen::Vector3d(g.origin[0], g.origin[1], 0)));
    View(&m.data_, data);
    dds_write(ros_map_w_, &m);
  }
  std::vector<geometry_msgs_msg_dds__PoseStamped_> poses;
  poses.reserve(s.trajectory.size());
  for (const SnapshotPose& p : s.trajectory) {
    geometry_msgs_msg_dds__PoseStamped_ q{};
    q.header_.stamp_ = RosTime(p.timestamp);
    q.header_.frame_id_ = h.frame_id_;
    q.pose_ = RosPose(S.TransformPose(p.T_wc));
    poses.push_back(q);
  }
  nav_msgs_msg_dds__Path_ path{};
  path.header_ = h;
  View(&path.poses_, poses);
  dds_write(ros_path_w_, &path);

  std::vector<uint8_t> bytes(s.points.size() * 12);
  for (size_t i = 0; i < s.points.size(); ++i) {
    const Eigen::Vector3f x = (S * s.points[i].cast<double>()).cast<float>();
    std::memcpy(&bytes[i * 12], x.data(), 12);  // little-endian hosts only (is_bigendian false)
  }
  static const std::string names[3] = {"x", "y", "z"};
  std::vector<sensor_msgs_msg_dds__PointField_> fields(3);
  for (int i = 0; i < 3; ++i) {
    fields[i].name_ = C(names[i]);
    fields[i].offset_ = 4 * i;
    fields[i].datatype_ = 7;  // FLOAT32
    fields[i].count_ = 1;
  }
  sensor_msgs_msg_dds__PointCloud2_ pc{};
  pc.header_ = h;
  pc.height_ = 1;
  pc.width_ = static_cast<uint32_t>(s.points.size());
  View(&pc.fields_, fields);
  pc.is_bigendian_ = false;
  pc.point_step_ = 12;
  pc.row_step_ = static_cast<uint32_t>(bytes.size());
  View(&pc.data_, bytes);
  pc.is_dense_ = true;
  dds_write(ros_points_w_, &pc);
}

void MapServer::Answer(const rumi_dds_Request& r) {
  std::shared_ptr<const MapSnapshot> snap;
  SnapshotStatus status;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    snap = latest_;
    status = status_;
    ++counters_.requests;
  }
  const ReplyPlan plan = PlanReply(r, snap.get(), options_);
  if (plan.code != rumi_dds_CODE_OK) {
    spdlog::info("dds: request {} of client {:x} refused: {}", r.request_id, r.client_id, plan.error);
    std::lock_guard<std::mutex> lock(mutex_);
    ++counters_.bad_requests;
  }
  if (status.instance.empty()) {
    status.instance = instance_;
    status.state = "starting";
  }
  for (size_t k = 0; k < plan.chunks(); ++k) {
    const size_t b = plan.bounds[k], e = plan.bounds[k + 1];
    rumi_dds_Reply d{};
    d.client_id = r.client_id;
    d.request_id = r.request_id;
    d.version = kDdsProtocolVersion;
    d.kind = r.kind;
    d.code = plan.code;
    d.error = C(plan.error);
    d.chunk = static_cast<uint32_t>(k);
    d.chunks = static_cast<uint32_t>(plan.chunks());
    d.total = plan.total;
    d.page = plan.page;
    d.pages = plan.pages;
    d.map_seq = snap ? snap->seq : -1;
    std::vector<rumi_dds_Status> statuses;
    if (plan.status) statuses.push_back(ToDds(status));
    View(&d.status, statuses);
    // Points go out straight from the plan: the same 3 packed floats.
    static_assert(sizeof(rumi_dds_MapPoint) == sizeof(Eigen::Vector3f), "MapPoint is 3 packed floats");
    if (!plan.points.empty()) {
      d.points._maximum = d.points._length = static_cast<uint32_t>(e - b);
      d.points._buffer = reinterpret_cast<rumi_dds_MapPoint*>(const_cast<Eigen::Vector3f*>(plan.points.data() + b));
      d.points._release = false;
    }
    std::vector<rumi_dds_Keyframe> kfs;
    for (size_t i = b; i < e && i < plan.keyframes.size(); ++i) {
      const SnapshotKeyframe& k = *plan.keyframes[i];
      rumi_dds_Keyframe x{};
      x.id = k.id;
      x.stamp_ns = k.timestamp;
      x.submap = C(k.submap);
      x.component = k.component;
      PoseTo(k.T_wc, x.t, x.q);
      kfs.push_back(x);
    }
    View(&d.keyframes, kfs);
    std::vector<rumi_dds_TrajectoryPose> poses;
    for (size_t i = b; i < e && i < plan.poses.size(); ++i) {
      rumi_dds_TrajectoryPose x{};
      x.stamp_ns = plan.poses[i]->timestamp;
      x.from_back = plan.poses[i]->from_back;
      PoseTo(plan.poses[i]->T_wc, x.t, x.q);
      poses.push_back(x);
    }
    View(&d.poses, poses);
    std::vector<rumi_dds_SubmapSummary> submaps;
    for (size_t i = b; i < e && i < plan.submaps.size(); ++i) {
      const SnapshotSubmap& s = *plan.submaps[i];
      rumi_dds_SubmapSummary x{};
      x.key = C(s.key);
      x.component = s.component;
      x.keyframes = s.keyframes;
      x.points = s.points;
      x.first_ns = s.first;
      x.last_ns = s.last;
      Sim3To(s.S_gl, x.sim3);
      submaps.push_back(x);
    }
    View(&d.submaps, submaps);
    std::vector<rumi_dds_GridChunk> grid;
    if (plan.grid) {
      const SnapshotGrid& g = snap->grid;
      rumi_dds_GridChunk x{};
      x.resolution = g.cells.resolution;
      for (int i = 0; i < 3; ++i) x.origin[i] = g.cells.origin[i];
      x.width = g.cells.width;
      x.height = g.cells.height;
      x.offset = b;
      x.cells._maximum = x.cells._length = static_cast<uint32_t>(e - b);
      x.cells._buffer = const_cast<uint8_t*>(g.cells.pixels.data() + b);
      x.cells._release = false;
      x.yaml = C(g.yaml);
      grid.push_back(x);
    }
    View(&d.grid, grid);
    const dds_return_t rc = dds_write(reply_w_, &d);
    std::lock_guard<std::mutex> lock(mutex_);
    if (rc < 0) {
      ++counters_.write_failures;
      spdlog::warn("dds: reply {} of client {:x} abandoned at chunk {}/{}: {}", r.request_id, r.client_id, k,
                   plan.chunks(), DdsError(rc));
      return;
    }
    ++counters_.chunks;
  }
  std::lock_guard<std::mutex> lock(mutex_);
  ++counters_.replies;
}

}  // namespace rumi
