#!/usr/bin/env bash
# Downloads the sequences of the RUMI-SLAM paper's Table IV into DEST:
#   DEST/tum/rgbd_dataset_freiburg*_*/   (TUM RGB-D: rgb.txt, rgb/, groundtruth.txt)
#   DEST/euroc/V*_*/mav0/                (EuRoC MAV, ASL layout)
#   DEST/icl/<archive stem>/             (ICL-NUIM, TUM-compatible release)
# For users with internet; never used by CI or tests. Downloads resume
# (wget -c / curl -C -), archives are checked before and after extraction,
# and a finished sequence is skipped on the next call.
#
#   scripts/download_datasets.sh DEST [tum|euroc|icl ...]
#
# Mirrors moved in the past; override the bases if a URL is dead:
#   TUM_BASE   (default https://cvg.cit.tum.de/rgbd/dataset)
#   EUROC_BASE (default http://robotics.ethz.ch/~asl-datasets/ijrr_euroc_mav_dataset)
#   ICL_BASE   (default https://www.doc.ic.ac.uk/~ahanda)
set -euo pipefail

TUM_BASE="${TUM_BASE:-https://cvg.cit.tum.de/rgbd/dataset}"
EUROC_BASE="${EUROC_BASE:-http://robotics.ethz.ch/~asl-datasets/ijrr_euroc_mav_dataset}"
ICL_BASE="${ICL_BASE:-https://www.doc.ic.ac.uk/~ahanda}"

TUM_SEQUENCES=(
  freiburg1/rgbd_dataset_freiburg1_room
  freiburg1/rgbd_dataset_freiburg1_teddy
  freiburg2/rgbd_dataset_freiburg2_desk
  freiburg2/rgbd_dataset_freiburg2_360_kidnap
  freiburg2/rgbd_dataset_freiburg2_pioneer_slam
  freiburg2/rgbd_dataset_freiburg2_pioneer_slam2
  freiburg2/rgbd_dataset_freiburg2_pioneer_slam3
  freiburg3/rgbd_dataset_freiburg3_long_office_household
  freiburg3/rgbd_dataset_freiburg3_teddy
)
EUROC_SEQUENCES=(
  vicon_room1/V1_02_medium
  vicon_room1/V1_03_difficult
  vicon_room2/V2_02_medium
  vicon_room2/V2_03_difficult
)
# living room traj 0, 2 and office traj 0, 2, 3 (office archives have no prefix).
ICL_SEQUENCES=(
  living_room_traj0_frei_png
  living_room_traj2_frei_png
  traj0_frei_png
  traj2_frei_png
  traj3_frei_png
)

usage() {
  echo "usage: $0 DEST [tum|euroc|icl ...]   (default: all three)" >&2
  exit 2
}

die() {
  echo "download_datasets: $*" >&2
  exit 1
}

# fetch URL FILE: resumable download into FILE.
fetch() {
  local url="$1" file="$2"
  echo "  fetching $url"
  if command -v wget >/dev/null 2>&1; then
    wget -c --tries=5 --timeout=60 -O "$file.part" "$url" || return 1
  elif command -v curl >/dev/null 2>&1; then
    curl -fL --retry 5 -C - -o "$file.part" "$url" || return 1
  else
    die "neither wget nor curl is installed"
  fi
  mv "$file.part" "$file"
}

# check_archive FILE: the archive is complete (lists without error).
check_archive() {
  local file="$1"
  case "$file" in
    *.zip) unzip -tqq "$file" >/dev/null ;;
    *.tgz | *.tar.gz) tar -tzf "$file" >/dev/null ;;
    *) return 1 ;;
  esac
}

# extract FILE DIR: into DIR/.partial, then renamed to DIR when complete.
extract() {
  local file="$1" dir="$2" tmp="$2.partial"
  rm -rf "$tmp"
  mkdir -p "$tmp"
  case "$file" in
    *.zip) unzip -q "$file" -d "$tmp" ;;
    *) tar -xzf "$file" -C "$tmp" ;;
  esac
  rm -rf "$dir"
  mv "$tmp" "$dir"
}

# get NAME URL ARCHIVE DIR CHECK: downloads, verifies, extracts, runs CHECK DIR.
get() {
  local name="$1" url="$2" archive="$3" dir="$4" check="$5"
  if [ -f "$dir/.rumi_complete" ]; then
    echo "$name: present ($dir)"
    return 0
  fi
  echo "$name:"
  if [ ! -f "$archive" ] || ! check_archive "$archive"; then
    fetch "$url" "$archive" || die "$name: download failed ($url); set the *_BASE variable to a working mirror"
    check_archive "$archive" || die "$name: $archive is damaged; delete it and run again"
  fi
  extract "$archive" "$dir"
  "$check" "$dir" || die "$name: $dir does not hold what was expected after extraction"
  touch "$dir/.rumi_complete"
  rm -f "$archive"
  echo "  ok: $dir"
}

# The TUM archive holds one top folder named like the sequence: flatten it.
check_tum() {
  local dir="$1" inner
  inner="$(find "$dir" -mindepth 1 -maxdepth 1 -type d | head -n 1)"
  if [ -n "$inner" ] && [ ! -f "$dir/rgb.txt" ] && [ -f "$inner/rgb.txt" ]; then
    (shopt -s dotglob && mv "$inner"/* "$dir"/) && rmdir "$inner"
  fi
  [ -f "$dir/rgb.txt" ] && [ -d "$dir/rgb" ] && [ -f "$dir/groundtruth.txt" ]
}

check_euroc() {
  local dir="$1"
  [ -f "$dir/mav0/cam0/data.csv" ] && [ -f "$dir/mav0/cam0/sensor.yaml" ] &&
    [ -f "$dir/mav0/state_groundtruth_estimate0/data.csv" ]
}

check_icl() {
  local dir="$1"
  [ -d "$dir/rgb" ] || return 1
  [ -f "$dir/associations.txt" ] || [ -f "$dir/rgb.txt" ] || return 1
  ls "$dir"/*.gt.freiburg >/dev/null 2>&1 || echo "  warning: no *.gt.freiburg in $dir (no ground truth)" >&2
  return 0
}

[ $# -ge 1 ] || usage
dest="$1"
shift
kinds=("$@")
[ ${#kinds[@]} -gt 0 ] || kinds=(tum euroc icl)
mkdir -p "$dest"
dest="$(cd "$dest" && pwd)"

for kind in "${kinds[@]}"; do
  case "$kind" in
    tum)
      mkdir -p "$dest/tum"
      for s in "${TUM_SEQUENCES[@]}"; do
        name="$(basename "$s")"
        get "$name" "$TUM_BASE/$s.tgz" "$dest/tum/$name.tgz" "$dest/tum/$name" check_tum
      done
      ;;
    euroc)
      mkdir -p "$dest/euroc"
      for s in "${EUROC_SEQUENCES[@]}"; do
        name="$(basename "$s")"
        get "$name" "$EUROC_BASE/$s/$name.zip" "$dest/euroc/$name.zip" "$dest/euroc/$name" check_euroc
      done
      ;;
    icl)
      mkdir -p "$dest/icl"
      for name in "${ICL_SEQUENCES[@]}"; do
        get "$name" "$ICL_BASE/$name.tar.gz" "$dest/icl/$name.tar.gz" "$dest/icl/$name" check_icl
      done
      ;;
    *) usage ;;
  esac
done
echo "done: $dest"
