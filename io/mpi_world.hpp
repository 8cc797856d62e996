#pragma once
/// @file mpi_world.hpp
/// The few MPI collectives of the distributed run and its tests, over MPI_COMM_WORLD: who this
/// process is, and bytes gathered from every process. For code linked with MPI only (io/run_mpi
/// and the MPI tests); nothing of bondem::core includes it.

#include <mpi.h>

#include <cstring>
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

/// Every process's @p mine, concatenated in rank order, on every process (@p at_root_only: on
/// rank 0 only; the others get nothing).
inline std::vector<char> gathered(const std::vector<char>& mine, bool at_root_only = false) {
  const int size = world_size();
  const int bytes = static_cast<int>(mine.size());
  std::vector<int> counts(static_cast<std::size_t>(size)), offsets(static_cast<std::size_t>(size));
  MPI_Allgather(&bytes, 1, MPI_INT, counts.data(), 1, MPI_INT, MPI_COMM_WORLD);
  int total = 0;
  for (int r = 0; r < size; ++r) {
    offsets[static_cast<std::size_t>(r)] = total;
    total += counts[static_cast<std::size_t>(r)];
  }
  std::vector<char> all;
  if (at_root_only) {
    if (world_rank() == 0) all.resize(static_cast<std::size_t>(total));
    MPI_Gatherv(mine.data(), bytes, MPI_BYTE, all.data(), counts.data(), offsets.data(), MPI_BYTE,
                0, MPI_COMM_WORLD);
  } else {
    all.resize(static_cast<std::size_t>(total));
    MPI_Allgatherv(mine.data(), bytes, MPI_BYTE, all.data(), counts.data(), offsets.data(),
                   MPI_BYTE, MPI_COMM_WORLD);
  }
  return all;
}

/// Every process sends @p out[r] to process r; returns what it receives, concatenated in rank
/// order, with the bytes from each process in @p counts.
inline std::vector<char> exchanged(const std::vector<std::vector<char>>& out,
                                   std::vector<int>& counts) {
  const auto size = static_cast<std::size_t>(world_size());
  std::vector<int> send_counts(size), send_offsets(size), receive_offsets(size);
  std::vector<char> sent;
  for (std::size_t r = 0; r < size; ++r) {
    send_offsets[r] = static_cast<int>(sent.size());
    send_counts[r] = static_cast<int>(out[r].size());
    sent.insert(sent.end(), out[r].begin(), out[r].end());
  }
  counts.assign(size, 0);
  MPI_Alltoall(send_counts.data(), 1, MPI_INT, counts.data(), 1, MPI_INT, MPI_COMM_WORLD);
  int total = 0;
  for (std::size_t r = 0; r < size; ++r) {
    receive_offsets[r] = total;
    total += counts[r];
  }
  std::vector<char> received(static_cast<std::size_t>(total));
  MPI_Alltoallv(sent.data(), send_counts.data(), send_offsets.data(), MPI_BYTE, received.data(),
                counts.data(), receive_offsets.data(), MPI_BYTE, MPI_COMM_WORLD);
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
