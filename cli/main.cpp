// Entry point of the `voxbrick` command: dispatches to the subcommands and turns errors into one line each.
#include <csignal>
#include <cstdio>
#include <exception>

#include "cli/Commands.h"

int main(int argc, char** argv) {
  // A file-size limit should surface as a write error naming the file, not kill the process.
  std::signal(SIGXFSZ, SIG_IGN);

  CLI::App app{"voxbrick: out-of-core volume rendering server and tools"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "voxbrick 0.1.0");
  voxbrick::cli::addPrepCommand(app);
  voxbrick::cli::addInfoCommand(app);
  voxbrick::cli::addRenderCommand(app);
  voxbrick::cli::addServeCommand(app);
  voxbrick::cli::addRequestCommand(app);
  voxbrick::cli::addLoadCommand(app);
  voxbrick::cli::addCompareCommand(app);
  voxbrick::cli::addBenchCommand(app);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const std::exception& e) {
    const char* name = app.get_subcommands().empty() ? "voxbrick" : app.get_subcommands()[0]->get_name().c_str();
    std::fprintf(stderr, "voxbrick %s: error: %s\n", name, e.what());
    return 1;
  }
  return 0;
}
