// The `--mpi` options of `render` and `serve` (MpiOptions.h).
#include "cli/MpiOptions.h"

#include "cli/Commands.h"

namespace voxbrick::cli {

void addMpiOptions(CLI::App* cmd, MpiArgs& args, const std::string& what) {
  cmd->add_flag("--mpi", args.mpi, what + " (docs/distributed.md)");
  cmd->add_option("--mpi-timeout", args.timeout, "--mpi: seconds a transfer may wait for a peer before it is named")
      ->capture_default_str()
      ->check(between(0.1, 3600, "s"));
  cmd->add_option("--mpi-encoding", args.encoding, "--mpi: pixels between ranks as half or float")
      ->capture_default_str()
      ->check(CLI::IsMember({"half", "float"}));
}

distributed::CompositeOptions compositeOptions(const MpiArgs& args) {
  distributed::CompositeOptions options;
  options.encoding = distributed::parsePixelEncoding(args.encoding);
  options.timeoutSeconds = args.timeout;
  return options;
}

}  // namespace voxbrick::cli
