#pragma once
// Internal: this process's place in MPI_COMM_WORLD and a progress log that only rank 0 prints,
// shared by the precomputes that deal their work to ranks (impulse_response.cc,
// virtual_dof.cc).
#include <irdm_common/error.h>
#include <irdm_common/files.h>

#include <mpi.h>
#include <sched.h>

#include <chrono>
#include <functional>
#include <string>
#include <thread>
#include <utility>

namespace irdm::fem
{
  struct MpiRank
  {
    int rank = 0, size = 1;

    MpiRank()
    {
      MPI_Comm_rank(MPI_COMM_WORLD, &rank);
      MPI_Comm_size(MPI_COMM_WORLD, &size);
    }

    /// log, called on rank 0 only (a no-op if log is empty).
    std::function<void(const std::string &)>
    rank0(std::function<void(const std::string &)> log) const
    {
      return [is_root = rank == 0, log = std::move(log)](const std::string &s) {
        if (is_root && log)
          log(s);
      };
    }
  };

  /// The output of a precompute that rank 0 writes: rank 0 checks the path and takes its
  /// lock at once, before any work, so that a bad path or a second run to the same file is
  /// refused at once (the lock of the other ranks is empty). `what` names the precompute.
  inline OutputLock
  lock_output_on_rank0(const MpiRank &mpi, const std::string &output, const std::string &mesh_file,
                       const std::string &what)
  {
    if (output.empty())
      throw InputError(what + ": no output file given");
    if (mpi.rank != 0)
      return OutputLock();
    check_output_file("--out", output, {mesh_file});
    return OutputLock(output);
  }

  /// The cores this process may run on (its affinity mask), and the machine's.
  inline std::pair<unsigned, unsigned>
  cores_allowed_of_machine()
  {
    cpu_set_t set;
    CPU_ZERO(&set);
    const unsigned machine = std::thread::hardware_concurrency();
    if (sched_getaffinity(0, sizeof set, &set) != 0)
      return {machine, machine};
    return {static_cast<unsigned>(CPU_COUNT(&set)), machine};
  }

  /// Returns when every rank has called it; a rank that waits sleeps (1 ms between polls).
  /// Before a collective that follows long work on one rank: Open MPI's blocking calls poll
  /// without sleeping, so the waiting ranks would take the cores that the working rank's
  /// threaded BLAS and MUMPS use.
  inline void
  wait_for_all_quietly()
  {
    MPI_Request request;
    MPI_Ibarrier(MPI_COMM_WORLD, &request);
    int done = 0;
    MPI_Test(&request, &done, MPI_STATUS_IGNORE);
    while (!done)
      {
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
        MPI_Test(&request, &done, MPI_STATUS_IGNORE);
      }
  }
} // namespace irdm::fem
