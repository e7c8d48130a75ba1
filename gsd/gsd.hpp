// GSD (device description) files of PROFIBUS-DP slaves: a tolerant parser and a typed model.
//
// Accepts the text syntax of GSD revisions 1-5 (PNO "Specification for PROFIBUS Device
// Description and Device Integration, Vol. 1: GSD"): `;` comments, `\` line continuation (also
// inside quoted strings and before a trailing comment), case-insensitive keywords, quoted
// strings, decimal and 0x hex numbers, the `#Profibus_DP` header and the blocks PrmText,
// ExtUserPrmData, Module, SlotDefinition, Unit_Diag_Area and the other `...End...` blocks.
// Unknown keywords are kept as key/value settings; nothing in a file is fatal: every problem
// becomes a line-numbered Diagnostic and parsing continues with the next line.
//
// Pure: parse() works on a string; parse_file() is the one helper that touches the file system.
// See docs/gsd.md for the model and what the parser accepts.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace candp2::gsd {

enum class Severity { Warning, Error };

// A parse problem or a check() finding. line is the 1-based physical line in the file (the line
// holding the offending token, also inside continued lines); 0 = the file as a whole.
struct Diagnostic {
  int line = 0;
  Severity severity = Severity::Error;
  std::string message;
};

// "FILE:LINE: message" for errors, "FILE:LINE: warning: message" for warnings.
std::string format(const Diagnostic& d, std::string_view file);

// Case-insensitive ASCII comparison, as GSD keywords are compared.
bool iequals(std::string_view a, std::string_view b);

// A keyword's value as the parser understood it.
struct Value {
  enum class Kind {
    None,     // "Keyword =" with nothing after it
    Number,   // 12, 0x0C, -3
    Numbers,  // octet string: 0x00,0x01,0x02
    String,   // "quoted" (text holds the contents without quotes)
    Text,     // anything else, kept as written (e.g. Slave_Family = 3@Digital@24V, 1.1)
  };
  Kind kind = Kind::None;
  std::int64_t number = 0;
  std::vector<std::int64_t> numbers;
  std::string text;  // String: the contents; Text: the raw value
};

// `Key = value` or `Key(index) = value`.
struct Setting {
  std::string key;                    // as written, e.g. "Unit_Diag_Bit"
  std::optional<std::int64_t> index;  // Unit_Diag_Bit(3) -> 3
  std::string raw;                    // value text as written (continuations joined, trimmed)
  Value value;
  int line = 0;
};

// PrmText = ref ... Text(value) = "text" ... EndPrmText
struct PrmText {
  std::int64_t ref = 0;
  std::vector<std::pair<std::int64_t, std::string>> texts;  // in file order
  int line = 0;

  const std::string* text_for(std::int64_t value) const;
  // Matches trimmed, case-insensitively ("Yes" finds Text(1)="Yes  ").
  std::optional<std::int64_t> value_for(std::string_view text) const;
};

enum class PrmType { Unsigned8, Unsigned16, Unsigned32, Signed8, Signed16, Signed32, Bit, BitArea };
std::string_view to_string(PrmType t);

// ExtUserPrmData = ref "name" / type default range-or-list / [Prm_Text_Ref = n] ... / End...
struct ExtUserPrmData {
  std::int64_t ref = 0;
  std::string name;
  PrmType type = PrmType::Unsigned8;
  int first_bit = 0;  // Bit(n): n; BitArea(a-b): a
  int last_bit = 0;   // Bit(n): n; BitArea(a-b): b
  std::int64_t default_value = 0;
  std::optional<std::int64_t> min, max;  // "min-max" form
  std::vector<std::int64_t> allowed;     // "a,b,c" form (empty for the range form)
  std::optional<std::int64_t> prm_text_ref;
  bool changeable = true;      // GSD rev 5 Changeable
  bool visible = true;         // GSD rev 5 Visible
  std::vector<Setting> other;  // any further keywords inside the block
  int line = 0;

  std::size_t size() const;           // bytes the value occupies in the parameter telegram
  bool allows(std::int64_t v) const;  // within min-max or in the list (type limits not included)
  std::string range_text() const;     // "0-13" or "0,1,5"
};

// Ext_User_Prm_Data_Const(offset) = bytes / Ext_User_Prm_Data_Ref(offset) = ref
struct PrmConst {
  std::int64_t offset = 0;
  std::vector<std::uint8_t> bytes;
  int line = 0;
};
struct PrmRef {
  std::int64_t offset = 0;
  std::int64_t ref = 0;
  int line = 0;
};
struct PrmLayout {
  std::vector<PrmConst> consts;
  std::vector<PrmRef> refs;
  bool empty() const { return consts.empty() && refs.empty(); }
};

// Any other block (UnitDiagType, Version_Firmware_Download, Data_Area_Beg, ...): its opening
// statement and every statement up to its end keyword, kept as settings.
struct Block {
  std::string keyword;            // opening keyword as written
  std::string header;             // value of the opening statement ("" for a bare keyword)
  std::vector<Setting> settings;  // bare lines appear with an empty key and the line as raw
  int line = 0;
};

// Module = "name" config bytes / [reference number] / keywords / EndModule
struct Module {
  std::string name;
  std::vector<std::uint8_t> config;       // Chk_Cfg identifier bytes (see gsd/cfg.hpp)
  std::optional<std::int64_t> reference;  // the bare number after the Module line (rev 3+)
  std::optional<std::int64_t> ext_module_prm_data_len;
  PrmLayout prm;  // Ext_User_Prm_Data_Const/Ref inside the module
  // Preset = 1: configuration tools put the module into every new configuration of the device,
  // before the user's modules, in GSD order (docs/gsd.md "Preset modules").
  bool preset = false;
  std::vector<Setting> settings;  // Preset (also as the field above), Info_Text, F_..., unknown
  std::vector<Block> blocks;      // Data_Area_Beg ... Data_Area_End
  int line = 0;
};

// SlotDefinition / Slot(n) = "name" default allowed / EndSlotDefinition
struct SlotDef {
  std::int64_t number = 0;
  std::string name;
  std::int64_t default_ref = 0;
  std::optional<std::int64_t> min, max;  // "a-b" form
  std::vector<std::int64_t> allowed;     // "a,b,c" form
  int line = 0;
};

// Unit_Diag_Bit(n) / Unit_Diag_Not_Bit(n) = "text"
struct UnitDiagBit {
  std::int64_t bit = 0;
  std::string text;
  bool negated = false;
  int line = 0;
};

// Unit_Diag_Area = first-last / Value(n) = "text" / Unit_Diag_Area_End
struct UnitDiagArea {
  std::int64_t first = 0, last = 0;
  std::vector<std::pair<std::int64_t, std::string>> values;
  int line = 0;
};

struct Limits {
  std::optional<std::int64_t> max_module, max_input_len, max_output_len, max_data_len;
  std::optional<std::int64_t> max_user_prm_data_len, user_prm_data_len, max_diag_data_len;
  std::optional<std::int64_t> min_slave_intervall, modul_offset;
  bool modular_station = false;
};

struct Model {
  bool has_header = false;        // #Profibus_DP seen
  std::vector<Setting> settings;  // top-level Keyword = value in file order (unknown ones too)
  std::vector<PrmText> prm_texts;
  std::vector<ExtUserPrmData> ext_user_prm_data;
  PrmLayout user_prm;  // top-level Ext_User_Prm_Data_Const/Ref
  std::vector<Module> modules;
  std::vector<SlotDef> slots;
  std::vector<UnitDiagBit> unit_diag_bits;
  std::vector<UnitDiagArea> unit_diag_areas;
  std::vector<Block> blocks;

  // Scalar keywords, case-insensitive; the first occurrence wins (duplicates are warned about).
  const Setting* find(std::string_view key) const;
  const Setting* find(std::string_view key, std::int64_t index) const;
  std::optional<std::int64_t> number(std::string_view key) const;
  std::optional<std::string> string(std::string_view key) const;

  std::string vendor_name() const;  // "" when missing
  std::string model_name() const;
  std::optional<std::int64_t> ident_number() const;
  std::optional<std::int64_t> gsd_revision() const;
  Limits limits() const;
  // Legacy User_Prm_Data bytes (values outside 0..255 were reported by the parser and dropped).
  std::optional<std::vector<std::uint8_t>> user_prm_data() const;

  const PrmText* prm_text(std::int64_t ref) const;
  const ExtUserPrmData* ext_user_prm(std::int64_t ref) const;
  const Module* module(std::string_view name) const;  // case-insensitive, trimmed
  // The modules with Preset = 1, as indices into `modules`, in GSD order.
  std::vector<std::size_t> preset_modules() const;
  // FixPresetModules = 1: the preset modules may be neither removed nor moved.
  bool fix_preset_modules() const;
};

// A DP rate (bit/s) as the GSD names it in its keywords: 1500000 → "1.5M" ("1.5M_supp",
// "MaxTsdr_1.5M"); nullopt for a rate without a keyword.
std::optional<std::string_view> rate_name(std::uint32_t baud);
// Every rate a GSD can name, slowest first (the eleven of the GSD specification, 31.25k included).
std::span<const std::uint32_t> gsd_rates();
// The GSD says the station supports `baud` (<rate>_supp = 1).
bool supports_rate(const Model& m, std::uint32_t baud);
// MaxTsdr_<rate>: the latest the station answers at `baud`, in bit times; nullopt when missing.
std::optional<std::uint32_t> max_tsdr(const Model& m, std::uint32_t baud);

struct ParseResult {
  Model model;
  std::vector<Diagnostic> diagnostics;  // in line order
  bool ok() const;                      // no Error diagnostics
  // The input is not a GSD at all (binary, or neither the '#Profibus_DP' header nor any GSD
  // keyword): diagnostics then hold one line "not a GSD file: ..." and the model is empty.
  bool not_gsd = false;
};

ParseResult parse(std::string_view text);

// Reads the file as bytes (ISO-8859-1 or UTF-8, kept as is) and parses it. A file that cannot
// be read gives an empty model and one Error diagnostic at line 0.
ParseResult parse_file(const std::string& path);

// For display: valid UTF-8 stays as is, anything else is taken as ISO-8859-1 (many GSD files).
std::string to_utf8(std::string_view s);
// A module or parameter name for messages: trimmed of blanks and tabs, then to_utf8.
std::string display_name(std::string_view name);

}  // namespace candp2::gsd
