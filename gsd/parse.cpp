// GSD text -> Model. Two passes: physical lines are joined into logical lines (comments
// stripped, `\` continuations followed), then each logical line is one statement that a small
// block state machine files into the model. Every problem is a Diagnostic; nothing throws.
#include <algorithm>
#include <cctype>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>

#include "gsd/gsd.hpp"
#include "gsd/text.hpp"

namespace candp2::gsd {

namespace {

using detail::Scanner;
using detail::trim;

// ---------------------------------------------------------------------------------------------
// Pass 1: logical lines.

struct LogicalLine {
  std::string text;
  // Where each joined physical line starts in text: (offset, 1-based line number).
  std::vector<std::pair<std::size_t, int>> starts;

  int line_at(std::size_t pos) const {
    if (starts.empty()) return 0;
    auto it = std::upper_bound(starts.begin(), starts.end(), pos,
                               [](std::size_t p, const auto& s) { return p < s.first; });
    return it == starts.begin() ? starts.front().second : std::prev(it)->second;
  }
};

// GSD spec: ';' starts a comment outside quoted strings; a line whose content ends in '\'
// (trailing blanks and a comment may follow it) continues on the next line, also inside a
// quoted string (SI1180fd.gse: Info_Text spans two lines).
std::vector<LogicalLine> split_lines(std::string_view src, std::vector<Diagnostic>& diags) {
  std::vector<LogicalLine> out;
  if (src.size() >= 3 && src.substr(0, 3) == "\xEF\xBB\xBF") src.remove_prefix(3);  // UTF-8 BOM
  LogicalLine cur;
  bool continuing = false;
  bool in_quote = false;
  int phys = 0;
  std::size_t i = 0;
  while (i < src.size()) {
    std::size_t nl = src.find('\n', i);
    if (nl == std::string_view::npos) nl = src.size();
    std::string_view pl = src.substr(i, nl - i);
    i = nl + 1;
    if (!pl.empty() && pl.back() == '\r') pl.remove_suffix(1);
    ++phys;

    std::string piece;
    bool q = in_quote;
    for (char c : pl) {
      if (!q && c == ';') break;
      if (c == '"') q = !q;
      piece += c;
    }
    while (!piece.empty() && (piece.back() == ' ' || piece.back() == '\t')) piece.pop_back();
    const bool cont = !piece.empty() && piece.back() == '\\';
    if (cont) piece.pop_back();

    if (!continuing) cur = LogicalLine{};
    cur.starts.emplace_back(cur.text.size(), phys);
    cur.text += piece;
    if (cont) {
      if (!q) cur.text += ' ';
      continuing = true;
      in_quote = q;
      continue;
    }
    if (q) {
      diags.push_back({phys, Severity::Error, "unterminated string (missing '\"')"});
      cur.text += '"';
    }
    in_quote = false;
    continuing = false;
    out.push_back(std::move(cur));
  }
  if (continuing) {
    if (in_quote) {
      diags.push_back({phys, Severity::Error, "unterminated string at end of file"});
      cur.text += '"';
    }
    out.push_back(std::move(cur));
  }
  return out;
}

// ---------------------------------------------------------------------------------------------
// Pass 2: statements.

struct Stmt {
  const LogicalLine* ll = nullptr;
  bool assign = false;  // Key[(index)] = value; otherwise a bare line
  std::string key;      // assign: keyword; bare: the whole trimmed line
  std::optional<std::int64_t> index;
  bool has_index = false;     // "(...)" was present (index may still have failed to parse)
  std::string_view value;     // assign: trimmed value; bare: == key
  std::size_t value_pos = 0;  // offset of value in ll->text
  int line = 0;               // line of the statement's first character

  int line_at(std::size_t value_offset) const { return ll->line_at(value_pos + value_offset); }
  Scanner scan() const { return Scanner(value); }
};

bool is_key_char(char c) {
  return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '.' || c == '-' ||
         c == '+';
}

enum class Expect { Any, Unsigned, String, Octets };

bool starts_with_i(std::string_view s, std::string_view prefix) {
  return s.size() >= prefix.size() && iequals(s.substr(0, prefix.size()), prefix);
}
bool ends_with_i(std::string_view s, std::string_view suffix) {
  return s.size() >= suffix.size() && iequals(s.substr(s.size() - suffix.size()), suffix);
}

// Value types of the GSD spec's DP keywords (Visible-String, Unsigned8/16, Octet-String).
Expect expected_type(std::string_view key) {
  static constexpr std::string_view kStrings[] = {"Vendor_Name",
                                                  "Model_Name",
                                                  "Revision",
                                                  "Hardware_Release",
                                                  "Software_Release",
                                                  "OrderNumber",
                                                  "Info_Text",
                                                  "Bitmap_Device",
                                                  "Bitmap_Diag",
                                                  "Bitmap_SF",
                                                  "Implementation_Type",
                                                  "Channel_Diag",
                                                  "Unit_Diag_Bit_Help",
                                                  "Unit_Diag_Not_Bit_Help",
                                                  "Channel_Diag_Help"};
  static constexpr std::string_view kUnsigned[] = {
      "GSD_Revision",          "Revision_Number",   "Ident_Number",      "Protocol_Ident",
      "Station_Type",          "Redundancy",        "Repeater_Ctrl_Sig", "24V_Pins",
      "Min_Slave_Intervall",   "Modular_Station",   "Max_Module",        "Max_Input_Len",
      "Max_Output_Len",        "Max_Data_Len",      "Modul_Offset",      "Max_Diag_Data_Len",
      "Max_User_Prm_Data_Len", "User_Prm_Data_Len", "Fail_Safe",         "DPV1_Slave"};
  for (auto k : kStrings)
    if (iequals(key, k)) return Expect::String;
  for (auto k : kUnsigned)
    if (iequals(key, k)) return Expect::Unsigned;
  if (ends_with_i(key, "_supp") || starts_with_i(key, "MaxTsdr_")) return Expect::Unsigned;
  if (iequals(key, "User_Prm_Data")) return Expect::Octets;
  return Expect::Any;
}

// Block kinds and their end keywords.
enum class BlockKind { None, PrmText, ExtUserPrmData, Module, Slots, UnitDiagArea, Generic };

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

std::string quote(std::string_view s) {
  std::string out = "'";
  for (char c : s.substr(0, 40)) out += (static_cast<unsigned char>(c) < 0x20) ? '?' : c;
  if (s.size() > 40) out += "...";
  return out + "'";
}

class Parser {
 public:
  ParseResult run(std::string_view text) {
    auto lines = split_lines(text, diags_);
    for (const auto& ll : lines) {
      Stmt st;
      if (!make_stmt(ll, st)) continue;
      statement(st);
    }
    close_at_eof();
    if (!model_.has_header)
      err(first_stmt_line_ ? first_stmt_line_ : 1, "missing '#Profibus_DP' header");
    std::stable_sort(diags_.begin(), diags_.end(),
                     [](const Diagnostic& a, const Diagnostic& b) { return a.line < b.line; });
    return ParseResult{std::move(model_), std::move(diags_)};
  }

 private:
  // --- diagnostics --------------------------------------------------------------------------
  void err(int line, std::string msg) { diags_.push_back({line, Severity::Error, std::move(msg)}); }
  void warn(int line, std::string msg) {
    diags_.push_back({line, Severity::Warning, std::move(msg)});
  }

  // --- statement splitting ------------------------------------------------------------------
  bool make_stmt(const LogicalLine& ll, Stmt& st) {
    std::string_view t = ll.text;
    std::size_t b = 0;
    while (b < t.size() && std::isspace(static_cast<unsigned char>(t[b]))) ++b;
    std::size_t e = t.size();
    while (e > b && std::isspace(static_cast<unsigned char>(t[e - 1]))) --e;
    if (b == e) return false;
    st.ll = &ll;
    st.line = ll.line_at(b);
    std::string_view body = t.substr(b, e - b);

    // First '=' outside quotes splits keyword and value.
    std::size_t eq = std::string_view::npos;
    bool q = false;
    for (std::size_t i = 0; i < body.size(); ++i) {
      if (body[i] == '"') q = !q;
      if (!q && body[i] == '=') {
        eq = i;
        break;
      }
    }
    if (eq == std::string_view::npos || body.front() == '#' || body.front() == '"') {
      st.assign = false;
      st.key = std::string(body);
      st.value = std::string_view(ll.text).substr(b, e - b);
      st.value_pos = b;
      return true;
    }
    st.assign = true;
    std::string_view lhs = trim(body.substr(0, eq));
    std::string_view rhs = body.substr(eq + 1);
    std::size_t rb = 0;
    while (rb < rhs.size() && std::isspace(static_cast<unsigned char>(rhs[rb]))) ++rb;
    st.value = std::string_view(ll.text).substr(b + eq + 1 + rb, rhs.size() - rb);
    st.value_pos = b + eq + 1 + rb;

    if (lhs.empty()) {
      err(st.line, "missing keyword before '='");
      return false;
    }
    std::size_t paren = lhs.find('(');
    if (paren != std::string_view::npos) {
      st.has_index = true;
      std::size_t close = lhs.rfind(')');
      std::string_view key = trim(lhs.substr(0, paren));
      st.key = std::string(key);
      if (close == std::string_view::npos || close < paren) {
        err(st.line, "missing ')' after " + quote(key) + "(");
      } else {
        std::string_view inner = trim(lhs.substr(paren + 1, close - paren - 1));
        Scanner sc(inner);
        auto n = sc.number(true);
        sc.ws();
        if (!n || !sc.eof())
          err(st.line, "index of " + quote(key) + " is not a number: " + quote(inner));
        else
          st.index = *n;
        if (!trim(lhs.substr(close + 1)).empty())
          err(st.line, "unexpected text after " + quote(lhs.substr(0, close + 1)));
      }
    } else {
      st.key = std::string(lhs);
    }
    if (st.key.empty()) {
      err(st.line, "missing keyword before '('");
      return false;
    }
    for (char c : st.key) {
      if (!is_key_char(c)) {
        warn(st.line, "keyword " + quote(st.key) + " contains the unexpected character " +
                          quote(std::string(1, c)));
        break;
      }
    }
    return true;
  }

  // --- dispatch -----------------------------------------------------------------------------
  bool is_end_word(const Stmt& st, BlockKind* kind = nullptr) const {
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
  bool is_hard_start(const Stmt& st) const {
    if (st.assign)
      return iequals(st.key, "PrmText") || iequals(st.key, "ExtUserPrmData") ||
             iequals(st.key, "Module") || iequals(st.key, "UnitDiagType") ||
             iequals(st.key, "Physical_Interface");
    return iequals(st.key, "SlotDefinition") || iequals(st.key, "Slot_Definition") ||
           iequals(st.key, "Version_Firmware_Download");
  }

  void statement(const Stmt& st) {
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

  void header(const Stmt& st) {
    std::string_view h = trim(std::string_view(st.key).substr(1));
    if (iequals(h, "Profibus_DP")) {
      if (model_.has_header) warn(st.line, "repeated '#Profibus_DP' header");
      model_.has_header = true;
      if (block_ != BlockKind::None) missing_end(st.line);
    } else {
      warn(st.line, "unknown section header " + quote(st.key) + " (ignored)");
    }
  }

  void missing_end(int line) {
    std::string what = block_ == BlockKind::Generic ? generic_end_ : std::string(end_word(block_));
    err(line, "missing " + what + " for the " +
                  std::string(block_ == BlockKind::Generic ? std::string_view(generic_.keyword)
                                                           : block_name(block_)) +
                  " started at line " + std::to_string(block_line_));
    close_block();
  }

  void close_at_eof() {
    if (data_area_) {
      err(data_area_->line, "missing Data_Area_End for the Data_Area_Beg at line " +
                                std::to_string(data_area_->line));
      module_.blocks.push_back(std::move(*data_area_));
      data_area_.reset();
    }
    if (block_ != BlockKind::None) {
      std::string what =
          block_ == BlockKind::Generic ? generic_end_ : std::string(end_word(block_));
      err(block_line_, "missing " + what + " (end of file reached)");
      close_block();
    }
  }

  void open_block(BlockKind k, int line) {
    block_ = k;
    block_line_ = line;
  }

  void close_block() {
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

  // --- top level ----------------------------------------------------------------------------
  void top(const Stmt& st) {
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

  // A plain top-level keyword: typed check for the DP keywords, duplicate warning, stored.
  void setting(const Stmt& st) {
    Setting s = make_setting(st);
    switch (expected_type(st.key)) {
      case Expect::String:
        if (s.value.kind != Value::Kind::String)
          err(st.line, st.key + " expects a quoted string, found " + quote(st.value));
        break;
      case Expect::Unsigned:
        if (s.value.kind != Value::Kind::Number || s.value.number < 0)
          err(st.line, st.key + " expects an unsigned number, found " + quote(st.value));
        break;
      case Expect::Octets: {
        auto bytes = octets(st, st.scan(), st.key);
        s.value.kind = Value::Kind::Numbers;
        s.value.numbers.assign(bytes.begin(), bytes.end());
        break;
      }
      case Expect::Any:
        break;
    }
    std::string id = detail::lower(st.key);
    if (st.index) id += "(" + std::to_string(*st.index) + ")";
    auto [it, fresh] = seen_.emplace(id, st.line);
    if (!fresh)
      warn(st.line, "duplicate keyword " + quote(st.key) + " (first at line " +
                        std::to_string(it->second) + "; that one is used)");
    model_.settings.push_back(std::move(s));
  }

  Setting make_setting(const Stmt& st) {
    Setting s;
    s.key = st.key;
    s.index = st.index;
    s.raw = std::string(st.value);
    s.value = detail::classify(st.value);
    s.line = st.line;
    return s;
  }

  // Ext_User_Prm_Data_Const(offset) / Ext_User_Prm_Data_Ref(offset), top level or in a module.
  bool prm_layout_stmt(const Stmt& st, PrmLayout& layout) {
    const bool is_const = iequals(st.key, "Ext_User_Prm_Data_Const");
    const bool is_ref = iequals(st.key, "Ext_User_Prm_Data_Ref");
    if (!is_const && !is_ref) return false;
    if (!st.index) {
      if (!st.has_index) err(st.line, st.key + " needs an offset: " + st.key + "(offset) = ...");
      return true;
    }
    if (*st.index < 0) {
      err(st.line, st.key + " offset " + std::to_string(*st.index) + " is negative");
      return true;
    }
    if (is_const) {
      auto bytes = octets(st, st.scan(), st.key);
      if (!bytes.empty()) layout.consts.push_back({*st.index, std::move(bytes), st.line});
    } else {
      auto n = single_number(st, st.key);
      if (n) layout.refs.push_back({*st.index, *n, st.line});
    }
    return true;
  }

  // --- value helpers ------------------------------------------------------------------------
  // Comma-separated bytes (whitespace also separates; continuations were joined in pass 1).
  std::vector<std::uint8_t> octets(const Stmt& st, Scanner sc, std::string_view what) {
    std::vector<std::uint8_t> out;
    sc.ws();
    while (!sc.eof()) {
      std::size_t at = sc.pos();
      std::string nerr;
      auto n = sc.number(true, &nerr);
      if (!n) {
        err(st.line_at(at),
            std::string(what) + ": " +
                (nerr.empty() ? "expected a byte value, found " + quote(sc.rest()) : nerr));
        return out;
      }
      if (*n < 0 || *n > 0xFF) {
        err(st.line_at(at), std::string(what) + ": value " + std::to_string(*n) +
                                " does not fit in a byte (0..255)");
      } else {
        out.push_back(static_cast<std::uint8_t>(*n));
      }
      sc.ws();
      if (sc.eat(',')) {
        sc.ws();
        if (sc.eof()) warn(st.line_at(sc.pos()), std::string(what) + ": trailing ','");
      }
    }
    return out;
  }

  std::optional<std::int64_t> single_number(const Stmt& st, std::string_view what) {
    Scanner sc = st.scan();
    std::string nerr;
    auto n = sc.number(true, &nerr);
    sc.ws();
    if (!n || !sc.eof()) {
      err(st.line,
          std::string(what) + " expects a number, found " + quote(nerr.empty() ? st.value : nerr));
      return std::nullopt;
    }
    return n;
  }

  bool string_value(const Stmt& st, std::string& out) {
    Scanner sc = st.scan();
    auto s = sc.quoted();
    sc.ws();
    if (!s) {
      err(st.line, st.key + " expects a quoted string, found " + quote(st.value));
      return false;
    }
    if (!sc.eof()) warn(st.line_at(sc.pos()), "text after the string ignored: " + quote(sc.rest()));
    out = std::move(*s);
    return true;
  }

  // "min-max" | "a,b,c" | "a". Returns false (and reports) when malformed.
  bool range_or_list(const Stmt& st, Scanner& sc, std::optional<std::int64_t>& min,
                     std::optional<std::int64_t>& max, std::vector<std::int64_t>& list,
                     std::string_view what) {
    sc.ws();
    std::size_t at = sc.pos();
    std::string nerr;
    auto first = sc.number(true, &nerr);
    if (!first) {
      err(st.line_at(at), std::string(what) + ": expected 'min-max' or a value list, found " +
                              quote(nerr.empty() ? sc.rest() : nerr));
      return false;
    }
    sc.ws();
    if (sc.eat('-')) {
      sc.ws();
      at = sc.pos();
      auto second = sc.number(true, &nerr);
      if (!second) {
        err(st.line_at(at), std::string(what) + ": expected the maximum after '-', found " +
                                quote(nerr.empty() ? sc.rest() : nerr));
        return false;
      }
      min = first;
      max = second;
      return true;
    }
    list.push_back(*first);
    while (sc.eat(',')) {
      sc.ws();
      at = sc.pos();
      auto n = sc.number(true, &nerr);
      if (!n) {
        err(st.line_at(at), std::string(what) + ": expected a value after ',', found " +
                                quote(nerr.empty() ? sc.rest() : nerr));
        return false;
      }
      list.push_back(*n);
      sc.ws();
    }
    return true;
  }

  void trailing(const Stmt& st, Scanner& sc) {
    sc.ws();
    if (!sc.eof()) err(st.line_at(sc.pos()), "unexpected text " + quote(sc.rest()));
  }

  // --- blocks -------------------------------------------------------------------------------
  void start_prm_text(const Stmt& st) {
    prm_text_ = PrmText{};
    prm_text_.line = st.line;
    if (auto n = single_number(st, "PrmText")) prm_text_.ref = *n;
    open_block(BlockKind::PrmText, st.line);
  }

  void start_eupd(const Stmt& st) {
    eupd_ = ExtUserPrmData{};
    eupd_.line = st.line;
    eupd_type_seen_ = eupd_type_ok_ = false;
    open_block(BlockKind::ExtUserPrmData, st.line);
    Scanner sc = st.scan();
    std::string nerr;
    auto ref = sc.number(true, &nerr);
    if (!ref) {
      err(st.line, "ExtUserPrmData expects a reference number, found " +
                       quote(nerr.empty() ? st.value : nerr));
      eupd_type_seen_ = true;  // already reported; the block is dropped
      return;
    }
    eupd_.ref = *ref;
    sc.ws();
    auto name = sc.quoted();
    if (!name) {
      err(st.line_at(sc.pos()), "ExtUserPrmData " + std::to_string(*ref) +
                                    " expects a quoted name, found " + quote(sc.rest()));
    } else {
      eupd_.name = std::move(*name);
    }
    sc.ws();
    if (!sc.eof()) type_line(st, sc);  // type on the same line (some hand-written files)
  }

  void type_line(const Stmt& st, Scanner& sc) {
    eupd_type_seen_ = true;
    std::size_t at = sc.pos();
    std::string_view word = sc.word();
    auto bad = [&](std::string msg) { err(st.line_at(at), std::move(msg)); };
    PrmType t;
    if (iequals(word, "Unsigned8"))
      t = PrmType::Unsigned8;
    else if (iequals(word, "Unsigned16"))
      t = PrmType::Unsigned16;
    else if (iequals(word, "Unsigned32"))
      t = PrmType::Unsigned32;
    else if (iequals(word, "Signed8"))
      t = PrmType::Signed8;
    else if (iequals(word, "Signed16"))
      t = PrmType::Signed16;
    else if (iequals(word, "Signed32"))
      t = PrmType::Signed32;
    else if (iequals(word, "Bit"))
      t = PrmType::Bit;
    else if (iequals(word, "BitArea"))
      t = PrmType::BitArea;
    else {
      bad("ExtUserPrmData " + std::to_string(eupd_.ref) + ": unknown data type " +
          quote(word.empty() ? sc.rest() : word) +
          " (expected Unsigned8/16/32, Signed8/16/32, Bit(n) or BitArea(a-b))");
      return;
    }
    eupd_.type = t;
    if (t == PrmType::Bit || t == PrmType::BitArea) {
      sc.ws();
      if (!sc.eat('(')) return bad(std::string(word) + " needs its bit position in '(...)'");
      sc.ws();
      auto a = sc.number(false);
      std::optional<std::int64_t> b = a;
      sc.ws();
      if (a && t == PrmType::BitArea) {
        b.reset();
        if (sc.eat('-')) {
          sc.ws();
          b = sc.number(false);
          sc.ws();
        }
      }
      if (!a || !b || !sc.eat(')'))
        return bad(t == PrmType::Bit ? "malformed Bit(n)" : "malformed BitArea(first-last)");
      // Out-of-range bit numbers are kept (clamped to int) and reported by check().
      eupd_.first_bit = static_cast<int>(std::min<std::int64_t>(*a, 1000));
      eupd_.last_bit = static_cast<int>(std::min<std::int64_t>(*b, 1000));
    }
    sc.ws();
    at = sc.pos();
    std::string nerr;
    auto def = sc.number(true, &nerr);
    if (!def)
      return bad("ExtUserPrmData " + std::to_string(eupd_.ref) +
                 ": expected the default value, found " + quote(nerr.empty() ? sc.rest() : nerr));
    eupd_.default_value = *def;
    sc.ws();
    if (sc.eof()) {
      warn(st.line_at(sc.pos()), "ExtUserPrmData " + std::to_string(eupd_.ref) +
                                     ": no allowed values given; the data type's range applies");
    } else if (!range_or_list(st, sc, eupd_.min, eupd_.max, eupd_.allowed,
                              "ExtUserPrmData " + std::to_string(eupd_.ref))) {
      return;
    }
    sc.ws();
    if (!sc.eof()) return bad("unexpected text " + quote(sc.rest()) + " after the value range");
    eupd_type_ok_ = true;
  }

  void start_module(const Stmt& st) {
    module_ = Module{};
    module_.line = st.line;
    open_block(BlockKind::Module, st.line);
    Scanner sc = st.scan();
    auto name = sc.quoted();
    if (!name) {
      err(st.line, "Module expects a quoted name, found " + quote(st.value));
      return;
    }
    module_.name = std::move(*name);
    module_.config = octets(st, sc, "Module " + quote(module_.name));
    if (module_.config.empty())
      err(st.line, "Module " + quote(module_.name) + " has no configuration bytes");
  }

  void start_area(const Stmt& st) {
    area_ = UnitDiagArea{};
    area_.line = st.line;
    open_block(BlockKind::UnitDiagArea, st.line);
    Scanner sc = st.scan();
    auto a = sc.number(false);
    sc.ws();
    std::optional<std::int64_t> b;
    if (a && sc.eat('-')) {
      sc.ws();
      b = sc.number(false);
    }
    sc.ws();
    if (!a || !b || !sc.eof()) {
      err(st.line, "Unit_Diag_Area expects 'first-last', found " + quote(st.value));
      return;
    }
    area_.first = *a;
    area_.last = *b;
  }

  void start_generic(const Stmt& st, std::string_view end) {
    generic_ = Block{};
    generic_.keyword = st.key;
    generic_.header = st.assign ? std::string(st.value) : std::string();
    generic_.line = st.line;
    generic_end_ = std::string(end);
    open_block(BlockKind::Generic, st.line);
  }

  void in_block(const Stmt& st) {
    BlockKind ek;
    if (block_ == BlockKind::Generic) {
      if (!st.assign && iequals(st.key, generic_end_)) return close_block();
      generic_.settings.push_back(st.assign ? make_setting(st) : bare_setting(st));
      return;
    }
    if (block_ == BlockKind::Module && data_area_) {
      if (!st.assign && iequals(st.key, "Data_Area_End")) {
        module_.blocks.push_back(std::move(*data_area_));
        data_area_.reset();
        return;
      }
      data_area_->settings.push_back(st.assign ? make_setting(st) : bare_setting(st));
      return;
    }
    if (is_end_word(st, &ek)) {
      if (ek == block_) return close_block();
      err(st.line, "unexpected " + quote(st.key) + " inside the " +
                       std::string(block_name(block_)) + " started at line " +
                       std::to_string(block_line_) + " (expected " + std::string(end_word(block_)) +
                       ")");
      return;
    }
    switch (block_) {
      case BlockKind::PrmText:
        return in_prm_text(st);
      case BlockKind::ExtUserPrmData:
        return in_eupd(st);
      case BlockKind::Module:
        return in_module(st);
      case BlockKind::Slots:
        return in_slots(st);
      case BlockKind::UnitDiagArea:
        return in_area(st);
      default:
        break;
    }
  }

  static Setting bare_setting(const Stmt& st) {
    Setting s;
    s.raw = st.key;
    s.value = detail::classify(st.key);
    s.line = st.line;
    return s;
  }

  // A statement that does not belong in a block that has a fixed body: the end keyword is
  // missing; close the block and handle the statement at the top level.
  void not_in_block(const Stmt& st) {
    missing_end(st.line);
    top(st);
  }

  void in_prm_text(const Stmt& st) {
    if (!st.assign || !iequals(st.key, "Text")) return not_in_block(st);
    if (!st.index) {
      if (!st.has_index) err(st.line, "Text needs a value: Text(n) = \"...\"");
      return;
    }
    std::string text;
    if (!string_value(st, text)) return;
    for (const auto& [v, t] : prm_text_.texts)
      if (v == *st.index)
        warn(st.line, "PrmText " + std::to_string(prm_text_.ref) + ": Text(" + std::to_string(v) +
                          ") defined twice");
    prm_text_.texts.emplace_back(*st.index, std::move(text));
  }

  void in_eupd(const Stmt& st) {
    if (!st.assign) {
      if (eupd_type_seen_) {
        err(st.line, "unexpected " + quote(st.key) + " in ExtUserPrmData " +
                         std::to_string(eupd_.ref) + " (the data type line was already given)");
        return;
      }
      Scanner sc = st.scan();
      type_line(st, sc);
      return;
    }
    if (!eupd_type_seen_) {
      eupd_type_seen_ = true;
      err(st.line, "ExtUserPrmData " + std::to_string(eupd_.ref) +
                       ": expected the data type line (e.g. 'Unsigned8 0 0-255') before " +
                       quote(st.key));
    }
    if (iequals(st.key, "Prm_Text_Ref")) {
      if (auto n = single_number(st, "Prm_Text_Ref")) eupd_.prm_text_ref = *n;
    } else if (iequals(st.key, "Changeable")) {
      if (auto n = single_number(st, "Changeable")) eupd_.changeable = *n != 0;
    } else if (iequals(st.key, "Visible")) {
      if (auto n = single_number(st, "Visible")) eupd_.visible = *n != 0;
    } else {
      eupd_.other.push_back(make_setting(st));
    }
  }

  void in_module(const Stmt& st) {
    if (!st.assign) {
      if (iequals(st.key, "Data_Area_Beg")) {
        data_area_ = Block{};
        data_area_->keyword = st.key;
        data_area_->line = st.line;
        return;
      }
      Scanner sc = st.scan();
      auto n = sc.number(false);
      sc.ws();
      if (n && sc.eof()) {
        if (module_.reference)
          err(st.line,
              "Module " + quote(module_.name) + " has a second reference number " + quote(st.key));
        else
          module_.reference = *n;
        return;
      }
      err(st.line, "unexpected " + quote(st.key) + " in Module " + quote(module_.name));
      return;
    }
    if (iequals(st.key, "Ext_Module_Prm_Data_Len")) {
      if (auto n = single_number(st, st.key)) module_.ext_module_prm_data_len = *n;
      return;
    }
    if (prm_layout_stmt(st, module_.prm)) return;
    module_.settings.push_back(make_setting(st));
  }

  void in_slots(const Stmt& st) {
    if (!st.assign || !iequals(st.key, "Slot")) return not_in_block(st);
    SlotDef s;
    s.line = st.line;
    if (!st.index) {
      if (!st.has_index) err(st.line, "Slot needs a number: Slot(n) = \"name\" default allowed");
      return;
    }
    s.number = *st.index;
    Scanner sc = st.scan();
    auto name = sc.quoted();
    if (!name) {
      err(st.line, "Slot(" + std::to_string(s.number) + ") expects a quoted name");
      return;
    }
    s.name = std::move(*name);
    sc.ws();
    std::string nerr;
    auto def = sc.number(false, &nerr);
    if (!def) {
      err(st.line_at(sc.pos()),
          "Slot(" + std::to_string(s.number) + ") expects the default module reference");
      return;
    }
    s.default_ref = *def;
    sc.ws();
    if (sc.eof()) {
      s.allowed.push_back(*def);
    } else if (!range_or_list(st, sc, s.min, s.max, s.allowed,
                              "Slot(" + std::to_string(s.number) + ")")) {
      return;
    }
    trailing(st, sc);
    model_.slots.push_back(std::move(s));
  }

  void in_area(const Stmt& st) {
    if (!st.assign || !iequals(st.key, "Value")) return not_in_block(st);
    if (!st.index) {
      if (!st.has_index) err(st.line, "Value needs a number: Value(n) = \"...\"");
      return;
    }
    std::string text;
    if (!string_value(st, text)) return;
    area_.values.emplace_back(*st.index, std::move(text));
  }

  Model model_;
  std::vector<Diagnostic> diags_;
  std::map<std::string, int> seen_;
  int first_stmt_line_ = 0;
  bool warned_before_header_ = false;

  BlockKind block_ = BlockKind::None;
  int block_line_ = 0;
  PrmText prm_text_;
  ExtUserPrmData eupd_;
  bool eupd_type_seen_ = false;
  bool eupd_type_ok_ = false;
  Module module_;
  std::optional<Block> data_area_;
  UnitDiagArea area_;
  Block generic_;
  std::string generic_end_;
};

}  // namespace

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

// A file that is not a GSD gets one line instead of one error per line (issue 12).
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
  return Parser().run(text);
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
