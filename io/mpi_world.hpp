#pragma once
/// @file mpi_world.hpp
/// The few MPI collectives of the distributed run and its tests, over MPI_COMM_WORLD: who this
/// process is, and bytes gathered from every process. For code linked with MPI only (io/run_mpi
/// and the MPI tests); nothing of bondem::core includes it.

#include <mpi.h>

#include <cstdint>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

namespace bondem {

/// This process's rank in MPI_COMM_WORLD.
inline int world_rank() {
  int rank = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  return rank;
}

/// The number of processes in MPI_COMM_WORLD.
inline int world_size() {
  int size = 1;
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  return size;
}

/// Bytes travel in units of kTransferUnit bytes (an MPI datatype of that many bytes), each
/// process's share padded to whole units, and their counts as 64-bit integers: MPI's int counts
/// and offsets then reach 2^31 units (128 GiB) where counting bytes would stop at 2 GiB (a
/// gather of the records of some 8 million particles).
inline constexpr std::int64_t kTransferUnit = 64;

/// The MPI datatype of @p kBytes contiguous bytes, committed on first use.
template <std::int64_t kBytes>
MPI_Datatype bytes_type() {
  static const MPI_Datatype type = [] {
    MPI_Datatype made = MPI_DATATYPE_NULL;
    MPI_Type_contiguous(static_cast<int>(kBytes), MPI_BYTE, &made);
    MPI_Type_commit(&made);
    return made;
  }();
  return type;
}

/// The MPI datatype of one transfer unit.
inline MPI_Datatype transfer_unit() {
  return bytes_type<kTransferUnit>();
}

/// Units that hold @p bytes.
inline std::int64_t units_of(std::int64_t bytes) {
  return (bytes + kTransferUnit - 1) / kTransferUnit;
}

/// @p units as an MPI count; throws std::length_error beyond what an int holds.
inline int mpi_count(std::int64_t units) {
  if (units > std::numeric_limits<int>::max()) {
    throw std::length_error("a transfer between processes exceeds 2^31 units");
  }
  return static_cast<int>(units);
}

/// The @p parts at @p data (each a process's bytes padded to whole units, one after the other,
/// @p bytes[r] bytes of process r in its units) with the padding taken out, in place; returns the
/// bytes kept.
inline std::size_t unpad(char* data, const std::vector<std::int64_t>& bytes) {
  std::size_t to = 0, from = 0;
  for (const std::int64_t b : bytes) {
    const auto n = static_cast<std::size_t>(b);
    if (to != from) std::memmove(data + to, data + from, n);
    to += n;
    from += static_cast<std::size_t>(units_of(b) * kTransferUnit);
  }
  return to;
}

/// unpad() of a vector of bytes, resized to what is kept.
inline void unpad(std::vector<char>& parts, const std::vector<std::int64_t>& bytes) {
  parts.resize(unpad(parts.data(), bytes));
}

/// Every process's @p mine, concatenated in rank order, on every process (@p at_root_only: on
/// rank 0 only; the others get nothing), received in place. Bytes travel in transfer units, @p mine
/// padded in place (pass it moved, with room for a unit more: a copy of a process's records at
/// the end of a large run is 100 B a particle); other trivially copyable values as datatypes of
/// their own size, unpadded (counts then reach 2^31 values). With @p bytes_from, the bytes each
/// process sent, by rank.
template <class T>
std::vector<T> gathered(std::vector<T> mine, bool at_root_only = false,
                        std::vector<std::int64_t>* bytes_from = nullptr) {
  static_assert(std::is_trivially_copyable_v<T>);
  constexpr auto kUnit = sizeof(T) == 1 ? kTransferUnit : static_cast<std::int64_t>(sizeof(T));
  const auto units = [](std::int64_t bytes) { return (bytes + kUnit - 1) / kUnit; };
  const auto values = [](std::int64_t units_count) {
    return static_cast<std::size_t>(units_count * kUnit) / sizeof(T);
  };
  const auto size = static_cast<std::size_t>(world_size());
  const auto my_bytes = static_cast<std::int64_t>(mine.size() * sizeof(T));
  std::vector<std::int64_t> bytes(size);
  MPI_Allgather(&my_bytes, 1, MPI_INT64_T, bytes.data(), 1, MPI_INT64_T, MPI_COMM_WORLD);
  std::vector<int> counts(size), offsets(size);
  std::int64_t total = 0;
  for (std::size_t r = 0; r < size; ++r) {
    offsets[r] = mpi_count(total);
    counts[r] = mpi_count(units(bytes[r]));
    total += counts[r];
  }
  mpi_count(total);
  mine.resize(values(units(my_bytes)));
  const bool receives = !at_root_only || world_rank() == 0;
  std::vector<T> all(receives ? values(total) : 0);
  const int my_units = mpi_count(units(my_bytes));
  if (at_root_only) {
    MPI_Gatherv(mine.data(), my_units, bytes_type<kUnit>(), all.data(), counts.data(),
                offsets.data(), bytes_type<kUnit>(), 0, MPI_COMM_WORLD);
  } else {
    MPI_Allgatherv(mine.data(), my_units, bytes_type<kUnit>(), all.data(), counts.data(),
                   offsets.data(), bytes_type<kUnit>(), MPI_COMM_WORLD);
  }
  if constexpr (sizeof(T) == 1) {
    if (receives) all.resize(unpad(reinterpret_cast<char*>(all.data()), bytes));
  }
  if (bytes_from != nullptr) *bytes_from = std::move(bytes);
  return all;
}

/// Every process sends @p out[r] to process r; returns what it receives, concatenated in rank
/// order, with the bytes from each process in @p counts.
inline std::vector<char> exchanged(const std::vector<std::vector<char>>& out,
                                   std::vector<std::int64_t>& counts) {
  const auto size = static_cast<std::size_t>(world_size());
  std::vector<std::int64_t> send_bytes(size);
  std::vector<int> send_units(size), send_offsets(size), receive_units(size), receive_offsets(size);
  std::int64_t total = 0;
  for (std::size_t r = 0; r < size; ++r) {
    send_bytes[r] = static_cast<std::int64_t>(out[r].size());
    send_offsets[r] = mpi_count(total);
    send_units[r] = mpi_count(units_of(send_bytes[r]));
    total += send_units[r];
  }
  std::vector<char> sent(static_cast<std::size_t>(mpi_count(total) * kTransferUnit));
  for (std::size_t r = 0; r < size; ++r) {
    if (!out[r].empty()) {
      std::memcpy(sent.data() + static_cast<std::size_t>(send_offsets[r]) * kTransferUnit,
                  out[r].data(), out[r].size());
    }
  }
  counts.assign(size, 0);
  MPI_Alltoall(send_bytes.data(), 1, MPI_INT64_T, counts.data(), 1, MPI_INT64_T, MPI_COMM_WORLD);
  total = 0;
  for (std::size_t r = 0; r < size; ++r) {
    receive_offsets[r] = mpi_count(total);
    receive_units[r] = mpi_count(units_of(counts[r]));
    total += receive_units[r];
  }
  std::vector<char> received(static_cast<std::size_t>(mpi_count(total) * kTransferUnit));
  MPI_Alltoallv(sent.data(), send_units.data(), send_offsets.data(), transfer_unit(),
                received.data(), receive_units.data(), receive_offsets.data(), transfer_unit(),
                MPI_COMM_WORLD);
  unpad(received, counts);
  return received;
}

/// The bytes of @p values.
template <class T>
inline std::vector<char> bytes_of(const std::vector<T>& values) {
  std::vector<char> bytes(values.size() * sizeof(T));
  if (!bytes.empty()) std::memcpy(bytes.data(), values.data(), bytes.size());
  return bytes;
}

/// The values whose bytes are @p bytes.
template <class T>
inline std::vector<T> values_of(const std::vector<char>& bytes) {
  std::vector<T> values(bytes.size() / sizeof(T));
  if (!values.empty()) std::memcpy(values.data(), bytes.data(), values.size() * sizeof(T));
  return values;
}

}  // namespace bondem
