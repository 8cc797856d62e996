#pragma once
/// @file pin_cpu.hpp
/// Pinning a thread to one CPU, for the probes of two CPUs (core_latency.cpp, core_transfer.cpp).
#include <pthread.h>
#include <sched.h>

namespace bondem::bench {

/// Pins the calling thread to @p cpu; false if the CPU is not available to the process.
inline bool pin_to(int cpu) {
  cpu_set_t set;
  CPU_ZERO(&set);
  CPU_SET(cpu, &set);
  return pthread_setaffinity_np(pthread_self(), sizeof set, &set) == 0;
}

}  // namespace bondem::bench
