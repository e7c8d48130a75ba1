#include "gsd/prm.hpp"

#include <algorithm>
#include <optional>

#include "gsd/text.hpp"

namespace candp2::gsd {

namespace {

std::string q(std::string_view s) {
  // Appended, not `"\"" + std::string(...)`: GCC 12 -O3 reports a false -Wrestrict inside
  // libstdc++ for a literal + std::string (GCC bug 105329).
  std::string out(1, '"');
  out += detail::trim(s);
  out += '"';
  return out;
}

bool bits_valid(const ExtUserPrmData& d) {
  return d.first_bit >= 0 && d.last_bit <= 7 && d.first_bit <= d.last_bit;
}

// Writes v at offset into buf (which is large enough). Bits outside the field stay.
void put(std::vector<std::uint8_t>& buf, std::size_t offset, const ExtUserPrmData& d,
         std::int64_t v) {
  const auto u = static_cast<std::uint64_t>(v);
  switch (d.type) {
    case PrmType::Bit:
    case PrmType::BitArea: {
      const unsigned width = static_cast<unsigned>(d.last_bit - d.first_bit + 1);
      const auto mask = static_cast<std::uint8_t>(((1u << width) - 1u) << d.first_bit);
      buf[offset] = static_cast<std::uint8_t>((buf[offset] & ~mask) |
                                              ((static_cast<unsigned>(u) << d.first_bit) & mask));
      return;
    }
    default: {
      const std::size_t n = d.size();
      for (std::size_t i = 0; i < n; ++i)  // big-endian
        buf[offset + i] = static_cast<std::uint8_t>(u >> (8 * (n - 1 - i)));
      return;
    }
  }
}

struct Resolved {
  const PrmOverride* ov;
  bool used = false;
};

EncodeResult encode(const Model& model, const PrmLayout& layout,
                    const std::vector<std::uint8_t>* legacy, std::size_t min_len,
                    std::span<const PrmOverride> overrides, const std::string& where) {
  EncodeResult r;
  auto error = [&](std::string msg) { r.errors.push_back(where + msg); };

  // Length: the largest of the declared length, the legacy bytes and every const/ref end.
  std::size_t len = min_len;
  if (legacy) len = std::max(len, legacy->size());
  for (const auto& c : layout.consts) {
    if (c.offset < 0 || static_cast<std::uint64_t>(c.offset) + c.bytes.size() > kMaxUserPrmLen) {
      error("Ext_User_Prm_Data_Const(" + std::to_string(c.offset) + ") reaches beyond the " +
            std::to_string(kMaxUserPrmLen) + "-byte limit of Set_Prm user data");
      continue;
    }
    len = std::max(len, static_cast<std::size_t>(c.offset) + c.bytes.size());
  }
  for (const auto& ref : layout.refs) {
    const ExtUserPrmData* d = model.ext_user_prm(ref.ref);
    const std::size_t size = d ? d->size() : 1;
    if (ref.offset < 0 || static_cast<std::uint64_t>(ref.offset) + size > kMaxUserPrmLen) continue;
    len = std::max(len, static_cast<std::size_t>(ref.offset) + size);
  }
  len = std::min(len, kMaxUserPrmLen);

  r.bytes.assign(len, 0);
  if (legacy) std::copy_n(legacy->begin(), std::min(legacy->size(), len), r.bytes.begin());
  for (const auto& c : layout.consts) {
    if (c.offset < 0 || static_cast<std::uint64_t>(c.offset) + c.bytes.size() > len) continue;
    std::copy(c.bytes.begin(), c.bytes.end(),
              r.bytes.begin() + static_cast<std::ptrdiff_t>(c.offset));
  }

  std::vector<Resolved> ovs;
  for (const auto& o : overrides) ovs.push_back({&o});

  for (const auto& ref : layout.refs) {
    const std::string at = "Ext_User_Prm_Data_Ref(" + std::to_string(ref.offset) + ")";
    const ExtUserPrmData* d = model.ext_user_prm(ref.ref);
    if (!d) {
      error(at + " = " + std::to_string(ref.ref) + ": no ExtUserPrmData " +
            std::to_string(ref.ref));
      continue;
    }
    if (ref.offset < 0 || static_cast<std::uint64_t>(ref.offset) + d->size() > len) {
      error(at + " " + q(d->name) + " reaches beyond the " + std::to_string(kMaxUserPrmLen) +
            "-byte limit of Set_Prm user data");
      continue;
    }
    if ((d->type == PrmType::Bit || d->type == PrmType::BitArea) && !bits_valid(*d)) {
      error(at + " " + q(d->name) + ": bit position outside 0..7");
      continue;
    }
    std::int64_t v = d->default_value;
    std::string source = "default";
    for (auto& o : ovs) {
      if (!iequals(detail::trim(o.ov->name), detail::trim(d->name))) continue;
      o.used = true;
      if (const auto* num = std::get_if<std::int64_t>(&o.ov->value)) {
        v = *num;
      } else {
        const std::string& text = std::get<std::string>(o.ov->value);
        const PrmText* t = d->prm_text_ref ? model.prm_text(*d->prm_text_ref) : nullptr;
        std::optional<std::int64_t> tv = t ? t->value_for(text) : std::nullopt;
        if (!tv) {
          detail::Scanner sc(detail::trim(text));
          tv = sc.number(true);
          sc.ws();
          if (tv && !sc.eof()) tv.reset();
        }
        if (!tv) {
          std::string known;
          if (t)
            for (const auto& [tvv, tt] : t->texts) known += (known.empty() ? "" : ", ") + q(tt);
          error(q(d->name) + " = " + q(text) + ": not a number" +
                (known.empty() ? std::string() : " nor one of " + known));
          v = d->default_value;
          continue;
        }
        v = *tv;
      }
      source = "value";
    }
    if (auto why = value_error(*d, v); !why.empty()) {
      error(q(d->name) + " " + source + " " + std::to_string(v) + ": " + why);
      // A rejected override leaves the parameter at its default.
      if (source == "default" || !value_error(*d, d->default_value).empty()) continue;
      v = d->default_value;
    }
    put(r.bytes, static_cast<std::size_t>(ref.offset), *d, v);
  }

  for (const auto& o : ovs) {
    if (o.used) continue;
    const bool defined =
        std::any_of(model.ext_user_prm_data.begin(), model.ext_user_prm_data.end(),
                    [&](const ExtUserPrmData& d) {
                      return iequals(detail::trim(d.name), detail::trim(o.ov->name));
                    });
    error(q(o.ov->name) + (defined ? ": not referenced by these parameter bytes"
                                   : ": no such parameter (ExtUserPrmData name)"));
  }
  return r;
}

}  // namespace

std::pair<std::int64_t, std::int64_t> type_limits(const ExtUserPrmData& d) {
  switch (d.type) {
    case PrmType::Unsigned8:
      return {0, 0xFF};
    case PrmType::Unsigned16:
      return {0, 0xFFFF};
    case PrmType::Unsigned32:
      return {0, 0xFFFFFFFFLL};
    case PrmType::Signed8:
      return {-128, 127};
    case PrmType::Signed16:
      return {-32768, 32767};
    case PrmType::Signed32:
      return {-2147483648LL, 2147483647LL};
    case PrmType::Bit:
      return {0, 1};
    case PrmType::BitArea: {
      if (!bits_valid(d)) return {0, 0};
      return {0, (1LL << (d.last_bit - d.first_bit + 1)) - 1};
    }
  }
  return {0, 0};
}

std::string value_error(const ExtUserPrmData& d, std::int64_t v) {
  const auto [lo, hi] = type_limits(d);
  if (v < lo || v > hi)
    return "outside what " + std::string(to_string(d.type)) + " holds (" + std::to_string(lo) +
           ".." + std::to_string(hi) + ")";
  if (!d.allows(v))
    return (d.min ? "outside the range " : "not in the allowed values ") + d.range_text();
  return "";
}

std::optional<PrmOverride> parse_override(std::string_view text, const Model* model) {
  auto unquote = [](std::string_view v) {
    v = detail::trim(v);
    if (v.size() >= 2 && v.front() == '"' && v.back() == '"') v = v.substr(1, v.size() - 2);
    return v;
  };
  std::size_t eq = std::string_view::npos;
  if (model) {  // the longest known name that is followed by '='
    std::size_t best = 0;
    const std::string_view t = detail::trim(text);
    const std::size_t lead = static_cast<std::size_t>(t.data() - text.data());
    for (const auto& d : model->ext_user_prm_data) {
      const std::string_view name = detail::trim(d.name);
      for (const std::size_t skip : {std::size_t{0}, std::size_t{1}}) {  // optional '"'
        if (skip && (t.empty() || t.front() != '"')) continue;
        if (name.empty() || t.size() < skip + name.size() ||
            !iequals(t.substr(skip, name.size()), name))
          continue;
        std::size_t p = skip + name.size();
        if (skip && p < t.size() && t[p] == '"') ++p;
        while (p < t.size() && (t[p] == ' ' || t[p] == '\t')) ++p;
        if (p < t.size() && t[p] == '=' && name.size() > best) {
          best = name.size();
          eq = lead + p;
        }
      }
    }
  }
  if (eq == std::string_view::npos) {  // the last '=' outside quotes
    bool q = false;
    for (std::size_t i = 0; i < text.size(); ++i) {
      if (text[i] == '"') q = !q;
      if (!q && text[i] == '=') eq = i;
    }
  }
  if (eq == std::string_view::npos) return std::nullopt;
  PrmOverride o;
  o.name = std::string(unquote(text.substr(0, eq)));
  if (o.name.empty()) return std::nullopt;
  const std::string_view v = unquote(text.substr(eq + 1));
  detail::Scanner sc(v);
  auto n = sc.number(true);
  sc.ws();
  if (n && sc.eof())
    o.value = *n;
  else
    o.value = std::string(v);
  return o;
}

EncodeResult encode_user_prm(const Model& model, std::span<const PrmOverride> overrides) {
  const auto legacy = model.user_prm_data();
  const auto len = model.limits().user_prm_data_len.value_or(0);
  return encode(model, model.user_prm, legacy ? &*legacy : nullptr,
                static_cast<std::size_t>(std::clamp<std::int64_t>(len, 0, kMaxUserPrmLen)),
                overrides, "");
}

EncodeResult encode_module_prm(const Model& model, const Module& module,
                               std::span<const PrmOverride> overrides) {
  const auto len = module.ext_module_prm_data_len.value_or(0);
  return encode(model, module.prm, nullptr,
                static_cast<std::size_t>(std::clamp<std::int64_t>(len, 0, kMaxUserPrmLen)),
                overrides, "Module \"" + module.name + "\": ");
}

}  // namespace candp2::gsd
