#include "manager/map_file.h"

#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <fstream>

#include "ipc/byte_io.h"
#include "manager/merge.h"
#include "manager/testing/test_scenario.h"

namespace rumi {
namespace {

namespace fs = std::filesystem;

class MapFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    tmp_.Create();
    path_ = (dir_ / "global.map").string();
    s_ = testing::MakeScenario(3, 1.0, 600);
    a_ = map_.AddSubmap(s_.front_a.submap);
    map_.AddSubmap(s_.front_b.submap);
    k_ = map_.AddSubmap(s_.back.submap);
    MergeAll(&map_, ManagerOptions());
  }
  std::vector<char> ReadAll() {
    std::ifstream in(path_, std::ios::binary);
    return std::vector<char>((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  }
  void WriteAll(const std::vector<char>& d) {
    std::ofstream out(path_, std::ios::binary | std::ios::trunc);
    out.write(d.data(), std::streamsize(d.size()));
  }
  TempDir tmp_;
  fs::path dir_ = tmp_.path();
  std::string path_;
  testing::Scenario s_;
  GlobalMap map_;
  int a_ = -1, k_ = -1;
};

TEST_F(MapFileTest, RoundTrip) {
  ASSERT_TRUE(map_.Connected(0, 1));
  std::string why;
  ASSERT_TRUE(SaveGlobalMap(map_, path_, &why)) << why;
  GlobalMap loaded;
  ASSERT_TRUE(LoadGlobalMap(path_, &loaded, &why)) << why;
  ASSERT_EQ(loaded.size(), map_.size());
  for (size_t i = 0; i < map_.size(); ++i) {
    EXPECT_EQ(loaded.Key(int(i)), map_.Key(int(i)));
    EXPECT_TRUE(loaded.ToGlobal(int(i)).Matrix().isApprox(map_.ToGlobal(int(i)).Matrix(), 1e-14));
    const Submap &x = loaded.submap(int(i)), &y = map_.submap(int(i));
    ASSERT_EQ(x.keyframes.size(), y.keyframes.size());
    ASSERT_EQ(x.points.size(), y.points.size());
    EXPECT_EQ(x.frames.size(), y.frames.size());
    EXPECT_EQ(x.keyframes.back().T_cw.Matrix(), y.keyframes.back().T_cw.Matrix());
    EXPECT_EQ(x.keyframes.back().point_ids, y.keyframes.back().point_ids);
    EXPECT_EQ(x.points.back().position, y.points.back().position);
  }
  EXPECT_TRUE(loaded.Connected(0, 1));
  EXPECT_TRUE(loaded.Connected(0, 2));
  ASSERT_EQ(loaded.fused().size(), map_.fused().size());
  EXPECT_EQ(loaded.fused().back().kept_point, map_.fused().back().kept_point);
  // Saving over an existing file leaves no temporary behind.
  ASSERT_TRUE(SaveGlobalMap(loaded, path_, &why)) << why;
  EXPECT_EQ(std::distance(fs::directory_iterator(dir_), fs::directory_iterator()), 1);
}

// Loop closure's memory travels with the map (version 2), so a restarted
// manager closes the same loops without searching again.
TEST_F(MapFileTest, LoopMemoryRoundTrip) {
  LoopMemory& m = map_.loops();
  const SubmapKey f0{SubmapSource::kFront, 1}, f1{SubmapSource::kFront, 2};
  m.raw_pose[{f0, 7}] = Se3(Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitY())), Eigen::Vector3d(1, 2, 3));
  m.raw_pose[{f1, 4}] = Se3();
  m.solved[{f0, 7}] = Sim3(1.2, Eigen::Quaterniond::Identity(), Eigen::Vector3d(0, 1, 0));
  LoopDetection d;
  d.query_submap = f1;
  d.query_keyframe = 4;
  d.query_time = 1030 * kNsPerSecond + 5;
  d.match_submap = f0;
  d.match_keyframe = 7;
  d.match_time = 1000 * kNsPerSecond;
  d.S_mq = Sim3(0.7, Eigen::Quaterniond(Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitZ())), Eigen::Vector3d(0.1, 0, 2));
  d.S_qm = Sim3(1.3, Eigen::Quaterniond::Identity(), Eigen::Vector3d(0, 0.5, 0));
  d.matches = 80;
  d.inliers = 61;
  d.score = 0.25;
  m.searched[{f1, 4}] = {d};
  m.searched[{f1, 5}] = {};  // searched, nothing found
  std::string why;
  ASSERT_TRUE(SaveGlobalMap(map_, path_, &why)) << why;
  GlobalMap loaded;
  ASSERT_TRUE(LoadGlobalMap(path_, &loaded, &why)) << why;
  const LoopMemory& l = loaded.loops();
  ASSERT_EQ(l.raw_pose.size(), 2u);
  EXPECT_EQ(l.raw_pose.at({f0, 7}).Matrix(), m.raw_pose.at({f0, 7}).Matrix());
  ASSERT_EQ(l.solved.size(), 1u);
  EXPECT_TRUE(l.solved.at({f0, 7}).Matrix().isApprox(m.solved.at({f0, 7}).Matrix(), 1e-15));
  ASSERT_EQ(l.searched.size(), 2u);
  EXPECT_TRUE(l.searched.at({f1, 5}).empty());
  ASSERT_EQ(l.searched.at({f1, 4}).size(), 1u);
  const LoopDetection& e = l.searched.at({f1, 4})[0];
  EXPECT_EQ(e.query_submap, f1);
  EXPECT_EQ(e.match_submap, f0);
  EXPECT_EQ(e.query_keyframe, 4);
  EXPECT_EQ(e.match_keyframe, 7);
  EXPECT_EQ(e.query_time, d.query_time);
  EXPECT_EQ(e.match_time, d.match_time);
  EXPECT_TRUE(e.S_mq.Matrix().isApprox(d.S_mq.Matrix(), 1e-15));
  EXPECT_TRUE(e.S_qm.Matrix().isApprox(d.S_qm.Matrix(), 1e-15));
  EXPECT_EQ(e.inliers, 61);
  EXPECT_EQ(e.matches, 80);
  EXPECT_EQ(e.score, 0.25);

  // A detection with a broken Sim(3) makes the file refused, the map kept.
  m.searched[{f1, 4}][0].S_qm = Sim3(-1.0, Eigen::Quaterniond::Identity(), Eigen::Vector3d::Zero());
  ASSERT_TRUE(SaveGlobalMap(map_, path_, &why)) << why;
  GlobalMap kept;
  kept.AddSubmap(s_.back.submap);
  EXPECT_FALSE(LoadGlobalMap(path_, &kept, &why));
  EXPECT_NE(why.find("invalid Sim(3)"), std::string::npos) << why;
  EXPECT_EQ(kept.size(), 1u);
}

// A map written before loop closure (version 1: no loop memory) still loads.
TEST_F(MapFileTest, VersionOneMapsLoad) {
  std::string why;
  ASSERT_TRUE(SaveGlobalMap(map_, path_, &why)) << why;  // no loops: three zero counts at the end
  std::vector<char> bytes = ReadAll();
  // Rewrite as version 1: without the three counts, size and checksum patched.
  bytes.resize(bytes.size() - 24);
  const uint32_t v1 = 1;
  std::memcpy(bytes.data() + 8, &v1, sizeof(v1));
  uint64_t name_len = 0;
  std::memcpy(&name_len, bytes.data() + 16, sizeof(name_len));
  const size_t size_at = 24 + name_len, body_at = size_at + 16;
  const uint64_t body_size = bytes.size() - body_at;
  const uint64_t checksum = Checksum64(reinterpret_cast<const uint8_t*>(bytes.data()) + body_at, body_size);
  std::memcpy(bytes.data() + size_at, &body_size, sizeof(body_size));
  std::memcpy(bytes.data() + size_at + 8, &checksum, sizeof(checksum));
  WriteAll(bytes);
  GlobalMap loaded;
  ASSERT_TRUE(LoadGlobalMap(path_, &loaded, &why)) << why;
  EXPECT_EQ(loaded.size(), map_.size());
  EXPECT_TRUE(loaded.loops().empty());
  EXPECT_EQ(loaded.fused().size(), map_.fused().size());
  // A version from the future is refused by name.
  const uint32_t v9 = 9;
  std::memcpy(bytes.data() + 8, &v9, sizeof(v9));
  WriteAll(bytes);
  EXPECT_FALSE(LoadGlobalMap(path_, &loaded, &why));
  EXPECT_NE(why.find("unsupported version 9"), std::string::npos) << why;
}

// The manager's raw submaps, saved from where they are: the same file as a
// map holding them unmerged (each its own component, identity Sim(3)s).
TEST_F(MapFileTest, SubmapsSavedAsTheyAre) {
  const std::vector<const Submap*> submaps{&s_.back.submap, &s_.front_a.submap};
  std::string why;
  ASSERT_TRUE(SaveSubmaps(submaps, path_, &why)) << why;
  GlobalMap loaded;
  ASSERT_TRUE(LoadGlobalMap(path_, &loaded, &why)) << why;
  ASSERT_EQ(loaded.size(), 2u);
  for (int i = 0; i < 2; ++i) {
    EXPECT_EQ(loaded.Key(i), (SubmapKey{submaps[size_t(i)]->source, submaps[size_t(i)]->id}));
    EXPECT_TRUE(loaded.ToGlobal(i).Matrix().isApprox(Eigen::Matrix4d::Identity()));
    EXPECT_EQ(loaded.submap(i).keyframes.size(), submaps[size_t(i)]->keyframes.size());
    EXPECT_EQ(loaded.submap(i).points.back().position, submaps[size_t(i)]->points.back().position);
  }
  EXPECT_FALSE(loaded.Connected(0, 1));
  EXPECT_TRUE(loaded.fused().empty());
  // Byte for byte what SaveGlobalMap writes for the same unmerged submaps.
  GlobalMap unmerged;
  for (const Submap* s : submaps) unmerged.AddSubmap(*s);
  const std::vector<char> direct = ReadAll();
  ASSERT_TRUE(SaveGlobalMap(unmerged, path_, &why)) << why;
  EXPECT_EQ(ReadAll(), direct);
}

// The raw submaps of a manager: the raw file and what was baked since, each
// baked submap in its own file; a broken file fails the whole load.
TEST_F(MapFileTest, RawSubmapsIncludeTheBakedOnes) {
  const std::string raw = (dir_ / "map.rumi.raw").string();
  std::string why;
  GlobalMap loaded;
  ASSERT_TRUE(LoadRawSubmaps(raw, &loaded, &why)) << why;  // neither there: nothing
  EXPECT_EQ(loaded.size(), 0u);
  ASSERT_TRUE(SaveSubmaps({&s_.front_b.submap}, raw, &why)) << why;
  fs::create_directories(RawBakedDir(raw));
  const SubmapKey back{s_.back.submap.source, s_.back.submap.id};
  const SubmapKey a{s_.front_a.submap.source, s_.front_a.submap.id};
  ASSERT_TRUE(SaveSubmaps({&s_.back.submap}, RawBakedPath(raw, back), &why)) << why;
  ASSERT_TRUE(SaveSubmaps({&s_.front_a.submap}, RawBakedPath(raw, a), &why)) << why;
  EXPECT_EQ(RawBakedPath(raw, a), raw + ".baked/front_" + std::to_string(a.id) + ".rumi");
  ASSERT_TRUE(LoadRawSubmaps(raw, &loaded, &why)) << why;
  ASSERT_EQ(loaded.size(), 3u);
  for (const Submap* s : {&s_.front_a.submap, &s_.front_b.submap, &s_.back.submap}) {
    const int i = loaded.Find({s->source, s->id});
    ASSERT_GE(i, 0);
    EXPECT_EQ(loaded.submap(i).keyframes.size(), s->keyframes.size());
    EXPECT_EQ(loaded.submap(i).points.back().position, s->points.back().position);
  }
  // A baked file that does not load: an error naming it, the map untouched.
  { std::ofstream(RawBakedPath(raw, back), std::ios::binary | std::ios::trunc) << "garbage"; }
  EXPECT_FALSE(LoadRawSubmaps(raw, &loaded, &why));
  EXPECT_NE(why.find("back_"), std::string::npos) << why;
  EXPECT_EQ(loaded.size(), 3u);
}

TEST_F(MapFileTest, TruncatedFileIsRefusedAndMapKept) {
  std::string why;
  ASSERT_TRUE(SaveGlobalMap(map_, path_, &why)) << why;
  auto bytes = ReadAll();
  GlobalMap current;
  current.AddSubmap(s_.front_a.submap);
  for (size_t cut : {bytes.size() - 1, bytes.size() / 2, size_t(30), size_t(3), size_t(0)}) {
    WriteAll(std::vector<char>(bytes.begin(), bytes.begin() + cut));
    EXPECT_FALSE(LoadGlobalMap(path_, &current, &why)) << cut;
    EXPECT_NE(why.find(path_), std::string::npos) << why;
    EXPECT_TRUE(why.find("truncated") != std::string::npos || why.find("magic") != std::string::npos ||
                why.find("exceeds the remaining") != std::string::npos)
        << why;
    ASSERT_EQ(current.size(), 1u);  // previous map kept
    EXPECT_EQ(current.submap(0).keyframes.size(), s_.front_a.submap.keyframes.size());
  }
}

TEST_F(MapFileTest, CorruptForeignAndMissingFiles) {
  std::string why;
  ASSERT_TRUE(SaveGlobalMap(map_, path_, &why)) << why;
  auto bytes = ReadAll();
  GlobalMap current;
  bytes[bytes.size() / 2] ^= 0x40;
  WriteAll(bytes);
  EXPECT_FALSE(LoadGlobalMap(path_, &current, &why));
  EXPECT_NE(why.find("checksum"), std::string::npos) << why;
  WriteAll({'h', 'e', 'l', 'l', 'o', ' ', 'w', 'o', 'r', 'l', 'd', '\n'});
  EXPECT_FALSE(LoadGlobalMap(path_, &current, &why));
  EXPECT_NE(why.find("magic"), std::string::npos) << why;
  EXPECT_FALSE(LoadGlobalMap((dir_ / "missing.map").string(), &current, &why));
  EXPECT_NE(why.find("missing.map"), std::string::npos) << why;
  EXPECT_EQ(current.size(), 0u);
}

// A serializer with another name: its files are foreign to the default one.
class NullSerializer : public SubmapSerializer {
 public:
  std::string Name() const override { return "null"; }
  std::vector<uint8_t> Encode(const Submap&) const override { return {}; }
  bool Decode(const uint8_t*, size_t, Submap* s, std::string*) const override {
    *s = Submap();
    return true;
  }
};

TEST_F(MapFileTest, SerializerIsPluggableAndChecked) {
  std::string why;
  GlobalMap one;
  one.AddSubmap(Submap());
  const NullSerializer null;
  ASSERT_TRUE(SaveGlobalMap(one, path_, &why, null)) << why;
  GlobalMap loaded;
  ASSERT_TRUE(LoadGlobalMap(path_, &loaded, &why, null)) << why;
  EXPECT_EQ(loaded.size(), 1u);
  EXPECT_FALSE(LoadGlobalMap(path_, &loaded, &why));
  EXPECT_NE(why.find("null"), std::string::npos) << why;
}

}  // namespace
}  // namespace rumi
