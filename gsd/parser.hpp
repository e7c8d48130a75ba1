// The GSD reader's block state machine (internal to gsd/): each statement (gsd/statements.hpp) is
// filed into the Model, inside a block (PrmText, ExtUserPrmData, Module, SlotDefinition,
// Unit_Diag_Area, or a block kept as generic settings) or at the top level. Every problem is a
// Diagnostic; nothing throws.
//   gsd/parse.cpp         run(), dispatch, opening and closing blocks, the top level
//   gsd/parse_blocks.cpp  the statements inside each kind of block
//   gsd/parse_values.cpp  typed values (numbers, strings, octets, ranges) and plain settings
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "gsd/gsd.hpp"
#include "gsd/statements.hpp"
#include "gsd/text.hpp"

namespace candp2::gsd::detail {

// Block kinds and their end keywords.
enum class BlockKind { None, PrmText, ExtUserPrmData, Module, Slots, UnitDiagArea, Generic };
std::string_view block_name(BlockKind k);
std::string_view end_word(BlockKind k);

class Parser {
 public:
  ParseResult run(std::string_view text);

 private:
  // --- diagnostics --------------------------------------------------------------------------
  void err(int line, std::string msg) { diags_.push_back({line, Severity::Error, std::move(msg)}); }
  void warn(int line, std::string msg) {
    diags_.push_back({line, Severity::Warning, std::move(msg)});
  }

  // --- dispatch (parse.cpp) -----------------------------------------------------------------
  bool is_end_word(const Stmt& st, BlockKind* kind = nullptr) const;
  // Statements that can only open a top-level block: seeing one inside another block means the
  // end keyword of that block is missing.
  bool is_hard_start(const Stmt& st) const;
  void statement(const Stmt& st);
  void header(const Stmt& st);
  void missing_end(int line);
  void close_at_eof();
  void open_block(BlockKind k, int line);
  void close_block();
  void top(const Stmt& st);
  // A statement that does not belong in a block that has a fixed body: the end keyword is
  // missing; close the block and handle the statement at the top level.
  void not_in_block(const Stmt& st);

  // --- values and settings (parse_values.cpp) -----------------------------------------------
  // A plain top-level keyword: typed check for the DP keywords, duplicate warning, stored.
  void setting(const Stmt& st);
  Setting make_setting(const Stmt& st);
  static Setting bare_setting(const Stmt& st);
  // Ext_User_Prm_Data_Const(offset) / Ext_User_Prm_Data_Ref(offset), top level or in a module.
  bool prm_layout_stmt(const Stmt& st, PrmLayout& layout);
  // Comma-separated bytes (whitespace also separates; continuations were joined in pass 1).
  std::vector<std::uint8_t> octets(const Stmt& st, Scanner sc, std::string_view what);
  std::optional<std::int64_t> single_number(const Stmt& st, std::string_view what);
  bool string_value(const Stmt& st, std::string& out);
  // "min-max" | "a,b,c" | "a". Returns false (and reports) when malformed.
  bool range_or_list(const Stmt& st, Scanner& sc, std::optional<std::int64_t>& min,
                     std::optional<std::int64_t>& max, std::vector<std::int64_t>& list,
                     std::string_view what);
  void trailing(const Stmt& st, Scanner& sc);

  // --- blocks (parse_blocks.cpp) ------------------------------------------------------------
  void start_prm_text(const Stmt& st);
  void start_eupd(const Stmt& st);
  void type_line(const Stmt& st, Scanner& sc);
  void start_module(const Stmt& st);
  void start_area(const Stmt& st);
  void start_generic(const Stmt& st, std::string_view end);
  void in_block(const Stmt& st);
  void in_prm_text(const Stmt& st);
  void in_eupd(const Stmt& st);
  void in_module(const Stmt& st);
  void in_slots(const Stmt& st);
  void in_area(const Stmt& st);

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

}  // namespace candp2::gsd::detail
