// The GSD parser's values: typed checks of the DP keywords, plain settings, octet strings,
// numbers, quoted strings and value ranges (gsd/parser.hpp).
#include <string>

#include "gsd/parser.hpp"

namespace candp2::gsd::detail {

namespace {

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
      "Max_User_Prm_Data_Len", "User_Prm_Data_Len", "Fail_Safe",         "DPV1_Slave",
      "FixPresetModules"};
  for (auto k : kStrings)
    if (iequals(key, k)) return Expect::String;
  for (auto k : kUnsigned)
    if (iequals(key, k)) return Expect::Unsigned;
  if (ends_with_i(key, "_supp") || starts_with_i(key, "MaxTsdr_")) return Expect::Unsigned;
  if (iequals(key, "User_Prm_Data")) return Expect::Octets;
  return Expect::Any;
}

}  // namespace

// A plain top-level keyword: typed check for the DP keywords, duplicate warning, stored.
void Parser::setting(const Stmt& st) {
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
  if (st.index) {
    id += '(';  // chars, not `"(" + ...`: GCC 12 -O3 false -Wrestrict
    id += std::to_string(*st.index);
    id += ')';
  }
  auto [it, fresh] = seen_.emplace(id, st.line);
  if (!fresh)
    warn(st.line, "duplicate keyword " + quote(st.key) + " (first at line " +
                      std::to_string(it->second) + "; that one is used)");
  model_.settings.push_back(std::move(s));
}

Setting Parser::make_setting(const Stmt& st) {
  Setting s;
  s.key = st.key;
  s.index = st.index;
  s.raw = std::string(st.value);
  s.value = detail::classify(st.value);
  s.line = st.line;
  return s;
}

Setting Parser::bare_setting(const Stmt& st) {
  Setting s;
  s.raw = st.key;
  s.value = detail::classify(st.key);
  s.line = st.line;
  return s;
}

// Ext_User_Prm_Data_Const(offset) / Ext_User_Prm_Data_Ref(offset), top level or in a module.
bool Parser::prm_layout_stmt(const Stmt& st, PrmLayout& layout) {
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

// Comma-separated bytes (whitespace also separates; continuations were joined in pass 1).
std::vector<std::uint8_t> Parser::octets(const Stmt& st, Scanner sc, std::string_view what) {
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
      err(st.line_at(at),
          std::string(what) + ": value " + std::to_string(*n) + " does not fit in a byte (0..255)");
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

std::optional<std::int64_t> Parser::single_number(const Stmt& st, std::string_view what) {
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

bool Parser::string_value(const Stmt& st, std::string& out) {
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
bool Parser::range_or_list(const Stmt& st, Scanner& sc, std::optional<std::int64_t>& min,
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

void Parser::trailing(const Stmt& st, Scanner& sc) {
  sc.ws();
  if (!sc.eof()) err(st.line_at(sc.pos()), "unexpected text " + quote(sc.rest()));
}

}  // namespace candp2::gsd::detail
