#pragma once
/// Shares of a pass's chunks per thread, balanced by the time each thread measured.
///
/// A pass over particles splits them into contiguous runs of chunks, one per thread. Equal runs
/// are not equal work: rows differ in pairs, and the threads near a split read what the other
/// thread wrote (cache lines moving between cores), which on the 20 800 peer lattice made one
/// thread's pass 1 ~15 % slower than the other's, while its sweeps ran faster. A split moves
/// toward equal measured times: after every call, or (a Deferred split, which the stepper's
/// passes share) once a step by the passes' summed cost per chunk. One split for every pass keeps
/// a particle's data in the caches of the core that wrote them: where each pass balanced its own
/// split, pass 1's and pass 2's boundaries lay 9-25 chunks apart on the 20 800 peer lattice, and
/// the particles between them crossed between the cores every step. That costs little when the
/// two cores share a level-3 cache and much when they do not (bench_core_latency): two threads
/// on the 20 800 lattice ran 0.96 of the time with the shared split when the host had put them
/// on different dies (eight alternating pairs, 1.56 against 1.64 s), the same when it had not
/// (1.16 against 1.18 s), and the same at 10^6 (1.90 against 1.89 s, 50 steps). What the times of
/// one step do not foretell (a CPU slowed by the host, a thread woken late) the threads even out
/// within the step: one that is done takes chunks from the back of a share still running
/// (measured on the peer lattices with two threads, steps paired in one process: 1-3 % faster at
/// 20 800 particles, 6 % at 10^6). The split decides only which thread computes a particle or
/// pair, never the order of any sum: results do not depend on it (the same reason they do not
/// depend on the thread count).
#include <omp.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <utility>
#include <vector>

namespace bondem {

/// A pass's contiguous shares of chunks, one per thread, balanced by measured time.
class ThreadSplit {
 public:
  /// Tag of a split that several passes share: run() leaves it where it is and keeps its
  /// threads' costs, and rebalance_pending() moves it once for all of them by their summed cost.
  struct Deferred {};
  /// A split that run() moves after each call.
  ThreadSplit() = default;
  /// A split moved by rebalance_pending() only.
  explicit ThreadSplit(Deferred) : deferred_(true) {}

  /// Equal shares of @p chunks over @p threads, unless the split already has these counts.
  void prepare(std::size_t chunks, int threads) {
    const auto shares = static_cast<std::size_t>(std::max(threads, 1));
    if (chunks == chunks_ && begin_.size() == shares + 1) return;
    chunks_ = chunks;
    begin_.assign(shares + 1, 0);
    for (std::size_t t = 0; t <= shares; ++t) begin_[t] = chunks * t / shares;
    seconds_.assign(shares, 0.0);
    cost_.assign(shares, 0.0);
    pending_cost_.assign(shares, 0.0);
    call_cost_.assign(shares, 0.0);
    pending_ = false;
    left_ = std::make_unique<Left[]>(shares);
    done_.assign(shares, 0);
  }

  /// Shares, one per thread of the pass's team.
  int threads() const { return static_cast<int>(seconds_.size()); }
  /// First chunk of thread @p t's share; begin(t + 1) ends it.
  std::size_t begin(int t) const { return begin_[static_cast<std::size_t>(t)]; }

  /// Runs @p work(share, first_chunk, end_chunk) -> Result over every chunk in a parallel region
  /// of threads() threads and folds the results into @p result with @p combine(Result&, const
  /// Result&), one at a time in no fixed order: it must be exact and commutative (integer sums,
  /// max, and). Each thread works through its own share from the front in shrinking pieces, then
  /// takes pieces from the back of the share with the most chunks left, so that a thread slowed
  /// by its CPU or by a late start does not keep the others waiting at the join. @p work may thus
  /// be called several times per share, on consecutive runs of its chunks, and on a share's
  /// chunks with another share's index: the index a thread passes is one no other thread passes
  /// during the call (its own). Shares beyond the team's size (a smaller team than asked for)
  /// are taken by its threads in turn. Then moves the split (rebalance).
  template <class Result, class Work, class Combine>
  Result run(Result result, Work&& work, Combine&& combine) {
    const int shares = threads();
    if (shares == 1) {
      const double start = omp_get_wtime();
      combine(result, work(0, begin(0), begin(1)));
      seconds_[0] = omp_get_wtime() - start;
      return result;
    }
    for (std::size_t t = 0; t < static_cast<std::size_t>(shares); ++t) {
      left_[t].range.store(pack(begin_[t], begin_[t + 1]), std::memory_order_relaxed);
      seconds_[t] = 0.0;  // a smaller team measures its threads' only
      done_[t] = 0;
    }
#pragma omp parallel num_threads(shares)
    {
      const int team = omp_get_num_threads();
      const int me = omp_get_thread_num();
      const double start = omp_get_wtime();
      std::size_t done = 0;
      std::optional<Result> mine;
      const auto take = [&](int index, std::size_t first, std::size_t end) {
        Result part = work(index, first, end);
        if (mine) {
          combine(*mine, part);
        } else {
          mine = std::move(part);
        }
        done += end - first;
      };
      for (int t = me; t < shares; t += team) {
        while (const auto piece = claim(static_cast<std::size_t>(t), true)) {
          take(t, piece->first, piece->second);
        }
      }
      if (stealing_) {
        for (;;) {
          std::size_t victim = 0, most = 0;
          for (std::size_t t = 0; t < static_cast<std::size_t>(shares); ++t) {
            const std::uint64_t range = left_[t].range.load(std::memory_order_relaxed);
            if (back(range) - front(range) > most) {
              most = back(range) - front(range);
              victim = t;
            }
          }
          if (most == 0) break;
          if (const auto piece = claim(victim, false)) take(me, piece->first, piece->second);
        }
      }
      seconds_[static_cast<std::size_t>(me)] = omp_get_wtime() - start;
      done_[static_cast<std::size_t>(me)] = done;
#pragma omp critical(bondem_thread_split)
      if (mine) combine(result, *mine);
    }
    if (deferred_) {
      add_pending(seconds_, done_);
    } else {
      rebalance(seconds_, done_);
    }
    return result;
  }

  /// What run() does after each call of a Deferred split: adds the seconds per chunk of share
  /// t's thread, @p seconds[t] over @p done[t] chunks (empty: its own share's), to the costs that
  /// rebalance_pending() moves the split by. Public for tests.
  void add_pending(std::span<const double> seconds, std::span<const std::size_t> done) {
    if (!costs_of(seconds, done, call_cost_)) return;
    for (std::size_t t = 0; t < call_cost_.size(); ++t) pending_cost_[t] += call_cost_[t];
    pending_ = true;
  }

  /// Moves the split by the costs that the run() calls since the last call added up: each
  /// share's seconds per chunk summed over those passes, so that the shares balance the passes'
  /// total time. Nothing when no call measured every share.
  void rebalance_pending() {
    if (!pending_) return;
    pending_ = false;
    rebalance_to(pending_cost_);
    std::fill(pending_cost_.begin(), pending_cost_.end(), 0.0);
  }

  /// Whether run() lets a thread take chunks of other shares (the default); off, each thread
  /// runs its share alone and the join waits for the slowest. Process-wide, for benchmarks.
  static void set_stealing(bool stealing) {
    stealing_ = stealing;
  }

  /// Moves each boundary halfway toward the split at which every share would take the same time
  /// at its chunks per second, by at most kMaxMove of the chunks. A share's seconds per chunk are
  /// an average over the last calls (weight kNewWeight for the newest): at 10^6 particles one
  /// step's times scatter by 10-15 %, and a split following each step wandered by 15 %.
  /// @p seconds: each share's time at the current split.
  void rebalance(std::span<const double> seconds) {
    rebalance(seconds, {});
  }

  /// rebalance() where share t's thread ran @p done[t] chunks in @p seconds[t] (with chunks
  /// taken from other shares); empty: its own share's.
  void rebalance(std::span<const double> seconds, std::span<const std::size_t> done) {
    if (!costs_of(seconds, done, call_cost_)) return;
    rebalance_to(call_cost_);
  }

 private:
  /// Each share's seconds per chunk in @p cost from its thread's @p seconds over @p done chunks
  /// (empty: its own share's); false, and @p cost untouched, if some share measured nothing.
  bool costs_of(std::span<const double> seconds, std::span<const std::size_t> done,
                std::span<double> cost) const {
    const std::size_t shares = cost_.size();
    if (seconds.size() != shares || shares < 2 || chunks_ < 2 * shares) return false;
    for (std::size_t t = 0; t < shares; ++t) {
      if (!(seconds[t] > 0.0)) return false;  // nothing measured: keep the split
      if (!done.empty() && done[t] == 0) return false;
    }
    for (std::size_t t = 0; t < shares; ++t) {
      const std::size_t chunks = done.empty() ? begin_[t + 1] - begin_[t] : done[t];
      cost[t] = seconds[t] / static_cast<double>(chunks);
    }
    return true;
  }

  /// rebalance() from each share's seconds per chunk, @p cost.
  void rebalance_to(std::span<const double> cost) {
    const std::size_t shares = cost_.size();
    if (cost.size() != shares || shares < 2 || chunks_ < 2 * shares) return;
    double total_speed = 0.0;
    for (std::size_t t = 0; t < shares; ++t) {
      cost_[t] = cost_[t] > 0.0 ? cost_[t] + kNewWeight * (cost[t] - cost_[t]) : cost[t];
      total_speed += 1.0 / cost_[t];
    }
    const double max_move = std::max(1.0, kMaxMove * static_cast<double>(chunks_));
    double target_end = 0.0;
    for (std::size_t t = 0; t + 1 < shares; ++t) {
      target_end += static_cast<double>(chunks_) / cost_[t] / total_speed;
      const double now = static_cast<double>(begin_[t + 1]);
      const double moved = now + std::clamp(0.5 * (target_end - now), -max_move, max_move);
      // At least one chunk per share, in order.
      const double lowest = static_cast<double>(begin_[t] + 1);
      const double highest = static_cast<double>(chunks_ - (shares - t - 1));
      begin_[t + 1] = static_cast<std::size_t>(std::clamp(std::round(moved), lowest, highest));
    }
  }

  /// The chunks of a share not yet claimed, [front, back), in one word: claims from both ends
  /// by compare-and-swap. A cache line of its own.
  struct alignas(64) Left {
    std::atomic<std::uint64_t> range{0};
  };
  static std::uint64_t pack(std::size_t front, std::size_t back) {
    return static_cast<std::uint64_t>(front) | (static_cast<std::uint64_t>(back) << 32);
  }
  static std::size_t front(std::uint64_t range) {
    return range & 0xffffffffu;
  }
  static std::size_t back(std::uint64_t range) {
    return range >> 32;
  }

  /// Claims a piece of share @p t's chunks left, from the front (its own thread) or the back:
  /// a quarter of them, at least kMinPiece (the pieces shrink toward the end, where the
  /// threads meet, and a pass is restarted a few times only). None when nothing is left.
  std::optional<std::pair<std::size_t, std::size_t>> claim(std::size_t t, bool from_front) {
    std::uint64_t range = left_[t].range.load(std::memory_order_relaxed);
    for (;;) {
      const std::size_t f = front(range), b = back(range);
      if (f >= b) return std::nullopt;
      const std::size_t piece = std::min(b - f, std::max(kMinPiece, (b - f) / 4));
      const std::uint64_t rest = from_front ? pack(f + piece, b) : pack(f, b - piece);
      if (left_[t].range.compare_exchange_weak(range, rest, std::memory_order_relaxed)) {
        return from_front ? std::pair{f, f + piece} : std::pair{b - piece, b};
      }
    }
  }

  static constexpr std::size_t kMinPiece = 2;
  static inline bool stealing_ = true;
  std::unique_ptr<Left[]> left_;  ///< per share
  /// Per thread of the last run() (thread t runs share t first): chunks it ran, its busy time.
  std::vector<std::size_t> done_;
  std::vector<double> seconds_;
  static constexpr double kMaxMove = 1.0 / 256.0;
  static constexpr double kNewWeight = 0.125;
  std::size_t chunks_ = 0;
  std::vector<std::size_t> begin_;    ///< size threads + 1
  std::vector<double> cost_;          ///< per share, average seconds per chunk (0: none yet)
  bool deferred_ = false;             ///< constructed with Deferred
  bool pending_ = false;              ///< pending_cost_ holds a measured call
  std::vector<double> pending_cost_;  ///< per share, seconds per chunk summed over the calls
  std::vector<double> call_cost_;     ///< per share, the last call's seconds per chunk
};

}  // namespace bondem
