// Entry point of the `voxbrick` command: dispatches to the subcommands and turns errors into one line each.
#include <csignal>
#include <cstdio>
#include <exception>
#include <string>

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include "cli/Commands.h"

namespace {

/// The subcommand being parsed or run, for the error line ("voxbrick" before one is known).
std::string commandName(const CLI::App& app) {
  return app.get_subcommands().empty() ? "voxbrick" : "voxbrick " + app.get_subcommands()[0]->get_name();
}

/// One line on stderr, "voxbrick SUB: error: MESSAGE": a usage error reads like any other failure, exit status 1.
int fail(const CLI::App& app, std::string message) {
  for (char& c : message)
    if (c == '\n' || c == '\r') c = ' ';
  std::fprintf(stderr, "%s: error: %s\n", commandName(app).c_str(), message.c_str());
  return 1;
}

}  // namespace

int main(int argc, char** argv) {
  // A file-size limit should surface as a write error naming the file, not kill the process.
  std::signal(SIGXFSZ, SIG_IGN);
  // Logs (the server's, any library's through spdlog) go to stderr; stdout carries only results.
  spdlog::set_default_logger(spdlog::stderr_color_mt("voxbrick"));

  CLI::App app{"voxbrick: out-of-core volume rendering server and tools"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "voxbrick 0.1.0");
  voxbrick::cli::addPrepCommand(app);
  voxbrick::cli::addInfoCommand(app);
  voxbrick::cli::addRenderCommand(app);
  voxbrick::cli::addOrbitCommand(app);
  voxbrick::cli::addServeCommand(app);
  voxbrick::cli::addRequestCommand(app);
  voxbrick::cli::addLoadCommand(app);
  voxbrick::cli::addCompareCommand(app);
  voxbrick::cli::addBenchCommand(app);
  voxbrick::cli::addPresetsCommand(app);
  voxbrick::cli::addSceneCommand(app);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help and --version end parsing with a "success" that prints and exits 0; every other parse error is a usage
    // error: one line, status 1 (CLI11's own codes, 104 to 114, and its second line pointing at --help are dropped).
    if (e.get_exit_code() == static_cast<int>(CLI::ExitCodes::Success)) return app.exit(e);
    // A word that is no subcommand is left over, and CLI11 only says that one is required: name the word.
    if (app.get_subcommands().empty() && !app.remaining().empty())
      return fail(app, "'" + app.remaining().front() + "' is not a subcommand (see voxbrick --help)");
    return fail(app, e.what());
  } catch (const std::exception& e) {
    return fail(app, e.what());
  }
  return 0;
}
