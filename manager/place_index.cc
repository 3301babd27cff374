#include "manager/place_index.h"

#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>

#include "common/orb_extractor.h"

namespace rumi {
namespace {

const uint8_t* Row(const std::vector<uint8_t>& d, size_t i) { return &d[i * 32]; }

// Bitwise majority of the rows `members` (ties: 0).
void Majority(const std::vector<uint8_t>& d, const std::vector<int>& members, uint8_t* out) {
  int count[256] = {0};
  for (int m : members) {
    const uint8_t* r = Row(d, size_t(m));
    for (int b = 0; b < 256; ++b) count[b] += (r[b >> 3] >> (b & 7)) & 1;
  }
  std::memset(out, 0, 32);
  for (int b = 0; b < 256; ++b)
    if (2 * count[b] > int(members.size())) out[b >> 3] |= uint8_t(1 << (b & 7));
}

}  // namespace

void PlaceVocabulary::Train(const std::vector<uint8_t>& all, const PlaceIndexOptions& o) {
  nodes_.clear();
  idf_.clear();
  num_words_ = 0;
  const size_t n_all = all.size() / 32;
  if (n_all == 0) return;
  // An even sample: the clustering's cost is linear in it.
  std::vector<uint8_t> d;
  const size_t n = std::min(n_all, size_t(std::max(1, o.max_train_descriptors)));
  d.reserve(n * 32);
  for (size_t i = 0; i < n; ++i) {
    const uint8_t* r = Row(all, i * n_all / n);
    d.insert(d.end(), r, r + 32);
  }
  std::mt19937 rng(o.seed);
  const int k = std::max(2, o.branching);
  std::vector<int> leaf_count;
  nodes_.push_back(Node{});
  // Depth-first; a node's children are appended together, so they are
  // contiguous.
  struct Task {
    int node, level;
    std::vector<int> members;
  };
  std::vector<Task> stack;
  {
    std::vector<int> everyone(n);
    for (size_t i = 0; i < n; ++i) everyone[i] = int(i);
    stack.push_back({0, 0, std::move(everyone)});
  }
  while (!stack.empty()) {
    Task t = std::move(stack.back());
    stack.pop_back();
    if (t.level >= o.levels || int(t.members.size()) <= k) {
      nodes_[size_t(t.node)].word = num_words_++;
      leaf_count.push_back(int(t.members.size()));
      continue;
    }
    // k-means++ seeding under the Hamming distance, then k-majority.
    std::vector<std::array<uint8_t, 32>> centres;
    std::vector<int> dist(t.members.size(), std::numeric_limits<int>::max());
    std::array<uint8_t, 32> c{};
    std::memcpy(c.data(), Row(d, size_t(t.members[rng() % t.members.size()])), 32);
    centres.push_back(c);
    while (int(centres.size()) < k) {
      double total = 0;
      for (size_t i = 0; i < t.members.size(); ++i) {
        dist[i] = std::min(dist[i], DescriptorDistance(Row(d, size_t(t.members[i])), centres.back().data()));
        total += double(dist[i]) * dist[i];
      }
      if (total <= 0) break;  // every member equals a centre
      double pick = std::uniform_real_distribution<double>(0, total)(rng);
      size_t chosen = t.members.size() - 1;
      for (size_t i = 0; i < t.members.size(); ++i) {
        pick -= double(dist[i]) * dist[i];
        if (pick <= 0) {
          chosen = i;
          break;
        }
      }
      std::memcpy(c.data(), Row(d, size_t(t.members[chosen])), 32);
      centres.push_back(c);
    }
    std::vector<std::vector<int>> clusters;
    for (int it = 0; it < std::max(1, o.kmajority_iterations); ++it) {
      clusters.assign(centres.size(), {});
      for (int m : t.members) {
        int best = 0, best_d = 257;
        for (size_t j = 0; j < centres.size(); ++j) {
          const int dd = DescriptorDistance(Row(d, size_t(m)), centres[j].data());
          if (dd < best_d) best_d = dd, best = int(j);
        }
        clusters[size_t(best)].push_back(m);
      }
      bool moved = false;
      for (size_t j = 0; j < centres.size(); ++j) {
        if (clusters[j].empty()) continue;
        std::array<uint8_t, 32> m{};
        Majority(d, clusters[j], m.data());
        moved |= m != centres[j];
        centres[j] = m;
      }
      if (!moved) break;
    }
    std::vector<size_t> kept;
    for (size_t j = 0; j < centres.size(); ++j)
      if (!clusters[j].empty()) kept.push_back(j);
    if (kept.size() < 2) {  // no split: a leaf
      nodes_[size_t(t.node)].word = num_words_++;
      leaf_count.push_back(int(t.members.size()));
      continue;
    }
    const int first = int(nodes_.size());
    nodes_[size_t(t.node)].first_child = first;
    nodes_[size_t(t.node)].num_children = int(kept.size());
    for (size_t j : kept) {
      Node child;
      std::memcpy(child.centre, centres[j].data(), 32);
      nodes_.push_back(child);
    }
    for (size_t c2 = 0; c2 < kept.size(); ++c2)
      stack.push_back({first + int(c2), t.level + 1, std::move(clusters[kept[c2]])});
  }
  // idf: a word most training descriptors fall into tells little.
  idf_.resize(size_t(num_words_));
  for (int w = 0; w < num_words_; ++w) idf_[size_t(w)] = float(std::log(double(n) / std::max(1, leaf_count[size_t(w)])));
}

int PlaceVocabulary::Word(const uint8_t* descriptor) const {
  int node = 0;
  while (nodes_[size_t(node)].num_children > 0) {
    const Node& p = nodes_[size_t(node)];
    int best = p.first_child, best_d = 257;
    for (int c = p.first_child; c < p.first_child + p.num_children; ++c) {
      const int dd = DescriptorDistance(descriptor, nodes_[size_t(c)].centre);
      if (dd < best_d) best_d = dd, best = c;
    }
    node = best;
  }
  return nodes_[size_t(node)].word;
}

BowVector PlaceVocabulary::Transform(const std::vector<uint8_t>& descriptors) const {
  BowVector v;
  if (!trained()) return v;
  std::vector<int> words;
  for (size_t i = 0; i < descriptors.size() / 32; ++i) words.push_back(Word(Row(descriptors, i)));
  std::sort(words.begin(), words.end());
  double total = 0;
  for (size_t i = 0; i < words.size();) {
    size_t j = i;
    while (j < words.size() && words[j] == words[i]) ++j;
    const float w = float(j - i) * idf_[size_t(words[i])];
    if (w > 0) {
      v.push_back({words[i], w});
      total += w;
    }
    i = j;
  }
  if (total > 0)
    for (auto& [word, w] : v) w = float(w / total);
  return v;
}

std::vector<uint8_t> KeyframeDescriptors(const Keyframe& kf) {
  std::vector<uint8_t> d;
  if (kf.descriptors.type() != CV_8U || kf.descriptors.cols != 32) return d;
  d.reserve(size_t(kf.descriptors.rows) * 32);
  for (int r = 0; r < kf.descriptors.rows; ++r) {
    const uint8_t* row = kf.descriptors.ptr<uint8_t>(r);
    if (HasDescriptor(row)) d.insert(d.end(), row, row + 32);
  }
  return d;
}

double BowScore(const BowVector& a, const BowVector& b) {
  // For L1-normalised non-negative vectors, 1 - |a - b|_1 / 2 is the sum of
  // the smaller weight over the common words.
  double s = 0;
  for (size_t i = 0, j = 0; i < a.size() && j < b.size();) {
    if (a[i].first < b[j].first) {
      ++i;
    } else if (b[j].first < a[i].first) {
      ++j;
    } else {
      s += std::min(a[i].second, b[j].second);
      ++i, ++j;
    }
  }
  return s;
}

void PlaceIndex::Add(int64_t key, const std::vector<uint8_t>& descriptors) {
  if (!slot_of_.emplace(key, keys_.size()).second) return;
  keys_.push_back(key);
  bows_.emplace_back();
  dead_.push_back(0);
  if (ready()) {
    bows_.back() = vocabulary_.Transform(descriptors);
    Index(keys_.size() - 1);
    return;
  }
  pending_.push_back(descriptors);
  pending_descriptors_ += descriptors.size() / 32;
  if (pending_descriptors_ >= size_t(std::max(1, o_.min_train_descriptors))) TrainNow();
}

void PlaceIndex::TrainNow() {
  if (ready() || pending_descriptors_ == 0) return;
  std::vector<uint8_t> all;
  all.reserve(pending_descriptors_ * 32);
  for (const auto& d : pending_) all.insert(all.end(), d.begin(), d.end());
  vocabulary_.Train(all, o_);
  postings_.assign(size_t(vocabulary_.num_words()), {});
  for (size_t slot = 0; slot < keys_.size(); ++slot) {
    bows_[slot] = vocabulary_.Transform(pending_[slot]);
    Index(slot);
  }
  pending_.clear();
  pending_.shrink_to_fit();
  pending_descriptors_ = 0;
}

void PlaceIndex::Index(size_t slot) {
  for (const auto& [word, w] : bows_[slot]) postings_[size_t(word)].push_back({int(slot), w});
}

void PlaceIndex::Remove(int64_t key) {
  const auto it = slot_of_.find(key);
  if (it == slot_of_.end()) return;
  const size_t slot = it->second;
  slot_of_.erase(it);
  dead_[slot] = 1;
  ++num_dead_;
  bows_[slot].clear();
  if (slot < pending_.size()) {  // not trained yet: its descriptors stay out of the training
    pending_descriptors_ -= pending_[slot].size() / 32;
    pending_[slot].clear();
  }
  if (ready() && num_dead_ > keys_.size() / 2) Compact();
}

void PlaceIndex::Compact() {
  std::vector<int64_t> keys;
  std::vector<BowVector> bows;
  for (size_t slot = 0; slot < keys_.size(); ++slot) {
    if (dead_[slot]) continue;
    keys.push_back(keys_[slot]);
    bows.push_back(std::move(bows_[slot]));
  }
  keys_ = std::move(keys);
  bows_ = std::move(bows);
  dead_.assign(keys_.size(), 0);
  num_dead_ = 0;
  slot_of_.clear();
  for (auto& list : postings_) list.clear();
  for (size_t slot = 0; slot < keys_.size(); ++slot) {
    slot_of_[keys_[slot]] = slot;
    Index(slot);
  }
}

const BowVector& PlaceIndex::Bow(int64_t key) const {
  static const BowVector kEmpty;
  const auto it = slot_of_.find(key);
  return it == slot_of_.end() ? kEmpty : bows_[it->second];
}

std::vector<PlaceIndex::Match> PlaceIndex::Score(const BowVector& query) const {
  std::vector<Match> out;
  last_postings_ = 0;
  if (!ready()) return out;
  acc_.resize(keys_.size(), 0.0f);
  for (const auto& [word, qw] : query) {
    if (word < 0 || size_t(word) >= postings_.size()) continue;
    const auto& list = postings_[size_t(word)];
    last_postings_ += list.size();
    for (const auto& [slot, w] : list) {
      if (dead_[size_t(slot)]) continue;
      if (acc_[size_t(slot)] == 0.0f) touched_.push_back(slot);
      acc_[size_t(slot)] += std::min(qw, w);
    }
  }
  out.reserve(touched_.size());
  for (int slot : touched_) {
    out.push_back({keys_[size_t(slot)], double(acc_[size_t(slot)])});
    acc_[size_t(slot)] = 0.0f;
  }
  touched_.clear();
  return out;
}

}  // namespace rumi
