// candp2 gsd FILE [--prm NAME=VALUE ...]: a GSD file's problems (parse diagnostics and the
// consistency check, "FILE:LINE: message") and a readable summary (docs/gsd.md). With --prm the
// user parameter bytes for these named values. Exit status: 0 no error, 1 errors in the file or
// in a --prm value, 2 the file cannot be read or a --prm option is not NAME=VALUE.
#include <cerrno>
#include <cstring>
#include <fstream>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "common/hex.hpp"
#include "gsd/check.hpp"
#include "gsd/gsd.hpp"
#include "gsd/prm.hpp"
#include "gsd/summary.hpp"
#include "tools/candp2/commands.hpp"
#include "tools/candp2/gsd_reading.hpp"

namespace candp2::cli {

namespace {

struct GsdArgs {
  std::string file;
  std::vector<std::string> prm;
  bool quiet = false;
};

std::string plural(std::size_t n, const char* word) {
  return std::to_string(n) + " " + word + (n == 1 ? "" : "s");
}

int run_gsd(const GsdArgs& a) {
  if (!std::ifstream(a.file, std::ios::binary)) {
    std::cerr << "candp2 gsd: " << a.file << ": cannot open the file: " << std::strerror(errno)
              << "\n";
    return 2;
  }
  const gsd::ParseResult parsed = gsd::parse_file(a.file);
  if (parsed.not_gsd) {  // one line, not one error per line of the input
    std::cout << a.file << ": " << gsd::to_utf8(parsed.diagnostics.front().message) << "\n";
    return 1;
  }
  std::vector<gsd::Diagnostic> all = parsed.diagnostics;
  const auto findings = gsd::check(parsed.model, &cli::candp2_reader());
  all.insert(all.end(), findings.begin(), findings.end());

  std::vector<gsd::PrmOverride> overrides;
  for (const auto& text : a.prm) {
    auto o = gsd::parse_override(text, &parsed.model);
    if (!o) {
      std::cerr << "candp2 gsd: --prm \"" << text << "\": expected NAME=VALUE, e.g. "
                << "\"CAN-Bitrate=500 kbit/s\"\n";
      return 2;
    }
    overrides.push_back(std::move(*o));
  }

  std::size_t errors = 0, warnings = 0;
  bool printed = false;  // sections are separated by one empty line
  auto section = [&] {
    if (printed) std::cout << "\n";
    printed = true;
  };
  if (!all.empty()) section();
  for (const auto& d : all) {
    std::cout << gsd::to_utf8(gsd::format(d, a.file)) << "\n";
    (d.severity == gsd::Severity::Error ? errors : warnings)++;
  }
  if (!a.quiet) {
    section();
    std::cout << gsd::summary(parsed.model, &cli::candp2_reader());
  }
  if (!overrides.empty()) {
    section();
    const gsd::EncodeResult enc = gsd::encode_user_prm(parsed.model, overrides);
    std::cout << "User parameters with --prm: " << enc.bytes.size() << " bytes "
              << hex_bytes(enc.bytes) << "\n";
    for (const auto& e : enc.errors) std::cout << "  error: " << gsd::to_utf8(e) << "\n";
    errors += enc.errors.size();
  }
  section();
  std::cout << a.file << ": " << plural(errors, "error") << ", " << plural(warnings, "warning")
            << "\n";
  return errors ? 1 : 0;
}

}  // namespace

void add_gsd(CLI::App& app, int& exit_code) {
  auto args = std::make_shared<GsdArgs>();
  auto* cmd = app.add_subcommand(
      "gsd",
      "Check a GSD file (syntax, limits, references, defaults in range; for the CAN-DP/2 also the "
      "modules against the gateway's slot rules) and print a summary; exit 0 no error, 1 errors, "
      "2 unreadable");
  cmd->add_option("FILE", args->file, "GSD file, e.g. gsd/CDPS04A4.GSD")->required();
  cmd->add_option("--prm", args->prm,
                  "NAME=VALUE of an ExtUserPrmData (number or PrmText text), repeatable: print "
                  "the user parameter bytes");
  cmd->add_flag("--quiet,-q", args->quiet, "print only the problems and the verdict");
  cmd->callback([args, &exit_code] { exit_code = run_gsd(*args); });
}

}  // namespace candp2::cli
