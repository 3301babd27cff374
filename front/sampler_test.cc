#include "front/sampler.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace rumi {
namespace {

// A scripted stream: frame i has timestamp i (ns = i * 1e6 to look real) and
// an 8x8 image whose first pixel is i % 256, so images can be traced back.
struct Script {
  std::vector<TrackingState> states;
  std::vector<int64_t> submaps;
  std::vector<int64_t> counts;  // frames in the current front submap

  // Appends n frames; a new submap starts counting from `first_count`.
  void Add(int n, TrackingState s, int64_t submap) {
    for (int i = 0; i < n; ++i) {
      const bool same = !submaps.empty() && submaps.back() == submap;
      counts.push_back(same ? counts.back() + 1 : 1);
      states.push_back(s);
      submaps.push_back(submap);
    }
  }
  SamplerFrame Frame(int i) const {
    SamplerFrame f;
    f.timestamp = static_cast<Timestamp>(i) * 1000000;
    f.image = cv::Mat(8, 8, CV_8UC1, cv::Scalar(i % 256));
    f.state = states[i];
    f.submap_id = submaps[i];
    f.submap_frames = counts[i];
    return f;
  }
  int size() const { return static_cast<int>(states.size()); }
};

std::vector<int> Indices(const ImageWindow& w) {
  std::vector<int> out;
  for (const auto& f : w.frames) out.push_back(static_cast<int>(f.timestamp / 1000000));
  return out;
}
std::string Sets(const ImageWindow& w) {
  std::string s;
  for (const auto& f : w.frames) s += static_cast<char>('0' + static_cast<int>(f.set));
  return s;
}

struct FeedResult {
  std::vector<ImageWindow> windows;
  std::vector<int> emitted_at;
};
FeedResult Feed(Sampler* sampler, const Script& sc, bool flush = false) {
  FeedResult r;
  for (int i = 0; i < sc.size(); ++i) {
    ImageWindow w;
    if (sampler->AddFrame(sc.Frame(i), &w)) {
      r.windows.push_back(w);
      r.emitted_at.push_back(i);
    }
  }
  ImageWindow w;
  if (flush && sampler->Flush(&w)) {
    r.windows.push_back(w);
    r.emitted_at.push_back(sc.size());
  }
  return r;
}

SamplerOptions PaperOptions() {
  SamplerOptions o;
  o.inter = 5;
  o.th_s3 = 8;
  o.th_s3_unit = S3Unit::kFrames;  // the paper's fr1_room figures count frames
  o.len = 4;
  o.max_s2 = 100;
  o.pre_loss = 0;  // rumi's pre-loss tail is not in the paper (own test below)
  return o;
}

// fr1_room-like: tracked in submap 0 for 30 frames, lost for 12 (4 of them
// re-initialising the new submap 1), tracked again in submap 1.
TEST(Sampler, PaperExampleSparseDenseSparseStopsAtThS3) {
  Script sc;
  sc.Add(30, TrackingState::kTracking, 0);  // frames 0..29
  sc.Add(8, TrackingState::kLost, 0);       // 30..37
  sc.Add(4, TrackingState::kInitializing, 1);  // 38..41, submap 1 counts 1..4
  sc.Add(20, TrackingState::kTracking, 1);  // 42..61, counts 5..24
  Sampler s(PaperOptions(), PinholeCameraOptions());
  const FeedResult r = Feed(&s, sc);
  ASSERT_EQ(r.windows.size(), 1u);
  // S1: tracked frames 0,5,..,25, the last len=4 kept. S2: 30..41 all.
  // S3: resume at 42 (count 5) -> 42 sampled; 43..46 counts 6..9: count 9 > 8
  // at frame 46 ends the window (the frame itself is not part of it).
  const std::vector<int> expect = {10, 15, 20, 25, 30, 31, 32, 33, 34, 35, 36, 37, 38, 39, 40, 41, 42};
  EXPECT_EQ(Indices(r.windows[0]), expect);
  EXPECT_EQ(Sets(r.windows[0]), "11112222222222223");
  EXPECT_EQ(r.emitted_at[0], 46);
  EXPECT_EQ(r.windows[0].id, 0);
  // Per-frame front state travels with each sample; images are the right ones.
  for (const auto& f : r.windows[0].frames) {
    const int i = static_cast<int>(f.timestamp / 1000000);
    EXPECT_EQ(f.front_state, sc.states[i]);
    EXPECT_EQ(f.front_submap_id, sc.submaps[i]);
    ASSERT_FALSE(f.image.empty());
    EXPECT_EQ(f.image.at<uint8_t>(0, 0), i % 256);
  }
}

TEST(Sampler, S3RunsUntilSubmapExceedsThreshold) {
  // New submap starts counting at the resume: counts 1..9 -> S3 samples at
  // resume+0 and resume+5 (inter 5), window ends at count 9.
  Script sc;
  sc.Add(12, TrackingState::kTracking, 0);  // 0..11 -> S1 0,5,10
  sc.Add(3, TrackingState::kLost, 0);       // 12..14
  sc.Add(15, TrackingState::kTracking, 1);  // 15..29 counts 1..15
  Sampler s(PaperOptions(), PinholeCameraOptions());
  const FeedResult r = Feed(&s, sc);
  ASSERT_EQ(r.windows.size(), 1u);
  EXPECT_EQ(Indices(r.windows[0]), (std::vector<int>{0, 5, 10, 12, 13, 14, 15, 20}));
  EXPECT_EQ(Sets(r.windows[0]), "11122233");
  EXPECT_EQ(r.emitted_at[0], 23);  // count 9 at frame 23
}

TEST(Sampler, NothingShippedWhileTrackingNeverFails) {
  Script sc;
  sc.Add(5, TrackingState::kInitializing, 0);  // start-up is not a loss
  sc.Add(200, TrackingState::kTracking, 0);
  Sampler s(PaperOptions(), PinholeCameraOptions());
  const FeedResult r = Feed(&s, sc, /*flush=*/true);
  EXPECT_TRUE(r.windows.empty());
  EXPECT_EQ(s.pending(), 4u);  // only the S1 ring (len 4)
}

TEST(Sampler, SecondLossDuringS3ExtendsTheWindow) {
  Script sc;
  sc.Add(10, TrackingState::kTracking, 0);  // 0..9 -> S1 0,5
  sc.Add(2, TrackingState::kLost, 0);       // 10,11
  sc.Add(6, TrackingState::kTracking, 1);   // 12..17 counts 1..6 -> S3 12,17
  sc.Add(3, TrackingState::kLost, 1);       // 18..20 -> S2 again
  sc.Add(12, TrackingState::kTracking, 2);  // 21..32 counts 1..12 -> S3 21,26; ends at count 9 (29)
  Sampler s(PaperOptions(), PinholeCameraOptions());
  const FeedResult r = Feed(&s, sc);
  ASSERT_EQ(r.windows.size(), 1u);
  EXPECT_EQ(Indices(r.windows[0]), (std::vector<int>{0, 5, 10, 11, 12, 17, 18, 19, 20, 21, 26}));
  EXPECT_EQ(Sets(r.windows[0]), "11223322233");
  EXPECT_EQ(r.emitted_at[0], 29);
}

TEST(Sampler, RelocalisationInSameSubmapCountsFramesSinceResume) {
  Script sc;
  sc.Add(20, TrackingState::kTracking, 7);  // submap 7 already holds 20 frames
  sc.Add(2, TrackingState::kLost, 7);
  sc.Add(20, TrackingState::kTracking, 7);  // relocalised: 22..41
  Sampler s(PaperOptions(), PinholeCameraOptions());
  const FeedResult r = Feed(&s, sc);
  ASSERT_EQ(r.windows.size(), 1u);
  // S1 0..15 (frames 0..19), S2 20, 21; resume at 22: tracked-since-resume
  // 1, 2, ..; 9 > 8 at frame 30 (the submap's own count, 23+, would end S3 at once).
  EXPECT_EQ(Indices(r.windows[0]), (std::vector<int>{0, 5, 10, 15, 20, 21, 22, 27}));
  EXPECT_EQ(r.emitted_at[0], 30);
}

TEST(Sampler, LongLossThinsS2ByDoublingStride) {
  SamplerOptions o = PaperOptions();
  o.max_s2 = 8;
  o.len = 1;
  Script sc;
  sc.Add(1, TrackingState::kTracking, 0);  // 0
  sc.Add(40, TrackingState::kLost, 0);     // 1..40, loss positions 0..39
  sc.Add(10, TrackingState::kTracking, 1);  // 41.. counts 1..; S3 at 41, 46; end at 49
  Sampler s(o, PinholeCameraOptions());
  const FeedResult r = Feed(&s, sc);
  ASSERT_EQ(r.windows.size(), 1u);
  // Dense to 8 samples (pos 0..7) -> stride 2 keeps 0,2,4,6; continue 8,10,12,14
  // -> 8 again -> stride 4 keeps 0,4,8,12; 16,20,24,28 -> stride 8 keeps
  // 0,8,16,24; then 32 (and 40 would be next). Frame index = pos + 1.
  std::vector<int> expect = {0, 1, 9, 17, 25, 33, 41, 46};
  EXPECT_EQ(Indices(r.windows[0]), expect);
  EXPECT_EQ(Sets(r.windows[0]), "12222233");
  // Whole loss covered (first and near-last lost frame), bounded count.
  int s2 = 0;
  for (const auto& f : r.windows[0].frames) s2 += f.set == SampleSet::kS2;
  EXPECT_LT(s2, o.max_s2);
}

TEST(Sampler, EndOfStreamFlushesPendingWindowWithS2) {
  Script sc;
  sc.Add(6, TrackingState::kTracking, 0);  // S1 0,5
  sc.Add(3, TrackingState::kLost, 0);      // 6,7,8
  Sampler s(PaperOptions(), PinholeCameraOptions());
  const FeedResult r = Feed(&s, sc, /*flush=*/true);
  ASSERT_EQ(r.windows.size(), 1u);
  EXPECT_EQ(Indices(r.windows[0]), (std::vector<int>{0, 5, 6, 7, 8}));
  ImageWindow w;
  EXPECT_FALSE(s.Flush(&w));  // nothing left
}

TEST(Sampler, ConsecutiveWindowsGetNewIdsAndS3SeedsS1) {
  Script sc;
  sc.Add(10, TrackingState::kTracking, 0);  // S1 0,5
  sc.Add(1, TrackingState::kLost, 0);       // 10
  sc.Add(12, TrackingState::kTracking, 1);  // 11..22 counts 1..12: S3 11,16; end at 19; S1 21
  sc.Add(1, TrackingState::kLost, 1);       // 23
  sc.Add(12, TrackingState::kTracking, 2);  // 24..: S3 24,29; end at 32
  Sampler s(PaperOptions(), PinholeCameraOptions());
  const FeedResult r = Feed(&s, sc);
  ASSERT_EQ(r.windows.size(), 2u);
  EXPECT_EQ(Indices(r.windows[0]), (std::vector<int>{0, 5, 10, 11, 16}));
  EXPECT_EQ(r.windows[1].id, 1);
  // S1 of the second window: the previous S3 samples 11, 16 then sparse 21.
  EXPECT_EQ(Indices(r.windows[1]), (std::vector<int>{11, 16, 21, 23, 24, 29}));
  EXPECT_EQ(Sets(r.windows[1]), "111233");
}

// rumi's pre-loss tail: the tracked frames after the last sparse sample go
// with the window on a loss, in S1 and again on a second loss during S3.
TEST(Sampler, PreLossTailShipsTheLastTrackedFrames) {
  SamplerOptions o = PaperOptions();
  o.pre_loss = 2;
  Script sc;
  sc.Add(9, TrackingState::kTracking, 0);  // S1 0,5; tail 6,7,8 -> the last 2: 7,8
  sc.Add(2, TrackingState::kLost, 0);      // 9,10
  sc.Add(8, TrackingState::kTracking, 1);  // 11..18 counts 1..8: S3 11,16; tail 17,18
  sc.Add(2, TrackingState::kLost, 1);      // 19,20: the tail goes in as S3
  sc.Add(9, TrackingState::kTracking, 2);  // 21..29: S3 21,26; count 9 at 29 ends it
  Sampler s(o, PinholeCameraOptions());
  const FeedResult r = Feed(&s, sc);
  ASSERT_EQ(r.windows.size(), 1u);
  EXPECT_EQ(Indices(r.windows[0]), (std::vector<int>{0, 5, 7, 8, 9, 10, 11, 16, 17, 18, 19, 20, 21, 26}));
  EXPECT_EQ(Sets(r.windows[0]), "11112233332233");
  EXPECT_EQ(r.emitted_at[0], 29);
  for (const auto& f : r.windows[0].frames) {
    const int i = static_cast<int>(f.timestamp / 1000000);
    EXPECT_EQ(f.image.at<uint8_t>(0, 0), i % 256);
    EXPECT_EQ(f.front_state, sc.states[i]);
  }
  EXPECT_EQ(s.tail(), 2u);  // 28, 29 wait for the next sample or loss
}

// Tail frames are copies: a driver reusing one buffer cannot change them.
TEST(Sampler, PreLossTailCopiesImages) {
  SamplerOptions o = PaperOptions();
  o.pre_loss = 4;
  Sampler s(o, PinholeCameraOptions());
  cv::Mat buffer(4, 4, CV_8UC1);
  ImageWindow w;
  for (int i = 0; i < 8; ++i) {  // tracked 0..4 (sample 0, tail 1..4), lost 5..7
    buffer.setTo(i + 1);
    SamplerFrame f;
    f.timestamp = i;
    f.image = buffer;
    f.state = i < 5 ? TrackingState::kTracking : TrackingState::kLost;
    f.submap_id = 0;
    f.submap_frames = i + 1;
    s.AddFrame(f, &w);
  }
  ASSERT_TRUE(s.Flush(&w));
  ASSERT_EQ(w.frames.size(), 8u);
  for (int i = 0; i < 8; ++i) EXPECT_EQ(w.frames[i].image.at<uint8_t>(0, 0), i + 1) << i;
}

TEST(Sampler, ClonesSampledImagesSoBufferReuseIsHarmless) {
  SamplerOptions o = PaperOptions();
  Sampler s(o, PinholeCameraOptions());
  cv::Mat buffer(4, 4, CV_8UC1);  // a camera driver reusing one buffer
  ImageWindow w;
  const TrackingState states[] = {TrackingState::kTracking, TrackingState::kLost, TrackingState::kLost};
  for (int i = 0; i < 3; ++i) {
    buffer.setTo(i + 1);
    SamplerFrame f;
    f.timestamp = i;
    f.image = buffer;
    f.state = states[i];
    f.submap_id = 0;
    f.submap_frames = i + 1;
    s.AddFrame(f, &w);
  }
  ASSERT_TRUE(s.Flush(&w));
  ASSERT_EQ(w.frames.size(), 3u);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(w.frames[i].image.at<uint8_t>(0, 0), i + 1);
}

// th_s3 in keyframes: re-initialisation frames do not end S3 at once; it
// lasts until the new submap holds more than th_s3 keyframes (or, after a
// relocalisation into the same submap, until th_s3 keyframes were added).
TEST(Sampler, S3CountsKeyframesOfTheNewSubmap) {
  struct F { TrackingState st; int64_t submap, frames, kfs; };
  auto script = [](bool same_submap) {
    std::vector<F> v;
    for (int i = 0; i < 20; ++i) v.push_back({TrackingState::kTracking, 0, i + 1, 1 + i / 4});
    for (int i = 0; i < 10; ++i) v.push_back({TrackingState::kLost, 0, 21 + i, 5});
    if (same_submap) {  // relocalised: submap 0 goes on from 5 keyframes
      for (int i = 0; i < 40; ++i) v.push_back({TrackingState::kTracking, 0, 31 + i, 5 + i / 3});
    } else {  // new submap 1: 10 initialising frames, then 2 keyframes + one per 3 frames
      for (int i = 0; i < 10; ++i) v.push_back({TrackingState::kInitializing, 1, 1 + i, 0});
      for (int i = 0; i < 40; ++i) v.push_back({TrackingState::kTracking, 1, 11 + i, 2 + i / 3});
    }
    return v;
  };
  auto run = [](const std::vector<F>& v, S3Unit unit, std::vector<int>* s3) {
    SamplerOptions o = PaperOptions();
    o.th_s3_unit = unit;
    Sampler sampler(o, PinholeCameraOptions());
    for (size_t i = 0; i < v.size(); ++i) {
      SamplerFrame f;
      f.timestamp = static_cast<Timestamp>(i) * 1000000;
      f.image = cv::Mat(8, 8, CV_8UC1, cv::Scalar(0));
      f.state = v[i].st;
      f.submap_id = v[i].submap;
      f.submap_frames = v[i].frames;
      f.submap_keyframes = v[i].kfs;
      ImageWindow w;
      if (sampler.AddFrame(f, &w)) {
        s3->clear();
        for (const auto& wf : w.frames)
          if (wf.set == SampleSet::kS3) s3->push_back(static_cast<int>(wf.timestamp / 1000000));
        return static_cast<int>(i);
      }
    }
    return -1;
  };
  std::vector<int> s3;
  // New submap: counting frames, the 10 initialising frames already exceed 8
  // at the resume (frame 40), so S3 is empty.
  EXPECT_EQ(run(script(false), S3Unit::kFrames, &s3), 40);
  EXPECT_TRUE(s3.empty());
  // Counting keyframes: 2 + (i - 40) / 3 > 8 first at i = 61.
  EXPECT_EQ(run(script(false), S3Unit::kKeyframes, &s3), 61);
  EXPECT_EQ(s3, (std::vector<int>{40, 45, 50, 55, 60}));
  // Same submap after relocalisation at frame 30: keyframes added since the
  // resume, 5 + (i - 30) / 3 - 5 > 8 first at i = 57.
  EXPECT_EQ(run(script(true), S3Unit::kKeyframes, &s3), 57);
  EXPECT_EQ(s3, (std::vector<int>{30, 35, 40, 45, 50, 55}));
  // ... and counting frames tracked since the resume: > 8 at i = 38.
  EXPECT_EQ(run(script(true), S3Unit::kFrames, &s3), 38);
  EXPECT_EQ(s3, (std::vector<int>{30, 35}));
}

// A start that takes longer than startup_frames (no texture, no motion):
// those frames go to the back like a loss, closed by S3 on the first map.
TEST(Sampler, LongStartGoesToTheBackClosedByS3) {
  auto feed = [](int startup, int init_frames, int tracked, bool flush, std::vector<ImageWindow>* out) {
    SamplerOptions o = PaperOptions();
    o.th_s3_unit = S3Unit::kKeyframes;
    o.startup_frames = startup;
    Sampler sampler(o, PinholeCameraOptions());
    const int n = init_frames + tracked;
    for (int i = 0; i < n; ++i) {
      SamplerFrame f;
      f.timestamp = static_cast<Timestamp>(i) * 1000000;
      f.image = cv::Mat(8, 8, CV_8UC1, cv::Scalar(i % 256));
      const bool init = i < init_frames;
      f.state = init ? TrackingState::kInitializing : TrackingState::kTracking;
      f.submap_id = 0;
      f.submap_frames = i + 1;
      f.submap_keyframes = init ? 0 : 2 + (i - init_frames) / 3;
      ImageWindow w;
      if (sampler.AddFrame(f, &w)) out->push_back(w);
    }
    ImageWindow w;
    if (flush && sampler.Flush(&w)) out->push_back(w);
    return sampler.pending();
  };
  std::vector<ImageWindow> w;
  feed(30, 40, 40, false, &w);
  ASSERT_EQ(w.size(), 1u);
  std::vector<int> expect;
  for (int i = 0; i < 40; ++i) expect.push_back(i);
  for (int i : {40, 45, 50, 55, 60}) expect.push_back(i);  // 2 + 21 / 3 > 8 at frame 61
  EXPECT_EQ(Indices(w[0]), expect);
  EXPECT_EQ(Sets(w[0]), std::string(40, '2') + "33333");
  // A normal start (30 frames, not more) is dropped: nothing is shipped and
  // only the S1 ring stays pending.
  w.clear();
  EXPECT_EQ(feed(30, 30, 40, true, &w), 4u);
  EXPECT_TRUE(w.empty());
  // startup_frames 0: never shipped.
  EXPECT_EQ(feed(0, 40, 40, true, &w), 4u);
  EXPECT_TRUE(w.empty());
  // A front that never starts leaves the back one window at the end.
  feed(30, 50, 0, true, &w);
  ASSERT_EQ(w.size(), 1u);
  EXPECT_EQ(w[0].frames.size(), 50u);
  w.clear();
  feed(30, 20, 0, true, &w);
  EXPECT_TRUE(w.empty());
}

TEST(SamplerOptions, CheckAndRead) {
  SamplerOptions o;
  EXPECT_TRUE(o.Check());
  EXPECT_EQ(o.inter, 5);
  EXPECT_EQ(o.th_s3, 20);
  EXPECT_EQ(o.th_s3_unit, S3Unit::kKeyframes);
  o.inter = 0;
  std::string why;
  EXPECT_FALSE(o.Check(&why));
  EXPECT_NE(why.find("inter"), std::string::npos);

  EXPECT_EQ(o.startup_frames, 30);
  EXPECT_EQ(o.pre_loss, 4);
  auto cfg = LoadConfigString(
      "inter: 3\nlen: 6\nth_s3: 12\nmax_s2: 50\nstartup_frames: 0\npre_loss: 1\nclone_images: false\n");
  SamplerOptions r;
  ReadOptions(cfg, &r);
  cfg.Finish();
  EXPECT_EQ(r.inter, 3);
  EXPECT_EQ(r.len, 6);
  EXPECT_EQ(r.th_s3, 12);
  EXPECT_EQ(r.max_s2, 50);
  EXPECT_EQ(r.startup_frames, 0);
  EXPECT_EQ(r.pre_loss, 1);
  EXPECT_FALSE(r.clone_images);
  auto negative = LoadConfigString("startup_frames: -1\n");
  SamplerOptions n;
  EXPECT_THROW(ReadOptions(negative, &n), ConfigError);
  auto negative_tail = LoadConfigString("pre_loss: -2\n");
  EXPECT_THROW(ReadOptions(negative_tail, &n), ConfigError);
  auto unit = LoadConfigString("th_s3_unit: frames\n");
  ReadOptions(unit, &r);
  EXPECT_EQ(r.th_s3_unit, S3Unit::kFrames);
  auto bad_unit = LoadConfigString("th_s3_unit: seconds\n");
  EXPECT_THROW(ReadOptions(bad_unit, &r), ConfigError);

  auto bad = LoadConfigString("inter: 0\n");
  EXPECT_THROW(ReadOptions(bad, &r), ConfigError);
  auto typo = LoadConfigString("intr: 3\n");
  SamplerOptions t;
  ReadOptions(typo, &t);
  EXPECT_THROW(typo.Finish(), ConfigError);
}

}  // namespace
}  // namespace rumi
