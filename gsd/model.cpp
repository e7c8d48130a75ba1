// Model accessors.
#include <algorithm>
#include <array>

#include "gsd/gsd.hpp"
#include "gsd/text.hpp"

namespace candp2::gsd {

std::string_view to_string(PrmType t) {
  switch (t) {
    case PrmType::Unsigned8:
      return "Unsigned8";
    case PrmType::Unsigned16:
      return "Unsigned16";
    case PrmType::Unsigned32:
      return "Unsigned32";
    case PrmType::Signed8:
      return "Signed8";
    case PrmType::Signed16:
      return "Signed16";
    case PrmType::Signed32:
      return "Signed32";
    case PrmType::Bit:
      return "Bit";
    case PrmType::BitArea:
      return "BitArea";
  }
  return "?";
}

const std::string* PrmText::text_for(std::int64_t value) const {
  for (const auto& [v, t] : texts)
    if (v == value) return &t;
  return nullptr;
}

std::optional<std::int64_t> PrmText::value_for(std::string_view text) const {
  text = detail::trim(text);
  for (const auto& [v, t] : texts)
    if (iequals(detail::trim(t), text)) return v;
  return std::nullopt;
}

std::size_t ExtUserPrmData::size() const {
  switch (type) {
    case PrmType::Unsigned16:
    case PrmType::Signed16:
      return 2;
    case PrmType::Unsigned32:
    case PrmType::Signed32:
      return 4;
    default:
      return 1;
  }
}

bool ExtUserPrmData::allows(std::int64_t v) const {
  if (min && max) return *min <= v && v <= *max;
  if (!allowed.empty()) return std::find(allowed.begin(), allowed.end(), v) != allowed.end();
  return true;
}

std::string ExtUserPrmData::range_text() const {
  // Appended piece by piece: GCC 12 at -O3 reports a false -Wrestrict inside libstdc++ for
  // `const char* + std::string` (GCC bug 105329), which would stop a -Werror build.
  std::string out;
  if (min && max) {
    out = std::to_string(*min);
    out += '-';
    out += std::to_string(*max);
    return out;
  }
  for (auto v : allowed) {
    if (!out.empty()) out += ',';
    out += std::to_string(v);
  }
  return out;
}

const Setting* Model::find(std::string_view key) const {
  for (const auto& s : settings)
    if (!s.index && iequals(s.key, key)) return &s;
  return nullptr;
}

const Setting* Model::find(std::string_view key, std::int64_t index) const {
  for (const auto& s : settings)
    if (s.index && *s.index == index && iequals(s.key, key)) return &s;
  return nullptr;
}

std::optional<std::int64_t> Model::number(std::string_view key) const {
  const Setting* s = find(key);
  if (s && s->value.kind == Value::Kind::Number) return s->value.number;
  return std::nullopt;
}

std::optional<std::string> Model::string(std::string_view key) const {
  const Setting* s = find(key);
  if (s && (s->value.kind == Value::Kind::String || s->value.kind == Value::Kind::Text))
    return s->value.text;
  return std::nullopt;
}

std::string Model::vendor_name() const {
  return string("Vendor_Name").value_or("");
}
std::string Model::model_name() const {
  return string("Model_Name").value_or("");
}
std::optional<std::int64_t> Model::ident_number() const {
  return number("Ident_Number");
}
std::optional<std::int64_t> Model::gsd_revision() const {
  return number("GSD_Revision");
}

Limits Model::limits() const {
  Limits l;
  l.max_module = number("Max_Module");
  l.max_input_len = number("Max_Input_Len");
  l.max_output_len = number("Max_Output_Len");
  l.max_data_len = number("Max_Data_Len");
  l.max_user_prm_data_len = number("Max_User_Prm_Data_Len");
  l.user_prm_data_len = number("User_Prm_Data_Len");
  l.max_diag_data_len = number("Max_Diag_Data_Len");
  l.min_slave_intervall = number("Min_Slave_Intervall");
  l.modul_offset = number("Modul_Offset");
  l.modular_station = number("Modular_Station").value_or(0) != 0;
  return l;
}

std::optional<std::vector<std::uint8_t>> Model::user_prm_data() const {
  const Setting* s = find("User_Prm_Data");
  if (!s) return std::nullopt;
  std::vector<std::uint8_t> out;
  if (s->value.kind == Value::Kind::Number && s->value.number >= 0 && s->value.number <= 0xFF)
    out.push_back(static_cast<std::uint8_t>(s->value.number));
  for (auto n : s->value.numbers)
    if (n >= 0 && n <= 0xFF) out.push_back(static_cast<std::uint8_t>(n));
  return out;
}

const PrmText* Model::prm_text(std::int64_t ref) const {
  for (const auto& t : prm_texts)
    if (t.ref == ref) return &t;
  return nullptr;
}

const ExtUserPrmData* Model::ext_user_prm(std::int64_t ref) const {
  for (const auto& d : ext_user_prm_data)
    if (d.ref == ref) return &d;
  return nullptr;
}

const Module* Model::module(std::string_view name) const {
  name = detail::trim(name);
  for (const auto& m : modules)
    if (iequals(detail::trim(m.name), name)) return &m;
  return nullptr;
}

std::string display_name(std::string_view name) {
  return to_utf8(detail::trim(name));
}

std::vector<std::size_t> Model::preset_modules() const {
  std::vector<std::size_t> out;
  for (std::size_t i = 0; i < modules.size(); ++i)
    if (modules[i].preset) out.push_back(i);
  return out;
}

bool Model::fix_preset_modules() const {
  return number("FixPresetModules").value_or(0) != 0;
}

namespace {
struct RateName {
  std::uint32_t baud;
  std::string_view name;
};
constexpr RateName kRateNames[] = {{9600, "9.6"},    {19200, "19.2"},   {31250, "31.25"},
                                   {45450, "45.45"}, {93750, "93.75"},  {187500, "187.5"},
                                   {500000, "500"},  {1500000, "1.5M"}, {3000000, "3M"},
                                   {6000000, "6M"},  {12000000, "12M"}};
}  // namespace

std::span<const std::uint32_t> gsd_rates() {
  static constexpr auto kRates = [] {
    std::array<std::uint32_t, std::size(kRateNames)> out{};
    for (std::size_t i = 0; i < out.size(); ++i) out[i] = kRateNames[i].baud;
    return out;
  }();
  return kRates;
}

std::optional<std::string_view> rate_name(std::uint32_t baud) {
  for (const auto& r : kRateNames)
    if (r.baud == baud) return r.name;
  return std::nullopt;
}

bool supports_rate(const Model& m, std::uint32_t baud) {
  const auto n = rate_name(baud);
  return n && m.number(std::string(*n) + "_supp").value_or(0) != 0;
}

std::optional<std::uint32_t> max_tsdr(const Model& m, std::uint32_t baud) {
  const auto n = rate_name(baud);
  if (!n) return std::nullopt;
  const auto v = m.number("MaxTsdr_" + std::string(*n));
  if (!v || *v < 0 || *v > 0xFFFF) return std::nullopt;
  return static_cast<std::uint32_t>(*v);
}

}  // namespace candp2::gsd
