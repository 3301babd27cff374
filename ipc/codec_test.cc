#include <gtest/gtest.h>

#include <cstring>
#include <random>

#include "ipc/envelope.h"
#include "ipc/submap_codec.h"
#include "ipc/test_data.h"
#include "ipc/window_codec.h"

namespace rumi {
namespace {

using ipc_test::MakeSubmap;
using ipc_test::MakeWindow;

bool SameBits(double a, double b) { return std::memcmp(&a, &b, sizeof(double)) == 0; }

void ExpectSe3Exact(const Se3& a, const Se3& b) {
  for (int i = 0; i < 4; ++i) EXPECT_TRUE(SameBits(a.rotation().coeffs()[i], b.rotation().coeffs()[i]));
  for (int i = 0; i < 3; ++i) EXPECT_TRUE(SameBits(a.translation()[i], b.translation()[i]));
}

void ExpectMatEqual(const cv::Mat& a, const cv::Mat& b) {
  EXPECT_EQ(a.rows, b.rows);
  EXPECT_EQ(a.cols, b.cols);
  EXPECT_EQ(a.type(), b.type());
  if (a.empty() || b.empty()) {
    EXPECT_EQ(a.empty(), b.empty());
    return;
  }
  ASSERT_EQ(a.total() * a.elemSize(), b.total() * b.elemSize());
  EXPECT_EQ(0, std::memcmp(a.data, b.data, a.total() * a.elemSize()));
}

void ExpectSubmapEqual(const Submap& a, const Submap& b) {
  EXPECT_EQ(a.id, b.id);
  EXPECT_EQ(a.source, b.source);
  EXPECT_EQ(a.camera.width, b.camera.width);
  EXPECT_EQ(a.camera.height, b.camera.height);
  EXPECT_TRUE(SameBits(a.camera.fx, b.camera.fx));
  EXPECT_TRUE(SameBits(a.camera.fy, b.camera.fy));
  EXPECT_TRUE(SameBits(a.camera.cx, b.camera.cx));
  EXPECT_TRUE(SameBits(a.camera.cy, b.camera.cy));
  ASSERT_EQ(a.keyframes.size(), b.keyframes.size());
  for (size_t i = 0; i < a.keyframes.size(); ++i) {
    const Keyframe &x = a.keyframes[i], &y = b.keyframes[i];
    EXPECT_EQ(x.id, y.id);
    EXPECT_EQ(x.timestamp, y.timestamp);
    ExpectSe3Exact(x.T_cw, y.T_cw);
    ASSERT_EQ(x.keypoints.size(), y.keypoints.size());
    for (size_t k = 0; k < x.keypoints.size(); ++k) EXPECT_EQ(x.keypoints[k], y.keypoints[k]);
    EXPECT_EQ(x.octaves, y.octaves);
    EXPECT_EQ(x.point_ids, y.point_ids);
    ExpectMatEqual(x.descriptors, y.descriptors);
  }
  ASSERT_EQ(a.points.size(), b.points.size());
  for (size_t i = 0; i < a.points.size(); ++i) {
    const MapPoint &x = a.points[i], &y = b.points[i];
    EXPECT_EQ(x.id, y.id);
    for (int d = 0; d < 3; ++d) EXPECT_TRUE(SameBits(x.position[d], y.position[d]));
    ExpectMatEqual(x.descriptor, y.descriptor);
    ASSERT_EQ(x.observations.size(), y.observations.size());
    for (size_t o = 0; o < x.observations.size(); ++o) {
      EXPECT_EQ(x.observations[o].keyframe_id, y.observations[o].keyframe_id);
      EXPECT_EQ(x.observations[o].keypoint_index, y.observations[o].keypoint_index);
    }
  }
  ASSERT_EQ(a.frames.size(), b.frames.size());
  for (size_t i = 0; i < a.frames.size(); ++i) {
    EXPECT_EQ(a.frames[i].timestamp, b.frames[i].timestamp);
    EXPECT_EQ(a.frames[i].state, b.frames[i].state);
    EXPECT_EQ(a.frames[i].submap_id, b.frames[i].submap_id);
    ExpectSe3Exact(a.frames[i].T_wc, b.frames[i].T_wc);
  }
  ASSERT_EQ(a.odometry.size(), b.odometry.size());
  for (size_t i = 0; i < a.odometry.size(); ++i) {
    EXPECT_EQ(a.odometry[i].timestamp, b.odometry[i].timestamp);
    ExpectSe3Exact(a.odometry[i].T_wb, b.odometry[i].T_wb);
  }
}

void ExpectWindowEqual(const ImageWindow& a, const ImageWindow& b) {
  EXPECT_EQ(a.id, b.id);
  const auto &c = a.camera, &d = b.camera;
  EXPECT_EQ(c.width, d.width);
  EXPECT_EQ(c.height, d.height);
  for (auto [x, y] : {std::pair{c.fx, d.fx}, {c.fy, d.fy}, {c.cx, d.cx}, {c.cy, d.cy}, {c.k1, d.k1},
                      {c.k2, d.k2}, {c.p1, d.p1}, {c.p2, d.p2}, {c.k3, d.k3}}) {
    EXPECT_TRUE(SameBits(x, y));
  }
  ASSERT_EQ(a.frames.size(), b.frames.size());
  for (size_t i = 0; i < a.frames.size(); ++i) {
    EXPECT_EQ(a.frames[i].timestamp, b.frames[i].timestamp);
    EXPECT_EQ(a.frames[i].front_state, b.frames[i].front_state);
    EXPECT_EQ(a.frames[i].set, b.frames[i].set);
    EXPECT_EQ(a.frames[i].front_submap_id, b.frames[i].front_submap_id);
    ExpectMatEqual(a.frames[i].image, b.frames[i].image);
  }
}

TEST(SubmapCodec, RoundTripIsExact) {
  for (int64_t id : {0, 1, 7}) {
    const Submap s = MakeSubmap(id);
    const auto bytes = EncodeSubmap(s);
    EXPECT_EQ(bytes.size(), EncodedSubmapSize(s));
    Submap out;
    std::string err;
    ASSERT_TRUE(DecodeSubmap(bytes.data(), bytes.size(), &out, &err)) << err;
    ExpectSubmapEqual(s, out);
    // Re-encoding the decoded submap gives the same bytes.
    EXPECT_EQ(EncodeSubmap(out), bytes);
  }
}

TEST(SubmapCodec, OdometryIsOptional) {
  Submap s = MakeSubmap(3);
  ASSERT_FALSE(s.odometry.empty());
  const size_t with = EncodedSubmapSize(s);
  s.odometry.clear();
  const auto bytes = EncodeSubmap(s);
  EXPECT_LT(bytes.size(), with);  // no ODOM section at all without a pose source
  Submap out = MakeSubmap(4);
  std::string err;
  ASSERT_TRUE(DecodeSubmap(bytes.data(), bytes.size(), &out, &err)) << err;
  EXPECT_TRUE(out.odometry.empty());
  ExpectSubmapEqual(s, out);
}

TEST(SubmapCodec, EmptySubmapAndEmptyMatsKeepType) {
  Submap s;
  Keyframe k;
  k.descriptors = cv::Mat(0, 0, CV_32FC1);
  s.keyframes.push_back(k);
  const auto bytes = EncodeSubmap(s);
  Submap out;
  ASSERT_TRUE(DecodeSubmap(bytes.data(), bytes.size(), &out));
  ASSERT_EQ(out.keyframes.size(), 1u);
  EXPECT_TRUE(out.keyframes[0].descriptors.empty());
  EXPECT_EQ(out.keyframes[0].descriptors.type(), CV_32FC1);
  EXPECT_EQ(out.id, -1);
}

TEST(SubmapCodec, EncodeIntoRefusesSmallBuffer) {
  const Submap s = MakeSubmap(3);
  std::vector<uint8_t> buf(EncodedSubmapSize(s) - 1);
  EXPECT_EQ(EncodeSubmapInto(s, buf.data(), buf.size()), 0u);
}

TEST(SubmapCodec, ClearErrorsOnForeignTruncatedAndNewerInput) {
  const auto bytes = EncodeSubmap(MakeSubmap(2));
  Submap out;
  std::string err;
  EXPECT_FALSE(DecodeSubmap(bytes.data(), 10, &out, &err));
  EXPECT_NE(err.find("truncated"), std::string::npos) << err;
  EXPECT_FALSE(DecodeSubmap(bytes.data(), bytes.size() - 8, &out, &err));
  EXPECT_NE(err.find("truncated"), std::string::npos) << err;
  const std::string junk = "P5\n640 480\n255\n................................................";
  EXPECT_FALSE(DecodeSubmap(reinterpret_cast<const uint8_t*>(junk.data()), junk.size(), &out, &err));
  EXPECT_NE(err.find("not rumi data"), std::string::npos) << err;
  // A window is not a submap.
  const auto win = EncodeWindow(MakeWindow(1, 2));
  EXPECT_FALSE(DecodeSubmap(win.data(), win.size(), &out, &err));
  EXPECT_NE(err.find("IWIN"), std::string::npos) << err;
  // A newer format version is refused by number.
  auto newer = bytes;
  newer[8] = 9;
  EXPECT_FALSE(DecodeSubmap(newer.data(), newer.size(), &out, &err));
  EXPECT_NE(err.find("format version 9"), std::string::npos) << err;
  EXPECT_FALSE(DecodeSubmap(nullptr, 0, &out, &err));
}

TEST(SubmapCodec, FuzzTruncationsAndBitFlipsNeverCrash) {
  const Submap s = MakeSubmap(5, 4, 20, 10);
  const auto bytes = EncodeSubmap(s);
  std::mt19937 rng(42);
  Submap out;
  std::string err;
  // Every truncation is rejected.
  for (size_t n = 0; n < bytes.size(); n += 1 + n / 50) {
    EXPECT_FALSE(DecodeSubmap(bytes.data(), n, &out, &err)) << n;
  }
  // Bit flips anywhere: caught by checksum or layout checks.
  int accepted = 0;
  for (int t = 0; t < 2000; ++t) {
    auto b = bytes;
    const int flips = 1 + t % 3;
    for (int f = 0; f < flips; ++f) b[rng() % b.size()] ^= static_cast<uint8_t>(1u << (rng() % 8));
    accepted += DecodeSubmap(b.data(), b.size(), &out, &err);
  }
  EXPECT_EQ(accepted, 0);
}

TEST(SubmapCodec, FuzzWithRepairedChecksumNeverCrashes) {
  const auto bytes = EncodeSubmap(MakeSubmap(9, 3, 10, 5));
  std::mt19937 rng(7);
  Submap out;
  std::string err;
  int decoded = 0, rejected = 0;
  for (int t = 0; t < 3000; ++t) {
    auto b = bytes;
    for (int f = 0; f < 1 + t % 4; ++f) {
      b[kEnvelopeHeaderBytes + rng() % (b.size() - kEnvelopeHeaderBytes)] = static_cast<uint8_t>(rng());
    }
    try {
      FinishEnvelope(b.data(), b.size());
    } catch (const CodecError&) {
      ++rejected;  // section table itself broken
      EXPECT_FALSE(DecodeSubmap(b.data(), b.size(), &out, &err));
      continue;
    }
    if (DecodeSubmap(b.data(), b.size(), &out, &err)) {
      ++decoded;
    } else {
      ++rejected;
      EXPECT_FALSE(err.empty());
    }
  }
  EXPECT_GT(rejected, 0);
  RecordProperty("decoded_after_repair", decoded);
}

// Frames of every kind the codec meets: odd sizes (padding), one without
// pixels, a non-continuous ROI, 16-bit colour.
ImageWindow MixedWindow(int frames) {
  ImageWindow w = MakeWindow(4, frames, 33, 17);
  w.frames[2].image = cv::Mat();
  cv::Mat big(40, 60, CV_8UC1, cv::Scalar(9));
  w.frames[3].image = big(cv::Rect(5, 5, 20, 10));
  w.frames[4].image = cv::Mat(3, 4, CV_16UC3, cv::Scalar(1000, 2000, 3000));
  return w;
}

// Decodes a copy and an in-place view of `bytes`; both must equal `w`.
void ExpectDecodesTo(const std::vector<uint8_t>& bytes, const ImageWindow& w, ImageWindow* view) {
  ImageWindow copy;
  std::string err;
  ASSERT_TRUE(DecodeWindow(bytes.data(), bytes.size(), &copy, false, &err)) << err;
  ASSERT_TRUE(DecodeWindow(bytes.data(), bytes.size(), view, true, &err)) << err;
  ExpectWindowEqual(w, copy);
  ExpectWindowEqual(w, *view);
  EXPECT_FALSE(copy.frames[0].image.data >= bytes.data() && copy.frames[0].image.data < bytes.data() + bytes.size());
}

TEST(WindowCodec, RoundTripCopyAndInPlace) {
  const ImageWindow w = MixedWindow(5);
  const auto bytes = EncodeWindow(w);
  EXPECT_EQ(bytes.size(), EncodedWindowSize(w));
  ImageWindow view;
  ExpectDecodesTo(bytes, w, &view);
  // In place really means no copy: pixels live inside the record, 64-aligned.
  const uint8_t* p = view.frames[0].image.data;
  EXPECT_GE(p, bytes.data());
  EXPECT_LT(p, bytes.data() + bytes.size());
  EXPECT_EQ((p - bytes.data()) % 64, 0);
}

// The PNG frames of a record: where each PNG signature starts.
std::vector<size_t> PngStarts(const std::vector<uint8_t>& b) {
  static const uint8_t sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  std::vector<size_t> at;
  for (size_t i = 0; i + 8 <= b.size(); ++i)
    if (std::equal(sig, sig + 8, b.begin() + static_cast<std::ptrdiff_t>(i))) at.push_back(i);
  return at;
}

// Frame i's row in the FRMS table (after the 40-byte header and HEAD).
size_t FrameRow(size_t i) { return kEnvelopeHeaderBytes + 16 + 96 + 16 + 48 * i; }

TEST(WindowCodec, PngFramesRoundTripExactlyInFewerBytes) {
  ImageWindow w = MixedWindow(6);
  w.frames[5].image = cv::Mat(5, 6, CV_32FC1, cv::Scalar(0.25f));  // PNG cannot hold it: raw
  const auto png = EncodeWindow(w, WindowPixels::kPng);
  const auto raw = EncodeWindow(w);
  EXPECT_EQ(PngStarts(png).size(), 4u);  // frames 0, 1, 3, 4
  EXPECT_TRUE(PngStarts(raw).empty());
  EXPECT_LT(png.size(), raw.size());
  ImageWindow view;
  ExpectDecodesTo(png, w, &view);
  // The raw float frame is still read in place; PNG frames have their own memory.
  EXPECT_TRUE(view.frames[5].image.data >= png.data() && view.frames[5].image.data < png.data() + png.size());
  EXPECT_FALSE(view.frames[0].image.data >= png.data() && view.frames[0].image.data < png.data() + png.size());

  // A 640x480 frame of smooth shading and noise of a few grey levels, as a
  // camera gives: PNG holds it in well under the raw bytes.
  ImageWindow cam = MakeWindow(1, 1, 640, 480);
  cv::Mat noise(480, 640, CV_8UC1);
  cv::RNG rng(1);
  rng.fill(noise, cv::RNG::NORMAL, 0, 2);
  cam.frames[0].image = cam.frames[0].image / 2 + noise;
  const auto cam_png = EncodeWindow(cam, WindowPixels::kPng);
  EXPECT_LT(cam_png.size(), EncodedWindowSize(cam) * 3 / 4);
  ExpectDecodesTo(cam_png, cam, &view);
}

TEST(WindowCodec, VersionOneRecordsStillDecode) {
  const ImageWindow w = MakeWindow(2, 3);
  auto b = EncodeWindow(w);
  b[8] = 1;  // u16 version after magic and kind
  b[9] = 0;
  FinishEnvelope(b.data(), b.size());
  ImageWindow out;
  std::string err;
  ASSERT_TRUE(DecodeWindow(b.data(), b.size(), &out, true, &err)) << err;
  ExpectWindowEqual(w, out);
}

TEST(WindowCodec, BadPngFramesAreNamedErrors) {
  const ImageWindow w = MakeWindow(3, 2, 64, 48);
  const auto good = EncodeWindow(w, WindowPixels::kPng);
  const std::vector<size_t> at = PngStarts(good);
  ASSERT_EQ(at.size(), 2u);
  ImageWindow out;
  std::string err;

  auto b = good;  // pixel data flipped (PNG bytes are not checksummed by the envelope)
  b[at[1] + 60] ^= 0x5a;
  EXPECT_FALSE(DecodeWindow(b.data(), b.size(), &out, false, &err));
  EXPECT_NE(err.find("frame 1"), std::string::npos) << err;

  b = good;  // the PNG's own header disagrees with the frame table
  b[at[0] + 23] ^= 1;  // IHDR height
  EXPECT_FALSE(DecodeWindow(b.data(), b.size(), &out, false, &err));
  EXPECT_NE(err.find("frame 0: not a PNG of 64x48"), std::string::npos) << err;

  // Metadata changed and its checksum made good again: frame, encoding, rows, cols.
  const auto patch = [&](size_t frame, uint16_t enc, int32_t rows, int32_t cols) {
    auto c = good;
    std::memcpy(&c[FrameRow(frame) + 18], &enc, 2);
    std::memcpy(&c[FrameRow(frame) + 20], &rows, 4);
    std::memcpy(&c[FrameRow(frame) + 24], &cols, 4);
    FinishEnvelope(c.data(), c.size());
    return c;
  };
  // A few PNG bytes must not claim gigabytes.
  b = patch(0, 1, 100000, 100000);
  EXPECT_FALSE(DecodeWindow(b.data(), b.size(), &out, false, &err));
  EXPECT_NE(err.find("frame 0: image too large"), std::string::npos) << err;
  // An encoding this version does not know.
  b = patch(1, 7, 48, 64);
  EXPECT_FALSE(DecodeWindow(b.data(), b.size(), &out, false, &err));
  EXPECT_NE(err.find("frame 1: unknown pixel encoding 7"), std::string::npos) << err;
  // Raw pixels labelled PNG.
  const auto raw = EncodeWindow(w);
  b = raw;
  const uint16_t png = 1;
  std::memcpy(&b[FrameRow(0) + 18], &png, 2);
  FinishEnvelope(b.data(), b.size());
  EXPECT_FALSE(DecodeWindow(b.data(), b.size(), &out, false, &err));
  EXPECT_NE(err.find("frame 0: not a PNG"), std::string::npos) << err;

  // Truncations and flips anywhere never crash.
  for (size_t n = 0; n < good.size(); n += 7) EXPECT_FALSE(DecodeWindow(good.data(), n, &out, false, &err));
  std::mt19937 rng(5);
  for (int t = 0; t < 500; ++t) {
    b = good;
    b[at[0] + rng() % (b.size() - at[0])] = static_cast<uint8_t>(rng());
    DecodeWindow(b.data(), b.size(), &out, t % 2 == 0, &err);
  }
}

TEST(WindowCodec, FuzzTruncationsAndFlipsNeverCrash) {
  const auto bytes = EncodeWindow(MakeWindow(11, 3, 16, 8));
  std::mt19937 rng(3);
  ImageWindow out;
  std::string err;
  for (size_t n = 0; n < bytes.size(); ++n) EXPECT_FALSE(DecodeWindow(bytes.data(), n, &out, true, &err));
  int meta_accepted = 0;
  for (int t = 0; t < 3000; ++t) {
    auto b = bytes;
    const size_t at = rng() % b.size();
    b[at] = static_cast<uint8_t>(rng());
    if (t % 2) {
      try {
        FinishEnvelope(b.data(), b.size());
      } catch (const CodecError&) {
      }
    }
    if (DecodeWindow(b.data(), b.size(), &out, t % 3 == 0, &err) && t % 2 == 0 && b != bytes) {
      ++meta_accepted;  // only pixel flips may pass unchecked
    }
  }
  // Without checksum repair, only changes in pixel bytes (unchecked) pass.
  ImageWindow ref;
  ASSERT_TRUE(DecodeWindow(bytes.data(), bytes.size(), &ref, false, &err));
  RecordProperty("pixel_flips_accepted", meta_accepted);
  // A flipped bit in the metadata is caught.
  auto b = bytes;
  b[kEnvelopeHeaderBytes + 20] ^= 1;
  EXPECT_FALSE(DecodeWindow(b.data(), b.size(), &out, false, &err));
  EXPECT_NE(err.find("checksum"), std::string::npos) << err;
}

}  // namespace
}  // namespace rumi
