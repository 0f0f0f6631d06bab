// imukit: capture, characterize, simulate and augment wearable IMUs.
#include <fmt/core.h>
#include <algorithm>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <new>
#include <string>
#include <system_error>

#include "command.hpp"
#include "imukit/core/error.hpp"

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

void report_error(std::string_view message) {
  // A message may quote a file name or a value given: printed as one line of text whatever
  // bytes those hold.
  fmt::print(stderr, "imukit: error: {}\n", escape_unprintable(message));
}

int run_reporting_errors(const std::function<int()>& action, const std::string& help) {
  try {
    return action();
  } catch (const UsageError& e) {
    report_error(fmt::format("{}; see `{}`", e.what(), help));
    return kUsage;
  } catch (const IoError& e) {
    report_error(e.what());
    return kIo;
  } catch (const Error& e) {
    report_error(e.what());
    return kBadInput;
  } catch (const std::filesystem::filesystem_error& e) {
    // Creating a folder or file where something else is in the way, permissions, disk full.
    std::string what = e.code().message();
    if (!e.path1().empty()) what = e.path1().string() + ": " + what;
    report_error(what);
    return kIo;
  } catch (const std::system_error& e) {
    // fmt::output_file and streams: "cannot open file 'x/y.dat': No such file or directory"
    // (found in review: reported as an internal error).
    report_error(e.what());
    return kIo;
  } catch (const std::bad_alloc&) {
    report_error("internal error: out of memory");
    return kInternal;
  } catch (const std::exception& e) {
    report_error(fmt::format("internal error (please report it): {}", e.what()));
    return kInternal;
  }
}

}  // namespace imukit::cli

int main(int argc, char** argv) {
  using imukit::cli::CommandSpec;
  using imukit::cli::report_error;
  using imukit::cli::run_reporting_errors;
  CLI::App app{"imukit: capture, characterize, simulate and augment wearable IMUs", "imukit"};
  app.set_version_flag("--version", std::string("imukit ") + IMUKIT_VERSION);
  app.require_subcommand(1);
  app.footer(
      "Run `imukit COMMAND --help` for a command's options and examples.\n"
      "Exit codes: 0 done, 1 bad input (a file's content, or data that cannot give what was "
      "asked),\n2 usage error (the command line), 3 I/O error (a file cannot be opened, read or "
      "written),\n4 internal error (a bug).");

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
      report_error(fmt::format("unknown command {} (commands: {}); see `imukit --help`",
                               imukit::quote_excerpt(word), names));
      return imukit::cli::kUsage;
    }
  }
  std::string help = "imukit --help";
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
    for (auto& [sub, action] : actions) {
      if (sub->parsed()) help = "imukit " + sub->get_name() + " --help";
    }
    report_error(fmt::format("{}; see `{}`", e.what(), help));
    return imukit::cli::kUsage;
  }
  for (auto& [sub, action] : actions) {
    if (sub->parsed()) help = "imukit " + sub->get_name() + " --help";
  }
  return run_reporting_errors(
      [&] {
        for (auto& [sub, action] : actions) {
          if (sub->parsed()) return action();
        }
        return 0;
      },
      help);
}
