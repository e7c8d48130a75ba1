// The GSD reader's first steps (internal to gsd/): physical lines joined into logical lines
// (comments stripped, `\` continuations followed), and a logical line split into one statement
// (`Key[(index)] = value` or a bare line). The statements are filed into the model by the block
// state machine in gsd/parser.hpp.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <iterator>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "gsd/gsd.hpp"
#include "gsd/text.hpp"

namespace candp2::gsd::detail {

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
std::vector<LogicalLine> split_lines(std::string_view src, std::vector<Diagnostic>& diags);

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

// Splits one logical line into a statement; false for a blank line or one that has no keyword
// (reported in `diags`).
bool make_stmt(const LogicalLine& ll, Stmt& st, std::vector<Diagnostic>& diags);

// A value for a message: in single quotes, control characters as '?', cut after 40 characters.
std::string quote(std::string_view s);

}  // namespace candp2::gsd::detail
