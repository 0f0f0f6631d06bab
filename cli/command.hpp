// The imukit command is a set of subcommands, one file each. A subcommand file registers itself
// with IMUKIT_REGISTER_COMMAND, so adding one never touches the others or main.cpp.
#pragma once

#include <CLI/CLI.hpp>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "imukit/core/error.hpp"

namespace imukit::cli {

// The exit codes of every command (docs/architecture.md, "Exit codes"). A command returns
// kOk or lets an exception carry the failure to main(), which maps it: CLI11's parse errors and
// UsageError to kUsage, IoError to kIo, any other imukit::Error to kBadInput, anything else
// (a bug) to kInternal.
enum ExitCode : int {
  kOk = 0,
  kBadInput = 1,  // an input's content is wrong, or the data cannot give what was asked
  kUsage = 2,     // the command line is wrong: unknown option, value out of range, missing file
  kIo = 3,        // a file cannot be opened, read or written, is not a regular file, or too large
  kInternal = 4,  // a bug: please report it
};

// The command line is wrong (what CLI11 cannot see: a missing input, options that conflict).
class UsageError : public Error {
 public:
  using Error::Error;
};

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

// Prints "imukit: error: MESSAGE" on stderr as one line, non-printable bytes escaped.
void report_error(std::string_view message);
// Runs a command's action and maps what it throws to a message and an exit code (ExitCode);
// `help` names the --help to point at after a usage error.
int run_reporting_errors(const std::function<int()>& action, const std::string& help);

}  // namespace imukit::cli

#define IMUKIT_REGISTER_COMMAND(ident, ...) \
  static const bool imukit_command_registered_##ident = ::imukit::cli::register_command(__VA_ARGS__)
