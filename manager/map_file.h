#pragma once
// The global map file: atomic save (write a new file, fsync, rename, fsync
// the folder) and checked reload. A truncated, corrupt or foreign file is
// refused with a clear error and the caller's map is left as it was.
//
// Layout (little-endian):
//   "RUMIGMAP" | u32 version | u32 0 | u64 n + serializer name | u64 body size
//   | u64 Checksum64(body) | body
//   body: u64 submaps, each { Sim3 (s, qx qy qz qw, tx ty tz as f64) | i64
//   union-find parent | u64 size + submap record from the serializer },
//   u64 fused, each { i32 dup, i32 kept, i64 dup point, i64 kept point },
//   and from version 2 the loop memory (GlobalMap::loops()):
//   u64 raw poses, each { key | i64 keyframe | Se3 (qx qy qz qw, tx ty tz) },
//   u64 solved poses, each { key | i64 keyframe | Sim3 },
//   u64 searched keyframes, each { key | i64 keyframe | u64 n, each
//   { key | i64 keyframe | i64 time (query), key | i64 keyframe | i64 time
//   (match) | Sim3 S_mq | Sim3 S_qm | i32 matches | i32 inliers | f64 score } };
//   key = { u8 source | i64 id }. Version 1 files (no loop memory) load.
// Every count and length is checked against the bytes that remain.
#include <cstdint>
#include <string>
#include <vector>

#include "manager/global_map.h"

namespace rumi {

constexpr uint32_t kGlobalMapFileVersion = 2;

// Pluggable submap record format. The name is stored in the file; a file
// written with another serializer is refused.
class SubmapSerializer {
 public:
  virtual ~SubmapSerializer() = default;
  virtual std::string Name() const = 0;
  virtual std::vector<uint8_t> Encode(const Submap& s) const = 0;
  virtual bool Decode(const uint8_t* data, size_t size, Submap* s, std::string* why) const = 0;
};

// The shared binary submap codec of ipc/ (same records as on the channels).
const SubmapSerializer& DefaultSubmapSerializer();

bool SaveGlobalMap(const GlobalMap& map, const std::string& path, std::string* why,
                   const SubmapSerializer& serializer = DefaultSubmapSerializer());

// The same file holding `submaps` as they are: each its own component with an
// identity Sim(3), no fused points (the manager's raw submaps, saved without
// first copying them into a GlobalMap).
bool SaveSubmaps(const std::vector<const Submap*>& submaps, const std::string& path, std::string* why,
                 const SubmapSerializer& serializer = DefaultSubmapSerializer());

// On failure returns false with *why naming the file and the problem; *map is
// untouched.
bool LoadGlobalMap(const std::string& path, GlobalMap* map, std::string* why,
                   const SubmapSerializer& serializer = DefaultSubmapSerializer());

// The raw submaps of a manager: those still kept raw (the raw file, e.g.
// map.rumi.raw) and those baked into the base since, each saved as it was
// received in RawBakedDir(raw file) (map.rumi.raw.baked/front_0.rumi, ...)
// when it was baked. Whoever needs a submap as received (the merge audit)
// finds it whatever was baked. A missing raw file or folder holds nothing;
// a file that does not load fails the whole call (*why names it).
std::string RawBakedDir(const std::string& raw_path);
std::string RawBakedPath(const std::string& raw_path, const SubmapKey& key);
bool LoadRawSubmaps(const std::string& raw_path, GlobalMap* map, std::string* why,
                    const SubmapSerializer& serializer = DefaultSubmapSerializer());

}  // namespace rumi
