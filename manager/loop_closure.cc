#include "manager/loop_closure.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <set>
#include <tuple>
#include <unordered_map>

#include <opencv2/core.hpp>

#include "common/descriptor_match.h"
#include "common/logging.h"
#include "common/orb_extractor.h"
#include "common/pnp.h"
#include "common/stats.h"
#include "common/timestamp.h"
#include "manager/front_point_search.h"
#include "manager/place_merge.h"
#include "manager/pose_graph.h"
#include "manager/sim3_alignment.h"
#include "manager/submap_index.h"

namespace rumi {

int64_t LoopClosureState::Handle(const SubmapKey& s, int64_t keyframe) {
  const auto [it, inserted] = handle_of_.try_emplace({s, keyframe}, int64_t(handles_.size()));
  if (inserted) handles_.push_back({s, keyframe});
  return it->second;
}

namespace {

// Lookups of one submap, built once per CloseLoops.
struct Prepared {
  SubmapIndex idx;
  std::unordered_map<int64_t, int> kf_index;
  explicit Prepared(const Submap& s) : idx(s) {
    for (size_t k = 0; k < s.keyframes.size(); ++k) kf_index[s.keyframes[k].id] = int(k);
  }
};

bool Verify(const Submap& Q, const Prepared& pq, int q, const Submap& M, const Prepared& pm, int m,
            const ManagerOptions& o, LoopDetection* out, std::string* why) {
  const auto fail = [&](const std::string& w) {
    if (why) *why = w;
    return false;
  };
  // The query keyframe's mapped corners: its own descriptor, its point.
  const Keyframe& kq = Q.keyframes[size_t(q)];
  std::vector<uint8_t> dq;
  std::vector<Eigen::Vector3d> xq;
  std::vector<Eigen::Vector2f> uq;  // the corner in the query image
  for (size_t i = 0; i < kq.point_ids.size(); ++i) {
    const int p = kq.point_ids[i] >= 0 ? pq.idx.Point(kq.point_ids[i]) : -1;
    if (p < 0) continue;
    const uint8_t* d = nullptr;
    if (kq.descriptors.type() == CV_8U && kq.descriptors.cols == 32 && int(i) < kq.descriptors.rows &&
        HasDescriptor(kq.descriptors.ptr<uint8_t>(int(i))))
      d = kq.descriptors.ptr<uint8_t>(int(i));
    else
      d = PointDescriptor(Q, Q.points[size_t(p)], pq.kf_index);
    if (!d) continue;
    dq.insert(dq.end(), d, d + 32);
    xq.push_back(Q.points[size_t(p)].position);
    uq.push_back(kq.keypoints[i]);
  }
  // The candidate's neighbourhood: the points of its window, each once.
  std::vector<uint8_t> dm;
  std::vector<Eigen::Vector3d> xm;
  std::set<int> seen;
  const int lo = std::max(0, m - o.loop_window), hi = std::min(int(M.keyframes.size()) - 1, m + o.loop_window);
  for (int k = lo; k <= hi; ++k)
    for (int64_t pid : M.keyframes[size_t(k)].point_ids) {
      const int p = pid >= 0 ? pm.idx.Point(pid) : -1;
      if (p < 0 || !seen.insert(p).second) continue;
      const uint8_t* d = PointDescriptor(M, M.points[size_t(p)], pm.kf_index);
      if (!d) continue;
      dm.insert(dm.end(), d, d + 32);
      xm.push_back(M.points[size_t(p)].position);
    }
  const auto matches = MatchDescriptors(dq.data(), dq.size() / 32, dm.data(), dm.size() / 32,
                                        {o.loop_max_hamming, o.loop_ratio, /*mutual=*/false});
  out->matches = int(matches.size());
  if (out->matches < o.loop_min_inliers)
    return fail("too few descriptor matches (" + std::to_string(matches.size()) + ")");
  std::vector<Eigen::Vector3d> src, dst;
  std::vector<double> depth;
  const Se3& T_cw = M.keyframes[size_t(m)].T_cw;
  for (const auto& [a, b] : matches) {
    src.push_back(xq[size_t(a)]);
    dst.push_back(xm[size_t(b)]);
    depth.push_back((T_cw * xm[size_t(b)]).z());
  }
  const double d = UpperMedian(depth);
  if (!(d > 0)) return fail("the matched points are not in front of the candidate");
  const RansacSim3Result rs = RansacSim3(src, dst, o.loop_ransac_ratio * d, o.ransac_iterations, o.ransac_seed);
  out->inliers = rs.num_inliers;
  if (!rs.ok || rs.num_inliers < o.loop_min_inliers)
    return fail("too few RANSAC inliers (" + std::to_string(rs.num_inliers) + " of " +
                std::to_string(matches.size()) + ")");
  // The query camera placed against the candidate's points by PnP, from
  // the RANSAC's guess: the 3D fit's rotation rests on monocular depths
  // (on a generated room it was degrees off while the drift was one), a
  // reprojection fit on the image. In the candidate's units (the Sim(3)'s
  // scale s brings query units there).
  const double s_mq = rs.transform.scale();
  const Sim3 guess = Sim3(s_mq, Eigen::Quaterniond::Identity(), Eigen::Vector3d::Zero()) * Sim3(kq.T_cw) *
                     rs.transform.Inverse();
  std::vector<cv::Point3f> obj;
  std::vector<cv::Point2f> img;
  for (size_t i = 0; i < matches.size(); ++i) {
    if (!rs.inliers[i]) continue;
    const Eigen::Vector3d& X = dst[i];
    obj.emplace_back(float(X.x()), float(X.y()), float(X.z()));
    img.emplace_back(uq[size_t(matches[i].first)].x(), uq[size_t(matches[i].first)].y());
  }
  std::vector<int> pnp_inliers;
  Se3 T_qM_pnp;
  // Keypoints are undistorted already: the pinhole K, no distortion.
  if (!PnpRansacFromGuess(obj, img, Q.camera, guess.R(), guess.translation(), o.loop_pnp_px, &T_qM_pnp, &pnp_inliers) ||
      int(pnp_inliers.size()) < o.loop_min_inliers)
    return fail("too few PnP inliers (" + std::to_string(pnp_inliers.size()) + " of " + std::to_string(obj.size()) +
                ")");
  out->inliers = int(pnp_inliers.size());
  const Sim3 T_qM(1.0, T_qM_pnp.rotation(), T_qM_pnp.translation());
  out->query_submap = {Q.source, Q.id};
  out->match_submap = {M.source, M.id};
  out->query_keyframe = kq.id;
  out->match_keyframe = M.keyframes[size_t(m)].id;
  out->query_time = kq.timestamp;
  out->match_time = M.keyframes[size_t(m)].timestamp;
  // p_q(cam, query units) = T_qM p_M / s, p_M = T_wc_m * p_m(cam).
  out->S_qm = Sim3(1.0 / s_mq, Eigen::Quaterniond::Identity(), Eigen::Vector3d::Zero()) * T_qM *
              Sim3(M.keyframes[size_t(m)].T_wc());
  // The same as a map of query-submap points into the candidate's frame.
  out->S_mq = Sim3(M.keyframes[size_t(m)].T_wc()) * out->S_qm.Inverse() * Sim3(kq.T_cw);
  return true;
}

// A node of a component's graph: a front keyframe.
struct Node {
  int submap = -1, keyframe = -1;
  Timestamp t = 0;
};

}  // namespace

bool VerifyLoop(const Submap& Q, int q, const Submap& M, int m, const ManagerOptions& options, LoopDetection* out,
                std::string* why) {
  return Verify(Q, Prepared(Q), q, M, Prepared(M), m, options, out, why);
}

LoopClosureReport CloseLoops(GlobalMap* map, const ManagerOptions& o, LoopClosureState* state,
                             const std::vector<bool>* fresh, const std::atomic<bool>* cancel) {
  LoopClosureReport rep;
  if (!o.loop_closure) return rep;
  {
    // Raw poses: a fresh submap's replace what was kept (a resent submap's
    // keyframes were refined since); a keyframe culled since keeps its own
    // (a loop found on it is carried to its living neighbour); the entries
    // of submaps no longer in the map go.
    std::map<std::pair<SubmapKey, int64_t>, Se3> raw;
    std::set<SubmapKey> present;
    for (size_t s = 0; s < map->size(); ++s) {
      const Submap& S = map->submap(int(s));
      if (S.source != SubmapSource::kFront) continue;
      present.insert(map->Key(int(s)));
      const bool is_fresh = !fresh || s >= fresh->size() || (*fresh)[s];
      for (const Keyframe& kf : S.keyframes) {
        const std::pair<SubmapKey, int64_t> key{map->Key(int(s)), kf.id};
        const auto it = state->memory.raw_pose.find(key);
        raw[key] = !is_fresh && it != state->memory.raw_pose.end() ? it->second : kf.T_wc();
      }
    }
    for (const auto& [key, T] : state->memory.raw_pose)
      if (present.count(key.first)) raw.emplace(key, T);
    state->memory.raw_pose = std::move(raw);
    for (auto it = state->memory.solved.begin(); it != state->memory.solved.end();)
      it = present.count(it->first.first) ? std::next(it) : state->memory.solved.erase(it);
  }
  auto t0 = std::chrono::steady_clock::now();
  const int n = int(map->size());
  std::vector<std::unique_ptr<Prepared>> prep(static_cast<size_t>(n));
  const auto prepared = [&](int s) -> const Prepared& {
    if (!prep[size_t(s)]) prep[size_t(s)] = std::make_unique<Prepared>(map->submap(s));
    return *prep[size_t(s)];
  };
  // Every front keyframe into the index (a key added before is kept as it
  // was: descriptors do not change).
  Timestamp first_t = 0, last_t = 0;
  bool any = false;
  for (int s = 0; s < n; ++s) {
    const Submap& S = map->submap(s);
    if (S.source != SubmapSource::kFront) continue;
    for (const Keyframe& kf : S.keyframes) {
      state->index.Add(state->Handle(map->Key(s), kf.id), KeyframeDescriptors(kf));
      first_t = any ? std::min(first_t, kf.timestamp) : kf.timestamp;
      last_t = any ? std::max(last_t, kf.timestamp) : kf.timestamp;
      any = true;
    }
  }
  // A session shorter than the training set may still loop: train on what
  // there is once the keyframes span a loop's gap.
  if (!state->index.ready() && any && NsToSeconds(last_t - first_t) >= o.loop_min_gap_s) state->index.TrainNow();
  // Where a handle's keyframe is in this map (-1, -1 when not).
  std::map<SubmapKey, int> submap_of;
  for (int s = 0; s < n; ++s) submap_of[map->Key(s)] = s;
  const auto locate = [&](const std::pair<SubmapKey, int64_t>& kf) -> std::pair<int, int> {
    const auto it = submap_of.find(kf.first);
    if (it == submap_of.end()) return {-1, -1};
    const auto k = prepared(it->second).idx.Keyframe(kf.second);
    return {k < 0 ? -1 : it->second, k};
  };
  // Keyframes culled from the map (or whose submap went) leave the index:
  // it follows the map, which follows the area covered, not the hours.
  state->index.RemoveUnless([&](int64_t h) { return locate(state->Keyframe(h)).first >= 0; });
  const int64_t gap_ns = int64_t(o.loop_min_gap_s * 1e9);
  if (state->index.ready()) {
    for (int s = 0; s < n; ++s) {
      const Submap& S = map->submap(s);
      if (S.source != SubmapSource::kFront) continue;
      for (size_t k = 0; k < S.keyframes.size(); ++k) {
        const Keyframe& kf = S.keyframes[k];
        const auto key = std::make_pair(map->Key(s), kf.id);
        if (state->memory.searched.count(key)) continue;
        if (cancel && cancel->load()) return rep;  // nothing changed yet
        ++rep.keyframes_queried;
        std::vector<LoopDetection>& found = state->memory.searched[key];
        const BowVector& bow = state->index.Bow(state->Handle(key.first, key.second));
        // ORB-SLAM's bar: a loop candidate must look at least as much like
        // this keyframe as its own neighbour does (here a share of it).
        const size_t nb = k > 0 ? k - 1 : k + 1;
        if (bow.empty() || nb >= S.keyframes.size()) continue;
        const double ref =
            BowScore(bow, state->index.Bow(state->Handle(key.first, S.keyframes[nb].id)));
        const auto older = [&](int64_t h) {
          const auto& c = state->Keyframe(h);
          const auto [cs, ck] = locate(c);
          return cs < 0 || map->submap(cs).keyframes[size_t(ck)].timestamp > kf.timestamp - gap_ns;
        };
        for (const PlaceIndex::Match& c : state->index.Query(bow, size_t(o.loop_candidates), older)) {
          if (c.score < o.loop_min_score_ratio * ref) break;
          const auto [cs, ck] = locate(state->Keyframe(c.key));
          ++rep.candidates_verified;
          LoopDetection d;
          d.score = c.score;
          if (Verify(S, prepared(s), int(k), map->submap(cs), prepared(cs), ck, o, &d, nullptr)) found.push_back(d);
        }
      }
    }
  }
  rep.seconds_detect = SecondsSince(t0);
  t0 = std::chrono::steady_clock::now();

  // The detections that hold in this map, per component.
  struct Found {
    LoopDetection d;
    int qs, qk, ms, mk;
    double depth;  // scene depth at the query keyframe (global units)
  };
  // Median depth of a keyframe's points, in global units.
  const auto depth_at = [&](int s, int k) {
    const Submap& S = map->submap(s);
    const Keyframe& kf = S.keyframes[size_t(k)];
    std::vector<double> z;
    for (int64_t pid : kf.point_ids) {
      const int p = pid >= 0 ? prepared(s).idx.Point(pid) : -1;
      if (p >= 0) z.push_back((kf.T_cw * S.points[size_t(p)].position).z());
    }
    return UpperMedian(std::move(z)) * map->ToGlobal(s).scale();
  };
  std::map<int, std::vector<Found>> by_component;
  // A detection's keyframe, or when it was culled, the living keyframe of
  // its submap nearest in time, with the raw relative pose between the two
  // (T: culled camera -> living camera); {-1, -1} when its submap is gone.
  struct Living {
    int s = -1, k = -1;
    Sim3 T;
  };
  const auto living = [&](const SubmapKey& key, int64_t id, Timestamp t) {
    Living l;
    const auto it = submap_of.find(key);
    if (it == submap_of.end() || map->submap(it->second).keyframes.empty()) return l;
    l.s = it->second;
    l.k = prepared(l.s).idx.Keyframe(id);
    if (l.k >= 0) return l;
    const auto raw = state->memory.raw_pose.find({key, id});
    if (raw == state->memory.raw_pose.end()) return Living{};
    const auto& kfs = map->submap(l.s).keyframes;
    const size_t k = size_t(NearestInTime(kfs.begin(), kfs.end(), t, [](const Keyframe& kf) { return kf.timestamp; }) -
                            kfs.begin());
    l.k = int(k);
    l.T = Sim3(state->memory.raw_pose.at({key, kfs[k].id})).Inverse() * Sim3(raw->second);
    return l;
  };
  for (const auto& [key, list] : state->memory.searched)
    for (const LoopDetection& d : list) {
      const Living q = living(d.query_submap, d.query_keyframe, d.query_time);
      const Living m = living(d.match_submap, d.match_keyframe, d.match_time);
      if (q.s < 0 || m.s < 0 || !map->Connected(q.s, m.s)) continue;
      ++rep.detections;
      LoopDetection carried = d;
      carried.S_qm = q.T * d.S_qm * m.T.Inverse();
      by_component[map->Component(q.s)].push_back({carried, q.s, q.k, m.s, m.k, depth_at(q.s, q.k)});
    }
  PoseGraphOptions pgo;
  pgo.consistency = o.loop_consistency;
  pgo.chi2_confidence = o.loop_chi2_confidence;
  pgo.variance_factor = o.loop_variance_factor;
  for (auto& [root, found] : by_component) {
    // Nodes: the component's front keyframes in time order.
    std::vector<Node> nodes;
    for (int s : map->Members(root)) {
      if (map->submap(s).source != SubmapSource::kFront) continue;
      for (size_t k = 0; k < map->submap(s).keyframes.size(); ++k)
        nodes.push_back({s, int(k), map->submap(s).keyframes[k].timestamp});
    }
    std::sort(nodes.begin(), nodes.end(), [](const Node& a, const Node& b) {
      return std::tie(a.t, a.submap, a.keyframe) < std::tie(b.t, b.submap, b.keyframe);
    });
    std::map<std::pair<int, int>, int> node_of;
    // The graph starts from the raw poses; `before` is what the keyframe's
    // points are in now: its raw pose in a fresh submap, else where the last
    // solve put it, scale included (a keyframe's pose keeps no scale, its
    // points do: taking the rigid pose there scaled the points again at
    // every rebuild, and a map replayed in rounds ran 120 m off).
    std::vector<Sim3> S_w(nodes.size()), before(nodes.size());
    for (size_t i = 0; i < nodes.size(); ++i) {
      node_of[{nodes[i].submap, nodes[i].keyframe}] = int(i);
      const Keyframe& kf = map->submap(nodes[i].submap).keyframes[size_t(nodes[i].keyframe)];
      const Sim3& S_gl = map->ToGlobal(nodes[i].submap);
      const std::pair<SubmapKey, int64_t> key{map->Key(nodes[i].submap), kf.id};
      S_w[i] = S_gl * Sim3(state->memory.raw_pose.at(key));
      const bool is_fresh = !fresh || size_t(nodes[i].submap) >= fresh->size() || (*fresh)[size_t(nodes[i].submap)];
      const auto solved = state->memory.solved.find(key);
      before[i] = is_fresh || solved == state->memory.solved.end() ? S_gl * Sim3(kf.T_wc()) : solved->second;
    }
    const std::vector<Sim3> start = S_w;
    // Translations are whitened in each node's own units, which a monocular
    // submap sets at its initialisation: a share of the scene depth there.
    PoseGraphOptions gopt = pgo;
    {
      std::vector<double> depth;
      for (size_t i = 0; i < nodes.size(); i += std::max<size_t>(1, nodes.size() / 64)) {
        const double d = depth_at(nodes[i].submap, nodes[i].keyframe) / map->ToGlobal(nodes[i].submap).scale();
        if (d > 0) depth.push_back(d);
      }
      const double d = UpperMedian(depth);
      if (d > 0) gopt.translation_sigma = o.loop_translation_sigma * d;
    }
    // The walk: each keyframe to the next as the map has them now (within a
    // submap its own tracking, across submaps the merge that joined them).
    std::vector<PoseGraphEdge> edges;
    for (size_t i = 0; i + 1 < nodes.size(); ++i) {
      PoseGraphEdge e;
      e.i = int(i);
      e.j = int(i + 1);
      e.S_ij = S_w[i].Inverse() * S_w[i + 1];
      e.kind = nodes[i].submap == nodes[i + 1].submap ? PoseGraphEdgeKind::kCovisibility : PoseGraphEdgeKind::kMerge;
      e.robust = false;
      // Across submaps the walk is a merge's placement over a gap in
      // tracking: far less certain than a submap's own tracking from one
      // keyframe to the next, so a loop re-places the submap there rather
      // than bend both.
      if (e.kind == PoseGraphEdgeKind::kMerge) e.weight = o.loop_merge_edge_weight;
      edges.push_back(e);
    }
    // Loops: runs of detections whose query keyframes follow each other
    // within loop_group_s in one submap, matched within loop_group_s of the
    // run's first match in one submap, and agreeing on the correction.
    std::sort(found.begin(), found.end(), [](const Found& a, const Found& b) {
      return std::tie(a.d.query_time, a.d.match_time) < std::tie(b.d.query_time, b.d.match_time);
    });
    const int64_t group_ns = int64_t(o.loop_group_s * 1e9);
    // The correction a detection asks of its query keyframe (global): where
    // the match puts it, S_wq = S_wm * S_qm^-1, against where it is.
    const auto correction = [&](const Found& f) {
      const Sim3& S_wq = S_w[size_t(node_of[{f.qs, f.qk}])];
      return S_w[size_t(node_of[{f.ms, f.mk}])] * f.d.S_qm.Inverse() * S_wq.Inverse();
    };
    // A keyframe may match several earlier passes (a room walked ten
    // times): each detection joins the open run of its own match, if any.
    std::vector<std::vector<size_t>> groups;
    for (size_t i = 0; i < found.size(); ++i) {
      const Found& f = found[i];
      const Eigen::Vector3d c = S_w[size_t(node_of[{f.qs, f.qk}])].translation();
      const Sim3 Cb = correction(f);
      std::vector<size_t>* joined = nullptr;
      for (auto g = groups.rbegin(); g != groups.rend() && !joined; ++g) {
        const Found& first = found[g->front()];
        const Found& prev = found[g->back()];
        if (f.d.query_time - prev.d.query_time > group_ns) continue;
        const Sim3 Ca = correction(first);
        const double rot = RotationAngle(Ca.rotation() * Cb.rotation().inverse()) * 180.0 / M_PI;
        // Agreement: the two corrections put this keyframe within a tenth
        // of its scene depth of each other.
        if (f.qs == prev.qs && f.ms == first.ms && std::llabs(f.d.match_time - first.d.match_time) <= group_ns &&
            (Ca * c - Cb * c).norm() <= 0.1 * f.depth && rot <= 5.0)
          joined = &*g;
      }
      if (joined)
        joined->push_back(i);
      else
        groups.push_back({i});
    }
    bool changed = false;
    // A loop decided at an earlier rebuild is not tried again: one that the
    // graph took is put back in (its correction spread, then one solve for
    // all of them), one it refused stays out. New loops go in together with
    // one solve, or one by one when the lot does not hold; at most
    // loop_max_solves solves a rebuild: a looped hour has hundreds of loops,
    // and closing each again with a solve of the whole graph took 31 s of a
    // rebuild at 2,000 keyframes (a daemon's watchdog killed it).
    int solves = 0;
    bool spread = false, unsolved = false;
    std::vector<LoopClosureState::GroupKey> decided_now;  // undone if the result cannot be kept
    std::vector<std::pair<size_t, LoopReport>> reports;  // by group, in order
    const auto group_key = [&](const std::vector<size_t>& g) {
      const Found& f = found[g.front()];
      return LoopClosureState::GroupKey{map->Key(f.qs), f.d.query_keyframe, map->Key(f.ms), f.d.match_keyframe};
    };
    const auto edge_of = [&](const Found& best) {
      PoseGraphEdge e;
      e.i = node_of[{best.qs, best.qk}];
      e.j = node_of[{best.ms, best.mk}];
      e.kind = PoseGraphEdgeKind::kLoop;
      e.S_ij = best.d.S_qm;
      // Plain least squares, as ORB-SLAM's essential graph: a right loop
      // after a long walk asks for a correction many times one edge's sigma,
      // which a robust loss takes for an outlier. A wrong one is refused
      // after the solve instead: spread over the walk it strains the walk's
      // own edges beyond their sigmas (CloseLoop's check).
      e.robust = false;
      return e;
    };
    // What closing a loop did to its query keyframe, from where it was before.
    const auto finish = [&](size_t gi, LoopReport lr, const PoseGraphEdge& e, const Found& best, const Sim3& q_before) {
      const Sim3 C = S_w[size_t(e.i)] * q_before.Inverse();
      lr.shift = (S_w[size_t(e.i)].translation() - q_before.translation()).norm();
      lr.rotation_deg = RotationAngle(C.rotation()) * 180.0 / M_PI;
      lr.scale_change = C.scale() - 1.0;
      lr.shift_ratio = best.depth > 0 ? lr.shift / best.depth : 0;
      lr.depth = best.depth / map->ToGlobal(best.qs).scale();
      rep.closed += lr.closed;
      reports.push_back({gi, std::move(lr)});
    };
    for (int pass = 0; pass < 2; ++pass) {  // 0: loops decided before, 1: new ones
      if (pass == 1 && spread) {
        // Warm start: where the last solve left each keyframe, a keyframe
        // new since carried from the one before it by the walk's raw step.
        // (Spreading each old loop's correction again from the raw poses
        // and solving once put a broken front's map 120 m off.)
        for (size_t i = 0; i < nodes.size(); ++i) {
          const Keyframe& kf = map->submap(nodes[i].submap).keyframes[size_t(nodes[i].keyframe)];
          const auto it = state->memory.solved.find({map->Key(nodes[i].submap), kf.id});
          if (it != state->memory.solved.end())
            S_w[i] = it->second;
          else if (i > 0)
            S_w[i] = S_w[i - 1] * (start[i - 1].Inverse() * start[i]);
        }
        const PoseGraphResult r = OptimizePoseGraph(&S_w, edges, {0}, gopt);
        ++solves;
        if (!r.ok) spdlog::warn("loop closure: the solve of the loops closed before failed: {}", r.message);
      }
      // New loops the graph has to move for, in the order they were made.
      struct Pending {
        size_t gi;
        LoopReport lr;
        PoseGraphEdge e;
        const Found* best;
        bool alone = false;  // taken out of a refused lot: tried by itself
      };
      std::vector<Pending> pending;
      for (size_t gi = 0; gi < groups.size(); ++gi) {
        const std::vector<size_t>& g = groups[gi];
        std::set<std::pair<int, int>> queries;
        for (size_t i : g) queries.insert({found[i].qs, found[i].qk});
        if (int(queries.size()) < o.loop_min_consistent) continue;
        const auto decided = state->decided.find(group_key(g));
        if ((pass == 0) != (decided != state->decided.end())) continue;
        const Found& best = found[*std::max_element(
            g.begin(), g.end(), [&](size_t a, size_t b) { return found[a].d.inliers < found[b].d.inliers; })];
        LoopReport lr;
        lr.edge = best.d;
        // Reported between the keyframes the edge joins: a culled keyframe's
        // detection is carried to a living one (S_qm is between those two),
        // and the loop audit takes the ground truth at these times.
        const auto report_at = [&](int sub, int k, int64_t* id, Timestamp* t) {
          const Keyframe& kf = map->submap(sub).keyframes[size_t(k)];
          *id = kf.id;
          *t = kf.timestamp;
        };
        report_at(best.qs, best.qk, &lr.edge.query_keyframe, &lr.edge.query_time);
        report_at(best.ms, best.mk, &lr.edge.match_keyframe, &lr.edge.match_time);
        lr.support = int(queries.size());
        const PoseGraphEdge e = edge_of(best);
        const Sim3 q_before = S_w[size_t(e.i)];
        const bool consistent = PoseGraphResidual(S_w, e, gopt).norm() <= gopt.outlier_factor * gopt.loss_scale;
        if (e.j >= e.i) {
          lr.reason = "the match is not older than the query";
        } else if (pass == 1 && std::min(best.qk, best.mk) < o.loop_skip_first_keyframes) {
          // A front's first keyframes rest on its initialisation alone.
          lr.reason = "at one of its front's first " + std::to_string(o.loop_skip_first_keyframes) + " keyframes";
        } else if (pass == 0) {
          lr.closed = decided->second;
          lr.reason = decided->second ? "closed at an earlier rebuild" : "refused at an earlier rebuild";
          if (decided->second) {
            spread = changed = true;
            edges.push_back(e);
          }
        } else if (consistent) {
          edges.push_back(e);
          lr.closed = true;
          lr.reason = "already consistent";
          state->decided[group_key(g)] = true;
          decided_now.push_back(group_key(g));
          unsolved = true;
        } else {
          pending.push_back({gi, std::move(lr), e, &best});
          continue;
        }
        finish(gi, std::move(lr), e, best, q_before);
      }
      if (pending.empty()) continue;
      // New loops go in together, with one solve: a looped hour brings a
      // few dozen with every pass (each pass meets the earlier ones all
      // along), and one solve each, loop_max_solves a rebuild, fell behind
      // (993 waiting after 20 minutes). When a lot does not hold, the rest
      // of the rebuild goes one by one. Spread in query order, each
      // correction only along the walk since the loop before it (spreading
      // each over its whole chain moved the keyframes between a pass and the
      // earlier one once per loop: 1,880 loops at once took scales past e^30).
      // At most loop_batch at once: a lot refused costs its solve.
      const size_t most = size_t(std::max(1, o.loop_batch));
      size_t next = 0, len = most;
      bool one_by_one = false;
      while (next < pending.size()) {
        len = std::min(len, pending.size() - next);
        for (size_t k = next; k < next + len; ++k)
          if (pending[k].alone) {
            len = std::max<size_t>(1, k - next);
            break;
          }
        // A lot only where a refusal leaves a solve for one loop alone: every
        // rebuild decides something.
        if (solves + 2 > o.loop_max_solves) len = 1;
        if (solves >= o.loop_max_solves) {
          for (; next < pending.size(); ++next) {
            Pending& p = pending[next];
            p.lr.reason = "waits for the next rebuild (loop_max_solves)";
            ++rep.waiting;
            finish(p.gi, std::move(p.lr), p.e, *p.best, S_w[size_t(p.e.i)]);
          }
          break;
        }
        // Spread in query order (the lot is tried, and one by one decided,
        // in the loops' own order).
        std::vector<size_t> order;
        for (size_t k = next; k < next + len; ++k) order.push_back(k);
        std::stable_sort(order.begin(), order.end(),
                         [&](size_t a, size_t b) { return pending[a].e.i < pending[b].e.i; });
        std::vector<NewGraphEdge> news;
        for (size_t k = 0; k < order.size(); ++k) {
          NewGraphEdge ne;
          ne.edge = pending[order[k]].e;
          const int from =
              k == 0 ? ne.edge.j : std::max(ne.edge.j, std::min(pending[order[k - 1]].e.i, ne.edge.i - 1));
          for (int n = from; n <= ne.edge.i; ++n) ne.chain.push_back(n);
          for (int n = ne.edge.i + 1; n < int(nodes.size()); ++n) ne.followers.push_back(n);
          news.push_back(std::move(ne));
        }
        const std::vector<Sim3> pre = S_w;
        const CloseLoopResult r = CloseLoopEdges(&S_w, edges, {0}, news, gopt);
        ++solves;
        spdlog::info("loop closure: {} new loop(s) in one solve: chi2 +{:.1f} ({} dof): {}", len, r.chi2_increase,
                     r.dof, r.reason);
        if (!r.accepted && len > 1 && gopt.consistency == "chi2" && r.new_residuals.size() == len) {
          // The lot's own worst loops out (each beyond one edge's bound, or
          // the worst when none is), to be tried alone at the end; the rest
          // again as a lot.
          const double bound = OneEdgeBound(gopt);
          std::vector<bool> out(len, false);
          size_t worst = 0, n_out = 0;
          for (size_t k = 0; k < len; ++k) {
            if (r.new_residuals[k] > r.new_residuals[worst]) worst = k;
            if (r.new_residuals[k] > bound) out[k] = true, ++n_out;
          }
          if (n_out == 0) out[worst] = true, n_out = 1;
          std::vector<Pending> kept, suspects;
          for (size_t k = 0; k < len; ++k) (out[k] ? suspects : kept).push_back(std::move(pending[order[k]]));
          std::stable_sort(kept.begin(), kept.end(), [](const Pending& a, const Pending& b) { return a.gi < b.gi; });
          std::vector<Pending> rest(std::make_move_iterator(pending.begin() + long(next + len)),
                                    std::make_move_iterator(pending.end()));
          pending.resize(next);
          for (auto* part : {&kept, &rest, &suspects})
            for (Pending& p : *part) pending.push_back(std::move(p));
          for (size_t k = pending.size() - suspects.size(); k < pending.size(); ++k) pending[k].alone = true;
          len = std::max<size_t>(1, kept.size());
          continue;
        }
        if (r.accepted || len == 1) {
          for (size_t k = next; k < next + len; ++k) {
            Pending& p = pending[k];
            p.lr.closed = r.accepted;
            p.lr.reason = len > 1 ? "accepted (one solve with " + std::to_string(len) + " new loops)" : r.reason;
            state->decided[group_key(groups[p.gi])] = r.accepted;
            decided_now.push_back(group_key(groups[p.gi]));
            if (r.accepted) edges.push_back(p.e);
            finish(p.gi, std::move(p.lr), p.e, *p.best, pre[size_t(p.e.i)]);
          }
          if (r.accepted) {
            changed = true;
            unsolved = false;
          }
          next += len;
          len = one_by_one ? 1 : most;
        } else {
          // One by one for the rest of this rebuild: halving costs up to
          // log2(most) solves per loop refused, and on a looped walk whose
          // fronts drift in scale most new loops strained the walk's edges
          // (a rebuild then decided one loop, not loop_max_solves).
          len = 1;
          one_by_one = true;
        }
      }
    }
    // Edges taken as consistent since the last solve join a last one: the
    // same graph then solves to the same map whether its loops came one by
    // one (this rebuild) or together (the next).
    if ((changed || spread) && unsolved) {
      const PoseGraphResult r = OptimizePoseGraph(&S_w, edges, {0}, gopt);
      if (!r.ok) spdlog::warn("loop closure: the last solve failed: {}", r.message);
    }
    std::stable_sort(reports.begin(), reports.end(),
                     [](const auto& a, const auto& b) { return a.first < b.first; });
    for (auto& [gi, lr] : reports) rep.loops.push_back(std::move(lr));
    // No loop closed: the keyframes stay where they are (a base corrected
    // by an earlier rebuild keeps its correction).
    if (!changed) continue;
    if (!std::all_of(S_w.begin(), S_w.end(), ValidPose)) {
      spdlog::warn("loop closure: a solve left a keyframe without a valid pose; the map is left as it was");
      for (const auto& key : decided_now) state->decided.erase(key);
      continue;
    }
    for (size_t i = 0; i < nodes.size(); ++i) {
      const Keyframe& kf = map->submap(nodes[i].submap).keyframes[size_t(nodes[i].keyframe)];
      state->memory.solved[{map->Key(nodes[i].submap), kf.id}] = S_w[i];
    }
    // Write the corrections back: keyframes, their points, the tracked
    // frames (nearest keyframe in time), back submaps (nearest front
    // keyframe in time).
    std::vector<Sim3> C(nodes.size());
    for (size_t i = 0; i < nodes.size(); ++i) {
      C[i] = S_w[i] * before[i].Inverse();
      rep.keyframes_moved += (S_w[i].translation() - start[i].translation()).norm() > 0;
    }
    std::map<int, std::vector<int>> nodes_of_submap;  // in time order
    for (size_t i = 0; i < nodes.size(); ++i) nodes_of_submap[nodes[i].submap].push_back(int(i));
    const auto nearest = [&](const std::vector<int>& list, Timestamp t) {
      return *NearestInTime(list.begin(), list.end(), t, [&](int i) { return nodes[size_t(i)].t; });
    };
    // A correction that is no correction (the same solve as at the last
    // rebuild) is not written: a submap touched by rounding would hash anew
    // and miss the merge and revisit memos at every rebuild.
    const auto none = [&](int i) {
      const Sim3& c = C[size_t(i)];
      return std::abs(c.scale() - 1.0) < 1e-9 && RotationAngle(c.rotation()) < 1e-9 &&
             (S_w[size_t(i)].translation() - before[size_t(i)].translation()).norm() <
                 1e-9 * (1.0 + before[size_t(i)].translation().norm());
    };
    for (const auto& [s, list] : nodes_of_submap) {
      if (std::all_of(list.begin(), list.end(), none)) continue;
      Submap& S = map->submap(s);
      const Sim3 S_gl = map->ToGlobal(s), S_lg = S_gl.Inverse();
      const auto local = [&](int i) { return S_lg * C[size_t(i)] * S_gl; };
      std::unordered_map<int64_t, int> node_of_kf;
      for (int i : list) node_of_kf[S.keyframes[size_t(nodes[size_t(i)].keyframe)].id] = i;
      for (MapPoint& p : S.points) {
        if (p.observations.empty()) continue;
        const auto it = node_of_kf.find(p.observations.front().keyframe_id);
        if (it != node_of_kf.end()) p.position = local(it->second) * p.position;
      }
      for (FrameRecord& f : S.frames) {
        if (f.state != TrackingState::kTracking && f.state != TrackingState::kCoarse) continue;
        const Sim3 L = local(nearest(list, f.timestamp)) * Sim3(f.T_wc);
        f.T_wc = Se3(L.rotation(), L.translation());
      }
      for (int i : list) {
        const Sim3 L = S_lg * S_w[size_t(i)];
        S.keyframes[size_t(nodes[size_t(i)].keyframe)].T_cw = Se3(L.rotation(), L.translation()).Inverse();
      }
    }
    std::vector<int> all(nodes.size());
    for (size_t i = 0; i < nodes.size(); ++i) all[i] = int(i);
    for (int s : map->Members(root)) {
      const Submap& B = map->submap(s);
      if (B.source == SubmapSource::kFront || B.keyframes.empty()) continue;
      const Timestamp mid = B.keyframes[B.keyframes.size() / 2].timestamp;
      const int k = nearest(all, mid);
      if (!none(k)) map->entry(s).S_gl = C[size_t(k)] * map->ToGlobal(s);
    }
  }
  rep.seconds_close = SecondsSince(t0);
  map->loops() = state->memory;
  return rep;
}

}  // namespace rumi
