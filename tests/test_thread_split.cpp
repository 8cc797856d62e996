// ThreadSplit: the threads' shares of a pass, balanced by measured time; sort_in_parallel: the
// same order for any thread count.
#include <gtest/gtest.h>
#include <omp.h>

#include <cstddef>
#include <cstdint>
#include <random>
#include <utility>
#include <vector>

#include "solver/engine/parallel_sort.hpp"
#include "solver/engine/thread_split.hpp"

namespace bondem {
namespace {

TEST(ThreadSplit, StartsEqualAndCoversEveryChunkOnce) {
  ThreadSplit split;
  split.prepare(10, 3);
  ASSERT_EQ(split.threads(), 3);
  EXPECT_EQ(split.begin(0), 0u);
  EXPECT_EQ(split.begin(1), 3u);
  EXPECT_EQ(split.begin(2), 6u);
  EXPECT_EQ(split.begin(3), 10u);
  // Every chunk visited once, whatever team OpenMP gives: the shares' counts add up exactly.
  std::vector<int> visits(10, 0);
  const std::size_t total = split.run(
      std::size_t{0},
      [&](int, std::size_t first, std::size_t end) {
        for (std::size_t c = first; c < end; ++c) ++visits[c];
        return end - first;
      },
      [](std::size_t& sum, std::size_t part) { sum += part; });
  EXPECT_EQ(total, 10u);
  for (const int v : visits) EXPECT_EQ(v, 1);
  EXPECT_EQ(split.begin(0), 0u);
  EXPECT_EQ(split.begin(3), 10u);
}

/// Runs a split of 64 chunks over two shares whose first share's chunks take 2 ms each and the
/// second's none: the record of which share index and thread ran each chunk, and the team size.
struct SlowShareRun {
  std::vector<int> visits = std::vector<int>(64, 0);
  std::vector<int> index = std::vector<int>(64, -1);
  std::vector<int> thread = std::vector<int>(64, -1);
  int team = 0;
  std::size_t total = 0;
};
SlowShareRun run_slow_share() {
  ThreadSplit split;
  split.prepare(64, 2);
  SlowShareRun r;
  r.total = split.run(
      std::size_t{0},
      [&](int share, std::size_t first, std::size_t end) {
        for (std::size_t c = first; c < end; ++c) {
          ++r.visits[c];  // each chunk by one thread: no race unless a chunk is run twice
          r.index[c] = share;
          r.thread[c] = omp_get_thread_num();
          if (c < 32) {
            const double until = omp_get_wtime() + 2e-3;
            while (omp_get_wtime() < until) {
            }
          }
        }
#pragma omp atomic write
        r.team = omp_get_num_threads();
        return end - first;
      },
      [](std::size_t& sum, std::size_t part) { sum += part; });
  return r;
}

TEST(ThreadSplit, ThreadsTakeChunksOfASlowShareEachOnceUnderTheirOwnIndex) {
  const SlowShareRun r = run_slow_share();
  EXPECT_EQ(r.total, 64u);
  for (const int v : r.visits) EXPECT_EQ(v, 1);
  // The index a thread passes is its own: one thread per index (the wall loads' sums rely on it).
  for (std::size_t c = 0; c < 64; ++c) {
    for (std::size_t d = 0; d < 64; ++d) {
      if (r.index[c] == r.index[d]) {
        EXPECT_EQ(r.thread[c], r.thread[d]);
      }
    }
  }
  if (r.team < 2) GTEST_SKIP() << "OpenMP gave a team of one thread";
  // Share 1's thread finishes at once and takes from the back of share 0 (unless it starts more
  // than the 64 ms that share 0 takes alone after the other thread).
  EXPECT_EQ(r.index[31], 1);
}

TEST(ThreadSplit, WithoutStealingEachShareRunsOnItsOwnThread) {
  ThreadSplit::set_stealing(false);
  const SlowShareRun r = run_slow_share();
  ThreadSplit::set_stealing(true);
  EXPECT_EQ(r.total, 64u);
  for (std::size_t c = 0; c < 64; ++c) {
    EXPECT_EQ(r.visits[c], 1);
    EXPECT_EQ(r.index[c], c < 32 ? 0 : 1);
  }
}

TEST(ThreadSplit, MovesTowardEqualTimesByAtMostItsStep) {
  // 1 280 chunks: the boundary moves by at most 1 280 / 256 = 5 chunks per call. Share 0 takes
  // three times as long per chunk as share 1: the times are equal with share 0 at 320 chunks.
  constexpr std::size_t kChunks = 1280;
  ThreadSplit split;
  split.prepare(kChunks, 2);
  std::size_t before = split.begin(1);
  for (int call = 0; call < 200; ++call) {
    const double share0 = 3.0 * static_cast<double>(split.begin(1));
    const double share1 = static_cast<double>(kChunks - split.begin(1));
    const std::vector<double> seconds{share0, share1};
    split.rebalance(seconds);
    const std::size_t now = split.begin(1);
    EXPECT_LE(now, before);  // toward share 1, never past the balance point
    EXPECT_LE(before - now, 5u);
    before = now;
  }
  // Half the remaining distance per call once within the step: within a chunk of 320.
  EXPECT_NEAR(static_cast<double>(split.begin(1)), 320.0, 1.0);
  EXPECT_EQ(split.begin(2), kChunks);
}

TEST(ThreadSplit, KeepsTheSplitWithoutTimesAndEveryShareNonEmpty) {
  ThreadSplit split;
  split.prepare(8, 2);
  split.rebalance(std::vector<double>{0.0, 1.0});  // a share measured nothing: no move
  EXPECT_EQ(split.begin(1), 4u);
  for (int call = 0; call < 50; ++call) split.rebalance(std::vector<double>{1.0e6, 1.0e-6});
  EXPECT_EQ(split.begin(1), 1u);  // the slow share keeps one chunk
  // The same counts keep the balanced split; others start equal again.
  split.prepare(8, 2);
  EXPECT_EQ(split.begin(1), 1u);
  split.prepare(9, 2);
  EXPECT_EQ(split.begin(1), 4u);
}

TEST(ThreadSplit, RebalancesByTheChunksEachThreadRan) {
  // Equal times, but thread 1 ran three times the chunks of thread 0 (it took some of share 0's):
  // thread 0 is three times slower per chunk, and the split moves toward share 1.
  ThreadSplit split;
  split.prepare(1280, 2);
  split.rebalance(std::vector<double>{1.0, 1.0}, std::vector<std::size_t>{320, 960});
  EXPECT_EQ(split.begin(1), 635u);  // 640 moved by its largest step, 1280 / 256 = 5 chunks
  // A thread that ran nothing measured nothing: no move.
  split.rebalance(std::vector<double>{1.0, 1.0}, std::vector<std::size_t>{0, 1280});
  EXPECT_EQ(split.begin(1), 635u);
}

TEST(ThreadSplit, DeferredSplitMovesOnceAStepByThePassesSummedCost) {
  // Two passes a step over 1 280 chunks split 640/640. Pass A: thread 0 takes 3 s per chunk,
  // thread 1 1 s; pass B: 1 s each. Summed, 4 against 2: the step's times are equal with share 0
  // at 1 280 / 3 = 426.7 chunks. Neither pass alone moves the split; rebalance_pending() does,
  // by at most 5 chunks a call (1 280 / 256), and only once per step's costs.
  constexpr std::size_t kChunks = 1280;
  ThreadSplit split{ThreadSplit::Deferred{}};
  split.prepare(kChunks, 2);
  const auto step = [&] {
    const double share0 = static_cast<double>(split.begin(1));
    const double share1 = static_cast<double>(kChunks - split.begin(1));
    split.add_pending(std::vector<double>{3.0 * share0, share1}, {});
    split.add_pending(std::vector<double>{share0, share1}, {});
  };
  step();
  EXPECT_EQ(split.begin(1), 640u);
  split.rebalance_pending();
  EXPECT_EQ(split.begin(1), 635u);
  split.rebalance_pending();  // nothing added since: no move
  EXPECT_EQ(split.begin(1), 635u);
  for (int call = 0; call < 300; ++call) {
    step();
    split.rebalance_pending();
  }
  EXPECT_NEAR(static_cast<double>(split.begin(1)), 1280.0 / 3.0, 1.0);
}

TEST(ThreadSplit, DeferredSplitStaysWhereItIsThroughRun) {
  // However the threads' times come out, run() on a Deferred split leaves its shares alone. With
  // share 0's chunks ten times as costly a split moved after each call would go toward share 1
  // (by a chunk a call); which way rebalance_pending() then moves it depends on the threads'
  // timing, which a loaded machine can invert, so only the former is asserted.
  ThreadSplit split{ThreadSplit::Deferred{}};
  split.prepare(64, 2);
  for (int call = 0; call < 20; ++call) {
    const std::size_t covered = split.run(
        std::size_t{0},
        [&](int share, std::size_t first, std::size_t end) {
          // Share 0's chunks ten times as costly: an immediate split would move.
          volatile double sink = 0.0;
          for (std::size_t c = first; c < end; ++c) {
            for (int k = 0; k < (share == 0 ? 20000 : 2000); ++k) sink = sink + 1.0;
          }
          return end - first;
        },
        [](std::size_t& all, std::size_t part) { all += part; });
    EXPECT_EQ(covered, 64u);
    EXPECT_EQ(split.begin(1), 32u);
  }
}

TEST(SortInParallel, GivesStdSortsOrderAtOneToFourThreads) {
  // 20 000 keys (above the 4 096 from which it splits) with many equal first values, ordered
  // with their index as the tie-break: one sorted sequence, which 3 threads (pieces merged
  // unevenly) and 4 must give exactly as 1 and 2 do.
  std::mt19937_64 random(7);
  std::vector<std::pair<std::int64_t, std::uint32_t>> keys(20000);
  for (std::size_t k = 0; k < keys.size(); ++k) {
    keys[k] = {static_cast<std::int64_t>(random() % 500), static_cast<std::uint32_t>(k)};
  }
  const auto less = [](const auto& a, const auto& b) { return a < b; };
  auto expected = keys;
  std::sort(expected.begin(), expected.end(), less);
  const int threads_before = omp_get_max_threads();
  for (const int threads : {1, 2, 3, 4}) {
    omp_set_num_threads(threads);
    auto sorted = keys;
    sort_in_parallel(sorted, less);
    EXPECT_EQ(sorted, expected) << threads << " threads";
  }
  omp_set_num_threads(threads_before);
}

}  // namespace
}  // namespace bondem
