// Entry point of the `voxbrick` command: dispatches to the subcommands and turns errors into one line each.
#include <algorithm>
#include <csignal>
#include <cstdio>
#include <exception>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include "cli/Commands.h"
#include "common/Names.h"

namespace {

/// The subcommand being parsed or run, for the error line ("voxbrick" before one is known).
std::string commandName(const CLI::App& app) {
  return app.get_subcommands().empty() ? "voxbrick" : "voxbrick " + app.get_subcommands()[0]->get_name();
}

/// "voxbrick SUB: error: MESSAGE" on stderr, exit status 1: a usage error reads like any other failure. One line,
/// unless the message ends in a table (lines after its first, such as a DICOM folder's series): those follow, indented.
int fail(const CLI::App& app, std::string message) {
  for (char& c : message)
    if (c == '\r') c = ' ';
  std::string first = message.substr(0, message.find('\n')), rest;
  for (size_t at = message.find('\n'); at != std::string::npos;) {
    const size_t next = message.find('\n', at + 1);
    rest += "  " + message.substr(at + 1, next == std::string::npos ? std::string::npos : next - at - 1) + "\n";
    at = next;
  }
  std::fprintf(stderr, "%s: error: %s\n%s", commandName(app).c_str(), first.c_str(), rest.c_str());
  return 1;
}

/// The names of `app`'s subcommands, in the order --help lists them.
std::vector<std::string> subcommandNames(const CLI::App& app) {
  std::vector<std::string> names;
  for (const CLI::App* sub : app.get_subcommands({})) names.push_back(sub->get_name());
  return names;
}

/// The long names of `sub`'s options ("--tf", "--size", ...).
std::vector<std::string> optionNames(const CLI::App& sub) {
  std::vector<std::string> names;
  for (const CLI::Option* option : sub.get_options())
    for (const std::string& name : option->get_lnames()) names.push_back("--" + name);
  return names;
}

/// The usage error of words left over: a word that is no subcommand, an option the subcommand does not have, or an
/// argument too many; each named, with the closest valid choice.
std::string leftOver(const CLI::App& app) {
  if (app.get_subcommands().empty()) {
    const std::string word = app.remaining().front();
    if (word.size() > 1 && word[0] == '-')
      return "unknown option '" + word +
             "' before a subcommand (voxbrick takes --help, --version or a subcommand; "
             "voxbrick --help lists them)";
    return voxbrick::common::unknownName("subcommand", word, subcommandNames(app)) +
           "; voxbrick --help says what each does";
  }
  const CLI::App& sub = *app.get_subcommands()[0];
  const std::vector<std::string> words = sub.remaining();
  // Options renamed so that one idea has one name in every command: the old name says the new one.
  static const std::map<std::string, std::string> renamed = {{"--host-budget", "--host-cache"}};
  for (const std::string& word : words)
    if (word.size() > 1 && word[0] == '-') {
      const std::vector<std::string> names = optionNames(sub);
      const auto old = renamed.find(word.substr(0, word.find('=')));
      if (old != renamed.end() && std::find(names.begin(), names.end(), old->second) != names.end())
        return "unknown option '" + word + "': it is now '" + old->second + "' (voxbrick " + sub.get_name() +
               " --help lists the options)";
      std::string message = "unknown option '" + word + "'";
      if (const auto closest = voxbrick::common::closestName(word, names))
        message += "; did you mean '" + *closest + "'?";
      return message + " (voxbrick " + sub.get_name() + " --help lists the options)";
    }
  std::string list;
  for (const std::string& word : words) list += (list.empty() ? "'" : ", '") + word + "'";
  return "unexpected argument" + std::string(words.size() == 1 ? " " : "s ") + list + " (voxbrick " + sub.get_name() +
         " --help shows what it takes)";
}

}  // namespace

int main(int argc, char** argv) {
  // Before anything else (it may run the program again): the server's allocator (cli/Allocator.cpp).
  if (argc > 1 && std::string_view(argv[1]) == "serve") voxbrick::cli::askHugePagesForMalloc(argv);
  // A file-size limit should surface as a write error naming the file, not kill the process.
  std::signal(SIGXFSZ, SIG_IGN);
  // Logs (the server's, any library's through spdlog) go to stderr; stdout carries only results.
  spdlog::set_default_logger(spdlog::stderr_color_mt("voxbrick"));

  // Named here, so that usage lines say "voxbrick", not the path the binary was run by.
  CLI::App app{"voxbrick: out-of-core volume rendering server and tools", "voxbrick"};
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
  voxbrick::cli::addTokenCommand(app);
  voxbrick::cli::defaultsInText(app);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help and --version end parsing with a "success" that prints and exits 0; every other parse error is a usage
    // error: one line, status 1 (CLI11's own codes, 104 to 114, and its second line pointing at --help are dropped).
    if (e.get_exit_code() == static_cast<int>(CLI::ExitCodes::Success)) return app.exit(e);
    // A word that is no subcommand is left over, and CLI11 only says that one is required: name the word. Words a
    // subcommand does not take: name the first unknown option (CLI11 lists them in reverse).
    if (app.get_subcommands().empty() && !app.remaining().empty()) return fail(app, leftOver(app));
    if (dynamic_cast<const CLI::ExtrasError*>(&e) && !app.get_subcommands().empty() &&
        !app.get_subcommands()[0]->remaining().empty())
      return fail(app, leftOver(app));
    if (app.get_subcommands().empty()) {
      std::string list;
      for (const std::string& name : subcommandNames(app)) list += (list.empty() ? "" : ", ") + name;
      return fail(app, "a subcommand is needed: one of " + list + " (voxbrick --help says what each does)");
    }
    return fail(app, e.what());
  } catch (const std::exception& e) {
    return fail(app, e.what());
  }
  return 0;
}
