#pragma once
/// Shares of a pass's chunks per thread, balanced by the time each thread measured.
///
/// A pass over particles splits them into contiguous runs of chunks, one per thread. Equal runs
/// are not equal work: rows differ in pairs, and the threads near a split read what the other
/// thread wrote (cache lines moving between cores), which on the 20 800 peer lattice made one
/// thread's pass 1 ~15 % slower than the other's, while its sweeps ran faster. Each pass keeps
/// its own split and moves it after every call toward equal measured times. The split decides
/// only which thread computes a particle or pair, never the order of any sum: results do not
/// depend on it (the same reason they do not depend on the thread count).
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <span>
#include <vector>

namespace bondem {

/// A pass's contiguous shares of chunks, one per thread, balanced by measured time.
class ThreadSplit {
 public:
  /// Equal shares of @p chunks over @p threads, unless the split already has these counts.
  void prepare(std::size_t chunks, int threads) {
    const auto shares = static_cast<std::size_t>(std::max(threads, 1));
    if (chunks == chunks_ && begin_.size() == shares + 1) return;
    chunks_ = chunks;
    begin_.assign(shares + 1, 0);
    for (std::size_t t = 0; t <= shares; ++t) begin_[t] = chunks * t / shares;
    seconds_.assign(shares, 0.0);
    cost_.assign(shares, 0.0);
  }

  /// Shares, one per thread of the pass's team.
  int threads() const { return static_cast<int>(seconds_.size()); }
  /// First chunk of thread @p t's share; begin(t + 1) ends it.
  std::size_t begin(int t) const { return begin_[static_cast<std::size_t>(t)]; }

  /// Runs @p work(share, first_chunk, end_chunk) -> Result for every share in a parallel region of
  /// threads() threads, timing each share, and folds the shares' results into @p result with
  /// @p combine(Result&, const Result&) one at a time in no fixed order: it must be exact and
  /// commutative (integer sums, max, and). Shares beyond the team's size (a smaller team than
  /// asked for) are taken by its threads in turn. Then moves the split (rebalance).
  template <class Result, class Work, class Combine>
  Result run(Result result, Work&& work, Combine&& combine) {
    const int shares = threads();
#pragma omp parallel num_threads(shares) if (shares > 1)
    {
      const int team = omp_get_num_threads();
      for (int t = omp_get_thread_num(); t < shares; t += team) {
        const double start = omp_get_wtime();
        const Result part = work(t, begin(t), begin(t + 1));
        seconds_[static_cast<std::size_t>(t)] = omp_get_wtime() - start;
#pragma omp critical(bondem_thread_split)
        combine(result, part);
      }
    }
    rebalance(seconds_);
    return result;
  }

  /// Moves each boundary halfway toward the split at which every share would take the same time
  /// at its chunks per second, by at most kMaxMove of the chunks. A share's seconds per chunk are
  /// an average over the last calls (weight kNewWeight for the newest): at 10^6 particles one
  /// step's times scatter by 10-15 %, and a split following each step wandered by 15 %.
  /// @p seconds: each share's time at the current split.
  void rebalance(std::span<const double> seconds) {
    const std::size_t shares = cost_.size();
    if (seconds.size() != shares || shares < 2 || chunks_ < 2 * shares) return;
    for (std::size_t t = 0; t < shares; ++t) {
      if (!(seconds[t] > 0.0)) return;  // nothing measured: keep the split
    }
    double total_speed = 0.0;
    for (std::size_t t = 0; t < shares; ++t) {
      const double cost = seconds[t] / static_cast<double>(begin_[t + 1] - begin_[t]);
      cost_[t] = cost_[t] > 0.0 ? cost_[t] + kNewWeight * (cost - cost_[t]) : cost;
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

 private:
  static constexpr double kMaxMove = 1.0 / 256.0;
  static constexpr double kNewWeight = 0.125;
  std::size_t chunks_ = 0;
  std::vector<std::size_t> begin_;  ///< size threads + 1
  std::vector<double> seconds_;     ///< each share's time in the last run
  std::vector<double> cost_;        ///< per share, average seconds per chunk (0: none yet)
};

}  // namespace bondem
