#include "back/blank_cut.h"

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>
#include <unordered_map>

#include <opencv2/imgcodecs.hpp>

#include "common/synth/synthetic_sequence.h"

namespace rumi {
namespace {

// Content some 16 pixels across (what a camera images), at `gain`.
cv::Mat Textured(double gain) {
  cv::Mat coarse(12, 16, CV_8UC1), img;
  cv::RNG rng(3);
  rng.fill(coarse, cv::RNG::UNIFORM, 0, 256);
  cv::resize(coarse, img, cv::Size(256, 192), 0, 0, cv::INTER_CUBIC);
  img.convertTo(img, CV_8U, gain);
  return img;
}

// What a camera's noise and its JPEG stream do to a frame (8-bit).
cv::Mat Degraded(const cv::Mat& image, double noise_sigma, int jpeg_quality, uint64_t seed) {
  cv::Mat f, n(image.size(), CV_32F), out;
  image.convertTo(f, CV_32F);
  cv::RNG rng(seed);
  rng.fill(n, cv::RNG::NORMAL, 0.0, noise_sigma);
  f += n;
  f.convertTo(out, CV_8U);
  if (jpeg_quality > 0) {
    std::vector<uchar> buf;
    cv::imencode(".jpg", out, buf, {cv::IMWRITE_JPEG_QUALITY, jpeg_quality});
    out = cv::imdecode(buf, cv::IMREAD_GRAYSCALE);
  }
  return out;
}

constexpr double kFlat = 1.0, kStructure = 0.3;  // BackOptions' defaults

TEST(BlankCut, ACoveredLensIsBlankADarkRoomIsNot) {
  cv::Mat covered(192, 256, CV_8UC1);
  cv::RNG rng(5);
  rng.fill(covered, cv::RNG::NORMAL, 8.0, 3.0);  // noise only, 3x a generated camera's read noise
  EXPECT_TRUE(IsBlankImage(covered, kFlat, kStructure));
  EXPECT_TRUE(IsBlankImage(cv::Mat(), kFlat, kStructure));
  EXPECT_TRUE(IsBlankImage(cv::Mat(192, 256, CV_8UC1, cv::Scalar(0)), kFlat, kStructure));
  EXPECT_FALSE(IsBlankImage(Textured(1.0), kFlat, kStructure));
  // 1.2 % gain: darker than the demo's stretch; flat, but it still shows the room.
  const cv::Mat dark = Degraded(Textured(0.012), 1.0, 0, 7);
  EXPECT_LE(MeasureBlank(dark).stddev, kFlat);
  EXPECT_FALSE(IsBlankImage(dark, kFlat, kStructure));
  cv::Mat colour;
  cv::cvtColor(Textured(1.0), colour, cv::COLOR_GRAY2BGR);
  EXPECT_FALSE(IsBlankImage(colour, kFlat, kStructure));
}

TEST(BlankCut, APlainWallCloseUpIsNotBlank) {
  // A plain wall at arm's length: its shading changes by 3 grey levels
  // across the frame and a faint texture adds half a level; with the
  // camera's noise the whole frame's standard deviation is ~1.3 levels
  // and 8-bit 4 x 4 block means would be flat (std 0.0-0.9 on such frames).
  cv::Mat wall(192, 256, CV_32F);
  cv::Mat faint(12, 16, CV_32F), faint_up;
  cv::RNG rng(11);
  rng.fill(faint, cv::RNG::UNIFORM, -0.5, 0.5);
  cv::resize(faint, faint_up, wall.size(), 0, 0, cv::INTER_CUBIC);
  for (int y = 0; y < wall.rows; ++y)
    for (int x = 0; x < wall.cols; ++x)
      wall.at<float>(y, x) = 120.f + 3.f * float(x) / float(wall.cols) + faint_up.at<float>(y, x);
  for (int q : {0, 80}) {
    const cv::Mat frame = Degraded(wall, 1.0, q, 3);
    const BlankMeasure m = MeasureBlank(frame);
    EXPECT_LE(m.stddev, kFlat) << "jpeg " << q;
    EXPECT_GT(m.structure, 0.6) << "jpeg " << q;
    EXPECT_FALSE(IsBlankImage(frame, kFlat, kStructure)) << "jpeg " << q;
  }
}

// Generated frames: `kidnap`'s covered lens (also noisier and through JPEG)
// against the demo's near-black `dark` stretch (seed 2, 2 % exposure).
TEST(BlankCut, GeneratedCoveredLensAgainstTheDemosDarkStretch) {
  SynthOptions k;
  k.scenario = SynthScenario::kKidnap;
  k.seed = 3;
  k.frames = 150;
  k.width = 320;
  k.height = 240;
  k.supersample = 1;
  const SyntheticSequence kidnap(k);
  const int covered = (kidnap.hard_begin() + kidnap.hard_end()) / 2;
  ASSERT_TRUE(kidnap.in_hard_stretch(covered));
  const cv::Mat lens = kidnap.Render(covered);
  for (double noise : {0.0, 3.0, 8.0})
    for (int q : {0, 95, 80, 50, 20}) {
      const cv::Mat frame = Degraded(lens, noise, q, uint64_t(covered));
      const BlankMeasure m = MeasureBlank(frame);
      EXPECT_TRUE(IsBlankImage(frame, kFlat, kStructure))
          << "noise " << noise << " jpeg " << q << ": stddev " << m.stddev << " structure " << m.structure;
    }
  EXPECT_FALSE(IsBlankImage(kidnap.Render(kidnap.hard_begin() - 5), kFlat, kStructure));

  SynthOptions d = k;
  d.scenario = SynthScenario::kDark;
  d.seed = 2;
  d.dark_gain = 0.02;
  const SyntheticSequence dark(d);
  const cv::Mat bottom = dark.Render((dark.hard_begin() + dark.hard_end()) / 2);
  for (int q : {0, 95, 80}) {
    const cv::Mat frame = Degraded(bottom, 0.0, q, 1);
    const BlankMeasure m = MeasureBlank(frame);
    EXPECT_LE(m.stddev, kFlat) << "jpeg " << q;  // flat: what the old test alone took for a covered lens
    EXPECT_FALSE(IsBlankImage(frame, kFlat, kStructure))
        << "jpeg " << q << ": stddev " << m.stddev << " structure " << m.structure;
  }
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
