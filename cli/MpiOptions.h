// The `--mpi` options `render` and `serve` share (docs/distributed.md): the flag, the deadline of every transfer
// between ranks, and how pixels travel between them.
#pragma once

#include <CLI/CLI.hpp>

#include <string>

#include "distributed/Compositor.h"

namespace voxbrick::cli {

struct MpiArgs {
  bool mpi = false;               ///< run across the ranks of mpirun (distributed/)
  double timeout = 10;            ///< seconds any one MPI transfer may wait for its peer
  std::string encoding = "half";  ///< how pixels travel between ranks: half or float
};

/// Registers --mpi (its help: `what`), --mpi-timeout and --mpi-encoding on `cmd`, storing into `args` (which must
/// outlive the app).
void addMpiOptions(CLI::App* cmd, MpiArgs& args, const std::string& what);

/// The compositing options the arguments ask for (the encoding and the deadline).
distributed::CompositeOptions compositeOptions(const MpiArgs& args);

}  // namespace voxbrick::cli
