#include "profibus_sim/dp_master.hpp"

#include <algorithm>
#include <cstring>

#include "common/hex.hpp"

namespace candp2::dp {

std::string_view to_string(MasterSlaveState s) {
  switch (s) {
    case MasterSlaveState::Init:
      return "Init";
    case MasterSlaveState::SetPrm:
      return "Set_Prm";
    case MasterSlaveState::ChkCfg:
      return "Chk_Cfg";
    case MasterSlaveState::CheckDiag:
      return "Check_Diag";
    case MasterSlaveState::DataExch:
      return "Data_Exch";
    case MasterSlaveState::Retry:
      return "Retry";
  }
  return "?";
}

std::string describe_diag(const DpSlave::Diag& d) {
  std::string out;
  auto add = [&](bool on, const char* word) {
    if (!on) return;
    if (!out.empty()) out += ' ';
    out += word;
  };
  add(d[0] & kDiag1StationNonExistent, "Station_Non_Existent");
  add(d[0] & kDiag1StationNotReady, "Station_Not_Ready");
  add(d[0] & kDiag1CfgFault, "Cfg_Fault");
  add(d[0] & kDiag1ExtDiag, "Ext_Diag");
  add(d[0] & kDiag1NotSupported, "Not_Supported");
  add(d[0] & kDiag1PrmFault, "Prm_Fault");
  add(d[1] & kDiag2PrmReq, "Prm_Req");
  add(d[1] & kDiag2WdOn, "WD_On");
  if (!out.empty()) out += ' ';
  out += d[3] == kNoMaster ? "master=none" : "master=" + std::to_string(d[3]);
  out += " ident=" + hex_bytes(std::span(d).subspan(4, 2), '\0');
  if (d[8] == kExtDiagPrmSap) {
    out += " Prm fault: byte " + std::to_string(d[9]) + ", correct value 0x" +
           hex_bytes(std::span(d).subspan(10, 1));
  } else if (d[8] == kExtDiagCfgSap) {
    out += " Cfg fault: slot " + std::to_string(d[9]) + ", code " + std::to_string(d[10]);
  } else {
    out += " ext=" + hex_bytes(std::span(d).subspan(8, 3));
  }
  return out;
}

DpMaster::DpMaster(MasterOptions options, LogSink* log) : options_(options), log_(log, "master") {}

std::size_t DpMaster::add_slave(DpSlave& slave, SlaveParameters params) {
  Entry e;
  e.slave = &slave;
  const auto decoded = decode_chk_cfg(params.cfg);
  for (std::size_t i = 0; i < decoded.entries.size(); ++i) {
    const auto& c = decoded.entries[i];
    const EntryAddress a = i < params.addresses.size() ? params.addresses[i] : EntryAddress{};
    auto fits = [&](std::uint16_t addr, std::size_t len) {
      if (addr + len <= kImageSize) return true;
      log_.error("slave " + std::to_string(slave.info().address) + " entry " + std::to_string(i) +
                 ": PLC address " + std::to_string(addr) + " + " + std::to_string(len) +
                 " bytes is outside the " + std::to_string(kImageSize) + "-byte image; not mapped");
      return false;
    };
    if (c.out_bytes() && a.output && fits(*a.output, c.out_bytes()))
      e.out_map.push_back({e.out_len, *a.output, c.out_bytes()});
    if (c.in_bytes() && a.input && fits(*a.input, c.in_bytes()))
      e.in_map.push_back({e.in_len, *a.input, c.in_bytes()});
    e.out_len += c.out_bytes();
    e.in_len += c.in_bytes();
  }
  e.out_buf.assign(e.out_len, 0);
  e.params = std::move(params);
  entries_.push_back(std::move(e));
  return entries_.size() - 1;
}

void DpMaster::go(Entry& e, MasterSlaveState next, std::string_view why) {
  if (e.state == next) return;
  log_.info("slave " + std::to_string(e.slave->info().address) + ": " +
            std::string(to_string(e.state)) + " -> " + std::string(to_string(next)) + " (" +
            std::string(why) + ")");
  e.state = next;
}

void DpMaster::read_diag(Entry& e, Time now) {
  const auto d = e.slave->slave_diag(now);
  if (!e.last_diag || *e.last_diag != d)
    log_.info("slave " + std::to_string(e.slave->info().address) + " diagnosis " + hex_bytes(d) +
              ": " + describe_diag(d));
  e.last_diag = d;
}

void DpMaster::fault(Entry& e, Time now, std::string_view why) {
  log_.warn("slave " + std::to_string(e.slave->info().address) + ": " + std::string(why) +
            "; retrying parameterization");
  e.retry_at = now + options_.retry_delay;
  go(e, MasterSlaveState::Retry, why);
}

void DpMaster::step(Entry& e, Time now) {
  switch (e.state) {
    case MasterSlaveState::Retry:
      if (now < e.retry_at) return;
      go(e, MasterSlaveState::Init, "retry");
      [[fallthrough]];
    case MasterSlaveState::Init:
      read_diag(e, now);
      go(e, MasterSlaveState::SetPrm, "slave answers");
      return;
    case MasterSlaveState::SetPrm:
      ++e.parameterizations;
      e.slave->set_prm(options_.address, e.params.prm, now);
      go(e, MasterSlaveState::ChkCfg, "Set_Prm sent");
      return;
    case MasterSlaveState::ChkCfg:
      e.slave->chk_cfg(options_.address, e.params.cfg, now);
      go(e, MasterSlaveState::CheckDiag, "Chk_Cfg sent");
      return;
    case MasterSlaveState::CheckDiag: {
      read_diag(e, now);
      const auto& d = *e.last_diag;
      const bool faulty = (d[0] & (kDiag1CfgFault | kDiag1PrmFault | kDiag1NotSupported)) ||
                          (d[0] & kDiag1StationNotReady) || (d[1] & kDiag2PrmReq);
      if (faulty)
        return fault(e, now, "slave not ready after parameterization: " + describe_diag(d));
      go(e, MasterSlaveState::DataExch, "slave ready");
      [[fallthrough]];
    }
    case MasterSlaveState::DataExch: {
      for (const auto& m : e.out_map)
        std::memcpy(e.out_buf.data() + m.dp_offset, image_.outputs.data() + m.plc_address,
                    m.length);
      auto in = e.slave->data_exchange(options_.address, e.out_buf, now);
      if (!in) {
        read_diag(e, now);
        return fault(e, now, "Data_Exchange not answered: " + describe_diag(*e.last_diag));
      }
      ++e.data_exchanges;
      // Inputs in slot order: for overlapping addresses the later slot's bytes win (emulator-spec
      // §8).
      for (const auto& m : e.in_map)
        std::memcpy(image_.inputs.data() + m.plc_address, in->data() + m.dp_offset, m.length);
      return;
    }
  }
}

void DpMaster::cycle(Time now) {
  if (program_) program_->scan(image_, now);
  for (auto& e : entries_)
    if (e.addressed) step(e, now);
}

void DpMaster::set_addressed(std::uint8_t slave_address, bool addressed, Time now) {
  for (auto& e : entries_) {
    if (e.slave->info().address != slave_address || e.addressed == addressed) continue;
    e.addressed = addressed;
    if (addressed) {
      e.retry_at = now;
      go(e, MasterSlaveState::Init, "addressed again");
    } else {
      log_.warn("slave " + std::to_string(slave_address) +
                ": no longer addressed (the PLC stopped)");
    }
  }
}

void DpMaster::reparameterize(std::uint8_t slave_address, Time now) {
  for (auto& e : entries_) {
    if (e.slave->info().address != slave_address) continue;
    e.retry_at = now;
    go(e, MasterSlaveState::Init, "re-parameterization requested");
  }
}

std::vector<DpMaster::SlaveView> DpMaster::slaves() const {
  std::vector<SlaveView> out;
  for (const auto& e : entries_)
    out.push_back({e.slave->info().address, e.state, e.last_diag, e.data_exchanges,
                   e.parameterizations, e.addressed});
  return out;
}

std::optional<DpMaster::SlaveView> DpMaster::slave(std::uint8_t address) const {
  for (const auto& v : slaves())
    if (v.address == address) return v;
  return std::nullopt;
}

}  // namespace candp2::dp
