#pragma once
/// @file run_mpi.hpp
/// A run decomposed over the processes of an MPI job (`mpirun -np R bondem run CASE`): each
/// process steps its subdomain with its own threads, and the outputs are the bytes run_case()
/// writes in one process. No MPI type appears here: a program includes it without mpi.h.

#include <iosfwd>
#include <string>

#include "io/run.hpp"
#include "solver/setup/case.hpp"

namespace bondem {

/// Run @p description as run_case() does, its particles decomposed over the processes of
/// MPI_COMM_WORLD (initialized by the caller, which calls this on every process).
///
/// Each process owns the particles in its box of a recursive coordinate bisection and keeps
/// copies (ghosts) of the others' particles within 2 r_max + 2 skin of it, whose motion their
/// owners send after every drift. All processes rebuild their lists together (when any particle has
/// moved half a skin), and at every rebuild the particles and their pairs' state are redistributed
/// over new cuts. Streams insert alike on every process, from the particles near their regions
/// gathered from all, and the new particles join their owners at the rebuild this forces, as a
/// run in one process rebuilds its list after an insertion. Each pair is counted by the owner of
/// its smaller id, each boundary contact by the particle's owner; totals are exact sums whose
/// digits add across processes. history.csv, checkpoint.bin, final_state.csv, clusters.csv and
/// layer.csv are therefore the bytes of the run in one process, for any number of processes and
/// threads; rank 0 writes them and the progress lines. A checkpoint continues on any number of
/// processes.
///
/// Returns on rank 0 the run's figures (elsewhere, the steps and the process's own particles).
/// Throws on every process the same error: CaseError (before writing anything), BlowUpError (no
/// last_good_state.csv yet), RunInterrupted.
RunResult run_case_distributed(Case description, const RunOptions& options, std::ostream& log);

}  // namespace bondem
