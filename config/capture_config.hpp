// The "capture" section of the daemon's configuration (docs/configuration.md#capture): pcapng
// captures of both buses (docs/capture.md). Public interface:
//   "capture": {"pcapng": "PATH", "max_mb": N, "files": K, "profibus_linktype": "…"}
// Parsed like every other section (config/json_reader.hpp: errors name the JSON path and what was
// expected); a capture directory that does not exist or is not writable is a configuration error.
#pragma once

#include <cstdint>
#include <nlohmann/json_fwd.hpp>
#include <string>

namespace candp2::config {

// How PROFIBUS telegrams are stored (docs/decisions.md "pcapng captures").
enum class CaptureProfibusLinktype {
  WiresharkUpperPdu,  // "wireshark_upper_pdu": LINKTYPE 252, exported PDUs for the "fdl" dissector
  ProfibusDl,         // "profibus_dl": LINKTYPE 257, the telegram alone
};

struct CaptureConfig {
  std::string pcapng;        // PATH, relative paths resolved against the configuration file
  std::uint32_t max_mb = 0;  // ring: the next file starts before one passes this; 0 = one file
  std::uint32_t files = 0;   // ring: keep the newest `files` files; 0 = keep all (needs max_mb)
  CaptureProfibusLinktype profibus_linktype = CaptureProfibusLinktype::WiresharkUpperPdu;
  std::string json_path = "$.capture";

  std::uint64_t max_bytes() const { return std::uint64_t{max_mb} * 1'000'000u; }  // 1 MB = 10^6 B
};

// The section at `path` (normally "$.capture") of the configuration `file`. Throws
// json_reader::Failure (path and message) like the other section parsers; parse_daemon turns it
// into a ConfigError naming the file.
CaptureConfig parse_capture(const nlohmann::json& j, const std::string& path,
                            const std::string& file);

// Whether a file can be created in the directory of `file_path` (the directory exists, is a
// directory, and a file can be made and removed in it). Empty when it can, else why not.
std::string directory_not_writable(const std::string& file_path);

}  // namespace candp2::config
