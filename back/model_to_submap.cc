#include "back/model_to_submap.h"

#include <algorithm>
#include <unordered_map>

namespace rumi {

namespace {
const char kImageExtension[] = ".png";
}

std::string ColmapImageName(Timestamp t) { return TimestampFileStem(t) + kImageExtension; }

bool ParseColmapImageName(const std::string& name, Timestamp* t) {
  const std::string ext = kImageExtension;
  if (name.size() <= ext.size() || name.compare(name.size() - ext.size(), ext.size(), ext) != 0)
    return false;
  const std::string stem = name.substr(0, name.size() - ext.size());
  // Only the exact padded form maps back, so a name denotes one timestamp.
  Timestamp v = 0;
  if (!ParseTimestampFileStem(stem, &v) || TimestampFileStem(v) != stem) return false;
  *t = v;
  return true;
}

bool ColmapModelToSubmap(const ColmapModel& model, int64_t submap_id, Submap* submap,
                         BackSubmapStats* stats, std::string* error) {
  auto fail = [error](const std::string& m) {
    if (error) *error = m;
    return false;
  };
  if (model.cameras.size() != 1) {
    return fail("expected exactly one camera, model has " + std::to_string(model.cameras.size()));
  }
  const ColmapCamera& cam = model.cameras.begin()->second;
  Submap out;
  out.id = submap_id;
  out.source = SubmapSource::kBack;
  out.camera.width = static_cast<int>(cam.width);
  out.camera.height = static_cast<int>(cam.height);
  if (cam.model_id == static_cast<int32_t>(ColmapCameraModel::kPinhole)) {
    out.camera.fx = cam.params[0];
    out.camera.fy = cam.params[1];
    out.camera.cx = cam.params[2] - kColmapPixelOffset;
    out.camera.cy = cam.params[3] - kColmapPixelOffset;
  } else if (cam.model_id == static_cast<int32_t>(ColmapCameraModel::kSimplePinhole)) {
    out.camera.fx = out.camera.fy = cam.params[0];
    out.camera.cx = cam.params[1] - kColmapPixelOffset;
    out.camera.cy = cam.params[2] - kColmapPixelOffset;
  } else {
    return fail("camera model id " + std::to_string(cam.model_id) +
                " is not PINHOLE/SIMPLE_PINHOLE (images must be undistorted)");
  }

  // Keyframes in time order.
  struct Entry {
    Timestamp t;
    const ColmapImage* image;
  };
  std::vector<Entry> entries;
  for (const auto& [id, im] : model.images) {
    Timestamp t = 0;
    if (!ParseColmapImageName(im.name, &t))
      return fail("image name '" + im.name + "' is not a rumi timestamp name");
    entries.push_back({t, &im});
  }
  std::sort(entries.begin(), entries.end(), [](const Entry& a, const Entry& b) { return a.t < b.t; });
  for (size_t i = 1; i < entries.size(); ++i) {
    if (entries[i].t == entries[i - 1].t)
      return fail("two images with timestamp " + std::to_string(entries[i].t));
  }

  // Point ids 0..m-1 in COLMAP id order (std::map iterates sorted).
  std::unordered_map<uint64_t, int64_t> point_index;
  for (const auto& [id, p] : model.points) {
    const int64_t idx = static_cast<int64_t>(point_index.size());
    point_index.emplace(id, idx);
    MapPoint mp;
    mp.id = idx;
    mp.position = p.xyz;
    out.points.push_back(std::move(mp));
  }

  std::unordered_map<uint32_t, int64_t> keyframe_of_image;
  for (const Entry& e : entries) {
    const ColmapImage& im = *e.image;
    Keyframe kf;
    kf.id = static_cast<int64_t>(out.keyframes.size());
    kf.timestamp = e.t;
    const Eigen::Quaterniond q(im.qvec[0], im.qvec[1], im.qvec[2], im.qvec[3]);  // w x y z
    kf.T_cw = Se3(q, im.tvec);
    kf.keypoints.reserve(im.xys.size());
    kf.point_ids.reserve(im.xys.size());
    for (size_t k = 0; k < im.xys.size(); ++k) {
      kf.keypoints.emplace_back(static_cast<float>(im.xys[k].x() - kColmapPixelOffset),
                                static_cast<float>(im.xys[k].y() - kColmapPixelOffset));
      const int64_t pid = im.point3d_ids[k];
      kf.point_ids.push_back(pid < 0 ? -1 : point_index.at(static_cast<uint64_t>(pid)));
    }
    kf.octaves.assign(im.xys.size(), 0);
    keyframe_of_image.emplace(im.id, kf.id);
    out.keyframes.push_back(std::move(kf));
  }

  // Observations from the tracks (validated against the images by the reader).
  BackSubmapStats st;
  double err_sum = 0.0;
  for (const auto& [id, p] : model.points) {
    MapPoint& mp = out.points[static_cast<size_t>(point_index.at(id))];
    for (const auto& t : p.track) {
      auto it = keyframe_of_image.find(t.image_id);
      if (it == keyframe_of_image.end())
        return fail("3D point " + std::to_string(id) + " observed by unknown image " +
                    std::to_string(t.image_id));
      mp.observations.push_back({it->second, static_cast<int32_t>(t.point2d_idx)});
    }
    st.num_observations += static_cast<int>(p.track.size());
    err_sum += p.error;
  }
  st.registered_images = static_cast<int>(out.keyframes.size());
  st.num_points = static_cast<int>(out.points.size());
  if (st.num_points > 0) {
    st.mean_reprojection_error_px = err_sum / st.num_points;
    st.mean_track_length = static_cast<double>(st.num_observations) / st.num_points;
  }
  *submap = std::move(out);
  if (stats) *stats = st;
  return true;
}

}  // namespace rumi
