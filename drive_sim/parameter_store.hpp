// EEPROM persistence of the drive's parameters (CAN manual example 7: REGID 0x84 writes the
// parameters to the EEPROM). The simulator core only talks to the small ParameterStore interface;
// file I/O lives in file_parameter_store.{hpp,cpp}. The text format is pure and tested here.
//
// State file format (UTF-8 text, one register per line, '#' starts a comment):
//   # candp2-drive parameter memory, format 1
//   0x35 = 0x000001F4   # SPEED_DELTAMA
//   0x68 = 0x0210       # CAN_ID_RX
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>

namespace candp2::drive {

// REGID -> value, as the registers hold it (16-bit registers zero-extended).
struct StoredParameters {
  std::map<std::uint8_t, std::uint32_t> values;
  friend bool operator==(const StoredParameters&, const StoredParameters&) = default;
};

class ParameterStore {
 public:
  virtual ~ParameterStore() = default;
  // nullopt and an empty *error: nothing stored yet (a new drive). nullopt and a message: the
  // store exists but cannot be used; the drive starts from its defaults and logs the message.
  virtual std::optional<StoredParameters> load(std::string* error) = 0;
  virtual bool save(const StoredParameters& parameters, std::string* error) = 0;
};

// In-memory store (tests, and owners that persist elsewhere).
class MemoryParameterStore final : public ParameterStore {
 public:
  std::optional<StoredParameters> load(std::string* error) override {
    if (error) error->clear();
    return stored;
  }
  bool save(const StoredParameters& parameters, std::string*) override {
    stored = parameters;
    ++saves;
    return true;
  }
  std::optional<StoredParameters> stored;
  int saves = 0;
};

std::string format_state_file(const StoredParameters& parameters);

struct StateFileParse {
  std::optional<StoredParameters> parameters;
  std::size_t line = 0;  // 1-based line of the first error
  std::string error;     // meaningful when !parameters
};
// Strict: any malformed line rejects the whole file (a half-applied parameter set is worse than
// the defaults). Values wider than the register are rejected as well.
StateFileParse parse_state_file(std::string_view text);

}  // namespace candp2::drive
