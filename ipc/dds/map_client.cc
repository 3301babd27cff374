#include "ipc/dds/map_client.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <set>
#include <random>
#include <thread>

#include "ipc/dds/request_handler.h"

namespace rumi {
namespace {

using Clock = std::chrono::steady_clock;
double Since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

Se3 PoseFrom(const double* t, const double* q) {
  return Se3(Eigen::Quaterniond(q[3], q[0], q[1], q[2]), Eigen::Vector3d(t[0], t[1], t[2]));
}
Sim3 Sim3From(const double* v) {
  return Sim3(v[0], Eigen::Quaterniond(v[4], v[1], v[2], v[3]), Eigen::Vector3d(v[5], v[6], v[7]));
}
std::string Str(const char* s) { return s ? s : ""; }

SnapshotStatus FromDds(const rumi_dds_Status& d) {
  SnapshotStatus s;
  CopyStatusFields(d, &s, Str);
  return s;
}

// Adds one chunk's items to the reply (chunks arrive in order per writer,
// but a resent request may bring a chunk twice: the caller drops those).
void Append(const rumi_dds_Reply& d, MapReply* r) {
  r->code = d.code;
  r->error = Str(d.error);
  r->total = d.total;
  r->page = d.page;
  r->pages = d.pages;
  r->map_seq = d.map_seq;
  if (d.status._length > 0) r->status = FromDds(d.status._buffer[0]);
  if (d.points._length > 0) {
    static_assert(sizeof(rumi_dds_MapPoint) == sizeof(Eigen::Vector3f), "MapPoint is 3 packed floats");
    if (r->points.empty()) r->points.reserve(static_cast<size_t>(std::max<int64_t>(d.total, 0)));
    const size_t at = r->points.size();
    r->points.resize(at + d.points._length);
    std::memcpy(r->points[at].data(), d.points._buffer, d.points._length * sizeof(Eigen::Vector3f));
  }
  for (uint32_t i = 0; i < d.keyframes._length; ++i) {
    const rumi_dds_Keyframe& k = d.keyframes._buffer[i];
    r->keyframes.push_back({k.id, k.stamp_ns, Str(k.submap), k.component, PoseFrom(k.t, k.q)});
  }
  for (uint32_t i = 0; i < d.poses._length; ++i) {
    const rumi_dds_TrajectoryPose& p = d.poses._buffer[i];
    r->poses.push_back({p.stamp_ns, p.from_back, PoseFrom(p.t, p.q)});
  }
  for (uint32_t i = 0; i < d.submaps._length; ++i) {
    const rumi_dds_SubmapSummary& s = d.submaps._buffer[i];
    r->submaps.push_back({Str(s.key), s.component, s.keyframes, s.points, s.first_ns, s.last_ns, Sim3From(s.sim3)});
  }
  for (uint32_t i = 0; i < d.grid._length; ++i) {
    const rumi_dds_GridChunk& g = d.grid._buffer[i];
    MapServerGrid& c = r->grid.cells;
    c.resolution = g.resolution;
    c.origin = Eigen::Vector3d(g.origin[0], g.origin[1], g.origin[2]);
    c.width = static_cast<int>(g.width);
    c.height = static_cast<int>(g.height);
    c.pixels.resize(static_cast<size_t>(g.width) * g.height, kPgmUnknown);
    if (g.offset + g.cells._length <= c.pixels.size())
      std::copy(g.cells._buffer, g.cells._buffer + g.cells._length, c.pixels.begin() + g.offset);
    r->grid.yaml = Str(g.yaml);
    r->grid.ok = true;
  }
}

}  // namespace

std::string NoServerMessage(const DdsOptions& o, const std::string& instance, double timeout_s) {
  return fmt::format("no rumi server for instance '{}' on DDS domain {} (interface '{}', topics {}/*) within {} s",
                     instance, o.domain_id, o.interface, TopicsFor(o, instance).prefix, timeout_s);
}

MapClient::MapClient(const DdsOptions& o, std::string instance) : options_(o), instance_(std::move(instance)) {
  std::random_device rd;
  client_id_ = (static_cast<uint64_t>(rd()) << 32) ^ rd() ^
               static_cast<uint64_t>(Clock::now().time_since_epoch().count());
}

MapClient::~MapClient() { participant_.Reset(); }

std::unique_ptr<MapClient> MapClient::Connect(const DdsOptions& o, const std::string& instance, double timeout_s,
                                              std::string* why) {
  std::unique_ptr<MapClient> c(new MapClient(o, instance));
  if (!c->Open(why)) return nullptr;
  if (!c->WaitMatched(timeout_s)) {
    if (why) *why = NoServerMessage(o, instance, timeout_s);
    return nullptr;
  }
  return c;
}

bool MapClient::Open(std::string* why) {
  participant_ = DdsEntity(CreateParticipant(options_, why));
  if (!participant_.ok()) return false;
  const dds_entity_t pp = participant_.get();
  const DdsTopics t = TopicsFor(options_, instance_);
  const dds_entity_t req = CreateTopic(pp, &rumi_dds_Request_desc, t.request, why);
  const dds_entity_t rep = CreateTopic(pp, &rumi_dds_Reply_desc, t.reply, why);
  const dds_entity_t st = CreateTopic(pp, &rumi_dds_Status_desc, t.status, why);
  const dds_entity_t po = CreateTopic(pp, &rumi_dds_PoseSample_desc, t.pose, why);
  const dds_entity_t ev = CreateTopic(pp, &rumi_dds_MapEvent_desc, t.events, why);
  if (req < 0 || rep < 0 || st < 0 || po < 0 || ev < 0) return false;
  request_w_ = CreateWriter(pp, req, DdsQosKind::kRpc, 1.0, why);
  reply_r_ = CreateReader(pp, rep, DdsQosKind::kRpc, why);
  status_r_ = CreateReader(pp, st, DdsQosKind::kState, why);
  pose_r_ = CreateReader(pp, po, DdsQosKind::kStream, why);
  events_r_ = CreateReader(pp, ev, DdsQosKind::kEvents, why);
  if (request_w_ <= 0 || reply_r_ <= 0 || status_r_ <= 0 || pose_r_ <= 0 || events_r_ <= 0) return false;
  reply_ws_ = dds_create_waitset(pp);
  const dds_entity_t cond = dds_create_readcondition(reply_r_, DDS_ANY_STATE);
  if (reply_ws_ < 0 || cond < 0 || dds_waitset_attach(reply_ws_, cond, 0) < 0) {
    if (why) *why = "cannot create the DDS waitset";
    return false;
  }
  return true;
}

bool MapClient::WaitMatched(double timeout_s) {
  const auto start = Clock::now();
  for (;;) {
    dds_publication_matched_status_t pub{};
    dds_subscription_matched_status_t sub{};
    dds_get_publication_matched_status(request_w_, &pub);
    dds_get_subscription_matched_status(reply_r_, &sub);
    if (pub.current_count > 0 && sub.current_count > 0) return true;
    if (Since(start) >= timeout_s) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
}

bool MapClient::Call(rumi_dds_Request request, double timeout_s, MapReply* reply, std::string* why) {
  request.version = kDdsProtocolVersion;
  request.client_id = client_id_;
  request.request_id = next_request_++;
  return CallRaw(request, timeout_s, reply, why);
}

bool MapClient::CallRaw(const rumi_dds_Request& request, double timeout_s, MapReply* reply, std::string* why) {
  *reply = MapReply();
  const auto start = Clock::now();
  auto last_send = start - std::chrono::hours(1);
  std::set<uint32_t> got;  // chunk indices seen
  uint32_t chunks = 0;
  bool any = false;
  for (;;) {
    // Resend while nothing came back: the server may not have matched our
    // reader yet when the first one arrived. Chunks seen twice are dropped.
    if (!any && Since(last_send) >= 1.0) {
      const dds_return_t rc = dds_write(request_w_, &request);
      if (rc < 0) {
        if (why) *why = "cannot send the request: " + DdsError(rc);
        return false;
      }
      last_send = Clock::now();
    }
    void* samples[1] = {nullptr};
    dds_sample_info_t info[1];
    const dds_return_t n = dds_take(reply_r_, samples, info, 1, 1);
    if (n > 0) {
      const auto& d = *static_cast<const rumi_dds_Reply*>(samples[0]);
      if (info[0].valid_data && d.client_id == request.client_id && d.request_id == request.request_id &&
          !got.count(d.chunk)) {
        if (got.empty()) chunks = d.chunks;
        any = true;
        got.insert(d.chunk);
        if (d.chunk != got.size() - 1) {  // a chunk was skipped: the writer gave up on it
          dds_return_loan(reply_r_, samples, n);
          if (why) *why = fmt::format("reply chunk {} arrived before chunk {}", d.chunk, got.size() - 1);
          return false;
        }
        Append(d, reply);
      }
      dds_return_loan(reply_r_, samples, n);
      if (any && got.size() >= chunks) return true;
      continue;
    }
    const double left = timeout_s - Since(start);
    if (left <= 0) {
      if (why)
        *why = any ? fmt::format("reply incomplete after {} s ({} of {} chunks)", timeout_s, got.size(), chunks)
                   : NoServerMessage(options_, instance_, timeout_s);
      return false;
    }
    // Until a sample is there, the next resend, or the time out.
    const double wait = any ? left : std::min(left, std::max(0.0, 1.0 - Since(last_send)));
    dds_waitset_wait(reply_ws_, nullptr, 0, static_cast<dds_duration_t>(wait * 1e9) + 1);
  }
}

bool MapClient::LatestStatus(double timeout_s, SnapshotStatus* status, std::string* why) {
  const auto start = Clock::now();
  for (;;) {
    void* samples[1] = {nullptr};
    dds_sample_info_t info[1];
    const dds_return_t n = dds_read(status_r_, samples, info, 1, 1);
    if (n > 0 && info[0].valid_data) {
      *status = FromDds(*static_cast<const rumi_dds_Status*>(samples[0]));
      dds_return_loan(status_r_, samples, n);
      return true;
    }
    if (n > 0) dds_return_loan(status_r_, samples, n);
    if (Since(start) >= timeout_s) {
      if (why) *why = NoServerMessage(options_, instance_, timeout_s);
      return false;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
}

bool MapClient::FollowPose(double timeout_s, const std::function<bool(const LivePose&)>& f) {
  auto last = Clock::now();
  for (;;) {
    void* samples[1] = {nullptr};
    dds_sample_info_t info[1];
    const dds_return_t n = dds_take(pose_r_, samples, info, 1, 1);
    if (n > 0) {
      bool more = true;
      if (info[0].valid_data) {
        const auto& d = *static_cast<const rumi_dds_PoseSample*>(samples[0]);
        LivePose p{d.stamp_ns, d.state, Str(d.submap), d.in_global, PoseFrom(d.t, d.q)};
        last = Clock::now();
        more = f(p);
      }
      dds_return_loan(pose_r_, samples, n);
      if (!more) return true;
      continue;
    }
    if (Since(last) >= timeout_s) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
}

std::vector<SnapshotEvent> MapClient::TakeEvents() {
  std::vector<SnapshotEvent> out;
  for (;;) {
    void* samples[16] = {nullptr};
    dds_sample_info_t info[16];
    const dds_return_t n = dds_take(events_r_, samples, info, 16, 16);
    if (n <= 0) return out;
    for (dds_return_t i = 0; i < n; ++i) {
      if (!info[i].valid_data) continue;
      const auto& d = *static_cast<const rumi_dds_MapEvent*>(samples[i]);
      out.push_back({Str(d.kind), Str(d.submap), Str(d.other), Sim3From(d.sim3), Str(d.detail)});
    }
    dds_return_loan(events_r_, samples, n);
  }
}

}  // namespace rumi
