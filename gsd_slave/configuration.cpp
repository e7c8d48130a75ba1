#include "gsd_slave/configuration.hpp"

#include <algorithm>

#include "common/hex.hpp"

namespace candp2::gsd_slave {

Configuration configuration_of(std::vector<const gsd::Module*> modules) {
  Configuration c;
  for (const gsd::Module* m : modules)
    c.bytes.insert(c.bytes.end(), m->config.begin(), m->config.end());
  c.modules = std::move(modules);
  c.decoded = gsd::decode_config(c.bytes);
  return c;
}

Configuration configuration_of(std::vector<std::uint8_t> bytes) {
  Configuration c;
  c.bytes = std::move(bytes);
  c.decoded = gsd::decode_config(c.bytes);
  return c;
}

namespace {

std::string preset_list(const gsd::Model& m, std::span<const std::size_t> presets) {
  std::string out;
  for (std::size_t i : presets) {
    if (!out.empty()) out += ", ";
    out += '"' + gsd::display_name(m.modules[i].name) + '"';
  }
  return out;
}

}  // namespace

WithPresets with_presets(const gsd::Model& m, std::span<const std::size_t> user) {
  const std::vector<std::size_t> presets = m.preset_modules();
  auto is_preset = [&](std::size_t i) { return m.modules[i].preset; };
  WithPresets out;
  if (std::none_of(user.begin(), user.end(), is_preset)) {
    // A new configuration: the tool puts the preset modules in first.
    out.modules = presets;
    out.added = presets.size();
    out.modules.insert(out.modules.end(), user.begin(), user.end());
    return out;
  }
  out.modules.assign(user.begin(), user.end());
  if (!m.fix_preset_modules()) return out;  // moving or removing them is allowed
  const std::string rule =
      " (FixPresetModules = 1): the preset modules stand first, in GSD order (" +
      preset_list(m, presets) + "); list them so, or leave them out of the list and they are added";
  const std::size_t k = presets.size();
  for (std::size_t i = 0; i < std::max(user.size(), k); ++i) {
    if (i < k && i < user.size() && user[i] == presets[i]) continue;
    if (i >= k && !is_preset(user[i])) continue;
    // Out of place from here: a preset module listed from here on was moved (or repeated);
    // when none is, the one due here was removed.
    for (std::size_t j = i; j < user.size(); ++j) {
      if (!is_preset(user[j])) continue;
      const auto slot = std::find(presets.begin(), presets.end(), user[j]) - presets.begin();
      // Appended piece by piece: literal + std::string trips GCC 12's false -Wrestrict at -O3.
      std::string text = "\"";
      text += gsd::display_name(m.modules[user[j]].name);
      text += "\" is a fixed preset module: it belongs at slot " + std::to_string(slot) +
              " and cannot be moved" + rule;
      out.problem = PresetProblem{j, std::move(text)};
      return out;
    }
    std::string text = "the fixed preset module \"";
    text += gsd::display_name(m.modules[presets[i]].name);
    text += "\" is missing at slot " + std::to_string(i) + " and cannot be removed" + rule;
    out.problem = PresetProblem{std::min(i, user.size()), std::move(text)};
    return out;
  }
  return out;
}

std::optional<CfgProblem> check_limits(const Profile& p, const Configuration& c) {
  const std::size_t in = c.decoded.input_len, out = c.decoded.output_len;
  const std::size_t last = c.decoded.entries.empty() ? 0 : c.decoded.entries.size() - 1;
  if (p.max_module && c.module_count() > *p.max_module)
    return CfgProblem{*p.max_module, CfgCode::TooManyModules,
                      std::to_string(c.module_count()) + " modules, Max_Module is " +
                          std::to_string(*p.max_module)};
  if (p.max_input_len && in > *p.max_input_len)
    return CfgProblem{
        last, CfgCode::InputTooLong,
        std::to_string(in) + " input bytes, Max_Input_Len is " + std::to_string(*p.max_input_len)};
  if (p.max_output_len && out > *p.max_output_len)
    return CfgProblem{last, CfgCode::OutputTooLong,
                      std::to_string(out) + " output bytes, Max_Output_Len is " +
                          std::to_string(*p.max_output_len)};
  if (p.max_data_len && in + out > *p.max_data_len)
    return CfgProblem{last, CfgCode::DataTooLong,
                      std::to_string(in + out) + " input and output bytes, Max_Data_Len is " +
                          std::to_string(*p.max_data_len)};
  return std::nullopt;
}

std::optional<CfgProblem> check_chk_cfg(const Profile& profile, const Configuration& real,
                                        std::span<const std::uint8_t> chk_cfg) {
  const gsd::CfgDecode got = gsd::decode_config(chk_cfg);
  if (got.error) return CfgProblem{got.entries.size(), CfgCode::Malformed, "Chk_Cfg " + *got.error};
  if (!std::equal(chk_cfg.begin(), chk_cfg.end(), real.bytes.begin(), real.bytes.end())) {
    const auto& mine = real.decoded.entries;
    const auto& theirs = got.entries;
    for (std::size_t i = 0; i < std::max(mine.size(), theirs.size()); ++i) {
      if (i < mine.size() && i < theirs.size() && mine[i].bytes == theirs[i].bytes) continue;
      std::string text = "Chk_Cfg entry " + std::to_string(i) + ": ";
      if (i >= theirs.size())
        text += "missing, the slave has " + hex_bytes(mine[i].bytes) + " (" +
                gsd::describe(mine[i]) + ")";
      else if (i >= mine.size())
        text += hex_bytes(theirs[i].bytes) + " (" + gsd::describe(theirs[i]) +
                ") is one more than the slave's " + std::to_string(mine.size()) + " entries";
      else
        text += hex_bytes(theirs[i].bytes) + " (" + gsd::describe(theirs[i]) + "), the slave has " +
                hex_bytes(mine[i].bytes) + " (" + gsd::describe(mine[i]) + ")";
      return CfgProblem{i, CfgCode::Differs, text};
    }
  }
  return check_limits(profile, real);
}

}  // namespace candp2::gsd_slave
