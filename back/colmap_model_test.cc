// Reads a small COLMAP binary model written byte by byte here (independently
// of the reader) and checks the conversion into a back submap.
#include "back/colmap_model.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <cstring>
#include <limits>

#include "back/model_to_submap.h"
#include "common/testing/temp_dir.h"

namespace rumi {
namespace {

class Bytes {
 public:
  template <typename T>
  Bytes& Put(T v) {
    const char* p = reinterpret_cast<const char*>(&v);
    data_.append(p, sizeof(T));
    return *this;
  }
  Bytes& Str(const std::string& s) {
    data_.append(s);
    data_.push_back('\0');
    return *this;
  }
  void Save(const std::string& path) const {
    std::ofstream(path, std::ios::binary).write(data_.data(), static_cast<std::streamsize>(data_.size()));
  }
  std::string data_;
};

// Ground truth of the tiny scene: two cameras looking at three points.
struct Scene {
  double fx = 500, fy = 480, cx = 319.5, cy = 239.5;  // rumi (OpenCV) convention
  Timestamp t[2] = {1341847980722988001LL, 7LL};       // second name sorts first
  Eigen::Quaterniond q[2];
  Eigen::Vector3d tv[2];
  Eigen::Vector3d X[3] = {{0.1, -0.2, 4.0}, {-0.5, 0.3, 5.0}, {0.7, 0.4, 6.0}};
  Scene() {
    // A rotation whose w x y z are all different, so a swapped order shows.
    q[0] = Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()));
    tv[0] = {0.2, -0.1, 0.5};
    q[1] = Eigen::Quaterniond(Eigen::AngleAxisd(-0.2, Eigen::Vector3d(0, 1, 0.2).normalized()));
    tv[1] = {-0.3, 0.05, 0.1};
  }
  // Pixel in rumi's convention of point j seen from image i.
  Eigen::Vector2d Project(int i, int j) const {
    const Eigen::Vector3d p = q[i] * X[j] + tv[i];
    return {fx * p.x() / p.z() + cx, fy * p.y() / p.z() + cy};
  }
};

const uint64_t kNone = std::numeric_limits<uint64_t>::max();

class ColmapModelTest : public ::testing::Test {
 protected:
  void SetUp() override { tmp_.Create(); }

  // Image ids 5 and 9; points 100, 200, 300. Image 5 sees all three (2D
  // indices 1, 2, 3; index 0 is an unmatched feature), image 9 sees 100 and 300.
  void WriteModel(int32_t camera_model = 1) {
    Bytes cams;
    cams.Put<uint64_t>(1).Put<uint32_t>(1).Put<int32_t>(camera_model).Put<uint64_t>(640).Put<uint64_t>(480);
    if (camera_model == 1) {
      cams.Put(s_.fx).Put(s_.fy).Put(s_.cx + 0.5).Put(s_.cy + 0.5);
    } else {
      for (int k = 0; k < ColmapCameraNumParams(camera_model); ++k) cams.Put(1.0 + k);
    }
    cams.Save(Path("cameras.bin"));

    Bytes ims;
    ims.Put<uint64_t>(2);
    const uint32_t ids[2] = {5, 9};
    for (int i = 0; i < 2; ++i) {
      ims.Put(ids[i]).Put(s_.q[i].w()).Put(s_.q[i].x()).Put(s_.q[i].y()).Put(s_.q[i].z());
      ims.Put(s_.tv[i].x()).Put(s_.tv[i].y()).Put(s_.tv[i].z()).Put<uint32_t>(1);
      ims.Str(ColmapImageName(s_.t[i]));
      std::vector<std::pair<int, uint64_t>> pts;  // (point j, id) per 2D index
      if (i == 0) pts = {{-1, kNone}, {0, 100}, {1, 200}, {2, 300}};
      else pts = {{2, 300}, {0, 100}};
      ims.Put<uint64_t>(pts.size());
      for (auto [j, id] : pts) {
        const Eigen::Vector2d px = j < 0 ? Eigen::Vector2d(10.0, 20.0) : s_.Project(i, j);
        ims.Put(px.x() + 0.5).Put(px.y() + 0.5).Put(id);  // COLMAP convention
      }
    }
    ims.Save(Path("images.bin"));

    Bytes pts;
    pts.Put<uint64_t>(3);
    const uint64_t pids[3] = {100, 200, 300};
    const std::vector<std::vector<std::pair<uint32_t, uint32_t>>> tracks = {
        {{5, 1}, {9, 1}}, {{5, 2}}, {{5, 3}, {9, 0}}};
    for (int j = 0; j < 3; ++j) {
      pts.Put(pids[j]).Put(s_.X[j].x()).Put(s_.X[j].y()).Put(s_.X[j].z());
      pts.Put<uint8_t>(10).Put<uint8_t>(20).Put<uint8_t>(30).Put(0.25 * (j + 1));
      pts.Put<uint64_t>(tracks[j].size());
      for (auto [im, idx] : tracks[j]) pts.Put(im).Put(idx);
    }
    pts.Save(Path("points3D.bin"));
  }
  std::string Path(const std::string& f) const { return (dir_ / f).string(); }
  std::string ReadAll(const std::string& f) const {
    std::ifstream in(Path(f), std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  }
  void WriteAll(const std::string& f, const std::string& d) const {
    std::ofstream(Path(f), std::ios::binary | std::ios::trunc).write(d.data(), static_cast<std::streamsize>(d.size()));
  }

  Scene s_;
  TempDir tmp_;
  std::filesystem::path dir_ = tmp_.path();
};

TEST_F(ColmapModelTest, ReadsHandWrittenModel) {
  WriteModel();
  ColmapModel m;
  std::string err;
  ASSERT_TRUE(ReadColmapModelBinary(dir_.string(), &m, &err)) << err;
  ASSERT_EQ(m.cameras.size(), 1u);
  const ColmapCamera& c = m.cameras.at(1);
  EXPECT_EQ(c.model_id, 1);
  EXPECT_EQ(c.width, 640u);
  EXPECT_EQ(c.height, 480u);
  ASSERT_EQ(c.params.size(), 4u);
  EXPECT_EQ(c.params[2], s_.cx + 0.5);
  ASSERT_EQ(m.images.size(), 2u);
  const ColmapImage& a = m.images.at(5);
  EXPECT_EQ(a.name, ColmapImageName(s_.t[0]));
  EXPECT_EQ(a.qvec[0], s_.q[0].w());
  EXPECT_EQ(a.qvec[3], s_.q[0].z());
  EXPECT_EQ(a.tvec[2], s_.tv[0].z());
  ASSERT_EQ(a.xys.size(), 4u);
  EXPECT_EQ(a.point3d_ids[0], -1);
  EXPECT_EQ(a.point3d_ids[2], 200);
  EXPECT_EQ(a.xys[0], Eigen::Vector2d(10.5, 20.5));
  ASSERT_EQ(m.points.size(), 3u);
  EXPECT_EQ(m.points.at(300).xyz, s_.X[2]);
  EXPECT_EQ(m.points.at(300).error, 0.75);
  EXPECT_EQ(m.points.at(200).rgb[1], 20);
  ASSERT_EQ(m.points.at(300).track.size(), 2u);
  EXPECT_EQ(m.points.at(300).track[1].image_id, 9u);
  EXPECT_EQ(m.points.at(300).track[1].point2d_idx, 0u);
}

TEST_F(ColmapModelTest, ConvertsToBackSubmap) {
  WriteModel();
  ColmapModel m;
  std::string err;
  ASSERT_TRUE(ReadColmapModelBinary(dir_.string(), &m, &err)) << err;
  Submap sm;
  BackSubmapStats st;
  ASSERT_TRUE(ColmapModelToSubmap(m, 42, &sm, &st, &err)) << err;
  EXPECT_EQ(sm.id, 42);
  EXPECT_EQ(sm.source, SubmapSource::kBack);
  // Intrinsics back in rumi's pixel convention.
  EXPECT_DOUBLE_EQ(sm.camera.cx, s_.cx);
  EXPECT_DOUBLE_EQ(sm.camera.cy, s_.cy);
  EXPECT_EQ(sm.camera.fx, s_.fx);
  EXPECT_EQ(sm.camera.fy, s_.fy);
  EXPECT_EQ(sm.camera.width, 640);
  // Sorted by time: image 9 (t = 7 ns) first; timestamps exact.
  ASSERT_EQ(sm.keyframes.size(), 2u);
  EXPECT_EQ(sm.keyframes[0].timestamp, s_.t[1]);
  EXPECT_EQ(sm.keyframes[1].timestamp, s_.t[0]);
  EXPECT_EQ(sm.keyframes[0].id, 0);
  EXPECT_EQ(sm.keyframes[1].id, 1);
  // Every observation reprojects onto its keypoint with T_cw and rumi's K:
  // fails on a swapped quaternion order, an inverted pose or a missed 0.5.
  int checked = 0;
  for (const MapPoint& p : sm.points) {
    for (const auto& o : p.observations) {
      const Keyframe& kf = sm.keyframes.at(static_cast<size_t>(o.keyframe_id));
      const Eigen::Vector3d pc = kf.T_cw * p.position;
      const Eigen::Vector2d px(sm.camera.fx * pc.x() / pc.z() + sm.camera.cx,
                               sm.camera.fy * pc.y() / pc.z() + sm.camera.cy);
      const Eigen::Vector2f kp = kf.keypoints.at(static_cast<size_t>(o.keypoint_index));
      EXPECT_NEAR(px.x(), kp.x(), 1e-3);
      EXPECT_NEAR(px.y(), kp.y(), 1e-3);
      EXPECT_EQ(kf.point_ids.at(static_cast<size_t>(o.keypoint_index)), p.id);
      ++checked;
    }
  }
  EXPECT_EQ(checked, 5);
  // Unmatched feature kept, without a point, shifted to the centre convention.
  const Keyframe& k1 = sm.keyframes[1];
  ASSERT_EQ(k1.keypoints.size(), 4u);
  EXPECT_EQ(k1.point_ids[0], -1);
  EXPECT_FLOAT_EQ(k1.keypoints[0].x(), 10.0f);
  EXPECT_FLOAT_EQ(k1.keypoints[0].y(), 20.0f);
  EXPECT_EQ(k1.octaves.size(), 4u);
  // Point ids renumbered 0..m-1 in COLMAP id order, positions kept.
  ASSERT_EQ(sm.points.size(), 3u);
  EXPECT_EQ(sm.points[2].id, 2);
  EXPECT_EQ(sm.points[2].position, s_.X[2]);
  EXPECT_EQ(st.registered_images, 2);
  EXPECT_EQ(st.num_points, 3);
  EXPECT_EQ(st.num_observations, 5);
  EXPECT_DOUBLE_EQ(st.mean_reprojection_error_px, 0.5);
  EXPECT_DOUBLE_EQ(st.mean_track_length, 5.0 / 3.0);
}

TEST(ColmapImageNameTest, TimestampRoundTripIsExact) {
  for (Timestamp t : {Timestamp{0}, Timestamp{1}, Timestamp{1341847980722988001LL},
                      Timestamp{1403636579763555584LL}, std::numeric_limits<Timestamp>::max()}) {
    const std::string name = ColmapImageName(t);
    EXPECT_EQ(name.size(), 24u) << name;
    Timestamp back = -1;
    ASSERT_TRUE(ParseColmapImageName(name, &back)) << name;
    EXPECT_EQ(back, t);
  }
  // Name order is time order.
  EXPECT_LT(ColmapImageName(999999999), ColmapImageName(1000000000));
  Timestamp t;
  EXPECT_FALSE(ParseColmapImageName("12.png", &t));  // not the padded form
  EXPECT_FALSE(ParseColmapImageName(TimestampFileStem(5) + ".jpg", &t));
  EXPECT_FALSE(ParseColmapImageName("0000000000000000000a.png", &t));
  EXPECT_FALSE(ParseColmapImageName(".png", &t));
}

TEST_F(ColmapModelTest, RejectsCorruptFiles) {
  ColmapModel m;
  std::string err;
  EXPECT_FALSE(ReadColmapModelBinary(dir_.string(), &m, &err));
  EXPECT_NE(err.find("cameras.bin"), std::string::npos) << err;

  WriteModel();
  const std::string images = ReadAll("images.bin");
  // Truncation anywhere is reported, never a crash.
  for (size_t cut : {size_t{3}, size_t{20}, images.size() / 2, images.size() - 1}) {
    WriteAll("images.bin", images.substr(0, cut));
    EXPECT_FALSE(ReadColmapModelBinary(dir_.string(), &m, &err)) << cut;
    EXPECT_NE(err.find("images.bin"), std::string::npos) << err;
  }
  // An absurd count is refused before allocating.
  std::string huge = images;
  const uint64_t n = uint64_t{1} << 60;
  std::memcpy(&huge[0], &n, 8);
  WriteAll("images.bin", huge);
  EXPECT_FALSE(ReadColmapModelBinary(dir_.string(), &m, &err));
  EXPECT_NE(err.find("exceeds"), std::string::npos) << err;
  // Trailing garbage.
  WriteAll("images.bin", images + "x");
  EXPECT_FALSE(ReadColmapModelBinary(dir_.string(), &m, &err));
  WriteAll("images.bin", images);
  ASSERT_TRUE(ReadColmapModelBinary(dir_.string(), &m, &err)) << err;

  // A track naming a 2D index the image does not have.
  std::string points = ReadAll("points3D.bin");
  const size_t last_idx = points.size() - 4;  // point2d_idx of the last track element
  const uint32_t bad = 77;
  std::memcpy(&points[last_idx], &bad, 4);
  WriteAll("points3D.bin", points);
  EXPECT_FALSE(ReadColmapModelBinary(dir_.string(), &m, &err));
  EXPECT_NE(err.find("track"), std::string::npos) << err;
}

TEST_F(ColmapModelTest, ConversionRefusesDistortedCameraAndForeignNames) {
  WriteModel(/*camera_model=*/4);  // OPENCV
  ColmapModel m;
  std::string err;
  ASSERT_TRUE(ReadColmapModelBinary(dir_.string(), &m, &err)) << err;
  Submap sm;
  EXPECT_FALSE(ColmapModelToSubmap(m, 0, &sm, nullptr, &err));
  EXPECT_NE(err.find("PINHOLE"), std::string::npos) << err;

  WriteModel();
  ASSERT_TRUE(ReadColmapModelBinary(dir_.string(), &m, &err)) << err;
  m.images.at(5).name = "frame_0001.png";
  EXPECT_FALSE(ColmapModelToSubmap(m, 0, &sm, nullptr, &err));
  EXPECT_NE(err.find("frame_0001.png"), std::string::npos) << err;
}

}  // namespace
}  // namespace rumi
