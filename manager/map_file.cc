#include "manager/map_file.h"

#include <cerrno>
#include <cmath>
#include <cstring>
#include <algorithm>
#include <filesystem>

#include "common/atomic_file.h"
#include "ipc/byte_io.h"
#include "ipc/submap_codec.h"

namespace rumi {
namespace {

constexpr char kMagic[8] = {'R', 'U', 'M', 'I', 'G', 'M', 'A', 'P'};

class IpcSubmapSerializer : public SubmapSerializer {
 public:
  std::string Name() const override { return "rumi-submap-v" + std::to_string(kSubmapFormatVersion); }
  std::vector<uint8_t> Encode(const Submap& s) const override { return EncodeSubmap(s); }
  bool Decode(const uint8_t* data, size_t size, Submap* s, std::string* why) const override {
    return DecodeSubmap(data, size, s, why);
  }
};

class Bytes {
 public:
  template <typename T>
  void Put(const T& v) {
    const auto* p = reinterpret_cast<const uint8_t*>(&v);
    b_.insert(b_.end(), p, p + sizeof(T));
  }
  void PutBytes(const void* p, size_t n) {
    const auto* c = static_cast<const uint8_t*>(p);
    b_.insert(b_.end(), c, c + n);
  }
  std::vector<uint8_t>& data() { return b_; }

 private:
  std::vector<uint8_t> b_;
};

void PutSim3(Bytes* b, const Sim3& S) {
  const double v[8] = {S.scale(),        S.rotation().x(),    S.rotation().y(),    S.rotation().z(),
                       S.rotation().w(), S.translation().x(), S.translation().y(), S.translation().z()};
  b->PutBytes(v, sizeof(v));
}

void PutKey(Bytes* b, const SubmapKey& k) {
  b->Put<uint8_t>(uint8_t(k.source));
  b->Put<int64_t>(k.id);
}

void PutLoops(Bytes* b, const LoopMemory& m) {
  b->Put<uint64_t>(m.raw_pose.size());
  for (const auto& [key, T] : m.raw_pose) {
    PutKey(b, key.first);
    b->Put<int64_t>(key.second);
    const double v[7] = {T.rotation().x(),    T.rotation().y(),    T.rotation().z(),   T.rotation().w(),
                         T.translation().x(), T.translation().y(), T.translation().z()};
    b->PutBytes(v, sizeof(v));
  }
  b->Put<uint64_t>(m.solved.size());
  for (const auto& [key, S] : m.solved) {
    PutKey(b, key.first);
    b->Put<int64_t>(key.second);
    PutSim3(b, S);
  }
  b->Put<uint64_t>(m.searched.size());
  for (const auto& [key, list] : m.searched) {
    PutKey(b, key.first);
    b->Put<int64_t>(key.second);
    b->Put<uint64_t>(list.size());
    for (const LoopDetection& d : list) {
      PutKey(b, d.query_submap);
      b->Put<int64_t>(d.query_keyframe);
      b->Put<int64_t>(d.query_time);
      PutKey(b, d.match_submap);
      b->Put<int64_t>(d.match_keyframe);
      b->Put<int64_t>(d.match_time);
      PutSim3(b, d.S_mq);
      PutSim3(b, d.S_qm);
      b->Put<int32_t>(d.matches);
      b->Put<int32_t>(d.inliers);
      b->Put<double>(d.score);
    }
  }
}

}  // namespace

const SubmapSerializer& DefaultSubmapSerializer() {
  static const IpcSubmapSerializer s;
  return s;
}

namespace {

// The file is written as it is built, a submap at a time: the header with
// placeholders, then the body, then the body's size and checksum patched in
// (the checksum read back from the written file). A long session's map is
// hundreds of MB; building it whole in memory took up to 3x that while it
// grew. Entry i: its submap, Sim(3) and union-find parent.
template <typename SubmapAt, typename Sim3At, typename ParentAt>
bool SaveEntries(size_t n, const SubmapAt& submap, const Sim3At& sim3, const ParentAt& parent,
                 const std::vector<FusedPoint>& fused, const LoopMemory& loops, const std::string& path,
                 std::string* why, const SubmapSerializer& serializer) {
  AtomicFileWriter out(path);
  Bytes chunk;
  const auto flush = [&] {
    out.Append(chunk.data().data(), chunk.data().size());
    chunk.data().clear();
  };
  chunk.PutBytes(kMagic, sizeof(kMagic));
  chunk.Put<uint32_t>(kGlobalMapFileVersion);
  chunk.Put<uint32_t>(0);
  const std::string name = serializer.Name();
  chunk.Put<uint64_t>(name.size());
  chunk.PutBytes(name.data(), name.size());
  const uint64_t size_at = chunk.data().size();
  chunk.Put<uint64_t>(0);  // body size
  chunk.Put<uint64_t>(0);  // body checksum
  const uint64_t body_at = chunk.data().size();
  chunk.Put<uint64_t>(n);
  for (size_t i = 0; i < n; ++i) {
    PutSim3(&chunk, sim3(i));
    chunk.Put<int64_t>(parent(i));
    const std::vector<uint8_t> rec = serializer.Encode(submap(i));
    chunk.Put<uint64_t>(rec.size());
    flush();
    out.Append(rec.data(), rec.size());
  }
  chunk.Put<uint64_t>(fused.size());
  for (const FusedPoint& f : fused) {
    chunk.Put<int32_t>(f.dup);
    chunk.Put<int32_t>(f.kept);
    chunk.Put<int64_t>(f.dup_point);
    chunk.Put<int64_t>(f.kept_point);
  }
  PutLoops(&chunk, loops);
  flush();
  const uint64_t body_size = out.size() - body_at;
  const auto body = out.Read(body_at, body_size);
  if (!body) {  // never commit a header without its checksum: the writer drops its temporary
    if (why) *why = out.error().empty() ? "cannot read back " + path + " to checksum it" : out.error();
    return false;
  }
  const uint64_t patch[2] = {body_size, Checksum64(body->data(), body_size)};
  out.Patch(size_at, patch, sizeof(patch));
  return out.Commit(why);
}

}  // namespace

bool SaveGlobalMap(const GlobalMap& map, const std::string& path, std::string* why,
                   const SubmapSerializer& serializer) {
  return SaveEntries(
      map.size(), [&](size_t i) -> const Submap& { return map.submap(int(i)); },
      [&](size_t i) -> const Sim3& { return map.ToGlobal(int(i)); }, [&](size_t i) { return map.RawParent(int(i)); },
      map.fused(), map.loops(), path, why, serializer);
}

bool SaveSubmaps(const std::vector<const Submap*>& submaps, const std::string& path, std::string* why,
                 const SubmapSerializer& serializer) {
  static const Sim3 identity;
  return SaveEntries(
      submaps.size(), [&](size_t i) -> const Submap& { return *submaps[i]; },
      [&](size_t) -> const Sim3& { return identity; }, [](size_t i) { return int64_t(i); }, {}, LoopMemory(), path,
      why, serializer);
}

namespace {

Sim3 GetSim3(BufferReader* b, const char* what) {
  double v[8];
  for (double& x : v) x = b->Get<double>();
  const Eigen::Quaterniond q(v[4], v[1], v[2], v[3]);
  bool finite = true;
  for (double x : v) finite &= std::isfinite(x);
  if (!finite || !(v[0] > 0) || !(std::abs(q.norm() - 1.0) < 1e-6)) b->Fail(std::string(what) + ": invalid Sim(3)");
  return Sim3(v[0], q, Eigen::Vector3d(v[5], v[6], v[7]));
}

SubmapKey GetKey(BufferReader* b) {
  const uint8_t source = b->Get<uint8_t>();
  if (source > uint8_t(SubmapSource::kMerged)) b->Fail("loop memory: bad submap source " + std::to_string(source));
  SubmapKey k;
  k.source = SubmapSource(source);
  k.id = b->Get<int64_t>();
  return k;
}

void ReadLoops(BufferReader* b, LoopMemory* m) {
  const uint64_t np = b->GetCount(9 + 8 + 56, "loop raw pose");
  for (uint64_t i = 0; i < np; ++i) {
    const SubmapKey key = GetKey(b);
    const int64_t kf = b->Get<int64_t>();
    double v[7];
    for (double& x : v) x = b->Get<double>();
    const Eigen::Quaterniond q(v[3], v[0], v[1], v[2]);
    bool finite = true;
    for (double x : v) finite &= std::isfinite(x);
    if (!finite || !(std::abs(q.norm() - 1.0) < 1e-6)) b->Fail("loop raw pose: invalid pose");
    m->raw_pose[{key, kf}] = Se3::FromUnitQuaternion(q, Eigen::Vector3d(v[4], v[5], v[6]));
  }
  const uint64_t nv = b->GetCount(9 + 8 + 64, "loop solved pose");
  for (uint64_t i = 0; i < nv; ++i) {
    const SubmapKey key = GetKey(b);
    const int64_t kf = b->Get<int64_t>();
    m->solved[{key, kf}] = GetSim3(b, "loop solved pose");
  }
  const uint64_t ns = b->GetCount(9 + 8 + 8, "loop search");
  for (uint64_t i = 0; i < ns; ++i) {
    const SubmapKey key = GetKey(b);
    const int64_t kf = b->Get<int64_t>();
    const uint64_t nd = b->GetCount(2 * (9 + 16) + 128 + 16, "loop detection");
    std::vector<LoopDetection>& list = m->searched[{key, kf}];
    for (uint64_t k = 0; k < nd; ++k) {
      LoopDetection d;
      d.query_submap = GetKey(b);
      d.query_keyframe = b->Get<int64_t>();
      d.query_time = b->Get<int64_t>();
      d.match_submap = GetKey(b);
      d.match_keyframe = b->Get<int64_t>();
      d.match_time = b->Get<int64_t>();
      d.S_mq = GetSim3(b, "loop detection");
      d.S_qm = GetSim3(b, "loop detection");
      d.matches = b->Get<int32_t>();
      d.inliers = b->Get<int32_t>();
      d.score = b->Get<double>();
      list.push_back(d);
    }
  }
}

}  // namespace

bool LoadGlobalMap(const std::string& path, GlobalMap* map, std::string* why,
                   const SubmapSerializer& serializer) {
  std::vector<uint8_t> data;
  if (!ReadFileBytes(path, &data, why)) return false;
  try {
    BufferReader r(data.data(), data.size(), "global map file '" + path + "'");
    if (data.size() < sizeof(kMagic) || std::memcmp(data.data(), kMagic, sizeof(kMagic)) != 0)
      r.Fail("not a rumi global map (bad magic)");
    r.Take(sizeof(kMagic));
    const uint32_t version = r.Get<uint32_t>();
    if (version < 1 || version > kGlobalMapFileVersion)
      r.Fail("unsupported version " + std::to_string(version) + " (this build reads 1 to " +
             std::to_string(kGlobalMapFileVersion) + ")");
    r.Get<uint32_t>();
    const uint64_t name_len = r.GetCount(1, "serializer name");
    const std::string name(reinterpret_cast<const char*>(r.Take(name_len)), name_len);
    if (name != serializer.Name())
      r.Fail("written with submap format '" + name + "', this build reads '" + serializer.Name() + "'");
    const uint64_t body_size = r.Get<uint64_t>();
    const uint64_t checksum = r.Get<uint64_t>();
    if (body_size != r.remaining())
      r.Fail("body is " + std::to_string(r.remaining()) + " bytes, header says " + std::to_string(body_size) +
             " (truncated or appended to)");
    const uint8_t* body = r.Take(body_size);
    if (Checksum64(body, body_size) != checksum) r.Fail("checksum mismatch (corrupt file)");

    BufferReader b(body, body_size, "global map file '" + path + "'");
    GlobalMap loaded;
    const uint64_t n = b.GetCount(80, "submap");
    std::vector<int64_t> parents;
    std::vector<Sim3> sims;
    for (uint64_t i = 0; i < n; ++i) {
      double v[8];
      for (double& x : v) x = b.Get<double>();
      const Eigen::Quaterniond q(v[4], v[1], v[2], v[3]);
      if (!(v[0] > 0) || !std::isfinite(v[0]) || !(std::abs(q.norm() - 1.0) < 1e-6))
        b.Fail("submap " + std::to_string(i) + ": invalid Sim(3)");
      sims.emplace_back(v[0], q, Eigen::Vector3d(v[5], v[6], v[7]));
      parents.push_back(b.Get<int64_t>());
      const uint64_t size = b.GetCount(1, "submap record");
      const uint8_t* rec = b.Take(size);
      Submap s;
      std::string err;
      if (!serializer.Decode(rec, size, &s, &err)) b.Fail("submap " + std::to_string(i) + ": " + err);
      if (loaded.AddSubmap(std::move(s), &err) < 0) b.Fail(err);
    }
    for (uint64_t i = 0; i < n; ++i) {
      if (parents[i] < 0 || uint64_t(parents[i]) >= n) b.Fail("submap " + std::to_string(i) + ": bad parent");
      loaded.entry(int(i)).S_gl = sims[i];
      loaded.SetParent(int(i), int(parents[i]));
    }
    for (uint64_t i = 0; i < n; ++i) {  // parent links must reach a root
      int64_t c = int64_t(i);
      for (uint64_t steps = 0; parents[c] != c; ++steps) {
        if (steps > n) b.Fail("union-find parents form a cycle");
        c = parents[c];
      }
    }
    const uint64_t nf = b.GetCount(24, "fused point");
    for (uint64_t i = 0; i < nf; ++i) {
      FusedPoint f;
      f.dup = b.Get<int32_t>();
      f.kept = b.Get<int32_t>();
      f.dup_point = b.Get<int64_t>();
      f.kept_point = b.Get<int64_t>();
      if (f.dup < 0 || uint64_t(f.dup) >= n || f.kept < 0 || uint64_t(f.kept) >= n) b.Fail("fused point: bad submap");
      loaded.fused().push_back(f);
    }
    if (version >= 2) ReadLoops(&b, &loaded.loops());
    if (b.remaining() != 0) b.Fail(std::to_string(b.remaining()) + " unexpected trailing bytes");
    *map = std::move(loaded);
    return true;
  } catch (const CodecError& e) {
    if (why) *why = e.what();
    return false;
  }
}

std::string RawBakedDir(const std::string& raw_path) { return raw_path + ".baked"; }

std::string RawBakedPath(const std::string& raw_path, const SubmapKey& key) {
  return RawBakedDir(raw_path) + "/" +
         (key.source == SubmapSource::kFront ? "front_" : "back_") + std::to_string(key.id) + ".rumi";
}

bool LoadRawSubmaps(const std::string& raw_path, GlobalMap* map, std::string* why,
                    const SubmapSerializer& serializer) {
  namespace fs = std::filesystem;
  GlobalMap out;
  std::error_code ec;
  if (fs::exists(raw_path, ec) && !LoadGlobalMap(raw_path, &out, why, serializer)) return false;
  std::vector<std::string> baked;
  const std::string dir = RawBakedDir(raw_path);
  if (fs::is_directory(dir, ec))
    for (const auto& e : fs::directory_iterator(dir, ec))
      if (e.path().extension() == ".rumi") baked.push_back(e.path().string());
  std::sort(baked.begin(), baked.end());
  for (const std::string& path : baked) {
    GlobalMap one;
    if (!LoadGlobalMap(path, &one, why, serializer)) return false;
    for (size_t i = 0; i < one.size(); ++i)
      if (out.Find(one.Key(int(i))) < 0 && out.AddSubmap(one.submap(int(i)), why) < 0) return false;
  }
  *map = std::move(out);
  return true;
}

}  // namespace rumi
