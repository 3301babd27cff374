#pragma once
// rumid's state folder (/var/lib/rumi/<instance> under systemd): everything
// a session leaves, in one place.
//
//   rumid.lock           held (flock) while a rumid runs on the folder
//   status.json          what `rumi status` shows, rewritten every second
//   generation           starts of front/back so far: ids stay unique across restarts
//   map.rumi, map.rumi.raw, map.rumi.raw.baked/, map.rumi.received/, merged*.txt, manager_stats.json
//   front/               front_frames.txt, front_samples.txt, front.txt, front_stats.json
//   back/                back_stats.json, spool/ (windows until built)
//   logs/                the children's logs (daemon.child_output: files)
#include <string>

namespace rumi {

struct StateDirLayout {
  std::string root;
  std::string Status() const { return root + "/status.json"; }
  std::string Lock() const { return root + "/rumid.lock"; }
  std::string Generation() const { return root + "/generation"; }
  std::string Front() const { return root + "/front"; }
  std::string Back() const { return root + "/back"; }
  std::string Logs() const { return root + "/logs"; }
};

// The state folder: the command line's, the config's (daemon.state_dir),
// systemd's $STATE_DIRECTORY, else /var/lib/rumi/<instance>.
std::string ResolveStateDir(const std::string& cli, const std::string& config, const std::string& instance);

// The lock of one rumid per instance on the machine: beside the instance's
// shared-memory segments (/dev/shm/.rumid_<instance>.lock: the same
// namespace, and a name the segment scan, "rumi_*", never reads).
std::string InstanceLockPath(const std::string& instance);

// Holds a rumid lock file (flock, released when the process ends, even by
// SIGKILL): rumid.lock in the state folder, and the instance's.
class StateDirLock {
 public:
  // False with *why when another rumid holds it (its pid in the message).
  bool Acquire(const StateDirLayout& layout, std::string* why);
  // `what` ends the message: "another rumid (pid 12) runs <what>".
  bool Acquire(const std::string& path, const std::string& what, std::string* why);
  // False when the locked file is no longer at its path (its folder was
  // deleted or replaced): the lock then guards nothing.
  bool StillHeld() const;
  ~StateDirLock();

 private:
  int fd_ = -1;
  std::string path_;
};

// Next number from the generation file (0, 1, 2, ... across rumid runs),
// written back atomically. -1 with *why when it cannot be written.
long NextGeneration(const StateDirLayout& layout, std::string* why);

}  // namespace rumi
