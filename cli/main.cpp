// imukit: capture, characterize, simulate and augment wearable IMUs.
#include <fmt/core.h>
#include <algorithm>
#include <cstdio>
#include <exception>
#include <string>

#include "cli/command.hpp"
#include "core/error.hpp"

#ifndef IMUKIT_VERSION
#define IMUKIT_VERSION "unknown"
#endif

namespace imukit::cli {

namespace {
std::vector<CommandSpec>& registry() {
  static std::vector<CommandSpec> commands;
  return commands;
}
}  // namespace

bool register_command(CommandSpec spec) {
  registry().push_back(std::move(spec));
  return true;
}

const std::vector<CommandSpec>& registered_commands() { return registry(); }

}  // namespace imukit::cli

int main(int argc, char** argv) {
  using imukit::cli::CommandSpec;
  CLI::App app{"imukit: capture, characterize, simulate and augment wearable IMUs", "imukit"};
  app.set_version_flag("--version", std::string("imukit ") + IMUKIT_VERSION);
  app.require_subcommand(1);
  app.footer("Run `imukit COMMAND --help` for a command's options and examples.");

  std::vector<CommandSpec> commands = imukit::cli::registered_commands();
  std::sort(commands.begin(), commands.end(),
            [](const CommandSpec& a, const CommandSpec& b) { return a.order < b.order; });
  std::vector<std::pair<CLI::App*, std::function<int()>>> actions;
  for (const CommandSpec& spec : commands) {
    CLI::App* sub = app.add_subcommand(spec.name, spec.summary);
    actions.emplace_back(sub, spec.setup(*sub));
  }

  // An unknown command gets the list of known ones (CLI11 would only say one is required).
  if (argc > 1 && argv[1][0] != '-') {
    const std::string word = argv[1];
    std::string names;
    bool known = false;
    for (const CommandSpec& spec : commands) {
      known = known || spec.name == word;
      names += (names.empty() ? "" : ", ") + spec.name;
    }
    if (!known) {
      fmt::print(stderr,
                 "imukit: error: unknown command '{}' (commands: {}); see `imukit --help`\n", word,
                 names);
      return 2;
    }
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    // One line: what was wrong and where the command's options and examples are.
    std::string where = "imukit --help";
    for (auto& [sub, action] : actions) {
      if (sub->parsed()) where = "imukit " + sub->get_name() + " --help";
    }
    fmt::print(stderr, "imukit: error: {}; see `{}`\n", e.what(), where);
    return e.get_exit_code();
  } catch (const imukit::Error& e) {
    fmt::print(stderr, "imukit: error: {}\n", e.what());
    return 2;
  }
  try {
    for (auto& [sub, action] : actions) {
      if (sub->parsed()) return action();
    }
    return 0;
  } catch (const imukit::Error& e) {
    fmt::print(stderr, "imukit: error: {}\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    fmt::print(stderr, "imukit: internal error: {}\n", e.what());
    return 3;
  }
}
