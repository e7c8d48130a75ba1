// Subcommands of the `candp2` tool. Each is defined in its own cmd_NAME.cpp.
#pragma once

#include <CLI/CLI.hpp>

namespace candp2::cli {

// Registers the subcommand on `app`; when it runs, it stores the process exit code in `exit_code`.
void add_replay(CLI::App& app, int& exit_code);    // candp2 replay SCENARIO
void add_validate(CLI::App& app, int& exit_code);  // candp2 validate CONFIG
void add_gsd(CLI::App& app, int& exit_code);       // candp2 gsd FILE
void add_sniff(CLI::App& app, int& exit_code);     // candp2 sniff PORT|FILE

}  // namespace candp2::cli
