// StaggeredVector: large buffers start at distinct cache-line offsets within a page (and on a huge
// page when they span one), small ones are plain, and the vector behaves as a std::vector (the
// allocator frees what it allocated: the sanitizer run of the unit tests checks that).

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <numeric>
#include <set>
#include <vector>

#include "solver/engine/staggered_vector.hpp"

namespace bondem {
namespace {

std::uintptr_t address(const void* pointer) {
  return reinterpret_cast<std::uintptr_t>(pointer);
}

TEST(StaggeredVector, LargeBuffersGetDistinctLineAlignedPageOffsets) {
  // Two more than the 8 ways of an L1 set: with malloc's own mappings all ten would share one
  // page offset.
  constexpr std::size_t kArrays = 10;
  const std::size_t values = kOwnMappingBytes / sizeof(double) + 1;
  std::vector<StaggeredVector<double>> arrays(kArrays);
  std::set<std::uintptr_t> offsets;
  for (StaggeredVector<double>& array : arrays) {
    array.assign(values, 1.0);
    EXPECT_EQ(address(array.data()) % kStaggerStep, 0U);
    offsets.insert(address(array.data()) % 4096);
  }
  EXPECT_EQ(offsets.size(), kArrays);
}

TEST(StaggeredVector, BuffersSpanningAHugePageStartOnOne) {
  // Huge pages only back whole 2 MiB pages inside a buffer: a buffer starting on a huge page
  // boundary (plus its stagger offset) wastes none of its head. The stagger still applies.
  constexpr std::size_t kArrays = 3;
  const std::size_t values = kHugePageBufferBytes / sizeof(double) + 1;
  std::vector<StaggeredVector<double>> arrays(kArrays);
  std::set<std::uintptr_t> offsets;
  for (StaggeredVector<double>& array : arrays) {
    assign_zeros(array, values);
    EXPECT_LT(address(array.data()) % kHugePageBytes, 4096U);
    offsets.insert(address(array.data()) % 4096);
    EXPECT_EQ(std::count(array.begin(), array.end(), 0.0), static_cast<std::ptrdiff_t>(values));
  }
  EXPECT_EQ(offsets.size(), kArrays);
}

TEST(StaggeredVector, KeepsItsValuesThroughGrowthAndCopies) {
  StaggeredVector<double> grown;
  // Through the threshold: small buffers first, then staggered ones.
  const std::size_t values = 3 * kOwnMappingBytes / sizeof(double);
  for (std::size_t i = 0; i < values; ++i) grown.push_back(static_cast<double>(i));
  StaggeredVector<double> copy = grown;
  ASSERT_EQ(copy.size(), values);
  std::vector<double> expected(values);
  std::iota(expected.begin(), expected.end(), 0.0);
  EXPECT_TRUE(std::equal(copy.begin(), copy.end(), expected.begin()));
  copy.resize(10);
  copy.shrink_to_fit();
  EXPECT_EQ(copy.back(), 9.0);
  StaggeredVector<std::uint8_t> empty;
  empty.reserve(0);
  EXPECT_TRUE(empty.empty());
}

}  // namespace
}  // namespace bondem
