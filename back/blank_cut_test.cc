#include "back/blank_cut.h"

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>
#include <unordered_map>

namespace rumi {
namespace {

// Content a few pixels across (what a camera images), at `gain`.
cv::Mat Textured(double gain) {
  cv::Mat coarse(12, 16, CV_8UC1), img;
  cv::RNG rng(3);
  rng.fill(coarse, cv::RNG::UNIFORM, 0, 256);
  cv::resize(coarse, img, cv::Size(64, 48), 0, 0, cv::INTER_CUBIC);
  img.convertTo(img, CV_8U, gain);
  return img;
}

TEST(BlankCut, ACoveredLensIsBlankADarkRoomIsNot) {
  cv::Mat covered(48, 64, CV_8UC1);
  cv::RNG rng(5);
  rng.fill(covered, cv::RNG::NORMAL, 8.0, 3.0);  // noise only, 5x a generated camera's read noise
  EXPECT_TRUE(IsBlankImage(covered, 1.0));
  EXPECT_TRUE(IsBlankImage(cv::Mat(), 1.0));
  EXPECT_FALSE(IsBlankImage(Textured(1.0), 1.0));
  // 3 % gain: darker than a generated `dark` stretch (10 %).
  cv::Mat dark = Textured(0.03);
  EXPECT_FALSE(IsBlankImage(dark, 1.0));
  cv::Mat colour;
  cv::cvtColor(Textured(1.0), colour, cv::COLOR_GRAY2BGR);
  EXPECT_FALSE(IsBlankImage(colour, 1.0));
}

TEST(BlankCut, StretchesNeedEnoughConsecutiveFrames) {
  const std::vector<Timestamp> t{0, 1, 2, 3, 4, 5, 6, 7};
  const std::vector<bool> blank{false, true, true, false, true, true, true, false};
  using P = std::vector<std::pair<Timestamp, Timestamp>>;
  EXPECT_EQ(BlankStretches(t, blank, 3), (P{{4, 6}}));
  EXPECT_EQ(BlankStretches(t, blank, 2), (P{{1, 2}, {4, 6}}));
  EXPECT_EQ(BlankStretches(t, std::vector<bool>(8, true), 3), (P{{0, 7}}));
  EXPECT_TRUE(BlankStretches(t, std::vector<bool>(8, false), 1).empty());
}

// Ten keyframes at t = 0..9 (a stretch covers 5), each point seen by three
// consecutive keyframes.
Submap TenKeyframes() {
  Submap s;
  s.source = SubmapSource::kBack;
  for (int k = 0; k < 10; ++k) {
    Keyframe kf;
    kf.id = k;
    kf.timestamp = k < 5 ? k : k + 1;
    kf.keypoints.assign(3, Eigen::Vector2f(10, 10));
    kf.point_ids.assign(3, -1);
    s.keyframes.push_back(kf);
  }
  for (int p = 0; p < 8; ++p) {
    MapPoint mp;
    mp.id = 100 + p;
    for (int j = 0; j < 3; ++j) {
      mp.observations.push_back({p + j, j});
      s.keyframes[size_t(p + j)].point_ids[size_t(j)] = mp.id;
    }
    s.points.push_back(mp);
  }
  return s;
}

TEST(BlankCut, AModelIsCutWhereTheCameraSawNothing) {
  const Submap s = TenKeyframes();
  const std::vector<Submap> pieces = CutAtStretches(s, {{5, 5}}, 3, 2);
  ASSERT_EQ(pieces.size(), 2u);
  EXPECT_EQ(pieces[0].keyframes.size(), 5u);
  EXPECT_EQ(pieces[1].keyframes.size(), 5u);
  EXPECT_EQ(pieces[1].keyframes.front().timestamp, 6);
  for (const Submap& p : pieces) {
    std::unordered_map<int64_t, const Keyframe*> kf;
    for (const Keyframe& k : p.keyframes) kf[k.id] = &k;
    int linked = 0;
    for (const Keyframe& k : p.keyframes)
      for (int64_t id : k.point_ids) linked += id >= 0;
    int observations = 0;
    for (const MapPoint& mp : p.points) {
      ASSERT_GE(mp.observations.size(), 2u);
      for (const auto& ob : mp.observations) {
        ASSERT_TRUE(kf.count(ob.keyframe_id));  // only its own side's keyframes
        EXPECT_EQ(kf[ob.keyframe_id]->point_ids[size_t(ob.keypoint_index)], mp.id);
        ++observations;
      }
    }
    EXPECT_EQ(linked, observations);  // a dropped point is unlinked
  }
  // Points 100-102 lie on the left, 105-107 on the right; 103 keeps two
  // observations on the left (keyframes 3, 4), 104 two on the right (6, 7).
  EXPECT_EQ(pieces[0].points.size(), 4u);
  EXPECT_EQ(pieces[1].points.size(), 4u);
  // With three observations needed, the points split by the cut go.
  EXPECT_EQ(CutAtStretches(s, {{5, 5}}, 3, 3)[0].points.size(), 3u);
}

TEST(BlankCut, AStretchWithoutKeyframesOnBothSidesCutsNothing) {
  const Submap s = TenKeyframes();
  for (const auto& st : std::vector<std::pair<Timestamp, Timestamp>>{{-5, -1}, {20, 30}}) {
    const std::vector<Submap> pieces = CutAtStretches(s, {st}, 3, 2);
    ASSERT_EQ(pieces.size(), 1u);
    EXPECT_EQ(pieces[0].points.size(), s.points.size());
  }
  // A side smaller than min_keyframes is dropped.
  const std::vector<Submap> pieces = CutAtStretches(s, {{1, 1}}, 3, 2);
  ASSERT_EQ(pieces.size(), 1u);
  EXPECT_EQ(pieces[0].keyframes.front().timestamp, 2);
}

}  // namespace
}  // namespace rumi
