// The GSD parser's blocks: PrmText, ExtUserPrmData (with its data type line), Module (with its
// Data_Area blocks), SlotDefinition, Unit_Diag_Area and the blocks kept as generic settings
// (gsd/parser.hpp).
#include <algorithm>
#include <string>

#include "gsd/parser.hpp"

namespace candp2::gsd::detail {

void Parser::start_prm_text(const Stmt& st) {
  prm_text_ = PrmText{};
  prm_text_.line = st.line;
  if (auto n = single_number(st, "PrmText")) prm_text_.ref = *n;
  open_block(BlockKind::PrmText, st.line);
}

void Parser::start_eupd(const Stmt& st) {
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

void Parser::type_line(const Stmt& st, Scanner& sc) {
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

void Parser::start_module(const Stmt& st) {
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

void Parser::start_area(const Stmt& st) {
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

void Parser::start_generic(const Stmt& st, std::string_view end) {
  generic_ = Block{};
  generic_.keyword = st.key;
  generic_.header = st.assign ? std::string(st.value) : std::string();
  generic_.line = st.line;
  generic_end_ = std::string(end);
  open_block(BlockKind::Generic, st.line);
}

void Parser::in_block(const Stmt& st) {
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
    err(st.line, "unexpected " + quote(st.key) + " inside the " + std::string(block_name(block_)) +
                     " started at line " + std::to_string(block_line_) + " (expected " +
                     std::string(end_word(block_)) + ")");
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

void Parser::in_prm_text(const Stmt& st) {
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

void Parser::in_eupd(const Stmt& st) {
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

void Parser::in_module(const Stmt& st) {
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
  if (iequals(st.key, "Preset")) {  // Boolean (GSD revision 2): 0 or 1
    if (auto n = single_number(st, st.key)) {
      if (*n == 0 || *n == 1)
        module_.preset = *n == 1;
      else
        err(st.line,
            "Module " + quote(module_.name) + ": Preset expects 0 or 1, found " + quote(st.value));
    }
  }
  module_.settings.push_back(make_setting(st));
}

void Parser::in_slots(const Stmt& st) {
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

void Parser::in_area(const Stmt& st) {
  if (!st.assign || !iequals(st.key, "Value")) return not_in_block(st);
  if (!st.index) {
    if (!st.has_index) err(st.line, "Value needs a number: Value(n) = \"...\"");
    return;
  }
  std::string text;
  if (!string_value(st, text)) return;
  area_.values.emplace_back(*st.index, std::move(text));
}

}  // namespace candp2::gsd::detail
