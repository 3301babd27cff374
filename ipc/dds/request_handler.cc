#include "ipc/dds/request_handler.h"

#include <algorithm>
#include <cmath>
#include <fmt/format.h>

namespace rumi {
namespace {

// Conservative serialised sizes (CDR with alignment), so a chunk stays below
// chunk_bytes; 4 KiB is left for the reply's own fields.
constexpr size_t kReplyOverhead = 4096;
constexpr size_t kPointBytes = 12, kPoseBytes = 80, kKeyframeBytes = 96, kSubmapBytes = 128;

const char* KindName(int32_t kind) {
  switch (kind) {
    case rumi_dds_KIND_STATUS: return "status";
    case rumi_dds_KIND_POINTS: return "points";
    case rumi_dds_KIND_KEYFRAMES: return "keyframes";
    case rumi_dds_KIND_TRAJECTORY: return "trajectory";
    case rumi_dds_KIND_SUBMAP: return "submap";
    case rumi_dds_KIND_GRID: return "grid";
    default: return nullptr;
  }
}

bool AllZero(const double* v) { return v[0] == 0 && v[1] == 0 && v[2] == 0; }

// Chunk bounds over n items of `bytes` each (plus `extra(i)` per item).
template <typename Extra>
std::vector<size_t> ChunkBounds(size_t n, size_t bytes, const DdsOptions& o, Extra extra) {
  const size_t budget = static_cast<size_t>(o.chunk_bytes) - kReplyOverhead;
  std::vector<size_t> b = {0};
  size_t used = 0;
  for (size_t i = 0; i < n; ++i) {
    const size_t s = bytes + extra(i);
    if (used > 0 && used + s > budget) {
      b.push_back(i);
      used = 0;
    }
    used += s;
  }
  b.push_back(n);
  return b;
}
std::vector<size_t> ChunkBounds(size_t n, size_t bytes, const DdsOptions& o) {
  return ChunkBounds(n, bytes, o, [](size_t) { return size_t{0}; });
}

ReplyPlan Error(int32_t code, std::string why) {
  ReplyPlan p;
  p.code = code;
  p.error = std::move(why);
  return p;
}

}  // namespace

std::string RequestProblem(const rumi_dds_Request& r, const DdsOptions& o) {
  if (r.version != kDdsProtocolVersion)
    return fmt::format("protocol version {} is not the server's {}", r.version, kDdsProtocolVersion);
  if (!KindName(r.kind)) return fmt::format("request kind {} is unknown", r.kind);
  if (r.kind == rumi_dds_KIND_POINTS) {
    for (int i = 0; i < 3; ++i)
      if (!std::isfinite(r.box_min[i]) || !std::isfinite(r.box_max[i])) return "the box holds a NaN or infinity";
    for (int i = 0; i < 3; ++i)
      if (r.box_min[i] > r.box_max[i])
        return fmt::format("box_min[{}] = {} is above box_max[{}] = {}", i, r.box_min[i], i, r.box_max[i]);
    if (r.page < 0) return fmt::format("page {} is negative", r.page);
    if (r.page_size < 0) return fmt::format("page_size {} is negative", r.page_size);
    if (r.page_size > o.max_page_points)
      return fmt::format("page_size {} is above the server's cap {}", r.page_size, o.max_page_points);
  }
  if (r.kind == rumi_dds_KIND_TRAJECTORY) {
    if (r.from_ns < 0 || r.to_ns < 0) return "a negative time bound";
    if (r.to_ns != 0 && r.from_ns > r.to_ns) return fmt::format("from_ns {} is after to_ns {}", r.from_ns, r.to_ns);
  }
  if (r.submap && std::string(r.submap).size() > 64) return "the submap key is longer than 64 characters";
  return "";
}

ReplyPlan PlanReply(const rumi_dds_Request& r, const MapSnapshot* snap, const DdsOptions& o) {
  const std::string problem = RequestProblem(r, o);
  if (!problem.empty())
    return Error(r.version != kDdsProtocolVersion ? rumi_dds_CODE_BAD_VERSION : rumi_dds_CODE_BAD_REQUEST, problem);
  ReplyPlan p;
  if (r.kind == rumi_dds_KIND_STATUS) {
    p.status = true;
    p.total = 1;
    return p;
  }
  if (!snap) return Error(rumi_dds_CODE_UNAVAILABLE, "no map yet (the manager has not built one)");
  switch (r.kind) {
    case rumi_dds_KIND_POINTS: {
      const bool all = AllZero(r.box_min) && AllZero(r.box_max);
      const Eigen::Vector3d lo(r.box_min[0], r.box_min[1], r.box_min[2]);
      const Eigen::Vector3d hi(r.box_max[0], r.box_max[1], r.box_max[2]);
      const int64_t size = r.page_size == 0 ? o.max_page_points : r.page_size;
      const int64_t skip = r.page * size;
      if (all) {  // the common case: a slice, no test per point
        p.total = static_cast<int64_t>(snap->points.size());
        const int64_t b = std::min(skip, p.total), e = std::min(skip + size, p.total);
        p.points.assign(snap->points.begin() + b, snap->points.begin() + e);
      } else {
        for (const Eigen::Vector3f& x : snap->points) {
          const Eigen::Vector3d d = x.cast<double>();
          if ((d.array() < lo.array()).any() || (d.array() > hi.array()).any()) continue;
          if (p.total >= skip && p.total < skip + size) p.points.push_back(x);
          ++p.total;
        }
      }
      p.page = r.page;
      p.pages = (p.total + size - 1) / size;
      if (r.page > 0 && r.page >= p.pages)
        return Error(rumi_dds_CODE_NOT_FOUND, fmt::format("page {} is past the last page {}", r.page, p.pages - 1));
      p.bounds = ChunkBounds(p.points.size(), kPointBytes, o);
      return p;
    }
    case rumi_dds_KIND_KEYFRAMES:
      for (const SnapshotKeyframe& k : snap->keyframes) p.keyframes.push_back(&k);
      p.total = static_cast<int64_t>(p.keyframes.size());
      p.bounds = ChunkBounds(p.keyframes.size(), kKeyframeBytes, o,
                             [&](size_t i) { return p.keyframes[i]->submap.size(); });
      return p;
    case rumi_dds_KIND_TRAJECTORY:
      for (const SnapshotPose& q : snap->trajectory) {
        if (r.from_ns != 0 && q.timestamp < r.from_ns) continue;
        if (r.to_ns != 0 && q.timestamp > r.to_ns) continue;
        p.poses.push_back(&q);
      }
      p.total = static_cast<int64_t>(p.poses.size());
      p.bounds = ChunkBounds(p.poses.size(), kPoseBytes, o);
      return p;
    case rumi_dds_KIND_SUBMAP: {
      const std::string key = r.submap ? r.submap : "";
      for (const SnapshotSubmap& s : snap->submaps)
        if (key.empty() || s.key == key) p.submaps.push_back(&s);
      if (!key.empty() && p.submaps.empty())
        return Error(rumi_dds_CODE_NOT_FOUND, "no submap '" + key + "' in the map (keys look like front#3, back#0)");
      p.total = static_cast<int64_t>(p.submaps.size());
      p.bounds = ChunkBounds(p.submaps.size(), kSubmapBytes, o, [&](size_t i) { return p.submaps[i]->key.size(); });
      return p;
    }
    case rumi_dds_KIND_GRID: {
      if (!snap->grid.ok) return Error(rumi_dds_CODE_UNAVAILABLE, "no grid: " + snap->status.grid);
      p.grid = true;
      const size_t n = snap->grid.cells.pixels.size();
      p.total = static_cast<int64_t>(n);
      // The YAML rides on every chunk.
      const size_t room = kReplyOverhead + snap->grid.yaml.size();
      if (room * 2 > static_cast<size_t>(o.chunk_bytes))
        return Error(rumi_dds_CODE_UNAVAILABLE, "the grid's YAML does not fit in one chunk");
      const size_t per = static_cast<size_t>(o.chunk_bytes) - room;
      p.bounds = {0};
      for (size_t b = per; b < n; b += per) p.bounds.push_back(b);
      p.bounds.push_back(n);
      return p;
    }
  }
  return Error(rumi_dds_CODE_BAD_REQUEST, "unreachable");
}

}  // namespace rumi
