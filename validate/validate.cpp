#include "validate/validate.hpp"

#include <cstdio>

#include "can/channel.hpp"
#include "gateway/cfg_reading.hpp"
#include "gateway/gateway.hpp"
#include "gsd/cfg.hpp"
#include "validate/text.hpp"

namespace candp2::validate {

std::string_view to_string(WarningKind k) {
  switch (k) {
    case WarningKind::AddressClamped:
      return "address-clamped";
    case WarningKind::DuplicateRx:
      return "duplicate-rx";
    case WarningKind::DuplicateTx:
      return "duplicate-tx";
    case WarningKind::InputCycle:
      return "input-cycle";
    case WarningKind::Overlap:
      return "overlap";
    case WarningKind::GsdEncoding:
      return "gsd-encoding";
    case WarningKind::Line:
      return "line";
  }
  return "?";
}

void format_warnings(std::ostream& os, const std::vector<Warning>& own,
                     const std::vector<Warning>& line) {
  os << "  warnings:";
  if (own.empty() && line.empty()) os << " none";
  os << "\n";
  for (const auto* list : {&own, &line})
    for (const auto& w : *list)
      os << "    " << (w.error ? "error: " : "") << w.json_path << ": " << w.message << "\n";
}

nlohmann::ordered_json warnings_json(const std::vector<Warning>& own,
                                     const std::vector<Warning>& line) {
  auto w = nlohmann::ordered_json::array();
  for (const auto* list : {&own, &line})
    for (const auto& x : *list)
      if (!x.error)
        w.push_back(
            {{"kind", to_string(x.kind)}, {"json_path", x.json_path}, {"message", x.message}});
  return w;
}

std::string prm_byte_name(std::size_t b) {
  // DP standard part (EN 50170 DDLM_Set_Prm) and docs/dp-slave.md "User parameters" user bytes.
  static constexpr const char* kNames[] = {
      "Station_Status", "WD_Fact_1",         "WD_Fact_2",
      "min_TSDR",       "Ident_Number high", "Ident_Number low",
      "Group_Ident",    "reserved",          "CAN bit rate index",
      "flags",          "ModuleID",          "diagnosis/counter flags",
      "reserved",       "wake-up time",      "SYNC time high",
      "SYNC time low"};
  if (b < std::size(kNames)) return std::string(kNames[b]) + " (byte " + std::to_string(b) + ")";
  return "byte " + std::to_string(b);
}

namespace {

std::string slot_name(const GatewayReport& r, std::size_t i) {
  std::string s = "slot " + std::to_string(i);
  if (i < r.input.entry_paths.size() && !r.input.entry_paths[i].empty())
    s += " (" + r.input.entry_paths[i] + ")";
  return s;
}

std::string path_of(const GatewayReport& r, std::size_t i) {
  if (i < r.input.entry_paths.size() && !r.input.entry_paths[i].empty())
    return r.input.entry_paths[i];
  return r.input.json_path;
}

void slot_warnings(GatewayReport& r) {
  if (!r.cfg_accepted || !r.prm) return;
  const auto& slots = r.slots;
  for (std::size_t i = 0; i < slots.size(); ++i) {
    if (!slots[i].slot) continue;
    const gw::Slot& s = *slots[i].slot;
    if (s.kind == gw::SlotKind::Rx && s.id) {
      // manual §5.2.1: the same Rx identifier on two input slots - the later slot wins.
      std::optional<std::size_t> winner;
      for (std::size_t k = i + 1; k < slots.size(); ++k)
        if (slots[k].slot && slots[k].slot->kind == gw::SlotKind::Rx && slots[k].slot->id == s.id)
          winner = k;
      if (winner)
        r.warnings.push_back({WarningKind::DuplicateRx, path_of(r, i),
                              "slot " + std::to_string(i) + " never receives: Rx identifier " +
                                  "0x" + can::ident_text(*s.id) + " is also configured in " +
                                  slot_name(r, *winner) +
                                  ", and the later slot wins (manual §5.2.1)"});
      if (const auto cycle = gw::ignored_input_cycle(s, *r.prm))
        r.warnings.push_back({WarningKind::InputCycle, path_of(r, i),
                              "cycle " + std::to_string(*cycle) +
                                  " ms in the comment bytes of an input slot is ignored "
                                  "(docs/slots.md)"});
    }
    if (s.kind == gw::SlotKind::Tx && s.id) {
      // docs/slots.md "Chk_Cfg slots": the same Tx identifier on two output slots is accepted.
      for (std::size_t k = 0; k < i; ++k) {
        if (!slots[k].slot || slots[k].slot->kind != gw::SlotKind::Tx || slots[k].slot->id != s.id)
          continue;
        r.warnings.push_back({WarningKind::DuplicateTx, path_of(r, i),
                              "Tx identifier 0x" + can::ident_text(*s.id) + " is also sent by " +
                                  slot_name(r, k) +
                                  ": two slots send frames with the same identifier (accepted, "
                                  "docs/slots.md)"});
        break;
      }
    }
  }
}

}  // namespace

GatewayReport check_gateway(GatewayInput input) {
  GatewayReport r;
  r.input = std::move(input);
  const GatewayInput& in = r.input;
  r.warnings = in.warnings;

  struct Discard final : can::FrameSink {
    void send(const can::Frame&) override {}
  } discard;
  const Time t0{0};
  gw::Gateway gateway({.address = in.address, .stored_sync_ms = in.stored_sync_ms}, discard, t0);
  r.dp_address = gateway.address();
  if (r.dp_address != in.address)
    r.warnings.push_back({WarningKind::AddressClamped, in.json_path + ".address",
                          "DP address " + std::to_string(in.address) + " is clamped to " +
                              std::to_string(r.dp_address) + " (manual §2.1: 3..124)"});

  // The master's start-up sequence (docs/modbus.md): Set_Prm, Chk_Cfg, Slave_Diag. The slave
  // ignores Chk_Cfg after a rejected Set_Prm, as it would on the bus.
  dp::DpSlave& slave = gateway.dp();
  r.prm_accepted = slave.set_prm(in.master_address, in.params.prm, t0);
  if (r.prm_accepted)
    r.prm = gateway.user_prm();
  else
    r.prm_fault = slave.prm_fault();
  r.cfg_accepted = slave.chk_cfg(in.master_address, in.params.cfg, t0);
  if (r.prm_accepted && !r.cfg_accepted) r.cfg_fault = slave.cfg_fault();
  r.diag = slave.slave_diag(t0);
  r.state = slave.state();
  r.not_supported = (r.diag[0] & dp::kDiag1NotSupported) != 0;
  r.sync_ms = gateway.status().sync_ms;

  const gsd::CfgDecode decoded = gsd::decode_config(in.params.cfg);
  r.cfg_decode_error = decoded.error;
  const auto& accepted = gateway.slot_config();
  for (std::size_t i = 0; i < decoded.entries.size(); ++i) {
    const gsd::CfgEntry& e = decoded.entries[i];
    SlotRow row;
    row.index = i;
    row.json_path = path_of(r, i);
    row.io = e.decoded.io;
    row.in_length = e.input_len();
    row.out_length = e.output_len();
    const dp::EntryAddress a =
        i < in.params.addresses.size() ? in.params.addresses[i] : dp::EntryAddress{};
    if (row.in_length) row.plc_input = a.input;
    if (row.out_length) row.plc_output = a.output;
    row.cfg_bytes = e.bytes;
    if (r.cfg_accepted && accepted && i < accepted->slots.size()) row.slot = accepted->slots[i];
    if (r.cfg_fault && r.cfg_fault->slot == i) row.fault_code = r.cfg_fault->code;
    r.slots.push_back(std::move(row));
  }
  slot_warnings(r);
  return r;
}

namespace {

// The PLC byte ranges seen so far, per direction: the master has one process image for all
// stations (docs/modbus.md).
class PlcImage {
 public:
  // What a later range overlapping an earlier one means, appended to the warning.
  struct Why {
    const char* input;
    const char* output;
  };

  // Records the `n` bytes from `addr` of the row at `path`; with `warnings`, one Overlap warning
  // at `path` for each earlier range of the same direction they overlap.
  void add(bool input, std::size_t n, std::optional<std::uint16_t> addr, const std::string& path,
           std::vector<Warning>* warnings, Why why) {
    if (n == 0 || !addr) return;
    auto& list = input ? in_ : out_;
    const Span s{*addr, *addr + n, path};
    const std::string area = input ? "I " : "Q ";
    for (const auto& o : list) {
      if (!warnings || s.begin >= o.end || o.begin >= s.end) continue;
      warnings->push_back({WarningKind::Overlap, s.path,
                           "PLC bytes " + area + range(s.begin, s.end - s.begin) + " overlap " +
                               area + range(o.begin, o.end - o.begin) + " of " + o.path +
                               (input ? why.input : why.output)});
    }
    list.push_back(s);
  }

  void add_slots(const GatewayReport& r, std::vector<Warning>* warnings, Why why) {
    for (const auto& row : r.slots)
      for (const bool input : {true, false})
        add(input, input ? row.in_length : row.out_length, input ? row.plc_input : row.plc_output,
            row.json_path, warnings, why);
  }

 private:
  struct Span {
    std::size_t begin, end;  // PLC byte addresses [begin, end)
    std::string path;
  };
  std::vector<Span> in_, out_;
};

}  // namespace

void check_overlaps(std::vector<GatewayReport>& reports) {
  PlcImage image;
  for (auto& r : reports)
    image.add_slots(r, &r.warnings,
                    {": the later slot's bytes win in the PLC image (docs/modbus.md)",
                     ": both slots send the same PLC bytes (docs/modbus.md)"});
}

void check_slave_overlaps(const std::vector<GatewayReport>& gateways,
                          std::vector<SlaveReport>& slaves) {
  PlcImage image;
  for (const auto& g : gateways) image.add_slots(g, nullptr, {});
  for (auto& s : slaves)
    for (const auto& row : s.modules)
      for (const bool input : {true, false})
        image.add(input, input ? row.in_length : row.out_length,
                  input ? row.plc_input : row.plc_output, row.json_path, &s.warnings,
                  {": the later bytes win in the PLC image (docs/modbus.md)",
                   ": both send the same PLC bytes (docs/modbus.md)"});
}

bool Report::valid() const {
  for (const auto& g : gateways)
    if (!g.valid()) return false;
  for (const auto& s : slaves)
    if (!s.valid()) return false;
  return line.valid();
}

std::size_t Report::warning_count() const {
  std::size_t n = 0;
  for (const auto& g : gateways) n += g.warnings.size();
  for (const auto& s : slaves) n += s.warnings.size();
  for (const auto& b : buses) n += b.problems.size();
  return n + line.warnings();
}

int exit_code(const Report& r, bool strict) {
  if (!r.valid()) return 1;
  if (strict && r.warning_count() > 0) return 1;
  return 0;
}

}  // namespace candp2::validate
