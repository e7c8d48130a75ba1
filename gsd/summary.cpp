#include "gsd/summary.hpp"

#include <algorithm>
#include <cstdio>
#include <sstream>

#include "common/hex.hpp"
#include "gsd/cfg.hpp"
#include "gsd/prm.hpp"
#include "gsd/text.hpp"

namespace candp2::gsd {

namespace {

// Pads to `width` characters (UTF-8 continuation bytes do not count).
std::string pad(std::string s, std::size_t width) {
  std::size_t chars = 0;
  for (char c : s) chars += (static_cast<unsigned char>(c) & 0xC0) != 0x80;
  if (chars < width) s.append(width - chars, ' ');
  return s;
}

std::string shown(std::string_view s) {
  return to_utf8(detail::trim(s));
}

// Up to 16 bytes inline; longer dumps continue on indented lines of 16 bytes.
std::string hex_block(const std::vector<std::uint8_t>& b, const std::string& indent) {
  if (b.empty()) return "(none)";
  std::string out;
  for (std::size_t i = 0; i < b.size(); i += 16) {
    const std::size_t n = std::min<std::size_t>(16, b.size() - i);
    if (i) out += "\n" + indent;
    out += hex_bytes(std::span<const std::uint8_t>(b.data() + i, n));
  }
  return out;
}

std::string position(std::int64_t offset, const ExtUserPrmData* d) {
  std::string s = "byte " + std::to_string(offset);
  if (!d) return s;
  if (d->size() > 1) s += ".." + std::to_string(offset + static_cast<std::int64_t>(d->size()) - 1);
  if (d->type == PrmType::Bit) s += " bit " + std::to_string(d->first_bit);
  if (d->type == PrmType::BitArea)
    s += " bits " + std::to_string(d->first_bit) + "-" + std::to_string(d->last_bit);
  return s;
}

void parameters(std::ostringstream& os, const Model& m, const PrmLayout& lay,
                const EncodeResult& enc, const std::string& indent) {
  for (const auto& r : lay.refs) {
    const ExtUserPrmData* d = m.ext_user_prm(r.ref);
    os << indent << pad(position(r.offset, d), 16);
    if (!d) {
      os << "(undefined ExtUserPrmData " << r.ref << ")\n";
      continue;
    }
    std::string value = std::to_string(d->default_value);
    if (d->prm_text_ref)
      if (const PrmText* t = m.prm_text(*d->prm_text_ref))
        if (const std::string* txt = t->text_for(d->default_value); txt && !shown(*txt).empty())
          value += " \"" + shown(*txt) + "\"";
    os << pad(shown(d->name), 34) << ' ' << pad(value, 18) << " [" << to_string(d->type) << ' '
       << d->range_text() << "]\n";
  }
  for (const auto& e : enc.errors) os << indent << "! " << to_utf8(e) << '\n';
}

}  // namespace

std::string summary(const Model& m, const DeviceReader* reader) {
  std::ostringstream os;
  os << shown(m.vendor_name()) << ' ' << shown(m.model_name()) << '\n';
  auto line = [&](const char* label, const std::string& value) {
    if (!value.empty()) os << "  " << pad(label, 22) << value << '\n';
  };
  if (auto id = m.ident_number()) {
    char buf[24];
    std::snprintf(buf, sizeof buf, "0x%04llX", static_cast<unsigned long long>(*id));
    line("Ident_Number", buf);
  }
  if (auto r = m.gsd_revision())
    line("GSD_Revision", std::to_string(*r));
  else
    line("GSD_Revision", "0 (no GSD_Revision keyword: a revision 0 file)");
  std::string rev = shown(m.string("Revision").value_or(""));
  const std::string hw = shown(m.string("Hardware_Release").value_or(""));
  const std::string sw = shown(m.string("Software_Release").value_or(""));
  if (!hw.empty() || !sw.empty()) rev += " (hardware " + hw + ", software " + sw + ")";
  line("Revision", rev);
  std::string bauds;
  for (const auto baud : gsd_rates())
    if (supports_rate(m, baud)) {
      // Appended piece by piece: literal + std::string trips GCC 12's false -Wrestrict at -O3.
      if (!bauds.empty()) bauds += ' ';
      bauds += *rate_name(baud);
      if (baud < 1'000'000) bauds += 'k';  // "9.6k" .. "500k", then "1.5M" .. "12M"
    }
  line("Baud rates", bauds.empty() ? "(none)" : bauds);

  const Limits l = m.limits();
  auto opt = [](const char* key, const std::optional<std::int64_t>& v) {
    return v ? std::string(key) + " " + std::to_string(*v) : std::string();
  };
  auto join = [](std::initializer_list<std::string> parts) {
    std::string s;
    for (const auto& p : parts)
      if (!p.empty()) s += (s.empty() ? "" : ", ") + p;
    return s;
  };
  line("Station", join({l.modular_station ? "modular" : "compact", opt("Max_Module", l.max_module),
                        opt("Modul_Offset", l.modul_offset)}));
  line("Data limits",
       join({opt("Max_Input_Len", l.max_input_len), opt("Max_Output_Len", l.max_output_len),
             opt("Max_Data_Len", l.max_data_len)}));
  line("Parameter limits", join({opt("Max_User_Prm_Data_Len", l.max_user_prm_data_len),
                                 opt("User_Prm_Data_Len", l.user_prm_data_len)}));
  line("Diagnosis", opt("Max_Diag_Data_Len", l.max_diag_data_len));
  if (l.min_slave_intervall)
    line("Min_Slave_Intervall", std::to_string(*l.min_slave_intervall) + " (" +
                                    std::to_string(*l.min_slave_intervall * 100) + " us)");

  const EncodeResult enc = encode_user_prm(m);
  os << "\nUser parameters: " << enc.bytes.size() << " bytes, defaults "
     << hex_block(enc.bytes, "    ") << '\n';
  parameters(os, m, m.user_prm, enc, "  ");

  os << "\nModules: " << m.modules.size() << '\n';
  if (const auto presets = m.preset_modules(); !presets.empty())
    os << "  " << presets.size() << " with Preset = 1, put first into every configuration"
       << (m.fix_preset_modules() ? " and fixed there (FixPresetModules = 1)" : "") << '\n';
  const bool device = reader && reader->applies(m.ident_number());
  for (const auto& mod : m.modules) {
    std::string quoted(1, '"');  // not `"\"" + ...`: GCC 12's false -Wrestrict at -O3
    quoted += shown(mod.name);
    quoted += '"';
    os << "  " << pad(std::move(quoted), 36) << ' ' << hex_bytes(mod.config);
    if (mod.reference) os << "  (ref " << *mod.reference << ")";
    if (mod.preset) os << "  (preset)";
    os << '\n';
    if (is_universal_module(mod.config)) {
      os << "      universal module: type, length and comment bytes are set in the "
            "configuration tool\n";
      continue;
    }
    const CfgDecode dec = decode_config(mod.config);
    for (const auto& e : dec.entries) {
      os << "      " << describe(e) << '\n';
      if (device) {
        const EntryVerdict v = reader->read(e);
        os << "      " << reader->device << ": " << (v.problem ? "rejected, " + *v.problem : v.text)
           << '\n';
      }
    }
    if (dec.error) os << "      ! malformed: " << *dec.error << '\n';
    if (!mod.prm.empty() || mod.ext_module_prm_data_len) {
      const EncodeResult me = encode_module_prm(m, mod);
      os << "      parameters: " << me.bytes.size() << " bytes, defaults "
         << hex_block(me.bytes, "        ") << '\n';
      parameters(os, m, mod.prm, me, "        ");
    }
  }
  if (!m.slots.empty()) os << "\nSlot definitions: " << m.slots.size() << '\n';
  if (!m.unit_diag_bits.empty() || !m.unit_diag_areas.empty())
    os << "\nUnit diagnosis: " << m.unit_diag_bits.size() << " bit texts, "
       << m.unit_diag_areas.size() << " areas\n";
  return os.str();
}

}  // namespace candp2::gsd
