#include "gsd/text.hpp"

#include <cctype>
#include <limits>

namespace candp2::gsd {

namespace detail {

std::string_view trim(std::string_view s) {
  std::size_t b = 0, e = s.size();
  while (b < e && std::isspace(static_cast<unsigned char>(s[b]))) ++b;
  while (e > b && std::isspace(static_cast<unsigned char>(s[e - 1]))) --e;
  return s.substr(b, e - b);
}

std::string lower(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

void Scanner::ws() {
  while (pos_ < s_.size() && std::isspace(static_cast<unsigned char>(s_[pos_]))) ++pos_;
}

bool Scanner::eat(char c) {
  if (pos_ < s_.size() && s_[pos_] == c) {
    ++pos_;
    return true;
  }
  return false;
}

std::optional<std::int64_t> Scanner::number(bool allow_sign, std::string* error) {
  const std::size_t start = pos_;
  std::size_t p = pos_;
  bool negative = false;
  if (allow_sign && p < s_.size() && (s_[p] == '-' || s_[p] == '+')) {
    negative = s_[p] == '-';
    ++p;
  }
  auto digit = [&](std::size_t i) {
    return i < s_.size() && std::isdigit(static_cast<unsigned char>(s_[i]));
  };
  if (!digit(p)) return std::nullopt;
  int base = 10;
  if (s_[p] == '0' && p + 1 < s_.size() && (s_[p + 1] == 'x' || s_[p + 1] == 'X') &&
      p + 2 < s_.size() && std::isxdigit(static_cast<unsigned char>(s_[p + 2]))) {
    base = 16;
    p += 2;
  }
  constexpr std::uint64_t kMax =
      static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max());
  std::uint64_t v = 0;
  bool overflow = false;
  for (; p < s_.size(); ++p) {
    const unsigned char c = static_cast<unsigned char>(s_[p]);
    int d;
    if (std::isdigit(c))
      d = c - '0';
    else if (base == 16 && std::isxdigit(c))
      d = std::tolower(c) - 'a' + 10;
    else
      break;
    if (v > (kMax - static_cast<std::uint64_t>(d)) / static_cast<std::uint64_t>(base))
      overflow = true;
    else
      v = v * static_cast<std::uint64_t>(base) + static_cast<std::uint64_t>(d);
  }
  if (p < s_.size()) {
    const unsigned char c = static_cast<unsigned char>(s_[p]);
    if (std::isalnum(c) || c == '_' || c == '.') return std::nullopt;  // "1.1", "0x1G", "12ab"
  }
  if (overflow) {
    if (error) *error = "number " + std::string(s_.substr(start, p - start)) + " is too large";
    return std::nullopt;
  }
  pos_ = p;
  const auto sv = static_cast<std::int64_t>(v);
  return negative ? -sv : sv;
}

std::optional<std::string> Scanner::quoted() {
  ws();
  if (pos_ >= s_.size() || s_[pos_] != '"') return std::nullopt;
  const std::size_t close = s_.find('"', pos_ + 1);
  if (close == std::string_view::npos) return std::nullopt;
  std::string out(s_.substr(pos_ + 1, close - pos_ - 1));
  pos_ = close + 1;
  return out;
}

std::string_view Scanner::word() {
  const std::size_t start = pos_;
  while (pos_ < s_.size() &&
         (std::isalnum(static_cast<unsigned char>(s_[pos_])) || s_[pos_] == '_'))
    ++pos_;
  return s_.substr(start, pos_ - start);
}

Value classify(std::string_view raw) {
  Value v;
  raw = trim(raw);
  if (raw.empty()) return v;
  if (raw.front() == '"') {
    Scanner sc(raw);
    auto s = sc.quoted();
    sc.ws();
    if (s && sc.eof()) {
      v.kind = Value::Kind::String;
      v.text = std::move(*s);
      return v;
    }
  } else {
    Scanner sc(raw);
    std::vector<std::int64_t> nums;
    bool ok = true;
    while (!sc.eof()) {
      auto n = sc.number(true);
      if (!n) {
        ok = false;
        break;
      }
      nums.push_back(*n);
      sc.ws();
      if (sc.eat(',')) sc.ws();
    }
    if (ok && !nums.empty()) {
      if (nums.size() == 1) {
        v.kind = Value::Kind::Number;
        v.number = nums.front();
      } else {
        v.kind = Value::Kind::Numbers;
        v.numbers = std::move(nums);
      }
      return v;
    }
  }
  v.kind = Value::Kind::Text;
  v.text = std::string(raw);
  return v;
}

}  // namespace detail

bool iequals(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (std::tolower(static_cast<unsigned char>(a[i])) !=
        std::tolower(static_cast<unsigned char>(b[i])))
      return false;
  return true;
}

std::string to_utf8(std::string_view s) {
  bool valid = true;
  for (std::size_t i = 0; i < s.size() && valid;) {
    const auto c = static_cast<unsigned char>(s[i]);
    std::size_t n = 0;
    if (c < 0x80)
      n = 0;
    else if ((c & 0xE0) == 0xC0 && c >= 0xC2)
      n = 1;
    else if ((c & 0xF0) == 0xE0)
      n = 2;
    else if ((c & 0xF8) == 0xF0 && c <= 0xF4)
      n = 3;
    else
      valid = false;
    for (std::size_t k = 1; valid && k <= n; ++k)
      if (i + k >= s.size() || (static_cast<unsigned char>(s[i + k]) & 0xC0) != 0x80) valid = false;
    i += n + 1;
  }
  if (valid) return std::string(s);
  std::string out;
  out.reserve(s.size() + 8);
  for (char ch : s) {
    const auto c = static_cast<unsigned char>(ch);
    if (c < 0x80) {
      out += ch;
    } else {
      out += static_cast<char>(0xC0 | (c >> 6));
      out += static_cast<char>(0x80 | (c & 0x3F));
    }
  }
  return out;
}

}  // namespace candp2::gsd
