#pragma once
// Errors the user can fix (bad scene, bad mesh, bad model file). The CLI prints the message
// and exits with status 2; anything else is a bug and exits with status 1.
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
} // namespace irdm
