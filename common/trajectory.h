#pragma once
// Stamped camera->world trajectories and their three text formats:
//   TUM    "t tx ty tz qx qy qz qw", seconds, '#' comments (rumi's output format)
//   KITTI  3x4 row-major [R|t] per line, no time; index-matched, so timestamps
//          are the line index in seconds unless a times file is given
//   EuRoC  csv "#timestamp [ns],p_x,p_y,p_z,q_w,q_x,q_y,q_z[,...]"
// Every reader throws std::runtime_error naming file:line and the reason on
// missing files, malformed lines, non-unit quaternions / non-rotations and
// timestamps that are not strictly increasing (unsorted or duplicate).
#include <iosfwd>
#include <string>
#include <vector>

#include "common/geometry.h"
#include "common/timestamp.h"

namespace rumi {

struct StampedPose {
  Timestamp t = 0;
  Se3 T_wc;  // camera -> world
};
using Trajectory = std::vector<StampedPose>;

enum class TrajectoryFormat { kTum, kKitti, kEuroc };
bool ParseTrajectoryFormat(const std::string& name, TrajectoryFormat* format);
const char* ToString(TrajectoryFormat format);
// Guesses from the first data line: commas -> EuRoC, 12 fields -> KITTI,
// 8 fields -> TUM. Throws when the file is missing or the guess fails.
TrajectoryFormat DetectTrajectoryFormat(const std::string& path);

struct TrajectoryReadOptions {
  // Real files have exact duplicate stamps (TUM fr2_desk ground truth, some
  // estimates). true keeps the first pose of each duplicate run (as evo's
  // nearest search would pick it) and logs a warning; false throws.
  // Decreasing timestamps always throw.
  bool drop_duplicates = false;
};

// Stream versions: `name` is used in error messages ("name:line: why").
Trajectory ParseTumTrajectory(std::istream& in, const std::string& name,
                              const TrajectoryReadOptions& options = {});
Trajectory ParseKittiTrajectory(std::istream& in, const std::string& name);
Trajectory ParseEurocTrajectory(std::istream& in, const std::string& name,
                                const TrajectoryReadOptions& options = {});
// One timestamp (seconds) per line, e.g. KITTI times.txt.
std::vector<Timestamp> ParseTimestampList(std::istream& in, const std::string& name);

void FormatTumTrajectory(const Trajectory& traj, std::ostream& out);
void FormatKittiTrajectory(const Trajectory& traj, std::ostream& out);  // drops timestamps
void FormatEurocTrajectory(const Trajectory& traj, std::ostream& out);

// File versions. ReadKittiTrajectory takes the timestamps from times_path
// when it is not empty (its count must match), else uses index i -> i s.
Trajectory ReadTumTrajectory(const std::string& path, const TrajectoryReadOptions& options = {});
Trajectory ReadKittiTrajectory(const std::string& path, const std::string& times_path = "");
Trajectory ReadEurocTrajectory(const std::string& path,
                               const TrajectoryReadOptions& options = {});
std::vector<Timestamp> ReadTimestampList(const std::string& path);
Trajectory ReadTrajectory(const std::string& path, TrajectoryFormat format,
                          const std::string& kitti_times_path = "",
                          const TrajectoryReadOptions& options = {});

void WriteTumTrajectory(const std::string& path, const Trajectory& traj);
void WriteKittiTrajectory(const std::string& path, const Trajectory& traj);
void WriteEurocTrajectory(const std::string& path, const Trajectory& traj);
void WriteTrajectory(const std::string& path, const Trajectory& traj, TrajectoryFormat format);

// Throws unless timestamps are strictly increasing; `name` goes in the message.
void CheckStrictlyIncreasing(const Trajectory& traj, const std::string& name);

// In time order with one pose per time (the first of each): a merged map
// holds a front and a back keyframe of the same frame.
void SortOnePosePerTime(Trajectory* traj);

}  // namespace rumi
