#include "common/orb_extractor.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

namespace rumi {
namespace {
constexpr int kPatchRadius = 15;  // orientation patch (ORB's 31x31 patch)
constexpr int kBorder = 19;       // room for the rotated descriptor pattern
}  // namespace

OrbExtractor::OrbExtractor(const OrbExtractorOptions& o) : o_(o) {
  const int n = o_.num_levels;
  scales_.resize(n);
  sigma2_.resize(n);
  for (int l = 0; l < n; ++l) {
    scales_[l] = std::pow(o_.scale_factor, l);
    sigma2_[l] = scales_[l] * scales_[l];
  }
  // Features per level in proportion to the level's area (geometric series).
  const double f = 1.0 / (o_.scale_factor * o_.scale_factor);
  double sum = 0, w = 1;
  for (int l = 0; l < n; ++l, w *= f) sum += w;
  per_level_.resize(n);
  int total = 0;
  w = 1;
  for (int l = 0; l < n - 1; ++l, w *= f) {
    per_level_[l] = static_cast<int>(std::round(o_.num_features * w / sum));
    total += per_level_[l];
  }
  per_level_[n - 1] = std::max(0, o_.num_features - total);
  orb_ = cv::ORB::create(o_.num_features, 1.2f, 1, kBorder, 0, 2, cv::ORB::HARRIS_SCORE, 31, 20);
  umax_.resize(kPatchRadius + 1);
  for (int v = 0; v <= kPatchRadius; ++v)
    umax_[v] = static_cast<int>(std::floor(std::sqrt(kPatchRadius * kPatchRadius - v * v + 0.5)));
}

void OrbExtractor::Extract(const cv::Mat& grey, std::vector<cv::KeyPoint>* keypoints,
                           cv::Mat* descriptors) {
  keypoints->clear();
  const int n = o_.num_levels;
  pyramid_.resize(n);
  pyramid_[0] = grey;
  for (int l = 1; l < n; ++l) {
    const cv::Size sz(cvRound(grey.cols / scales_[l]), cvRound(grey.rows / scales_[l]));
    cv::resize(pyramid_[l - 1], pyramid_[l], sz, 0, 0, cv::INTER_LINEAR);
  }
  std::vector<cv::Mat> level_desc(n);
  std::vector<std::vector<cv::KeyPoint>> level_kps(n);
  std::vector<cv::KeyPoint> fast;
  for (int l = 0; l < n; ++l) {
    const cv::Mat& img = pyramid_[l];
    if (img.cols <= 2 * kBorder + 8 || img.rows <= 2 * kBorder + 8 || per_level_[l] == 0) continue;
    // Strong corners over the whole level; weak ones only in cells without
    // any (cheaper than a low threshold everywhere).
    cv::FAST(img, fast, o_.fast_threshold, true);
    const int cs = std::max(8, static_cast<int>(o_.cell_size));
    const int gw = (img.cols + cs - 1) / cs, gh = (img.rows + cs - 1) / cs;
    std::vector<std::vector<int>> cells(gw * gh);
    auto bucket = [&](int i) {
      const cv::Point2f& p = fast[i].pt;
      if (p.x < kBorder || p.y < kBorder || p.x >= img.cols - kBorder || p.y >= img.rows - kBorder) return;
      cells[static_cast<int>(p.y) / cs * gw + static_cast<int>(p.x) / cs].push_back(i);
    };
    for (int i = 0; i < static_cast<int>(fast.size()); ++i) bucket(i);
    std::vector<cv::KeyPoint> weak;
    for (int cy = 0; cy < gh; ++cy) {
      for (int cx = 0; cx < gw; ++cx) {
        if (!cells[cy * gw + cx].empty()) continue;
        const int x0 = std::max(kBorder - 3, cx * cs - 3), y0 = std::max(kBorder - 3, cy * cs - 3);
        const int x1 = std::min(img.cols - kBorder + 3, (cx + 1) * cs + 3);
        const int y1 = std::min(img.rows - kBorder + 3, (cy + 1) * cs + 3);
        if (x1 - x0 < 8 || y1 - y0 < 8) continue;
        cv::FAST(img(cv::Rect(x0, y0, x1 - x0, y1 - y0)), weak, o_.fast_min_threshold, true);
        for (cv::KeyPoint& k : weak) {
          k.pt.x += x0;
          k.pt.y += y0;
          if (static_cast<int>(k.pt.x) / cs != cx || static_cast<int>(k.pt.y) / cs != cy) continue;
          fast.push_back(k);
          bucket(static_cast<int>(fast.size()) - 1);
        }
      }
    }
    for (auto& c : cells) {
      if (c.empty()) continue;
      std::sort(c.begin(), c.end(), [&](int a, int b) { return fast[a].response > fast[b].response; });
    }
    std::vector<cv::KeyPoint>& kept = level_kps[l];
    // Round-robin over cells: rank 0 of every cell, then rank 1, ... so the
    // budget is spread evenly; strong (>= threshold) corners before weak ones.
    for (int pass = 0; pass < 2 && static_cast<int>(kept.size()) < per_level_[l]; ++pass) {
      for (size_t rank = 0; static_cast<int>(kept.size()) < per_level_[l]; ++rank) {
        bool any = false;
        for (auto& c : cells) {
          if (rank >= c.size()) continue;
          const cv::KeyPoint& kp = fast[c[rank]];
          const bool strong = kp.response >= o_.fast_threshold;
          any = true;
          if ((pass == 0) != strong) continue;
          kept.push_back(kp);
          if (static_cast<int>(kept.size()) >= per_level_[l]) break;
        }
        if (!any) break;
      }
    }
    // Orientation by intensity centroid.
    for (size_t i = 0; i < kept.size(); ++i) {
      cv::KeyPoint& kp = kept[i];
      const int cx = cvRound(kp.pt.x), cy = cvRound(kp.pt.y);
      const uchar* center = img.ptr<uchar>(cy) + cx;
      const int step = static_cast<int>(img.step1());
      int m01 = 0, m10 = 0;
      for (int u = -kPatchRadius; u <= kPatchRadius; ++u) m10 += u * center[u];
      for (int v = 1; v <= kPatchRadius; ++v) {
        int vsum = 0;
        for (int u = -umax_[v]; u <= umax_[v]; ++u) {
          const int pv = center[u + v * step], mv = center[u - v * step];
          vsum += pv - mv;
          m10 += u * (pv + mv);
        }
        m01 += v * vsum;
      }
      kp.angle = cv::fastAtan2(static_cast<float>(m01), static_cast<float>(m10));
      kp.octave = 0;
      kp.class_id = static_cast<int>(i);
      kp.size = 31.f;
    }
    std::vector<cv::KeyPoint> kps = kept;
    cv::Mat desc;
    orb_->compute(img, kps, desc);  // keeps the given angles
    std::vector<cv::KeyPoint> out;
    cv::Mat d(static_cast<int>(kps.size()), 32, CV_8U);
    for (size_t i = 0; i < kps.size(); ++i) {
      cv::KeyPoint kp = kept[kps[i].class_id];
      kp.pt *= static_cast<float>(scales_[l]);
      kp.octave = l;
      kp.size = static_cast<float>(31 * scales_[l]);
      kp.class_id = -1;
      out.push_back(kp);
      desc.row(static_cast<int>(i)).copyTo(d.row(static_cast<int>(i)));
    }
    level_kps[l] = std::move(out);
    level_desc[l] = d;
  }
  std::vector<cv::Mat> descs;
  for (int l = 0; l < n; ++l) {
    keypoints->insert(keypoints->end(), level_kps[l].begin(), level_kps[l].end());
    if (!level_desc[l].empty()) descs.push_back(level_desc[l]);
  }
  if (descs.empty()) *descriptors = cv::Mat(0, 32, CV_8U);
  else cv::vconcat(descs, *descriptors);
}

int DescriptorDistance(const cv::Mat& a, const cv::Mat& b) {
  return DescriptorDistance(a.ptr<uint8_t>(), b.ptr<uint8_t>());
}

const OptionSpec<OrbExtractorOptions>& OrbExtractorOptions::Spec() {
  using O = OrbExtractorOptions;
  static const auto* spec = [] {
    auto* s = new OptionSpec<O>("orb");
    s->Number("num_features", &O::num_features, AtLeast(0), AtMost(100000),
              "features per frame; 0: auto (1000 up to 640x480, 2000 above)");
    s->Number("num_levels", &O::num_levels, AtLeast(1), AtMost(16), "pyramid levels");
    s->Number("scale_factor", &O::scale_factor, Above(1.0), Below(2.0), "pyramid scale between levels");
    s->Number("fast_threshold", &O::fast_threshold, AtLeast(1), AtMost(255), "preferred FAST corner strength");
    s->Number("fast_min_threshold", &O::fast_min_threshold, AtLeast(1), AtMost(255),
              "fallback FAST threshold in low-texture cells");
    s->Number("cell_size", &O::cell_size, AtLeast(8), AtMost(1024), "grid bucket side in pixels (level 0)");
    s->Rule("num_features must be 0 (auto) or >= 50", [](const O& o) { return o.num_features == 0 || o.num_features >= 50; });
    s->Rule("fast_min_threshold must be <= fast_threshold",
            [](const O& o) { return o.fast_min_threshold <= o.fast_threshold; });
    return s;
  }();
  return *spec;
}

bool OrbExtractorOptions::Check(std::string* why) const { return Spec().Check(*this, why); }

}  // namespace rumi
