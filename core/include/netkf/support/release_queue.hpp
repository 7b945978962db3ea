#pragma once
// Samples held until their release time (a link's delay): the channel emulator's and the
// relay's. Ordered by release time, so jitter reorders samples as netem does; equal times leave
// in arrival order. Not thread-safe: its owner guards it.
#include <chrono>
#include <cstdint>
#include <map>
#include <optional>
#include <queue>
#include <utility>
#include <vector>

namespace netkf {

template <class Sample>
class ReleaseQueue {
 public:
  using Clock = std::chrono::steady_clock;

  /// Hold `sample` of link `link_id` until `release`. True when it is now the earliest
  /// (whoever owns the timer must re-arm it).
  bool hold(Clock::time_point release, int link_id, Sample sample) {
    const bool earliest = queue_.empty() || release < queue_.top().release;
    queue_.push(Held{release, next_sequence_++, link_id, std::move(sample)});
    ++held_[link_id];
    return earliest;
  }

  /// Every sample due at `now`, in release order.
  std::vector<Sample> take_due(Clock::time_point now) {
    std::vector<Sample> due;
    while (!queue_.empty() && queue_.top().release <= now) {
      // top() is const; the element is popped right after, so moving out of it is safe.
      Held& top = const_cast<Held&>(queue_.top());
      --held_[top.link_id];
      due.push_back(std::move(top.sample));
      queue_.pop();
    }
    return due;
  }

  std::optional<Clock::time_point> next_release() const {
    if (queue_.empty()) return std::nullopt;
    return queue_.top().release;
  }
  std::size_t size() const { return queue_.size(); }
  std::uint64_t held(int link_id) const {
    const auto it = held_.find(link_id);
    return it == held_.end() ? 0 : it->second;
  }

 private:
  struct Held {
    Clock::time_point release;
    std::uint64_t sequence;  // arrival order: ties leave first-in first-out
    int link_id;
    Sample sample;
  };
  struct Later {
    bool operator()(const Held& a, const Held& b) const {
      return a.release != b.release ? a.release > b.release : a.sequence > b.sequence;
    }
  };
  std::priority_queue<Held, std::vector<Held>, Later> queue_;
  std::map<int, std::uint64_t> held_;
  std::uint64_t next_sequence_ = 0;
};

}  // namespace netkf
