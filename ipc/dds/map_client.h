#pragma once
// The client side of rumi's DDS map service: `rumi query` and tests use it.
// Connect finds the server of one instance (its request reader and reply
// writer matched); Call sends a request, resends it while nothing comes
// back (discovery may still be settling on the server side), and
// reassembles the reply's chunks in order.
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "ipc/dds/dds_entity.h"
#include "ipc/dds/dds_options.h"
#include "ipc/dds/map_server.h"
#include "ipc/dds/map_snapshot.h"
#include "rumi_map.h"

namespace rumi {

struct MapReply {
  int32_t code = -1;
  std::string error;
  int64_t total = 0, page = 0, pages = 0, map_seq = -1;
  SnapshotStatus status;
  std::vector<Eigen::Vector3f> points;
  std::vector<SnapshotKeyframe> keyframes;
  std::vector<SnapshotPose> poses;
  std::vector<SnapshotSubmap> submaps;
  SnapshotGrid grid;  // cells and yaml; S_gm is not sent (it is in the yaml)
};

class MapClient {
 public:
  // nullptr with *why ("no rumi server for instance 'x' on domain 0 within
  // 5 s") when none answers in time.
  static std::unique_ptr<MapClient> Connect(const DdsOptions& o, const std::string& instance, double timeout_s,
                                            std::string* why);
  ~MapClient();

  // A request with version, client and request ids filled in. False with
  // *why on a time out; a server error is a true return with reply->code != 0.
  bool Call(rumi_dds_Request request, double timeout_s, MapReply* reply, std::string* why);
  // Sends r as it is (tests of malformed requests): no id or version filled.
  bool CallRaw(const rumi_dds_Request& request, double timeout_s, MapReply* reply, std::string* why);

  // The last status the server published (transient-local), within timeout.
  bool LatestStatus(double timeout_s, SnapshotStatus* status, std::string* why);
  // Calls f for each pose sample until f returns false (true), or until no
  // pose came for timeout_s (false).
  bool FollowPose(double timeout_s, const std::function<bool(const LivePose&)>& f);
  // The map's events (received, merged, rejected, loop, culled, saved) come
  // since the last call, without waiting; a client that connects late gets
  // the server's last 64 (transient-local).
  std::vector<SnapshotEvent> TakeEvents();

  uint64_t client_id() const { return client_id_; }

 private:
  MapClient(const DdsOptions& o, std::string instance);
  bool Open(std::string* why);
  bool WaitMatched(double timeout_s);

  DdsOptions options_;
  std::string instance_;
  DdsEntity participant_;
  dds_entity_t request_w_ = 0, reply_r_ = 0, status_r_ = 0, pose_r_ = 0, events_r_ = 0;
  dds_entity_t reply_ws_ = 0;  // wakes Call when a reply sample is there
  uint64_t client_id_ = 0;
  uint64_t next_request_ = 1;
};

// One line per request kind for errors: "no rumi server for instance 'x' on
// domain 0 (topics rumi/x/*) within 5 s".
std::string NoServerMessage(const DdsOptions& o, const std::string& instance, double timeout_s);

}  // namespace rumi
