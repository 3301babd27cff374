#include "manager/map_file.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "manager/merge.h"
#include "manager/test_scenario.h"

namespace rumi {
namespace {

namespace fs = std::filesystem;

class MapFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("rumi_map_file_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    path_ = (dir_ / "global.map").string();
    s_ = testing::MakeScenario(3, 1.0, 600);
    a_ = map_.AddSubmap(s_.front_a.submap);
    map_.AddSubmap(s_.front_b.submap);
    k_ = map_.AddSubmap(s_.back.submap);
    MergeAll(&map_, ManagerOptions());
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::vector<char> ReadAll() {
    std::ifstream in(path_, std::ios::binary);
    return std::vector<char>((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  }
  void WriteAll(const std::vector<char>& d) {
    std::ofstream out(path_, std::ios::binary | std::ios::trunc);
    out.write(d.data(), std::streamsize(d.size()));
  }
  fs::path dir_;
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
