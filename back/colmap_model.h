#pragma once
// Reader of COLMAP's binary sparse model (cameras.bin, images.bin,
// points3D.bin, little-endian, as written by COLMAP 3.x). Values are kept in
// COLMAP's own conventions here (pixel centre of the top-left pixel at
// (0.5, 0.5), qvec w x y z world->camera); model_to_submap converts to rumi's.
#include <Eigen/Core>

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace rumi {

// COLMAP camera model ids (colmap/base/camera_models.h).
enum class ColmapCameraModel : int32_t {
  kSimplePinhole = 0,
  kPinhole = 1,
  kSimpleRadial = 2,
  kRadial = 3,
  kOpenCv = 4,
  kOpenCvFisheye = 5,
  kFullOpenCv = 6,
  kFov = 7,
  kSimpleRadialFisheye = 8,
  kRadialFisheye = 9,
  kThinPrismFisheye = 10,
};
// Number of parameters of a model id; -1 for an unknown id.
int ColmapCameraNumParams(int32_t model_id);

struct ColmapCamera {
  uint32_t id = 0;
  int32_t model_id = 0;
  uint64_t width = 0, height = 0;
  std::vector<double> params;
};

struct ColmapImage {
  uint32_t id = 0;
  Eigen::Vector4d qvec{1, 0, 0, 0};  // w x y z, world -> camera
  Eigen::Vector3d tvec = Eigen::Vector3d::Zero();
  uint32_t camera_id = 0;
  std::string name;
  std::vector<Eigen::Vector2d> xys;  // COLMAP pixel convention
  std::vector<int64_t> point3d_ids;  // -1 for none
};

struct ColmapPoint3D {
  uint64_t id = 0;
  Eigen::Vector3d xyz = Eigen::Vector3d::Zero();
  uint8_t rgb[3] = {0, 0, 0};
  double error = 0.0;  // mean reprojection error in pixels (COLMAP's)
  struct TrackElement {
    uint32_t image_id;
    uint32_t point2d_idx;
  };
  std::vector<TrackElement> track;
};

struct ColmapModel {
  std::map<uint32_t, ColmapCamera> cameras;
  std::map<uint32_t, ColmapImage> images;
  std::map<uint64_t, ColmapPoint3D> points;
};

// Reads <dir>/cameras.bin, images.bin and points3D.bin. Returns false with a
// message naming the file and what was wrong (missing, truncated, inconsistent
// ids, absurd counts); never throws on corrupt input.
bool ReadColmapModelBinary(const std::string& dir, ColmapModel* model, std::string* error);

}  // namespace rumi
