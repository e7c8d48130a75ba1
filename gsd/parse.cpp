// GSD text -> Model. Two passes: physical lines are joined into logical lines (comments
// stripped, `\` continuations followed), then each logical line is one statement that a small
// block state machine files into the model. Every problem is a Diagnostic; nothing throws.
//   gsd/statements.cpp    pass 1 (logical lines) and statement splitting
//   gsd/parse.cpp         the public entry points, run(), dispatch, blocks opened and closed
//   gsd/parse_blocks.cpp  statements inside blocks
//   gsd/parse_values.cpp  typed values and plain settings
#include <algorithm>
#include <cctype>
#include <fstream>
#include <sstream>

#include "gsd/gsd.hpp"
#include "gsd/parser.hpp"

namespace candp2::gsd {

namespace detail {

namespace {

struct EndWord {
  std::string_view word;
  BlockKind kind;
};
constexpr EndWord kEndWords[] = {
    {"EndPrmText", BlockKind::PrmText},
    {"EndExtUserPrmData", BlockKind::ExtUserPrmData},
    {"EndModule", BlockKind::Module},
    {"EndSlotDefinition", BlockKind::Slots},
    {"End_Slot_Definition", BlockKind::Slots},
    {"Unit_Diag_Area_End", BlockKind::UnitDiagArea},
    {"X_Unit_Diag_Area_End", BlockKind::Generic},
    {"EndUnitDiagType", BlockKind::Generic},
    {"End_Version_Firmware_Download", BlockKind::Generic},
    {"End_Physical_Interface", BlockKind::Generic},
    {"Data_Area_End", BlockKind::Generic},
};

// Generic blocks: opening keyword (assignment or bare line) -> end keyword.
struct GenericBlock {
  std::string_view start;
  bool assign;
  std::string_view end;
};
constexpr GenericBlock kGenericBlocks[] = {
    {"X_Unit_Diag_Area", true, "X_Unit_Diag_Area_End"},
    {"UnitDiagType", true, "EndUnitDiagType"},
    {"Version_Firmware_Download", false, "End_Version_Firmware_Download"},
    {"Physical_Interface", true, "End_Physical_Interface"},
};

}  // namespace

std::string_view block_name(BlockKind k) {
  switch (k) {
    case BlockKind::PrmText:
      return "PrmText";
    case BlockKind::ExtUserPrmData:
      return "ExtUserPrmData";
    case BlockKind::Module:
      return "Module";
    case BlockKind::Slots:
      return "SlotDefinition";
    case BlockKind::UnitDiagArea:
      return "Unit_Diag_Area";
    case BlockKind::Generic:
      return "block";
    case BlockKind::None:
      break;
  }
  return "";
}

std::string_view end_word(BlockKind k) {
  switch (k) {
    case BlockKind::PrmText:
      return "EndPrmText";
    case BlockKind::ExtUserPrmData:
      return "EndExtUserPrmData";
    case BlockKind::Module:
      return "EndModule";
    case BlockKind::Slots:
      return "EndSlotDefinition";
    case BlockKind::UnitDiagArea:
      return "Unit_Diag_Area_End";
    default:
      break;
  }
  return "";
}

ParseResult Parser::run(std::string_view text) {
  auto lines = split_lines(text, diags_);
  for (const auto& ll : lines) {
    Stmt st;
    if (!make_stmt(ll, st, diags_)) continue;
    statement(st);
  }
  close_at_eof();
  if (!model_.has_header)
    err(first_stmt_line_ ? first_stmt_line_ : 1, "missing '#Profibus_DP' header");
  std::stable_sort(diags_.begin(), diags_.end(),
                   [](const Diagnostic& a, const Diagnostic& b) { return a.line < b.line; });
  return ParseResult{std::move(model_), std::move(diags_)};
}

void Parser::statement(const Stmt& st) {
  if (!first_stmt_line_) first_stmt_line_ = st.line;
  if (!st.assign && st.key.front() == '#') {
    header(st);
    return;
  }
  if (!model_.has_header && !warned_before_header_) {
    warned_before_header_ = true;
    err(st.line, "statement before the '#Profibus_DP' header");
  }
  if (block_ != BlockKind::None) {
    if (is_hard_start(st)) {
      missing_end(st.line);
    } else {
      in_block(st);
      return;
    }
  }
  top(st);
}

bool Parser::is_end_word(const Stmt& st, BlockKind* kind) const {
  if (st.assign) return false;
  for (const auto& ew : kEndWords)
    if (iequals(st.key, ew.word)) {
      if (kind) *kind = ew.kind;
      return true;
    }
  return false;
}

// Statements that can only open a top-level block: seeing one inside another block means the
// end keyword of that block is missing.
bool Parser::is_hard_start(const Stmt& st) const {
  if (st.assign)
    return iequals(st.key, "PrmText") || iequals(st.key, "ExtUserPrmData") ||
           iequals(st.key, "Module") || iequals(st.key, "UnitDiagType") ||
           iequals(st.key, "Physical_Interface");
  return iequals(st.key, "SlotDefinition") || iequals(st.key, "Slot_Definition") ||
         iequals(st.key, "Version_Firmware_Download");
}

void Parser::header(const Stmt& st) {
  std::string_view h = trim(std::string_view(st.key).substr(1));
  if (iequals(h, "Profibus_DP")) {
    if (model_.has_header) warn(st.line, "repeated '#Profibus_DP' header");
    model_.has_header = true;
    if (block_ != BlockKind::None) missing_end(st.line);
  } else {
    warn(st.line, "unknown section header " + quote(st.key) + " (ignored)");
  }
}

void Parser::missing_end(int line) {
  std::string what = block_ == BlockKind::Generic ? generic_end_ : std::string(end_word(block_));
  err(line, "missing " + what + " for the " +
                std::string(block_ == BlockKind::Generic ? std::string_view(generic_.keyword)
                                                         : block_name(block_)) +
                " started at line " + std::to_string(block_line_));
  close_block();
}

void Parser::close_at_eof() {
  if (data_area_) {
    err(data_area_->line,
        "missing Data_Area_End for the Data_Area_Beg at line " + std::to_string(data_area_->line));
    module_.blocks.push_back(std::move(*data_area_));
    data_area_.reset();
  }
  if (block_ != BlockKind::None) {
    std::string what = block_ == BlockKind::Generic ? generic_end_ : std::string(end_word(block_));
    err(block_line_, "missing " + what + " (end of file reached)");
    close_block();
  }
}

void Parser::open_block(BlockKind k, int line) {
  block_ = k;
  block_line_ = line;
}

void Parser::close_block() {
  switch (block_) {
    case BlockKind::PrmText:
      model_.prm_texts.push_back(std::move(prm_text_));
      break;
    case BlockKind::ExtUserPrmData:
      if (eupd_type_ok_) {
        model_.ext_user_prm_data.push_back(std::move(eupd_));
      } else if (!eupd_type_seen_) {
        err(eupd_.line, "ExtUserPrmData " + std::to_string(eupd_.ref) +
                            " has no data type line (e.g. 'Unsigned8 0 0-255')");
      }
      break;
    case BlockKind::Module:
      if (data_area_) {
        err(data_area_->line, "missing Data_Area_End for the Data_Area_Beg at line " +
                                  std::to_string(data_area_->line));
        module_.blocks.push_back(std::move(*data_area_));
        data_area_.reset();
      }
      model_.modules.push_back(std::move(module_));
      break;
    case BlockKind::UnitDiagArea:
      model_.unit_diag_areas.push_back(std::move(area_));
      break;
    case BlockKind::Generic:
      model_.blocks.push_back(std::move(generic_));
      break;
    case BlockKind::Slots:
    case BlockKind::None:
      break;
  }
  block_ = BlockKind::None;
}

void Parser::top(const Stmt& st) {
  BlockKind ek;
  if (is_end_word(st, &ek)) {
    err(st.line, quote(st.key) + " without a matching block start");
    return;
  }
  if (!st.assign) {
    for (const auto& g : kGenericBlocks)
      if (!g.assign && iequals(st.key, g.start)) return start_generic(st, g.end);
    if (iequals(st.key, "SlotDefinition") || iequals(st.key, "Slot_Definition")) {
      open_block(BlockKind::Slots, st.line);
      return;
    }
    err(st.line, "expected 'Keyword = value', found " + quote(st.key));
    return;
  }
  if (iequals(st.key, "PrmText")) return start_prm_text(st);
  if (iequals(st.key, "ExtUserPrmData")) return start_eupd(st);
  if (iequals(st.key, "Module")) return start_module(st);
  if (iequals(st.key, "Unit_Diag_Area")) return start_area(st);
  for (const auto& g : kGenericBlocks)
    if (g.assign && iequals(st.key, g.start)) return start_generic(st, g.end);
  if (prm_layout_stmt(st, model_.user_prm)) return;
  if (iequals(st.key, "Unit_Diag_Bit") || iequals(st.key, "Unit_Diag_Not_Bit")) {
    UnitDiagBit b;
    b.negated = iequals(st.key, "Unit_Diag_Not_Bit");
    b.line = st.line;
    if (!st.index) {
      if (!st.has_index) err(st.line, st.key + " needs a bit number: " + st.key + "(n)");
      return;
    }
    b.bit = *st.index;
    if (!string_value(st, b.text)) return;
    model_.unit_diag_bits.push_back(std::move(b));
    return;
  }
  setting(st);
}

// A statement that does not belong in a block that has a fixed body: the end keyword is
// missing; close the block and handle the statement at the top level.
void Parser::not_in_block(const Stmt& st) {
  missing_end(st.line);
  top(st);
}

}  // namespace detail

std::string format(const Diagnostic& d, std::string_view file) {
  std::ostringstream os;
  os << file << ':' << d.line << ": " << (d.severity == Severity::Warning ? "warning: " : "")
     << d.message;
  return os.str();
}

bool ParseResult::ok() const {
  return std::none_of(diagnostics.begin(), diagnostics.end(),
                      [](const Diagnostic& d) { return d.severity == Severity::Error; });
}

namespace {

// A file that is not a GSD gets one line instead of one error per line.
std::optional<std::string> not_a_gsd(std::string_view text) {
  const std::string_view head = text.substr(0, 4096);
  std::size_t control = 0;
  for (const char ch : head) {
    const auto c = static_cast<unsigned char>(ch);
    if (c == 0) return "binary data (NUL bytes)";
    if (c < 0x20 && c != '\t' && c != '\r' && c != '\n' && c != '\f' && c != 0x1A) ++control;
  }
  if (control * 10 > head.size()) return "binary data (control characters)";
  // Case-insensitive search for the header or any keyword every DP slave GSD has (GSD spec (M)).
  std::string lower(text);
  std::transform(lower.begin(), lower.end(), lower.begin(), [](char c) {
    return static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  });
  static constexpr std::string_view kSigns[] = {"#profibus_dp", "vendor_name",    "model_name",
                                                "ident_number", "protocol_ident", "station_type",
                                                "gsd_revision"};
  for (auto sign : kSigns)
    if (lower.find(sign) != std::string::npos) return std::nullopt;
  return "no '#Profibus_DP' header and no GSD keyword (Vendor_Name, Ident_Number, ...)";
}

}  // namespace

ParseResult parse(std::string_view text) {
  if (auto why = not_a_gsd(text)) {
    ParseResult r;
    r.not_gsd = true;
    r.diagnostics.push_back({0, Severity::Error, "not a GSD file: " + *why});
    return r;
  }
  return detail::Parser().run(text);
}

ParseResult parse_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    ParseResult r;
    r.diagnostics.push_back({0, Severity::Error, "cannot open the file"});
    return r;
  }
  std::ostringstream ss;
  ss << in.rdbuf();
  if (in.bad()) {
    ParseResult r;
    r.diagnostics.push_back({0, Severity::Error, "cannot read the file"});
    return r;
  }
  return parse(ss.str());
}

}  // namespace candp2::gsd
