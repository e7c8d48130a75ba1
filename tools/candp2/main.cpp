// candp2: offline tools around the CAN-DP/2 emulator (replay, validate, gsd, sniff).
#include <iostream>

#include "tools/candp2/commands.hpp"

int main(int argc, char** argv) {
  CLI::App app{"candp2 - tools for the CAN-DP/2 PROFIBUS-DP/CAN gateway emulator"};
  app.set_version_flag("--version", std::string("candp2 ") + CANDP2_VERSION);
  app.require_subcommand(1);
  int exit_code = 0;
  candp2::cli::add_replay(app, exit_code);
  candp2::cli::add_validate(app, exit_code);
  candp2::cli::add_gsd(app, exit_code);
  candp2::cli::add_sniff(app, exit_code);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int rc = app.exit(e);
    // Usage errors are "unusable input" (exit 2), like validate's contract.
    return rc == 0 ? 0 : 2;
  }
  return exit_code;
}
