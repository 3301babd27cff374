#include "back/colmap_model.h"

#include <cstring>
#include <limits>
#include <type_traits>

#include "common/atomic_file.h"

namespace rumi {

int ColmapCameraNumParams(int32_t model_id) {
  switch (model_id) {
    case 0: return 3;   // SIMPLE_PINHOLE f cx cy
    case 1: return 4;   // PINHOLE fx fy cx cy
    case 2: return 4;   // SIMPLE_RADIAL
    case 3: return 5;   // RADIAL
    case 4: return 8;   // OPENCV
    case 5: return 8;   // OPENCV_FISHEYE
    case 6: return 12;  // FULL_OPENCV
    case 7: return 5;   // FOV
    case 8: return 4;   // SIMPLE_RADIAL_FISHEYE
    case 9: return 5;   // RADIAL_FISHEYE
    case 10: return 12; // THIN_PRISM_FISHEYE
    default: return -1;
  }
}

namespace {

// Bounds-checked little-endian reader over a whole file in memory.
class Reader {
 public:
  Reader(std::string path, std::string data) : path_(std::move(path)), data_(std::move(data)) {}

  template <typename T>
  bool Get(T* v) {
    static_assert(std::is_arithmetic<T>::value, "arithmetic only");
    if (data_.size() - pos_ < sizeof(T)) return Truncated();
    std::memcpy(v, data_.data() + pos_, sizeof(T));  // x86/ARM hosts are little-endian
    pos_ += sizeof(T);
    return true;
  }
  bool GetString(std::string* s) {
    const size_t end = data_.find('\0', pos_);
    if (end == std::string::npos) return Truncated();
    s->assign(data_, pos_, end - pos_);
    pos_ = end + 1;
    return true;
  }
  // A count of items each at least min_bytes long must fit in what is left.
  bool GetCount(uint64_t* n, size_t min_bytes, const char* what) {
    if (!Get(n)) return false;
    if (*n > (data_.size() - pos_) / min_bytes) {
      return Fail(std::string("count of ") + what + " (" + std::to_string(*n) +
                  ") exceeds the file size");
    }
    return true;
  }
  bool AtEnd() const { return pos_ == data_.size(); }
  bool Fail(const std::string& why) {
    if (error_.empty()) error_ = path_ + ": " + why + " (at byte " + std::to_string(pos_) + ")";
    return false;
  }
  const std::string& error() const { return error_; }

 private:
  bool Truncated() { return Fail("truncated file"); }
  std::string path_;
  std::string data_;
  size_t pos_ = 0;
  std::string error_;
};

bool LoadFile(const std::string& path, std::string* data, std::string* error) {
  return ReadFileText(path, data, error);
}

bool ReadCameras(Reader& r, ColmapModel* m) {
  uint64_t n = 0;
  if (!r.GetCount(&n, 4 + 4 + 8 + 8, "cameras")) return false;
  for (uint64_t i = 0; i < n; ++i) {
    ColmapCamera c;
    if (!r.Get(&c.id) || !r.Get(&c.model_id) || !r.Get(&c.width) || !r.Get(&c.height)) return false;
    const int np = ColmapCameraNumParams(c.model_id);
    if (np < 0) return r.Fail("unknown camera model id " + std::to_string(c.model_id));
    c.params.resize(np);
    for (double& p : c.params)
      if (!r.Get(&p)) return false;
    if (!m->cameras.emplace(c.id, std::move(c)).second) return r.Fail("duplicate camera id");
  }
  if (!r.AtEnd()) return r.Fail("trailing bytes");
  return true;
}

bool ReadImages(Reader& r, ColmapModel* m) {
  uint64_t n = 0;
  if (!r.GetCount(&n, 4 + 7 * 8 + 4 + 1 + 8, "images")) return false;
  for (uint64_t i = 0; i < n; ++i) {
    ColmapImage im;
    if (!r.Get(&im.id)) return false;
    for (int k = 0; k < 4; ++k)
      if (!r.Get(&im.qvec[k])) return false;
    for (int k = 0; k < 3; ++k)
      if (!r.Get(&im.tvec[k])) return false;
    if (!r.Get(&im.camera_id) || !r.GetString(&im.name)) return false;
    uint64_t np = 0;
    if (!r.GetCount(&np, 3 * 8, "2D points")) return false;
    im.xys.resize(np);
    im.point3d_ids.resize(np);
    for (uint64_t k = 0; k < np; ++k) {
      uint64_t pid = 0;
      if (!r.Get(&im.xys[k].x()) || !r.Get(&im.xys[k].y()) || !r.Get(&pid)) return false;
      // COLMAP marks "no 3D point" with the max uint64.
      im.point3d_ids[k] = pid == std::numeric_limits<uint64_t>::max() ? -1 : static_cast<int64_t>(pid);
      if (im.point3d_ids[k] < -1) return r.Fail("3D point id out of range");
    }
    if (im.qvec.norm() < 1e-6) return r.Fail("image '" + im.name + "' has a zero quaternion");
    if (!m->images.emplace(im.id, std::move(im)).second) return r.Fail("duplicate image id");
  }
  if (!r.AtEnd()) return r.Fail("trailing bytes");
  return true;
}

bool ReadPoints(Reader& r, ColmapModel* m) {
  uint64_t n = 0;
  if (!r.GetCount(&n, 8 + 3 * 8 + 3 + 8 + 8, "3D points")) return false;
  for (uint64_t i = 0; i < n; ++i) {
    ColmapPoint3D p;
    if (!r.Get(&p.id)) return false;
    for (int k = 0; k < 3; ++k)
      if (!r.Get(&p.xyz[k])) return false;
    for (int k = 0; k < 3; ++k)
      if (!r.Get(&p.rgb[k])) return false;
    if (!r.Get(&p.error)) return false;
    uint64_t nt = 0;
    if (!r.GetCount(&nt, 8, "track elements")) return false;
    p.track.resize(nt);
    for (auto& t : p.track)
      if (!r.Get(&t.image_id) || !r.Get(&t.point2d_idx)) return false;
    if (!m->points.emplace(p.id, std::move(p)).second) return r.Fail("duplicate 3D point id");
  }
  if (!r.AtEnd()) return r.Fail("trailing bytes");
  return true;
}

}  // namespace

bool ReadColmapModelBinary(const std::string& dir, ColmapModel* model, std::string* error) {
  std::string err_local;
  std::string& err = error ? *error : err_local;
  ColmapModel m;
  struct Part {
    const char* name;
    bool (*read)(Reader&, ColmapModel*);
  };
  const Part parts[] = {{"cameras.bin", ReadCameras}, {"images.bin", ReadImages},
                        {"points3D.bin", ReadPoints}};
  for (const Part& part : parts) {
    const std::string path = dir + "/" + part.name;
    std::string data;
    if (!LoadFile(path, &data, &err)) return false;
    Reader r(path, std::move(data));
    if (!part.read(r, &m)) {
      err = r.error();
      return false;
    }
  }
  // Cross-references: every id a file names must exist in the others.
  for (const auto& [id, im] : m.images) {
    if (!m.cameras.count(im.camera_id)) {
      err = dir + "/images.bin: image '" + im.name + "' names unknown camera " +
            std::to_string(im.camera_id);
      return false;
    }
    for (int64_t pid : im.point3d_ids) {
      if (pid >= 0 && !m.points.count(static_cast<uint64_t>(pid))) {
        err = dir + "/images.bin: image '" + im.name + "' names unknown 3D point " +
              std::to_string(pid);
        return false;
      }
    }
  }
  for (const auto& [id, p] : m.points) {
    for (const auto& t : p.track) {
      auto it = m.images.find(t.image_id);
      if (it == m.images.end() || t.point2d_idx >= it->second.xys.size()) {
        err = dir + "/points3D.bin: 3D point " + std::to_string(id) +
              " has a track element outside the images (image " + std::to_string(t.image_id) +
              ", point2D " + std::to_string(t.point2d_idx) + ")";
        return false;
      }
    }
  }
  *model = std::move(m);
  return true;
}

}  // namespace rumi
