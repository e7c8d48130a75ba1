// GSD text -> logical lines -> statements (gsd/statements.hpp).
#include "gsd/statements.hpp"

#include <algorithm>
#include <cctype>

namespace candp2::gsd::detail {

namespace {

bool is_key_char(char c) {
  return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '.' || c == '-' ||
         c == '+';
}

}  // namespace

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

std::string quote(std::string_view s) {
  std::string out = "'";
  for (char c : s.substr(0, 40)) out += (static_cast<unsigned char>(c) < 0x20) ? '?' : c;
  if (s.size() > 40) out += "...";
  return out + "'";
}

bool make_stmt(const LogicalLine& ll, Stmt& st, std::vector<Diagnostic>& diags) {
  auto err = [&](int line, std::string msg) {
    diags.push_back({line, Severity::Error, std::move(msg)});
  };
  auto warn = [&](int line, std::string msg) {
    diags.push_back({line, Severity::Warning, std::move(msg)});
  };
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

}  // namespace candp2::gsd::detail
