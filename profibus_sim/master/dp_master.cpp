#include "profibus_sim/master/dp_master.hpp"

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

std::string describe_diag(std::span<const std::uint8_t> d) {
  std::string out;
  auto add = [&](bool on, const char* word) {
    if (!on) return;
    if (!out.empty()) out += ' ';
    out += word;
  };
  if (d.size() < kDiagStdLen) return "short diagnosis " + hex_bytes(d);
  // The station status bits by their names in kDiagBitNames, in its order. The words the logs
  // have always shown: Invalid_Slave_Response, Master_Lock, Stat_Diag, Deactivated are left out.
  constexpr std::uint8_t kSpelled[] = {
      kDiag1StationNonExistent | kDiag1StationNotReady | kDiag1CfgFault | kDiag1ExtDiag |
          kDiag1NotSupported | kDiag1PrmFault,
      kDiag2PrmReq | kDiag2WdOn | kDiag2FreezeMode | kDiag2SyncMode, kDiag3ExtDiagOverflow};
  for (const auto& b : kDiagBitNames) add(d[b.byte] & b.mask & kSpelled[b.byte], b.name);
  if (!out.empty()) out += ' ';
  out += d[3] == kNoMaster ? "master=none" : "master=" + std::to_string(d[3]);
  out += " ident=" + hex_bytes(d.subspan(4, 2), '\0');
  const bool candp2 = d.size() == DpSlave::kDiagLen && d[4] == 0x04 && d[5] == 0xA4;
  if (candp2 && d[8] == kExtDiagPrmSap) {
    out += " Prm fault: byte " + std::to_string(d[9]) + ", correct value 0x" +
           hex_bytes(d.subspan(10, 1));
  } else if (candp2 && d[8] == kExtDiagCfgSap) {
    out += " Cfg fault: slot " + std::to_string(d[9]) + ", code " + std::to_string(d[10]);
  } else if (candp2) {
    out += " ext=" + hex_bytes(d.subspan(8, 3));
  } else if (d.size() > kDiagStdLen) {
    out += " ext=" + hex_bytes(d.subspan(kDiagStdLen));
  }
  return out;
}

DpMaster::DpMaster(MasterOptions options, LogSink* log) : options_(options), log_(log, "master") {}

std::size_t DpMaster::add_slave(DpSlave& slave, SlaveParameters params) {
  auto link = std::make_unique<InProcessLink>(slave);
  SlaveLink& ref = *link;
  const auto index = add_slave(ref, std::move(params));
  entries_[index]->owned = std::move(link);
  return index;
}

ImageMap map_image(const SlaveParameters& params,
                   const std::function<void(std::size_t, std::uint16_t, std::size_t)>& skipped) {
  ImageMap map;
  const auto decoded = decode_chk_cfg(params.cfg);
  for (std::size_t i = 0; i < decoded.entries.size(); ++i) {
    const auto& c = decoded.entries[i];
    const EntryAddress a = i < params.addresses.size() ? params.addresses[i] : EntryAddress{};
    auto fits = [&](std::uint16_t addr, std::size_t len) {
      if (addr + len <= kImageSize) return true;
      if (skipped) skipped(i, addr, len);
      return false;
    };
    if (c.out_bytes() && a.output && fits(*a.output, c.out_bytes()))
      map.out.push_back({map.out_len, *a.output, c.out_bytes()});
    if (c.in_bytes() && a.input && fits(*a.input, c.in_bytes()))
      map.in.push_back({map.in_len, *a.input, c.in_bytes()});
    map.out_len += c.out_bytes();
    map.in_len += c.in_bytes();
  }
  return map;
}

std::size_t DpMaster::add_slave(SlaveLink& link, SlaveParameters params) {
  auto e = std::make_unique<Entry>();
  e->link = &link;
  e->map = map_image(params, [&](std::size_t i, std::uint16_t addr, std::size_t len) {
    log_.error("slave " + std::to_string(link.address()) + " entry " + std::to_string(i) +
               ": PLC address " + std::to_string(addr) + " + " + std::to_string(len) +
               " bytes is outside the " + std::to_string(kImageSize) + "-byte image; not mapped");
  });
  e->out_buf.assign(e->map.out_len, 0);
  e->params = std::move(params);
  entries_.push_back(std::move(e));
  return entries_.size() - 1;
}

// ---------------------------------------------------------------- the state table

const DpMaster::StateRow DpMaster::kStates[] = {
    {MasterSlaveState::Init, &DpMaster::on_init},
    {MasterSlaveState::SetPrm, &DpMaster::on_set_prm},
    {MasterSlaveState::ChkCfg, &DpMaster::on_chk_cfg},
    {MasterSlaveState::CheckDiag, &DpMaster::on_check_diag},
    {MasterSlaveState::DataExch, &DpMaster::on_data_exch},
    {MasterSlaveState::Retry, &DpMaster::on_retry},
};

void DpMaster::step(Entry& e, Time now) {
  if (e.busy) return;  // the answer to the last request has not come yet
  for (const auto& row : kStates)
    if (row.state == e.state) return (this->*row.step)(e, now);
}

void DpMaster::go(Entry& e, MasterSlaveState next, std::string_view why) {
  if (e.state == next) return;
  log_.info("slave " + std::to_string(e.address()) + ": " + std::string(to_string(e.state)) +
            " -> " + std::string(to_string(next)) + " (" + std::string(why) + ")");
  e.state = next;
}

void DpMaster::send(Entry& e, Service service, std::vector<std::uint8_t> data, Time now,
                    OnAnswer then) {
  e.busy = true;
  const auto generation = e.generation;
  Entry* entry = &e;
  e.link->request({service, options_.address, std::move(data)}, now,
                  [this, entry, generation, then](const Response& r, Time at) {
                    entry->busy = false;
                    if (entry->generation != generation) return;  // reparameterize() came between
                    (this->*then)(*entry, r, at);
                  });
}

void DpMaster::set_diag(Entry& e, std::vector<std::uint8_t> d) {
  if (e.diag_bytes != d || !e.last_diag)
    log_.info("slave " + std::to_string(e.address()) + " diagnosis " + hex_bytes(d) + ": " +
              describe_diag(d));
  DpSlave::Diag first{};
  std::copy_n(d.begin(), std::min(d.size(), first.size()), first.begin());
  e.last_diag = first;
  e.diag_bytes = std::move(d);
}

void DpMaster::lost(Entry& e, Time now, std::string_view what) {
  // What a real master's diagnosis shows for a station that does not answer: Station_Non_Existent
  // (manual table 3.4.3, diag byte 0 bit 0, set by the master), no master address.
  std::vector<std::uint8_t> d(kDiagStdLen, 0);
  d[0] = kDiag1StationNonExistent;
  d[3] = kNoMaster;
  const bool was_there = !e.last_diag || !((*e.last_diag)[0] & kDiag1StationNonExistent);
  if (was_there) {
    ++e.station_lost;
    log_.warn("slave " + std::to_string(e.address()) + ": no response to " + std::string(what) +
              ": station lost");
  }
  set_diag(e, std::move(d));
  if (options_.lost_waits_retry) {
    e.retry_at = now + options_.retry_delay;
    e.diag_due = false;
    return go(e, MasterSlaveState::Retry, "no response to " + std::string(what));
  }
  go(e, MasterSlaveState::Init, "no response to " + std::string(what));
}

void DpMaster::invalid(Entry& e, Time now, std::string_view why) {
  // manual table 3.4.3, diag byte 0 bit 5 Invalid_Slave_Response (set by the master).
  std::vector<std::uint8_t> d = e.diag_bytes;
  if (d.size() < kDiagStdLen) d.resize(kDiagStdLen, 0);
  d[0] = static_cast<std::uint8_t>((d[0] & ~kDiag1StationNonExistent) | kDiag1InvalidSlaveResponse);
  set_diag(e, std::move(d));
  fault(e, now, "invalid slave response: " + std::string(why));
}

void DpMaster::fault(Entry& e, Time now, std::string_view why) {
  log_.warn("slave " + std::to_string(e.address()) + ": " + std::string(why) +
            "; retrying parameterization");
  e.retry_at = now + options_.retry_delay;
  e.diag_due = false;
  go(e, MasterSlaveState::Retry, why);
}

bool DpMaster::answered(Entry& e, const Response& r, Time now, std::string_view what) {
  if (r.status != Response::Status::NoResponse) return true;
  lost(e, now, what);
  return false;
}

bool DpMaster::take_diag(Entry& e, const Response& r, Time now) {
  if (!answered(e, r, now, to_string(Service::SlaveDiag))) return false;
  // IEC 61158-6-3: 6 standard bytes and up to 238 bytes of Ext_Diag_Data.
  if (r.status != Response::Status::Ok || r.data.size() < kDiagStdLen ||
      r.data.size() > kDiagMaxLen) {
    invalid(e, now,
            r.status != Response::Status::Ok
                ? std::string(to_string(Service::SlaveDiag)) + " refused"
                : std::string(to_string(Service::SlaveDiag)) + " with " +
                      std::to_string(r.data.size()) + " bytes (expected " +
                      std::to_string(kDiagStdLen) + ".." + std::to_string(kDiagMaxLen) + ")");
    return false;
  }
  set_diag(e, r.data);
  return true;
}

// ---------------------------------------------------------------- state handlers

void DpMaster::on_retry(Entry& e, Time now) {
  if (now < e.retry_at) return;
  go(e, MasterSlaveState::Init, "retry");
  on_init(e, now);
}

void DpMaster::on_init(Entry& e, Time now) {
  send(e, Service::SlaveDiag, {}, now, &DpMaster::init_answered);
}

void DpMaster::init_answered(Entry& e, const Response& r, Time now) {
  if (!take_diag(e, r, now)) return;
  go(e, MasterSlaveState::SetPrm, "slave answers");
  if (options_.parameterize_in_one_go) on_set_prm(e, now);
}

void DpMaster::on_set_prm(Entry& e, Time now) {
  ++e.parameterizations;
  // A class 1 master parameterizes with Lock_Req (docs/dp-slave.md "Lock"): the configured
  // Station_Status of a CAN-DP/2 (docs/validate.md) has it clear.
  send(e, Service::SetPrm, with_lock_req(e.params.prm), now, &DpMaster::set_prm_answered);
}

void DpMaster::set_prm_answered(Entry& e, const Response& r, Time now) {
  if (!answered(e, r, now, to_string(Service::SetPrm))) return;
  if (r.status != Response::Status::Ok) return fault(e, now, "Set_Prm refused");
  go(e, MasterSlaveState::ChkCfg, "Set_Prm sent");
  if (options_.parameterize_in_one_go) on_chk_cfg(e, now);
}

void DpMaster::on_chk_cfg(Entry& e, Time now) {
  send(e, Service::ChkCfg, e.params.cfg, now, &DpMaster::chk_cfg_answered);
}

void DpMaster::chk_cfg_answered(Entry& e, const Response& r, Time now) {
  if (!answered(e, r, now, to_string(Service::ChkCfg))) return;
  if (r.status != Response::Status::Ok) return fault(e, now, "Chk_Cfg refused");
  go(e, MasterSlaveState::CheckDiag, "Chk_Cfg sent");
  if (options_.parameterize_in_one_go) on_check_diag(e, now);
}

namespace {
bool not_ready(const DpSlave::Diag& d) {
  return (d[0] & (kDiag1CfgFault | kDiag1PrmFault | kDiag1NotSupported)) ||
         (d[0] & kDiag1StationNotReady) || (d[1] & kDiag2PrmReq);
}
}  // namespace

void DpMaster::on_check_diag(Entry& e, Time now) {
  send(e, Service::SlaveDiag, {}, now, &DpMaster::check_diag_answered);
}

void DpMaster::check_diag_answered(Entry& e, const Response& r, Time now) {
  if (!take_diag(e, r, now)) return;
  if (not_ready(*e.last_diag))
    return fault(e, now, "slave not ready after parameterization: " + describe_diag(e.diag_bytes));
  go(e, MasterSlaveState::DataExch, "slave ready");
  on_data_exch(e, now);  // the first Data_Exchange in the same cycle
}

void DpMaster::on_data_exch(Entry& e, Time now) {
  if (e.diag_due) return send(e, Service::SlaveDiag, {}, now, &DpMaster::diag_due_answered);
  for (const auto& m : e.map.out)
    std::memcpy(e.out_buf.data() + m.dp_offset, image_.outputs.data() + m.plc_address, m.length);
  send(e, Service::DataExchange, e.out_buf, now, &DpMaster::exchange_answered);
}

void DpMaster::diag_due_answered(Entry& e, const Response& r, Time now) {
  e.diag_due = false;
  if (!take_diag(e, r, now)) return;
  if (not_ready(*e.last_diag))
    return fault(e, now, "diagnosis during Data_Exch: " + describe_diag(e.diag_bytes));
}

void DpMaster::exchange_answered(Entry& e, const Response& r, Time now) {
  if (!answered(e, r, now, to_string(Service::DataExchange))) return;
  if (r.status == Response::Status::Refused) {
    // The slave left Data_Exch (watchdog, reset): read why, then parameterize again.
    return send(e, Service::SlaveDiag, {}, now, &DpMaster::refused_diag_answered);
  }
  if (r.data.size() != e.map.in_len)
    return invalid(e, now,
                   "Data_Exchange with " + std::to_string(r.data.size()) +
                       " input bytes (configured " + std::to_string(e.map.in_len) + ")");
  ++e.data_exchanges;
  // Inputs in slot order: for overlapping addresses the later slot's bytes win (docs/modbus.md).
  for (const auto& m : e.map.in)
    std::memcpy(image_.inputs.data() + m.plc_address, r.data.data() + m.dp_offset, m.length);
  if (r.diag_pending) e.diag_due = true;  // DH: read the new diagnosis in the next cycle
}

void DpMaster::refused_diag_answered(Entry& e, const Response& r, Time now) {
  if (!take_diag(e, r, now)) return;
  fault(e, now, "Data_Exchange not answered: " + describe_diag(e.diag_bytes));
}

// ---------------------------------------------------------------- cycle, control, views

void DpMaster::cycle(Time now) {
  if (program_) program_->scan(image_, now);
  for (auto& e : entries_)
    if (e->addressed) step(*e, now);
}

void DpMaster::set_addressed(std::uint8_t slave_address, bool addressed, Time now) {
  for (auto& e : entries_) {
    if (e->address() != slave_address || e->addressed == addressed) continue;
    e->addressed = addressed;
    if (addressed) {
      e->retry_at = now;
      e->diag_due = false;
      ++e->generation;  // an answer still outstanding belongs to the time before the stop
      go(*e, MasterSlaveState::Init, "addressed again");
    } else {
      log_.warn("slave " + std::to_string(slave_address) +
                ": no longer addressed (the PLC stopped)");
    }
  }
}

void DpMaster::reparameterize(std::uint8_t slave_address, Time now) {
  for (auto& e : entries_) {
    if (e->address() != slave_address) continue;
    e->retry_at = now;
    e->diag_due = false;
    ++e->generation;  // an answer still outstanding belongs to the old attempt
    go(*e, MasterSlaveState::Init, "re-parameterization requested");
  }
}

std::vector<DpMaster::SlaveView> DpMaster::slaves() const {
  std::vector<SlaveView> out;
  for (const auto& e : entries_)
    out.push_back({e->address(), e->state, e->last_diag, e->data_exchanges, e->parameterizations,
                   e->station_lost, e->addressed, e->diag_bytes});
  return out;
}

std::optional<DpMaster::SlaveView> DpMaster::slave(std::uint8_t address) const {
  for (const auto& v : slaves())
    if (v.address == address) return v;
  return std::nullopt;
}

// ---------------------------------------------------------------- links

std::string_view to_string(Response::Status s) {
  switch (s) {
    case Response::Status::Ok:
      return "OK";
    case Response::Status::Refused:
      return "refused";
    case Response::Status::NoResponse:
      return "no response";
  }
  return "?";
}

void InProcessLink::request(Request req, Time now, Completion done) {
  Response r;
  if (slave_.offline()) {
    slave_.advance(now);  // off the bus, its time runs on
    return done(r, now);  // NoResponse
  }
  r.status = Response::Status::Ok;
  switch (req.service) {
    case Service::SlaveDiag:
      r.data = slave_.diagnosis(now);
      break;
    case Service::SetPrm:
      slave_.set_prm(req.master, req.data, now);  // the result shows in the diagnosis
      break;
    case Service::ChkCfg:
      slave_.chk_cfg(req.master, req.data, now);
      break;
    case Service::GetCfg:
      if (auto cfg = slave_.get_cfg(now)) r.data = std::move(*cfg);
      break;
    case Service::DataExchange:
      if (auto in = slave_.data_exchange(req.master, req.data, now))
        r.data.assign(in->begin(), in->end());
      else
        r.status = Response::Status::Refused;  // not in Data_Exch: the FDL answer would be RS
      break;
    case Service::GlobalControl:
      slave_.global_control(req.master, req.data.empty() ? 0 : req.data[0], now,
                            req.data.size() > 1 ? req.data[1] : 0);
      break;
    case Service::SetSlaveAdd:
    case Service::RdInp:
    case Service::RdOutp:
      r.status = Response::Status::Refused;  // a class 2 master's service: not on this link
      break;
  }
  done(r, now);
}

}  // namespace candp2::dp
