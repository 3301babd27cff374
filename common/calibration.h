#pragma once
// Camera calibration from images of a chessboard (`rumi calibrate`,
// docs/calibrate.md): OpenCV finds the board's inner corners, calibrateCamera
// fits pinhole + radtan (k1 k2 p1 p2, k3 only from many views), and the result
// is refused, naming what was wrong, when it cannot be trusted: too few views,
// boards that leave much of the image unseen (the distortion there would be a
// guess), boards that all face the camera, a large reprojection error or an
// unsettled focal length. A refused
// calibration is never written: the rat robot's config would rather keep an
// obvious guess than get a wrong measurement.
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "common/camera.h"
#include "common/option_spec.h"

namespace rumi {

struct CalibrationOptions {
  std::string pattern = "chessboard";  // ChArUco: planned
  int board_cols = 9;        // inner corners along the board's long side (10x7 squares: 9x6)
  int board_rows = 6;        // inner corners along the other side
  double square_m = 0.025;   // side of a square; scales the board poses only, not the intrinsics
  int min_views = 10;        // images with the whole board found
  double min_coverage = 0.5;  // share of the image inside the outline of at least one board
  double max_rms_px = 1.0;   // overall reprojection RMS
  // A view this far above the median view error (and above max_rms_px) is a
  // blurred or mis-detected board: dropped once, and the fit redone.
  double outlier_factor = 3.0;
  double max_focal_std = 0.01;  // 1-sigma of fx, fy relative to them
  // Boards that all face the camera leave the focal length undetermined (it
  // trades off against their distance, and the fit still looks good), so
  // this many views must have the board tilted by at least min_tilt_deg.
  int min_tilted_views = 3;
  double min_tilt_deg = 15;
  int k3_min_views = 20;        // k3 fitted from this many views on, else fixed to 0 (overfits on few views)
  // Views picked from a stream (CalibrationViewPicker): the board must hold
  // still (mean corner motion since the previous frame <= steady_px: no
  // motion blur) and be somewhere new (mean corner distance to every kept
  // view >= min_move of the image diagonal).
  double steady_px = 1.5;
  double min_move = 0.05;
  static const OptionSpec<CalibrationOptions>& Spec();
  bool Check(std::string* why = nullptr) const;
};

// One input image; an empty `grey` is an image that could not be read.
struct CalibrationImage {
  std::string name;
  cv::Mat grey;  // CV_8UC1
};

struct CalibrationView {
  std::string name;
  bool board_found = false;
  bool used = false;      // in the final fit
  std::string rejected;   // why not used ("" when used)
  double rms_px = -1;     // reprojection RMS of this view in the fit it took part in (-1: none)
  double tilt_deg = -1;   // angle between the board's normal and the optical axis in that fit
  std::vector<cv::Point2f> corners;  // when board_found
};

struct CalibrationResult {
  bool ok = false;  // calibrated and within every limit
  std::string why;  // when !ok: what was wrong and what to do about it
  std::vector<CalibrationView> views;  // one per input image, in input order
  int width = 0, height = 0;           // the image size calibrated (the most common one)
  int boards_found = 0;
  int views_used = 0;
  double coverage = 0;                    // of the used views, as CalibrationOptions::min_coverage
  std::vector<std::string> empty_regions;  // ninths of the image no board reached ("top left", ...)
  bool fitted = false;                    // calibrateCamera ran (camera, rms_px, *_std are set)
  PinholeCameraOptions camera;
  bool k3_fitted = false;
  double rms_px = 0;
  double fx_std = 0, fy_std = 0, cx_std = 0, cy_std = 0;  // 1-sigma, pixels
  // Several lines for people: views, error, intrinsics, distortion, coverage.
  std::string Summary() const;
};

// The board's inner corners in one grey image, row by row, subpixel; false
// when the whole board is not found. board: (cols, rows) inner corners.
bool FindBoardCorners(const cv::Mat& grey, const cv::Size& board, std::vector<cv::Point2f>* corners);

// Fits the camera to the images (all of one size; others are rejected).
// Throws std::invalid_argument when the options fail Check.
CalibrationResult CalibrateCamera(const std::vector<CalibrationImage>& images, const CalibrationOptions& options);

// Every image file (.png .jpg .jpeg .bmp .pgm .ppm .pnm .tif .tiff .webp, any
// case) of a folder, sorted by name, as grey; one that cannot be decoded comes
// back with an empty image. Throws std::runtime_error when the folder is
// missing or holds no image file.
std::vector<CalibrationImage> ReadCalibrationImages(const std::string& dir);

// Picks calibration views from a stream of frames (`rumi calibrate --link`):
// a frame becomes a view when the whole board is found, holds still and is
// somewhere new (CalibrationOptions::steady_px, min_move). Every frame must
// have the first one's size.
class CalibrationViewPicker {
 public:
  enum class Verdict { kKept, kNoBoard, kMoving, kSeen, kOtherSize, kUnreadable };
  explicit CalibrationViewPicker(const CalibrationOptions& options);
  Verdict Offer(const cv::Mat& grey, const std::string& name);
  const std::vector<CalibrationImage>& views() const { return views_; }
  // Of the kept views, as CalibrationResult::coverage and empty_regions.
  double Coverage(std::vector<std::string>* empty_regions) const;

 private:
  CalibrationOptions o_;
  cv::Size size_;
  std::vector<cv::Point2f> previous_;  // the last frame's corners (empty: no board)
  std::vector<CalibrationImage> views_;
  std::vector<std::vector<cv::Point2f>> corners_;  // per kept view
};
const char* ToString(CalibrationViewPicker::Verdict v);

// A rumi config holding the `camera:` section, with the fit's figures as
// comments (the config reader is strict: no extra keys).
std::string CalibrationConfigYaml(const CalibrationResult& result, const CalibrationOptions& options);

}  // namespace rumi
