#include "common/calibration.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "common/camera_config.h"
#include "common/stats.h"

namespace rumi {
namespace fs = std::filesystem;

const OptionSpec<CalibrationOptions>& CalibrationOptions::Spec() {
  using O = CalibrationOptions;
  static const auto* spec = [] {
    auto* s = new OptionSpec<O>("calibration");
    s->Choice("pattern", &O::pattern, {"chessboard"}, "calibration target");
    s->Number("board_cols", &O::board_cols, AtLeast(3), AtMost(100), "inner corners along the long side");
    s->Number("board_rows", &O::board_rows, AtLeast(2), AtMost(100), "inner corners along the other side");
    s->Number("square_m", &O::square_m, Above(0.0), AtMost(10.0), "side of a square, metres");
    s->Number("min_views", &O::min_views, AtLeast(3), AtMost(10000), "images with the whole board found");
    s->Number("min_coverage", &O::min_coverage, AtLeast(0.0), AtMost(1.0), "share of the image the boards reach");
    s->Number("max_rms_px", &O::max_rms_px, Above(0.0), Unbounded<double>(), "overall reprojection RMS, pixels");
    s->Number("outlier_factor", &O::outlier_factor, Above(1.0), Unbounded<double>(),
              "a view this many times the median view error is dropped");
    s->Number("max_focal_std", &O::max_focal_std, Above(0.0), Unbounded<double>(),
              "1-sigma of fx, fy relative to them");
    s->Number("min_tilted_views", &O::min_tilted_views, AtLeast(0), Unbounded<int>(),
              "views with the board tilted by min_tilt_deg or more");
    s->Number("min_tilt_deg", &O::min_tilt_deg, AtLeast(0.0), Below(90.0),
              "a tilted board's angle to the image plane, degrees");
    s->Number("k3_min_views", &O::k3_min_views, AtLeast(0), Unbounded<int>(), "fit k3 from this many views on");
    s->Number("steady_px", &O::steady_px, Above(0.0), Unbounded<double>(),
              "stream: a board moving more than this since the previous frame (mean corner, px) is skipped");
    s->Number("min_move", &O::min_move, AtLeast(0.0), AtMost(1.0),
              "stream: a new view's corners lie this far (of the image diagonal) from every kept view's");
    return s;
  }();
  return *spec;
}

bool CalibrationOptions::Check(std::string* why) const { return Spec().Check(*this, why); }

bool FindBoardCorners(const cv::Mat& grey, const cv::Size& board, std::vector<cv::Point2f>* corners) {
  // The quad-based detector with cornerSubPix first: on crisp boards its
  // corners are 3x closer to the truth (0.05 px RMS) than the sector-based
  // detector's own; that one, which copes better with blur and clutter, is the
  // fallback, refined the same way.
  const int flags = cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE | cv::CALIB_CB_FAST_CHECK;
  if (!cv::findChessboardCorners(grey, board, *corners, flags) &&
      !cv::findChessboardCornersSB(grey, board, *corners, cv::CALIB_CB_NORMALIZE_IMAGE)) {
    corners->clear();
    return false;
  }
  // The search window must stay inside the corner's four squares: well under the closest corner spacing.
  double spacing = 1e9;
  for (int r = 0; r < board.height; ++r)
    for (int c = 0; c + 1 < board.width; ++c)
      spacing = std::min(spacing, cv::norm((*corners)[r * board.width + c + 1] - (*corners)[r * board.width + c]));
  const int win = std::clamp(static_cast<int>(spacing * 0.4), 2, 11);
  cv::cornerSubPix(grey, *corners, cv::Size(win, win), cv::Size(-1, -1),
                   cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 50, 0.001));
  return true;
}

namespace {

const char* const kRegionNames[9] = {"top left", "top",    "top right",   "left",        "centre",
                                     "right",    "bottom left", "bottom", "bottom right"};

// Share of the image inside the convex hull of at least one view's corners,
// and the ninths of the image that the hulls reach less than a quarter of.
double Coverage(const std::vector<const std::vector<cv::Point2f>*>& views, int width, int height,
                std::vector<std::string>* empty_regions) {
  const double scale = 4.0;  // a coarse mask is plenty for a percentage
  const int mw = std::max(1, static_cast<int>(std::ceil(width / scale)));
  const int mh = std::max(1, static_cast<int>(std::ceil(height / scale)));
  cv::Mat mask = cv::Mat::zeros(mh, mw, CV_8UC1);
  for (const auto* corners : views) {
    std::vector<cv::Point2f> hull;
    cv::convexHull(*corners, hull);
    std::vector<cv::Point> poly;
    for (const cv::Point2f& p : hull) poly.emplace_back(cvRound(p.x / scale), cvRound(p.y / scale));
    cv::fillConvexPoly(mask, poly, cv::Scalar(255));
  }
  empty_regions->clear();
  for (int i = 0; i < 9; ++i) {
    const int x0 = mw * (i % 3) / 3, x1 = mw * (i % 3 + 1) / 3;
    const int y0 = mh * (i / 3) / 3, y1 = mh * (i / 3 + 1) / 3;
    const cv::Mat cell = mask(cv::Range(y0, std::max(y1, y0 + 1)), cv::Range(x0, std::max(x1, x0 + 1)));
    if (cv::countNonZero(cell) < 0.25 * cell.total()) empty_regions->push_back(kRegionNames[i]);
  }
  return static_cast<double>(cv::countNonZero(mask)) / mask.total();
}

std::string Join(const std::vector<std::string>& v) {
  std::string s;
  for (const std::string& x : v) s += (s.empty() ? "" : ", ") + x;
  return s;
}


}  // namespace

CalibrationResult CalibrateCamera(const std::vector<CalibrationImage>& images, const CalibrationOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw std::invalid_argument("calibration options: " + why);
  const cv::Size board(options.board_cols, options.board_rows);
  CalibrationResult r;
  r.views.resize(images.size());
  if (images.empty()) {
    r.why = "no images";
    return r;
  }

  // The most common size is the camera's; the others belong to another mode or camera.
  std::map<std::pair<int, int>, int> sizes;
  for (const CalibrationImage& im : images)
    if (!im.grey.empty()) ++sizes[{im.grey.cols, im.grey.rows}];
  int best = 0;
  for (const auto& [size, n] : sizes)
    if (n > best) best = n, r.width = size.first, r.height = size.second;

  int unreadable = 0, no_board = 0, other_size = 0;
  for (size_t i = 0; i < images.size(); ++i) {
    const CalibrationImage& im = images[i];
    CalibrationView& v = r.views[i];
    v.name = im.name;
    if (im.grey.empty() || im.grey.type() != CV_8UC1) {
      v.rejected = im.grey.empty() ? "unreadable" : "not an 8-bit grey image";
      ++unreadable;
    } else if (im.grey.cols != r.width || im.grey.rows != r.height) {
      v.rejected = fmt::format("size {}x{}, not {}x{} as most images", im.grey.cols, im.grey.rows, r.width, r.height);
      ++other_size;
    } else if (!FindBoardCorners(im.grey, board, &v.corners)) {
      v.corners.clear();
      v.rejected = fmt::format("no whole {}x{} board found", board.width, board.height);
      ++no_board;
    } else {
      v.board_found = true;
      v.used = true;
      ++r.boards_found;
    }
  }
  auto used = [&r] {
    std::vector<size_t> u;
    for (size_t i = 0; i < r.views.size(); ++i)
      if (r.views[i].used) u.push_back(i);
    return u;
  };
  auto measure_coverage = [&] {
    std::vector<const std::vector<cv::Point2f>*> c;
    for (size_t i : used()) c.push_back(&r.views[i].corners);
    r.coverage = Coverage(c, r.width, r.height, &r.empty_regions);
  };
  r.views_used = r.boards_found;
  if (r.boards_found < options.min_views) {
    std::string detail;
    if (unreadable) detail += fmt::format("; {} unreadable", unreadable);
    if (other_size) detail += fmt::format("; {} of another size", other_size);
    if (no_board) detail += fmt::format("; {} with no whole {}x{} board", no_board, board.width, board.height);
    r.why = fmt::format("only {} of {} images show the whole board, need >= {}{}", r.boards_found, images.size(),
                        options.min_views, detail);
    if (r.boards_found == 0 && no_board > 0)
      r.why += fmt::format(" (is the board size right? it counts inner corners: {}x{} for a board of {}x{} squares)",
                           board.width, board.height, board.width + 1, board.height + 1);
    return r;
  }
  measure_coverage();
  auto coverage_problem = [&] {
    std::string s = fmt::format("the boards cover {:.0f} % of the image, need >= {:.0f} %: move the board to the "
                                "edges and corners of the image",
                                100 * r.coverage, 100 * options.min_coverage);
    if (!r.empty_regions.empty()) s += " (little or nothing in: " + Join(r.empty_regions) + ")";
    return s;
  };
  if (r.coverage < options.min_coverage) {
    r.why = coverage_problem();
    return r;
  }

  // The board: inner corner (c, r) at (c, r, 0) squares, row by row as OpenCV returns them.
  std::vector<cv::Point3f> object;
  for (int y = 0; y < board.height; ++y)
    for (int x = 0; x < board.width; ++x)
      object.emplace_back(static_cast<float>(x * options.square_m), static_cast<float>(y * options.square_m), 0.f);

  auto fit = [&] {
    const std::vector<size_t> u = used();
    std::vector<std::vector<cv::Point3f>> obj(u.size(), object);
    std::vector<std::vector<cv::Point2f>> img;
    for (size_t i : u) img.push_back(r.views[i].corners);
    r.k3_fitted = static_cast<int>(u.size()) >= options.k3_min_views;
    cv::Mat K, dist = cv::Mat::zeros(1, 5, CV_64F), std_intrinsics, std_extrinsics, per_view;
    std::vector<cv::Mat> rvecs, tvecs;
    const int flags = r.k3_fitted ? 0 : cv::CALIB_FIX_K3;
    try {
      r.rms_px = cv::calibrateCamera(
          obj, img, cv::Size(r.width, r.height), K, dist, rvecs, tvecs, std_intrinsics, std_extrinsics, per_view,
          flags, cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 100, DBL_EPSILON));
    } catch (const cv::Exception& e) {  // degenerate views (e.g. all parallel to the image)
      r.why = std::string("OpenCV could not fit the camera: ") + e.what() +
              "; tilt the board (30 to 45 degrees) in several views";
      return false;
    }
    for (size_t k = 0; k < u.size(); ++k) {
      CalibrationView& v = r.views[u[k]];
      v.rms_px = per_view.at<double>(static_cast<int>(k));
      cv::Mat R;
      cv::Rodrigues(rvecs[k], R);
      v.tilt_deg = std::acos(std::min(1.0, std::abs(R.at<double>(2, 2)))) * 180.0 / CV_PI;
    }
    PinholeCameraOptions& c = r.camera;
    c = PinholeCameraOptions();
    c.width = r.width;
    c.height = r.height;
    c.fx = K.at<double>(0, 0);
    c.fy = K.at<double>(1, 1);
    c.cx = K.at<double>(0, 2);
    c.cy = K.at<double>(1, 2);
    const double* d = dist.ptr<double>();
    c.k1 = d[0], c.k2 = d[1], c.p1 = d[2], c.p2 = d[3], c.k3 = d[4];
    r.fx_std = std_intrinsics.at<double>(0);
    r.fy_std = std_intrinsics.at<double>(1);
    r.cx_std = std_intrinsics.at<double>(2);
    r.cy_std = std_intrinsics.at<double>(3);
    r.views_used = static_cast<int>(u.size());
    r.fitted = true;
    return true;
  };
  if (!fit()) return r;

  // Drop the views that disagree with the rest, once, and fit again.
  std::vector<double> errors;
  for (size_t i : used()) errors.push_back(r.views[i].rms_px);
  const double median = UpperMedian(errors);
  const double limit = std::max(options.outlier_factor * median, options.max_rms_px);
  int dropped = 0;
  for (size_t i : used()) {
    CalibrationView& v = r.views[i];
    if (v.rms_px <= limit) continue;
    v.used = false;
    v.rejected = fmt::format("reprojection RMS {:.2f} px, above {:.0f}x the median view ({:.2f} px) and {:.2f} px: "
                             "a blurred or mis-detected board",
                             v.rms_px, options.outlier_factor, median, options.max_rms_px);
    ++dropped;
  }
  if (dropped > 0) {
    r.views_used = static_cast<int>(used().size());
    if (r.views_used < options.min_views) {
      r.why = fmt::format("only {} views left after dropping {} with a large reprojection error, need >= {}",
                          r.views_used, dropped, options.min_views);
      return r;
    }
    measure_coverage();
    if (r.coverage < options.min_coverage) {
      r.why = coverage_problem();
      return r;
    }
    if (!fit()) return r;
  }

  if (!(r.rms_px <= options.max_rms_px)) {
    r.why = fmt::format("reprojection RMS {:.2f} px > {:.2f} px: blurred images, a board that is not flat, or a "
                        "wrong board size",
                        r.rms_px, options.max_rms_px);
    return r;
  }
  int tilted = 0;
  for (size_t i : used()) tilted += r.views[i].tilt_deg >= options.min_tilt_deg;
  if (tilted < options.min_tilted_views) {
    r.why = fmt::format("only {} of {} views have the board tilted by >= {:.0f} degrees, need >= {}: boards facing "
                        "the camera leave the focal length undetermined; tilt the board (30 to 45 degrees) left, "
                        "right, up and down in several views",
                        tilted, r.views_used, options.min_tilt_deg, options.min_tilted_views);
    return r;
  }
  const double focal_std = std::max(r.fx_std / std::abs(r.camera.fx), r.fy_std / std::abs(r.camera.fy));
  if (!(focal_std <= options.max_focal_std)) {
    r.why = fmt::format("the focal length is uncertain by {:.1f} % (1 sigma), need <= {:.1f} %: tilt the board "
                        "(30 to 45 degrees) towards the camera in several views, in different directions",
                        100 * focal_std, 100 * options.max_focal_std);
    return r;
  }
  if (!r.camera.Check(&why)) {
    r.why = "the fit gives an invalid camera: " + why;
    return r;
  }
  r.ok = true;
  return r;
}

std::string CalibrationResult::Summary() const {
  std::string s;
  int rejected = 0;
  for (const CalibrationView& v : views) rejected += !v.used;
  s += fmt::format("{} images: {} with the whole board, {} views used, {} rejected\n", views.size(), boards_found,
                   views_used, rejected);
  for (const CalibrationView& v : views) {
    if (v.used && v.rms_px >= 0)
      s += fmt::format("  {:<24} {:.3f} px, board tilted {:.0f} deg\n", v.name, v.rms_px, v.tilt_deg);
    else if (v.used)
      s += fmt::format("  {:<24} board found\n", v.name);
    else
      s += fmt::format("  {:<24} rejected: {}\n", v.name, v.rejected);
  }
  if (boards_found > 0) {
    s += fmt::format("coverage {:.0f} % of the {}x{} image", 100 * coverage, width, height);
    s += empty_regions.empty() ? "\n" : " (little or nothing in: " + Join(empty_regions) + ")\n";
  }
  if (fitted) {
    const PinholeCameraOptions& c = camera;
    s += fmt::format("RMS reprojection error {:.3f} px\n", rms_px);
    s += fmt::format("fx {:.2f} ± {:.2f}  fy {:.2f} ± {:.2f}  cx {:.2f} ± {:.2f}  cy {:.2f} ± {:.2f}\n", c.fx,
                     fx_std, c.fy, fy_std, c.cx, cx_std, c.cy, cy_std);
    s += fmt::format("k1 {:.5f}  k2 {:.5f}  p1 {:.5f}  p2 {:.5f}  k3 {:.5f}{}\n", c.k1, c.k2, c.p1, c.p2, c.k3,
                     k3_fitted ? "" : " (fixed: fewer views than k3_min_views)");
  }
  s += ok ? "calibration ok" : "REFUSED: " + why;
  return s;
}

std::vector<CalibrationImage> ReadCalibrationImages(const std::string& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw std::runtime_error(dir + ": no such folder");
  static const char* const kExtensions[] = {".png", ".jpg", ".jpeg", ".bmp", ".pgm", ".ppm",
                                           ".pnm", ".tif", ".tiff", ".webp"};
  std::vector<fs::path> files;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    if (!it->is_regular_file(ec)) continue;
    std::string ext = it->path().extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char ch) { return std::tolower(ch); });
    for (const char* e : kExtensions)
      if (ext == e) files.push_back(it->path());
  }
  if (ec) throw std::runtime_error(dir + ": " + ec.message());
  if (files.empty())
    throw std::runtime_error(dir + ": no image files (.png .jpg .jpeg .bmp .pgm .ppm .pnm .tif .tiff .webp)");
  std::sort(files.begin(), files.end());
  std::vector<CalibrationImage> images;
  for (const fs::path& f : files)
    images.push_back({f.filename().string(), cv::imread(f.string(), cv::IMREAD_GRAYSCALE)});
  return images;
}

namespace {
double MeanCornerDistance(const std::vector<cv::Point2f>& a, const std::vector<cv::Point2f>& b) {
  double sum = 0;
  for (size_t i = 0; i < a.size(); ++i) sum += cv::norm(a[i] - b[i]);
  return a.empty() ? 0 : sum / static_cast<double>(a.size());
}
}  // namespace

CalibrationViewPicker::CalibrationViewPicker(const CalibrationOptions& options) : o_(options) {
  std::string why;
  if (!o_.Check(&why)) throw std::invalid_argument("calibration options: " + why);
}

CalibrationViewPicker::Verdict CalibrationViewPicker::Offer(const cv::Mat& grey, const std::string& name) {
  if (grey.empty() || grey.type() != CV_8UC1) return Verdict::kUnreadable;
  if (size_.empty()) size_ = grey.size();
  if (grey.size() != size_) return Verdict::kOtherSize;
  std::vector<cv::Point2f> corners;
  if (!FindBoardCorners(grey, cv::Size(o_.board_cols, o_.board_rows), &corners)) {
    previous_.clear();
    return Verdict::kNoBoard;
  }
  // The detector may number a board from either end: compare against the
  // previous frame as found, a moved board shows as motion either way.
  const bool steady = previous_.size() == corners.size() && MeanCornerDistance(corners, previous_) <= o_.steady_px;
  previous_ = corners;
  if (!steady) return Verdict::kMoving;
  const double diagonal = std::hypot(size_.width, size_.height);
  for (const auto& kept : corners_) {
    std::vector<cv::Point2f> reversed(kept.rbegin(), kept.rend());
    if (std::min(MeanCornerDistance(corners, kept), MeanCornerDistance(corners, reversed)) < o_.min_move * diagonal)
      return Verdict::kSeen;
  }
  views_.push_back({name, grey.clone()});
  corners_.push_back(std::move(corners));
  return Verdict::kKept;
}

double CalibrationViewPicker::Coverage(std::vector<std::string>* empty_regions) const {
  std::vector<const std::vector<cv::Point2f>*> v;
  for (const auto& c : corners_) v.push_back(&c);
  std::vector<std::string> empty;
  const double c = rumi::Coverage(v, size_.width, size_.height, &empty);
  if (empty_regions) *empty_regions = std::move(empty);
  return c;
}

const char* ToString(CalibrationViewPicker::Verdict v) {
  switch (v) {
    case CalibrationViewPicker::Verdict::kKept: return "kept";
    case CalibrationViewPicker::Verdict::kNoBoard: return "no whole board";
    case CalibrationViewPicker::Verdict::kMoving: return "board moving";
    case CalibrationViewPicker::Verdict::kSeen: return "too close to a kept view";
    case CalibrationViewPicker::Verdict::kOtherSize: return "another image size";
    case CalibrationViewPicker::Verdict::kUnreadable: return "unreadable";
  }
  return "?";
}

std::string CalibrationConfigYaml(const CalibrationResult& r, const CalibrationOptions& o) {
  std::string s = "# Camera calibration by `rumi calibrate` (docs/calibrate.md): pinhole + radtan.\n";
  s += fmt::format("# {} views of a {}x{} chessboard (inner corners, {} m squares); {} of {} images rejected\n",
                   r.views_used, o.board_cols, o.board_rows, o.square_m, r.views.size() - r.views_used,
                   r.views.size());
  s += fmt::format("# RMS reprojection error {:.3f} px; boards cover {:.0f} % of the image; k3 {}\n", r.rms_px,
                   100 * r.coverage, r.k3_fitted ? "fitted" : "fixed to 0");
  s += fmt::format("# 1-sigma: fx {:.2f} px, fy {:.2f} px, cx {:.2f} px, cy {:.2f} px\n", r.fx_std, r.fy_std, r.cx_std,
                   r.cy_std);
  return s + CameraSectionYaml(r.camera);
}

}  // namespace rumi
