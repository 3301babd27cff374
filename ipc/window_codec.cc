#include "ipc/window_codec.h"

#include <cstring>
#include <limits>

#include <opencv2/imgcodecs.hpp>

#include "ipc/envelope.h"

namespace rumi {
namespace {

constexpr uint32_t kKind = FourCc("IWIN");
constexpr uint32_t kHead = FourCc("HEAD");
constexpr uint32_t kFrames = FourCc("FRMS");
constexpr uint32_t kPixels = FourCc("PIXL");
constexpr size_t kImageAlign = 64;

// Per frame: its PNG bytes, or empty for raw pixels.
using PngFrames = std::vector<std::vector<uchar>>;

bool PngCanHold(const cv::Mat& m) {
  const int cn = m.channels(), depth = m.depth();
  return !m.empty() && (depth == CV_8U || depth == CV_16U) && (cn == 1 || cn == 3 || cn == 4);
}

constexpr uint64_t kMaxPngFrameBytes = uint64_t{256} << 20;

// The PNG signature and an IHDR chunk with this width and height.
bool PngHeaderSays(const uint8_t* p, uint64_t n, int32_t rows, int32_t cols) {
  static const uint8_t kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (n < 24 || std::memcmp(p, kSignature, 8) != 0 || std::memcmp(p + 12, "IHDR", 4) != 0) return false;
  const auto be32 = [](const uint8_t* q) {
    return static_cast<uint32_t>(q[0]) << 24 | static_cast<uint32_t>(q[1]) << 16 | static_cast<uint32_t>(q[2]) << 8 | q[3];
  };
  return be32(p + 16) == static_cast<uint32_t>(cols) && be32(p + 20) == static_cast<uint32_t>(rows);
}

PngFrames EncodePng(const ImageWindow& win) {
  PngFrames out(win.frames.size());
  // Level 1: within 3 % of level 9's bytes at a quarter of its time (a 60-frame
  // 640x480 window: 10.3 MB in 0.54 s against 9.8 MB in 2.0 s).
  const std::vector<int> params = {cv::IMWRITE_PNG_COMPRESSION, 1};
  for (size_t i = 0; i < win.frames.size(); ++i) {
    const cv::Mat& m = win.frames[i].image;
    bool ok = false;
    try {
      ok = PngCanHold(m) && cv::imencode(".png", m, out[i], params);
    } catch (const cv::Exception&) {
    }
    if (!ok) out[i].clear();  // stays raw
  }
  return out;
}

template <typename W>
void EncodeBody(W& w, const ImageWindow& win, const PngFrames* png = nullptr) {
  BeginEnvelope(w, kKind, kWindowFormatVersion);
  size_t at = BeginSection(w, kHead);
  w.template Put<int64_t>(win.id);
  const PinholeCameraOptions& c = win.camera;
  w.template Put<int32_t>(c.width);
  w.template Put<int32_t>(c.height);
  for (double v : {c.fx, c.fy, c.cx, c.cy, c.k1, c.k2, c.p1, c.p2, c.k3}) w.template Put<double>(v);
  w.template Put<uint64_t>(win.frames.size());
  EndSection(w, at);

  // Metadata table: per frame, where its pixels start in the PIXL section.
  at = BeginSection(w, kFrames);
  uint64_t offset = 0;
  for (size_t i = 0; i < win.frames.size(); ++i) {
    const WindowFrame& f = win.frames[i];
    const bool as_png = png && !(*png)[i].empty();
    w.template Put<int64_t>(f.timestamp);
    w.template Put<int64_t>(f.front_submap_id);
    w.template Put<uint8_t>(static_cast<uint8_t>(f.front_state));
    w.template Put<uint8_t>(static_cast<uint8_t>(f.set));
    w.template Put<uint16_t>(static_cast<uint16_t>(as_png ? WindowPixels::kPng : WindowPixels::kRaw));
    w.template Put<int32_t>(f.image.rows);
    w.template Put<int32_t>(f.image.cols);
    w.template Put<int32_t>(f.image.empty() ? CV_8UC1 : f.image.type());
    const uint64_t bytes = as_png ? (*png)[i].size() : f.image.empty() ? 0 : f.image.total() * f.image.elemSize();
    w.template Put<uint64_t>(offset);
    w.template Put<uint64_t>(bytes);
    offset = (offset + bytes + kImageAlign - 1) / kImageAlign * kImageAlign;
  }
  EndSection(w, at);

  at = BeginSection(w, kPixels, kSectionUnchecked);
  w.Align(kImageAlign);  // PIXL payload offsets are relative to this point
  for (size_t i = 0; i < win.frames.size(); ++i) {
    const WindowFrame& f = win.frames[i];
    if (f.image.empty()) continue;
    if (png && !(*png)[i].empty()) {
      w.PutBytes((*png)[i].data(), (*png)[i].size());
      w.Align(kImageAlign);
      continue;
    }
    const size_t row_bytes = static_cast<size_t>(f.image.cols) * f.image.elemSize();
    if (f.image.isContinuous()) {
      w.PutBytes(f.image.data, row_bytes * f.image.rows);
    } else {
      for (int r = 0; r < f.image.rows; ++r) w.PutBytes(f.image.ptr(r), row_bytes);
    }
    w.Align(kImageAlign);
  }
  EndSection(w, at);
}

}  // namespace

size_t EncodedWindowSize(const ImageWindow& w) {
  return EnvelopeSize([&](auto& writer) { EncodeBody(writer, w); });
}

size_t EncodeWindowInto(const ImageWindow& w, uint8_t* out, size_t capacity) {
  return EncodeEnvelopeInto([&](auto& writer) { EncodeBody(writer, w); }, out, capacity);
}

std::vector<uint8_t> EncodeWindow(const ImageWindow& w, WindowPixels pixels) {
  if (pixels == WindowPixels::kRaw) return EncodeEnvelope([&](auto& writer) { EncodeBody(writer, w); });
  const PngFrames png = EncodePng(w);
  return EncodeEnvelope([&](auto& writer) { EncodeBody(writer, w, &png); });
}

bool DecodeWindow(const uint8_t* data, size_t size, ImageWindow* out, bool in_place,
                  std::string* error) {
  const std::string what = "image window record";
  try {
    uint16_t version = 0;
    const auto sections = ParseEnvelope(data, size, kKind, kWindowFormatVersion, what, &version);
    ImageWindow win;
    uint64_t n = 0;
    {
      const Section& sec = FindSection(sections, kHead, what);
      BufferReader r(sec.data, sec.size, what + " HEAD");
      win.id = r.Get<int64_t>();
      PinholeCameraOptions& c = win.camera;
      c.width = r.Get<int32_t>();
      c.height = r.Get<int32_t>();
      for (double* v : {&c.fx, &c.fy, &c.cx, &c.cy, &c.k1, &c.k2, &c.p1, &c.p2, &c.k3}) *v = r.Get<double>();
      n = r.Get<uint64_t>();
      if (r.remaining() != 0) r.Fail("unread bytes");
    }
    const Section& meta = FindSection(sections, kFrames, what);
    const Section& pix = FindSection(sections, kPixels, what);
    BufferReader r(meta.data, meta.size, what + " FRMS");
    constexpr size_t kRow = 48;
    if (n != meta.size / kRow || meta.size % kRow != 0) {
      r.Fail("frame table of " + std::to_string(meta.size) + " bytes does not hold " + std::to_string(n) + " frames");
    }
    // Pixel offsets are relative to the first 64-aligned byte of the PIXL payload.
    const size_t lead = (kImageAlign - (reinterpret_cast<uintptr_t>(pix.data) - reinterpret_cast<uintptr_t>(data)) % kImageAlign) % kImageAlign;
    if (lead > pix.size) r.Fail("pixel section truncated");
    const uint8_t* pixels = pix.data + lead;
    const size_t pixel_bytes = pix.size - lead;
    win.frames.resize(n);
    for (size_t i = 0; i < n; ++i) {
      WindowFrame& f = win.frames[i];
      f.timestamp = r.Get<int64_t>();
      f.front_submap_id = r.Get<int64_t>();
      const uint8_t st = r.Get<uint8_t>();
      const uint8_t set = r.Get<uint8_t>();
      const uint16_t encoding = r.Get<uint16_t>();  // version 1: always 0
      if (version >= 2 && encoding > static_cast<uint16_t>(WindowPixels::kPng)) {
        r.Fail("frame " + std::to_string(i) + ": unknown pixel encoding " + std::to_string(encoding));
      }
      const bool png = version >= 2 && encoding == static_cast<uint16_t>(WindowPixels::kPng);
      if (st > static_cast<uint8_t>(TrackingState::kCoarse)) r.Fail("unknown tracking state " + std::to_string(st));
      if (set < 1 || set > 3) r.Fail("unknown sample set " + std::to_string(set));
      f.front_state = static_cast<TrackingState>(st);
      f.set = static_cast<SampleSet>(set);
      const int32_t rows = r.Get<int32_t>(), cols = r.Get<int32_t>(), type = r.Get<int32_t>();
      const uint64_t offset = r.Get<uint64_t>(), bytes = r.Get<uint64_t>();
      if (rows < 0 || cols < 0 || type < 0 || CV_MAT_DEPTH(type) > CV_16F ||
          type != CV_MAKETYPE(CV_MAT_DEPTH(type), CV_MAT_CN(type)) || CV_MAT_CN(type) > 4) {
        r.Fail("bad image geometry");
      }
      if (!png && static_cast<uint64_t>(rows) * static_cast<uint64_t>(cols) * CV_ELEM_SIZE(type) != bytes) {
        r.Fail("image byte count disagrees with its size");
      }
      if (offset > pixel_bytes || bytes > pixel_bytes - offset) r.Fail("image pixels out of range");
      if (png) {
        // PNG bytes are not checksummed: what they decode to must be exactly
        // the frame recorded, and the header must say so before anything is
        // allocated (a few bytes must not claim gigabytes).
        const uint64_t raw_bytes = static_cast<uint64_t>(rows) * static_cast<uint64_t>(cols) * CV_ELEM_SIZE(type);
        if (raw_bytes > kMaxPngFrameBytes) r.Fail("frame " + std::to_string(i) + ": image too large for a PNG frame");
        if (!PngHeaderSays(pixels + offset, bytes, rows, cols)) {
          r.Fail("frame " + std::to_string(i) + ": not a PNG of " + std::to_string(cols) + "x" + std::to_string(rows));
        }
        cv::Mat decoded;
        if (bytes <= static_cast<uint64_t>(std::numeric_limits<int>::max())) {
          try {
            decoded = cv::imdecode(cv::Mat(1, static_cast<int>(bytes), CV_8UC1, const_cast<uint8_t*>(pixels + offset)),
                                   cv::IMREAD_UNCHANGED);
          } catch (const cv::Exception&) {
            decoded = cv::Mat();
          }
        }
        if (decoded.empty()) r.Fail("frame " + std::to_string(i) + ": its PNG does not decode");
        if (decoded.rows != rows || decoded.cols != cols || decoded.type() != type) {
          r.Fail("frame " + std::to_string(i) + ": its PNG decodes to " + std::to_string(decoded.cols) + "x" +
                 std::to_string(decoded.rows) + " type " + std::to_string(decoded.type()) + ", recorded " +
                 std::to_string(cols) + "x" + std::to_string(rows) + " type " + std::to_string(type));
        }
        f.image = decoded;
        continue;
      }
      if (bytes == 0) {
        f.image = cv::Mat();
        continue;
      }
      cv::Mat view(rows, cols, type, const_cast<uint8_t*>(pixels + offset));
      f.image = in_place ? view : view.clone();
    }
    *out = std::move(win);
    return true;
  } catch (const CodecError& e) {
    if (error) *error = e.what();
    return false;
  }
}

}  // namespace rumi
