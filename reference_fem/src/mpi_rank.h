#pragma once
// Internal: this process's place in MPI_COMM_WORLD and a progress log that only rank 0 prints,
// shared by the precomputes that deal their work to ranks (impulse_response.cc,
// virtual_dof.cc).
#include <mpi.h>

#include <functional>
#include <string>

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
} // namespace irdm::fem
