// The imukit command is a set of subcommands, one file each. A subcommand file registers itself
// with IMUKIT_REGISTER_COMMAND, so adding one never touches the others or main.cpp.
#pragma once

#include <CLI/CLI.hpp>
#include <functional>
#include <string>
#include <vector>

namespace imukit::cli {

// Declares a subcommand's options on `sub` and returns what to run once parsing succeeded
// (returning the process exit code).
using CommandSetup = std::function<std::function<int()>(CLI::App& sub)>;

struct CommandSpec {
  std::string name;
  std::string summary;
  int order = 0;  // position in --help: the data flow order of DESIGN.md
  CommandSetup setup;
};

bool register_command(CommandSpec spec);
const std::vector<CommandSpec>& registered_commands();

}  // namespace imukit::cli

#define IMUKIT_REGISTER_COMMAND(ident, ...) \
  static const bool imukit_command_registered_##ident = ::imukit::cli::register_command(__VA_ARGS__)
