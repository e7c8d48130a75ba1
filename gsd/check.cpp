#include "gsd/check.hpp"

#include <algorithm>
#include <map>

#include "common/hex.hpp"
#include "gsd/cfg.hpp"
#include "gsd/prm.hpp"
#include "gsd/text.hpp"

namespace candp2::gsd {

namespace {

// GSD spec limits (PNO GSD specification, DP keywords; IEC 61158-6-3 telegram sizes).
constexpr std::int64_t kMaxIoLen = 244;    // Max_Input_Len / Max_Output_Len
constexpr std::int64_t kMaxDataLen = 488;  // Max_Data_Len
constexpr std::int64_t kMinDiagLen = 6;    // Max_Diag_Data_Len: 6..244
constexpr std::int64_t kMaxDiagLen = 244;
constexpr std::size_t kMaxNameLen = 32;  // Vendor_Name, Model_Name, module names

// Baud-rate keywords and their MaxTsdr partners.
constexpr std::pair<std::string_view, std::string_view> kBauds[] = {
    {"9.6_supp", "MaxTsdr_9.6"},     {"19.2_supp", "MaxTsdr_19.2"},
    {"31.25_supp", "MaxTsdr_31.25"}, {"45.45_supp", "MaxTsdr_45.45"},
    {"93.75_supp", "MaxTsdr_93.75"}, {"187.5_supp", "MaxTsdr_187.5"},
    {"500_supp", "MaxTsdr_500"},     {"1.5M_supp", "MaxTsdr_1.5M"},
    {"3M_supp", "MaxTsdr_3M"},       {"6M_supp", "MaxTsdr_6M"},
    {"12M_supp", "MaxTsdr_12M"}};

std::string q(std::string_view s) {
  // Appended, not `"\"" + std::string(...)`: GCC 12 -O3 reports a false -Wrestrict inside
  // libstdc++ for a literal + std::string (GCC bug 105329).
  std::string out(1, '"');
  out += detail::trim(s);
  out += '"';
  return out;
}

class Checker {
 public:
  Checker(const Model& m, const DeviceReader* reader) : m_(m), reader_(reader) {}

  std::vector<Diagnostic> run() {
    mandatory();
    bauds();
    limits();
    prm_texts();
    ext_user_prm_data();
    layout(m_.user_prm, "", declared_user_len(), 0);
    legacy_user_prm();
    modules();
    presets();
    slots();
    areas();
    std::stable_sort(out_.begin(), out_.end(),
                     [](const Diagnostic& a, const Diagnostic& b) { return a.line < b.line; });
    return std::move(out_);
  }

 private:
  void err(int line, std::string msg) { out_.push_back({line, Severity::Error, std::move(msg)}); }
  void warn(int line, std::string msg) {
    out_.push_back({line, Severity::Warning, std::move(msg)});
  }
  int line_of(std::string_view key) const {
    const Setting* s = m_.find(key);
    return s ? s->line : 0;
  }

  void mandatory() {
    // GSD spec: keywords marked (M) for every DP slave.
    static constexpr std::string_view kMandatory[] = {
        "Vendor_Name",      "Model_Name",       "Revision",
        "Ident_Number",     "Protocol_Ident",   "Station_Type",
        "Hardware_Release", "Software_Release", "Min_Slave_Intervall"};
    for (auto k : kMandatory)
      if (!m_.find(k)) err(0, "mandatory keyword " + std::string(k) + " is missing");
    // GSD_Revision came with revision 1 of the GSD specification: files written before it (real
    // Siemens files of the 1990s) have none and are revision 0 (the summary says so).
    if (auto id = m_.ident_number(); id && (*id < 0 || *id > 0xFFFF))
      err(line_of("Ident_Number"), "Ident_Number " + std::to_string(*id) + " exceeds 0xFFFF");
    for (auto k : {"Vendor_Name", "Model_Name"})
      if (auto s = m_.string(k); s && s->size() > kMaxNameLen)
        warn(line_of(k),
             std::string(k) + " is longer than " + std::to_string(kMaxNameLen) + " characters");
    if (auto v = m_.number("Min_Slave_Intervall"); v && (*v < 1 || *v > 0xFFFF))
      err(line_of("Min_Slave_Intervall"), "Min_Slave_Intervall must be 1..65535 (x 100 us)");
  }

  void bauds() {
    bool any = false;
    for (const auto& [supp, tsdr] : kBauds) {
      if (m_.number(supp).value_or(0) == 0) continue;
      any = true;
      if (!m_.find(tsdr)) warn(line_of(supp), std::string(supp) + " without " + std::string(tsdr));
    }
    if (!any) err(0, "no supported baud rate (no *_supp keyword = 1)");
  }

  void limits() {
    const Limits l = m_.limits();
    if (l.modular_station) {
      // GSD spec: (M) for modular stations.
      if (!l.max_module) err(line_of("Modular_Station"), "modular station without Max_Module");
      if (!l.max_input_len)
        err(line_of("Modular_Station"), "modular station without Max_Input_Len");
      if (!l.max_output_len)
        err(line_of("Modular_Station"), "modular station without Max_Output_Len");
    } else if (m_.modules.size() != 1 && !m_.modules.empty()) {
      warn(line_of("Modular_Station"), "compact station (Modular_Station = 0) with " +
                                           std::to_string(m_.modules.size()) + " modules");
    }
    if (m_.modules.empty()) err(0, "no Module defined");
    auto range = [&](const char* key, const std::optional<std::int64_t>& v, std::int64_t lo,
                     std::int64_t hi) {
      if (v && (*v < lo || *v > hi))
        err(line_of(key), std::string(key) + " = " + std::to_string(*v) + " outside " +
                              std::to_string(lo) + ".." + std::to_string(hi));
    };
    range("Max_Module", l.max_module, 1, 244);
    range("Max_Input_Len", l.max_input_len, 0, kMaxIoLen);
    range("Max_Output_Len", l.max_output_len, 0, kMaxIoLen);
    range("Max_Data_Len", l.max_data_len, 0, kMaxDataLen);
    range("Max_User_Prm_Data_Len", l.max_user_prm_data_len, 0,
          static_cast<std::int64_t>(kMaxUserPrmLen));
    range("User_Prm_Data_Len", l.user_prm_data_len, 0, static_cast<std::int64_t>(kMaxUserPrmLen));
    range("Max_Diag_Data_Len", l.max_diag_data_len, kMinDiagLen, kMaxDiagLen);
    if (l.max_user_prm_data_len && l.user_prm_data_len &&
        *l.user_prm_data_len > *l.max_user_prm_data_len)
      err(line_of("User_Prm_Data_Len"),
          "User_Prm_Data_Len " + std::to_string(*l.user_prm_data_len) +
              " exceeds Max_User_Prm_Data_Len " + std::to_string(*l.max_user_prm_data_len));
    if (l.max_data_len && l.max_input_len && l.max_output_len &&
        *l.max_data_len > *l.max_input_len + *l.max_output_len)
      warn(line_of("Max_Data_Len"), "Max_Data_Len exceeds Max_Input_Len + Max_Output_Len");
  }

  void prm_texts() {
    std::map<std::int64_t, int> seen;
    for (const auto& t : m_.prm_texts) {
      auto [it, fresh] = seen.emplace(t.ref, t.line);
      if (!fresh)
        err(t.line, "PrmText " + std::to_string(t.ref) + " defined twice (first at line " +
                        std::to_string(it->second) + ")");
      if (t.texts.empty()) warn(t.line, "PrmText " + std::to_string(t.ref) + " has no Text");
    }
  }

  void ext_user_prm_data() {
    std::map<std::int64_t, int> seen;
    for (const auto& d : m_.ext_user_prm_data) {
      const std::string name = "ExtUserPrmData " + std::to_string(d.ref) + " " + q(d.name);
      auto [it, fresh] = seen.emplace(d.ref, d.line);
      if (!fresh)
        err(d.line, name + " defined twice (first at line " + std::to_string(it->second) + ")");
      if (d.type == PrmType::Bit && (d.first_bit < 0 || d.first_bit > 7)) {
        err(d.line, name + ": Bit(" + std::to_string(d.first_bit) + ") outside 0..7");
        continue;
      }
      if (d.type == PrmType::BitArea &&
          (d.first_bit < 0 || d.last_bit > 7 || d.first_bit > d.last_bit)) {
        err(d.line, name + ": BitArea(" + std::to_string(d.first_bit) + "-" +
                        std::to_string(d.last_bit) + ") is not within 0..7 in ascending order");
        continue;
      }
      const auto [lo, hi] = type_limits(d);
      if (d.min && d.max) {
        if (*d.min > *d.max) err(d.line, name + ": range " + d.range_text() + " is reversed");
        if (*d.min < lo || *d.max > hi)
          err(d.line, name + ": range " + d.range_text() + " exceeds what " +
                          std::string(to_string(d.type)) + " holds (" + std::to_string(lo) + ".." +
                          std::to_string(hi) + ")");
      }
      for (auto v : d.allowed)
        if (v < lo || v > hi)
          err(d.line, name + ": allowed value " + std::to_string(v) + " exceeds what " +
                          std::string(to_string(d.type)) + " holds");
      if (auto why = value_error(d, d.default_value); !why.empty())
        err(d.line, name + ": default " + std::to_string(d.default_value) + " " + why);
      if (d.prm_text_ref) {
        const PrmText* t = m_.prm_text(*d.prm_text_ref);
        if (!t)
          err(d.line, name + ": Prm_Text_Ref = " + std::to_string(*d.prm_text_ref) +
                          " refers to an undefined PrmText");
        else if (!t->text_for(d.default_value))
          warn(d.line, name + ": default " + std::to_string(d.default_value) +
                           " has no Text in PrmText " + std::to_string(t->ref));
      }
    }
  }

  // Ext_User_Prm_Data_* must fit in Max_User_Prm_Data_Len (GSD spec); where only
  // User_Prm_Data_Len is given, in that.
  std::optional<std::int64_t> declared_user_len() const {
    const Limits l = m_.limits();
    return l.max_user_prm_data_len ? l.max_user_prm_data_len : l.user_prm_data_len;
  }

  void layout(const PrmLayout& lay, const std::string& where, std::optional<std::int64_t> len,
              int owner_line) {
    const Limits lim = m_.limits();
    const char* len_name = !where.empty()              ? "Ext_Module_Prm_Data_Len"
                           : lim.max_user_prm_data_len ? "Max_User_Prm_Data_Len"
                                                       : "User_Prm_Data_Len";
    std::int64_t total = 0;
    for (const auto& c : lay.consts) {
      const std::int64_t end = c.offset + static_cast<std::int64_t>(c.bytes.size());
      total = std::max(total, end);
      if (len && end > *len)
        err(c.line, where + "Ext_User_Prm_Data_Const(" + std::to_string(c.offset) +
                        ") ends at byte " + std::to_string(end) + ", beyond " + len_name + " = " +
                        std::to_string(*len));
    }
    if (!len && !lay.empty())
      warn(owner_line ? owner_line
                      : (lay.refs.empty() ? lay.consts.front().line : lay.refs.front().line),
           where + "parameter bytes without " + len_name);
    for (const auto& r : lay.refs)
      if (const ExtUserPrmData* d = m_.ext_user_prm(r.ref))
        total = std::max(total, r.offset + static_cast<std::int64_t>(d->size()));
    // Masters without Ext_User_Prm_Data support send User_Prm_Data_Len bytes instead.
    if (where.empty() && lim.max_user_prm_data_len && lim.user_prm_data_len &&
        total > *lim.user_prm_data_len && (!len || total <= *len))
      warn(line_of("User_Prm_Data_Len"),
           "the Ext_User_Prm_Data parameter bytes are " + std::to_string(total) +
               " long, User_Prm_Data_Len says " + std::to_string(*lim.user_prm_data_len));
    for (const auto& r : lay.refs) {
      const ExtUserPrmData* d = m_.ext_user_prm(r.ref);
      const std::string at = where + "Ext_User_Prm_Data_Ref(" + std::to_string(r.offset) + ")";
      if (!d) {
        err(r.line, at + " = " + std::to_string(r.ref) + " refers to an undefined ExtUserPrmData");
        continue;
      }
      const std::int64_t end = r.offset + static_cast<std::int64_t>(d->size());
      if (len && end > *len)
        err(r.line, at + " " + q(d->name) + " ends at byte " + std::to_string(end) + ", beyond " +
                        len_name + " = " + std::to_string(*len));
    }
    // Two references writing the same bits.
    for (std::size_t i = 0; i < lay.refs.size(); ++i) {
      const ExtUserPrmData* a = m_.ext_user_prm(lay.refs[i].ref);
      if (!a) continue;
      for (std::size_t j = i + 1; j < lay.refs.size(); ++j) {
        const ExtUserPrmData* b = m_.ext_user_prm(lay.refs[j].ref);
        if (!b || !overlap(lay.refs[i].offset, *a, lay.refs[j].offset, *b)) continue;
        warn(lay.refs[j].line, where + q(b->name) + " overlaps " + q(a->name) + " (line " +
                                   std::to_string(lay.refs[i].line) + ")");
      }
    }
  }

  static std::uint64_t bit_mask(std::int64_t offset, const ExtUserPrmData& d, std::int64_t base) {
    // Bits the value occupies, relative to byte `base`, as a 64-bit window.
    std::uint64_t mask = 0;
    const std::int64_t rel = offset - base;
    if (rel < 0 || rel >= 8) return 0;
    if (d.type == PrmType::Bit || d.type == PrmType::BitArea) {
      if (d.first_bit < 0 || d.last_bit > 7 || d.first_bit > d.last_bit) return 0;
      const unsigned width = static_cast<unsigned>(d.last_bit - d.first_bit + 1);
      mask = ((1ull << width) - 1) << d.first_bit;
      return mask << (8 * rel);
    }
    for (std::size_t i = 0; i < d.size() && rel + static_cast<std::int64_t>(i) < 8; ++i)
      mask |= 0xFFull << (8 * (rel + static_cast<std::int64_t>(i)));
    return mask;
  }

  static bool overlap(std::int64_t oa, const ExtUserPrmData& a, std::int64_t ob,
                      const ExtUserPrmData& b) {
    const std::int64_t base = std::min(oa, ob);
    if (std::max(oa, ob) - base >= 4) return false;
    return (bit_mask(oa, a, base) & bit_mask(ob, b, base)) != 0;
  }

  void legacy_user_prm() {
    const auto legacy = m_.user_prm_data();
    const Limits l = m_.limits();
    if (legacy && l.user_prm_data_len &&
        static_cast<std::int64_t>(legacy->size()) != *l.user_prm_data_len)
      err(line_of("User_Prm_Data"), "User_Prm_Data has " + std::to_string(legacy->size()) +
                                        " bytes, User_Prm_Data_Len says " +
                                        std::to_string(*l.user_prm_data_len));
    if (!legacy || m_.user_prm.empty()) return;
    // What a master using only Ext_User_Prm_Data_* sends, against the legacy bytes.
    Model modern = m_;
    modern.settings.erase(
        std::remove_if(modern.settings.begin(), modern.settings.end(),
                       [](const Setting& s) { return iequals(s.key, "User_Prm_Data"); }),
        modern.settings.end());
    const EncodeResult enc = encode_user_prm(modern);
    for (std::size_t i = 0; i < std::min(legacy->size(), enc.bytes.size()); ++i) {
      if ((*legacy)[i] == enc.bytes[i]) continue;
      warn(line_of("User_Prm_Data"),
           "User_Prm_Data byte " + std::to_string(i) + " is " + hex_bytes({&(*legacy)[i], 1}) +
               ", the Ext_User_Prm_Data defaults give " + hex_bytes({&enc.bytes[i], 1}));
      break;
    }
  }

  void modules() {
    const Limits l = m_.limits();
    const bool device = reader_ && reader_->applies(m_.ident_number());
    std::map<std::int64_t, int> refs;
    for (const auto& mod : m_.modules) {
      const std::string name = "Module " + q(mod.name);
      if (detail::trim(mod.name).size() > kMaxNameLen)
        warn(mod.line, name + ": name longer than " + std::to_string(kMaxNameLen) + " characters");
      if (mod.reference) {
        auto [it, fresh] = refs.emplace(*mod.reference, mod.line);
        if (!fresh)
          err(mod.line, name + ": reference number " + std::to_string(*mod.reference) +
                            " already used at line " + std::to_string(it->second));
      }
      if (mod.config.empty()) continue;  // reported by the parser
      const CfgDecode dec = decode_config(mod.config);
      if (dec.error) {
        err(mod.line, name + ": malformed configuration: " + *dec.error);
        continue;
      }
      if (l.max_input_len && static_cast<std::int64_t>(dec.input_len) > *l.max_input_len)
        err(mod.line, name + ": " + std::to_string(dec.input_len) +
                          " input bytes exceed Max_Input_Len " + std::to_string(*l.max_input_len));
      if (l.max_output_len && static_cast<std::int64_t>(dec.output_len) > *l.max_output_len)
        err(mod.line, name + ": " + std::to_string(dec.output_len) +
                          " output bytes exceed Max_Output_Len " +
                          std::to_string(*l.max_output_len));
      if (l.max_data_len &&
          static_cast<std::int64_t>(dec.input_len + dec.output_len) > *l.max_data_len)
        err(mod.line, name + ": data exceeds Max_Data_Len " + std::to_string(*l.max_data_len));
      if (device && !is_universal_module(mod.config)) {
        for (const auto& e : dec.entries) {
          const EntryVerdict v = reader_->read(e);
          if (v.problem)
            err(mod.line, name + ": the " + reader_->device + " rejects this entry (" + *v.problem +
                              "; " + reader_->rules + ")");
        }
      }
      if (!mod.prm.empty() || mod.ext_module_prm_data_len)
        layout(mod.prm, name + ": ", mod.ext_module_prm_data_len, mod.line);
    }
  }

  // Preset / FixPresetModules (docs/gsd.md "Preset modules").
  void presets() {
    const auto fix = m_.number("FixPresetModules");
    const int fix_line = line_of("FixPresetModules");
    if (fix && *fix != 0 && *fix != 1)
      err(fix_line, "FixPresetModules expects 0 or 1, found " + std::to_string(*fix));
    const auto presets = m_.preset_modules();
    if (m_.fix_preset_modules() && presets.empty())
      warn(fix_line, "FixPresetModules = 1, but no module has Preset = 1");
    const Limits l = m_.limits();
    if (l.max_module && static_cast<std::int64_t>(presets.size()) > *l.max_module)
      err(m_.modules[presets[static_cast<std::size_t>(*l.max_module)]].line,
          std::to_string(presets.size()) + " modules have Preset = 1, more than Max_Module " +
              std::to_string(*l.max_module) + ": no configuration can hold them");
  }

  void slots() {
    std::map<std::int64_t, int> seen;
    for (const auto& s : m_.slots) {
      auto [it, fresh] = seen.emplace(s.number, s.line);
      if (!fresh)
        err(s.line, "Slot(" + std::to_string(s.number) + ") defined twice (first at line " +
                        std::to_string(it->second) + ")");
      auto known = [&](std::int64_t ref) {
        return std::any_of(m_.modules.begin(), m_.modules.end(),
                           [&](const Module& m) { return m.reference == ref; });
      };
      if (!known(s.default_ref))
        err(s.line, "Slot(" + std::to_string(s.number) + "): default module reference " +
                        std::to_string(s.default_ref) + " is not defined");
      for (auto r : s.allowed)
        if (!known(r))
          err(s.line, "Slot(" + std::to_string(s.number) + "): module reference " +
                          std::to_string(r) + " is not defined");
      if (s.min && s.max && *s.min > *s.max)
        err(s.line, "Slot(" + std::to_string(s.number) + "): range is reversed");
    }
  }

  void areas() {
    for (const auto& a : m_.unit_diag_areas)
      if (a.first > a.last)
        err(a.line, "Unit_Diag_Area " + std::to_string(a.first) + "-" + std::to_string(a.last) +
                        " is reversed");
  }

  const Model& m_;
  const DeviceReader* reader_;
  std::vector<Diagnostic> out_;
};

}  // namespace

std::vector<Diagnostic> check(const Model& model, const DeviceReader* reader) {
  return Checker(model, reader).run();
}

}  // namespace candp2::gsd
