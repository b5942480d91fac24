#pragma once
// Error classes, each with its own exit status in the CLI (docs/exit-codes.md):
//   InputError    2  the user can fix it: bad scene, mesh, model file, option or output path;
//                    also a refusal (a lock held by another run, a job larger than the machine)
//   IoError       4  the system failed a read or write (disk full, I/O error); nothing was
//                    committed under the final name
// Anything else is a bug and exits with status 1.
#include <stdexcept>
#include <string>

namespace irdm
{
  struct InputError : std::runtime_error
  {
    explicit InputError(const std::string &what)
      : std::runtime_error(what)
    {}
  };

  struct IoError : std::runtime_error
  {
    explicit IoError(const std::string &what)
      : std::runtime_error(what)
    {}
  };
} // namespace irdm
