// StaggeredVector: large buffers start at distinct cache-line offsets within a page (and on a huge
// page when they span one), small ones are plain, assign_zeros and populate give what they say,
// and the vector behaves as a std::vector (the allocator frees what it allocated: the sanitizer
// run of the unit tests checks that).

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

TEST(StaggeredVector, AssignZerosGivesZerosAtEverySize) {
  // Each path of assign_zeros: small (a plain assign), fresh pages populated on the calling
  // thread, in 1 MiB pieces on every thread, on huge pages, and a smaller size within the
  // capacity, whose old values (-1 here) must all be overwritten.
  StaggeredVector<double> values;
  for (const std::size_t bytes : {kPopulatedBytes - 8, kPopulatedBytes + 8, kOwnMappingBytes + 4104,
                                  3 * kHugePageBufferBytes + 8, kPopulatedBytes + 8}) {
    const std::size_t count = bytes / sizeof(double);
    values.assign(std::min(values.capacity(), count), -1.0);
    assign_zeros(values, count);
    ASSERT_EQ(values.size(), count);
    EXPECT_EQ(std::count(values.begin(), values.end(), 0.0), static_cast<std::ptrdiff_t>(count))
        << bytes << " bytes";
  }
}

TEST(StaggeredVector, PopulateKeepsTheBytes) {
  // An unaligned range: its partial first and last pages are left alone, every byte is kept.
  std::vector<std::uint8_t> bytes(5 * 4096 + 123);
  for (std::size_t i = 0; i < bytes.size(); ++i) bytes[i] = static_cast<std::uint8_t>(i * 7 + 1);
  const std::vector<std::uint8_t> before = bytes;
  populate(bytes.data() + 17, bytes.size() - 40);
  EXPECT_EQ(bytes, before);
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
