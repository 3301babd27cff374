#pragma once
// Answers one request from a snapshot, without DDS: validation (a malformed
// request gets an error naming the problem), filtering, paging, and the
// split of the answer into chunks below the configured sample size. The
// server (map_server.h) only turns a ReplyPlan into samples.
#include <cstdint>
#include <string>
#include <vector>

#include "ipc/dds/dds_options.h"
#include "ipc/dds/map_snapshot.h"

#include "rumi_map.h"  // idlc, from rumi_map.idl

namespace rumi {

constexpr uint32_t kDdsProtocolVersion = 2;  // 2: Status.link

// "" when r can be answered, else the problem ("page_size -3 is negative").
std::string RequestProblem(const rumi_dds_Request& r, const DdsOptions& o);

struct ReplyPlan {
  int32_t code = rumi_dds_CODE_OK;
  std::string error;
  int64_t total = 0, page = 0, pages = 0;
  // The items, one kind filled; chunk k holds [bounds[k], bounds[k + 1]).
  std::vector<Eigen::Vector3f> points;
  std::vector<const SnapshotKeyframe*> keyframes;
  std::vector<const SnapshotPose*> poses;
  std::vector<const SnapshotSubmap*> submaps;
  bool status = false;
  bool grid = false;  // grid bytes are chunked by offset
  std::vector<size_t> bounds = {0, 0};
  size_t chunks() const { return bounds.size() - 1; }
};

// snapshot may be null (nothing built yet): status still answers.
ReplyPlan PlanReply(const rumi_dds_Request& r, const MapSnapshot* snapshot, const DdsOptions& o);

}  // namespace rumi
