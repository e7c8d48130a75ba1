// FDL slave front end (docs/profibus.md "DP services over FDL", "FCB/FCV", "Timing").
#include "profibus_sim/fdl/fdl_slave.hpp"

#include <string>

#include "common/hex.hpp"
#include "profibus_sim/fdl/dp_wire.hpp"

namespace candp2::fdl {

namespace {

std::vector<std::uint8_t> short_response(const Telegram& req, std::uint8_t function) {
  return encode(short_answer(req, function));
}

// A response carrying data, SAPs swapped (docs/profibus.md: "SD2 with DSAP 62 / SSAP 60
// swapped"); SD1 when there is neither a SAP nor data (profibus_sim/fdl/dp_wire.hpp).
std::vector<std::uint8_t> data_response(const Telegram& req, std::uint8_t function,
                                        std::span<const std::uint8_t> data) {
  return encode(data_answer(req, function, data));
}

bool is_srd(std::uint8_t function) {
  return function == kFcSrdLow || function == kFcSrdHigh;
}
bool is_sdn(std::uint8_t function) {
  return function == kFcSdnLow || function == kFcSdnHigh;
}

std::string who(std::uint8_t station, std::uint8_t master) {
  return "station " + std::to_string(station) + " master " + std::to_string(master);
}

}  // namespace

SlaveFrontEnd::SlaveFrontEnd(SlaveFrontEndOptions options, LogSink* log)
    : options_(options), log_(log, "fdl") {
  if (options_.baud == 0) options_.baud = 19200;
}

bool SlaveFrontEnd::add(dp::DpSlave& slave) {
  const std::uint8_t a = slave.info().address;
  if (a >= kBroadcast || stations_[a]) return false;
  auto st = std::make_unique<Station>();
  st->slave = &slave;
  st->min_tsdr = options_.default_min_tsdr_bits;
  stations_[a] = st.get();
  owned_.push_back(std::move(st));
  return true;
}

std::vector<std::uint8_t> SlaveFrontEnd::addresses() const {
  std::vector<std::uint8_t> out;
  for (std::size_t a = 0; a < stations_.size(); ++a)
    if (stations_[a]) out.push_back(static_cast<std::uint8_t>(a));
  return out;
}

const StationStats* SlaveFrontEnd::stats(std::uint8_t address) const {
  if (address >= stations_.size() || !stations_[address]) return nullptr;
  return &stations_[address]->stats;
}

std::uint8_t SlaveFrontEnd::min_tsdr_bits(std::uint8_t address) const {
  if (address >= stations_.size() || !stations_[address]) return options_.default_min_tsdr_bits;
  return stations_[address]->min_tsdr;
}

Duration SlaveFrontEnd::bit_times(std::uint32_t bits) const {
  return phy::bits_to_time(options_.baud, bits);
}

std::optional<Reply> SlaveFrontEnd::on_telegram(const Telegram& t, Time request_end) {
  if (t.kind != Kind::SD1 && t.kind != Kind::SD2 && t.kind != Kind::SD3) return std::nullopt;
  if (!t.is_request() || t.da > kAddrMask || t.sa > kAddrMask) return std::nullopt;
  const std::uint8_t fn = t.function();

  // docs/profibus.md: address 127 = broadcast, nobody answers. Global_Control (SDN, DSAP 58)
  // reaches every station (it is ignored by this device, docs/dp-slave.md "States", but counts as
  // master activity).
  if (t.da == kBroadcast) {
    if (is_sdn(fn) && t.dsap == kSapGlobalControl &&
        (!options_.master_address || t.sa == *options_.master_address)) {
      for (Station* st : stations_) {
        if (!st || st->slave->offline()) continue;
        ++st->stats.requests;
        st->slave->global_control(t.sa, t.du.empty() ? 0 : t.du[0], request_end,
                                  t.du.size() > 1 ? t.du[1] : 0);
      }
    }
    return std::nullopt;
  }
  Station* st = stations_[t.da];
  if (!st) return std::nullopt;  // another station's telegram
  ++st->stats.requests;
  if (st->slave->offline()) {  // off the bus: it hears nothing, answers nothing
    ++st->stats.ignored;
    st->slave->advance(request_end);
    return std::nullopt;
  }
  const bool debug = log_.enabled(LogLevel::Debug);
  if (debug) log_.debug(who(t.da, t.sa) + " request " + hex_bytes(encode(t)));

  if (options_.master_address && t.sa != *options_.master_address) {
    ++st->stats.ignored;
    if (debug)
      log_.debug(who(t.da, t.sa) + ": ignored, only master " +
                 std::to_string(*options_.master_address) + " is answered");
    return std::nullopt;
  }

  std::optional<std::vector<std::uint8_t>> response;
  if (fn == kFcFdlStatus) {
    // docs/profibus.md: FDL_Status SD1 FC 0x49 -> SD1 FC 0x00 (slave, OK). The master starts
    // its FCB sequence afresh after it (FCB=1, FCV=0 next).
    st->links[t.sa] = Link{};
    if (debug) log_.debug(who(t.da, t.sa) + ": FDL_Status, FCB sequence restarts");
    response = short_response(t, kFcOk);
  } else if (is_sdn(fn)) {
    // SDN: never answered. Global_Control to this station; anything else is dropped.
    if (t.dsap == kSapGlobalControl)
      st->slave->global_control(t.sa, t.du.empty() ? 0 : t.du[0], request_end,
                                t.du.size() > 1 ? t.du[1] : 0);
    ++st->stats.ignored;
    return std::nullopt;
  } else if (is_srd(fn)) {
    Link& link = st->links[t.sa];
    // docs/profibus.md "FCB/FCV": FCV=1 and the same FCB as the previous request of this master
    // is a repetition: resend the last response without executing again.
    if (t.fcv() && link.valid && link.fcb == t.fcb()) {
      ++st->stats.repetitions;
      if (debug) log_.debug(who(t.da, t.sa) + ": FCB repetition, last response resent");
      response = link.last_response;
    } else {
      response = execute(*st, t, request_end);
      link.valid = true;
      link.fcb = t.fcb();
      link.last_response = response;
    }
  } else {
    // SDA, MSRD, Ident, LSAP status, time event: not offered by a DP slave here.
    if (debug) log_.debug(who(t.da, t.sa) + ": FC function " + std::to_string(fn) + " ignored");
  }

  if (!response) {
    ++st->stats.ignored;
    return std::nullopt;
  }
  ++st->stats.responses;
  if (debug) log_.debug(who(t.da, t.sa) + " response " + hex_bytes(*response));
  return Reply{std::move(*response), request_end + bit_times(st->min_tsdr), t.da};
}

std::optional<std::vector<std::uint8_t>> SlaveFrontEnd::execute(Station& st, const Telegram& t,
                                                                Time now) {
  dp::DpSlave& dp = *st.slave;
  if (!t.dsap) return data_exchange(st, t, now);
  switch (*t.dsap) {
    case kSapSlaveDiag: {
      auto d = dp.diagnosis(now);
      auto response = data_response(t, kFcDl, d);
      st.diag_read[t.sa] = std::move(d);
      return response;
    }
    case kSapSetPrm: {
      // docs/profibus.md: Set_Prm -> SC; a fault shows in the diagnosis (docs/dp-slave.md
      // "States").
      if (dp.set_prm(t.sa, t.du, now) && t.du.size() > 3 && t.du[3] != 0) {
        // Set_Prm byte 3 = min_TSDR in bit times; 0 keeps the value in force.
        if (st.min_tsdr != t.du[3])
          log_.debug(who(t.da, t.sa) + ": min_TSDR " + std::to_string(t.du[3]) + " bit times");
        st.min_tsdr = t.du[3];
      }
      return encode(Telegram::sc());
    }
    case kSapChkCfg:
      dp.chk_cfg(t.sa, t.du, now);
      return encode(Telegram::sc());
    case kSapGetCfg: {
      const auto cfg = dp.get_cfg(now);
      return data_response(
          t, kFcDl, cfg ? std::span<const std::uint8_t>(*cfg) : std::span<const std::uint8_t>());
    }
    case kSapRdInp:
      return data_response(t, kFcDl, dp.inputs());
    case kSapRdOutp:
      return data_response(t, kFcDl, dp.outputs());
    case kSapGlobalControl:
      dp.global_control(t.sa, t.du.empty() ? 0 : t.du[0], now, t.du.size() > 1 ? t.du[1] : 0);
      return encode(Telegram::sc());
    case kSapSetSlaveAdd:
      return set_slave_add(st, t, now);
    default:
      // MM services (54) and unknown SAPs: RS, "no service activated" (docs/profibus.md).
      log_.debug(who(t.da, t.sa) + ": SAP " + std::to_string(*t.dsap) + " not activated: RS");
      return short_response(t, kFcRs);
  }
}

std::optional<std::vector<std::uint8_t>> SlaveFrontEnd::data_exchange(Station& st,
                                                                      const Telegram& t, Time now) {
  dp::DpSlave& dp = *st.slave;
  const auto in = dp.data_exchange(t.sa, t.du, now);
  if (!in) {
    // Not in Data_Exch for this master (or the output length is wrong): the default SAP is not
    // activated, the answer is RS. Masters handle it this way: pyprofibus dp_master.py
    // (e7c98158) raises "Service not active on slave" on FC_RS in Data_Exchange; profirust
    // src/dp/peripheral.rs (860b938e) takes ResponseStatus::SapNotEnabled as "revalidating
    // config" and parameterizes the slave again.
    log_.debug(who(t.da, t.sa) + ": Data_Exchange in " + std::string(dp::to_string(dp.state())) +
               ": RS");
    return short_response(t, kFcRs);
  }
  // DH while new diagnosis is pending: the diagnosis differs from what this master last read
  // with Slave_Diag (docs/decisions.md).
  const bool pending = st.diag_read[t.sa] != dp.diagnosis(now);
  // SC when the slave has no input bytes; with diagnosis pending the short acknowledge cannot say
  // so, so an SD1 with FC DH is sent (docs/decisions.md "FDL on the wire", dp_wire.hpp).
  return encode(data_exchange_answer(t, *in, pending));
}

// Set_Slave_Add (SAP 55): SC when the slave took the new address (it answers there from now on),
// RS when it refuses (the CAN-DP/2 never takes one, docs/dp-slave.md) or the address is taken.
std::optional<std::vector<std::uint8_t>> SlaveFrontEnd::set_slave_add(Station& st,
                                                                      const Telegram& t, Time now) {
  const std::uint8_t old = st.slave->info().address;
  const bool taken = !t.du.empty() && t.du[0] < stations_.size() && stations_[t.du[0]] &&
                     stations_[t.du[0]] != &st;
  if (taken || !st.slave->set_slave_add(t.sa, t.du, now)) {
    log_.debug(who(t.da, t.sa) + ": Set_Slave_Add " + hex_bytes(t.du) + " not taken: RS");
    return short_response(t, kFcRs);
  }
  stations_[old] = nullptr;
  stations_[st.slave->info().address] = &st;
  st.links = {};
  return encode(Telegram::sc());
}

std::optional<Reply> SlaveFrontEnd::drain(Time now) {
  std::optional<Reply> last;
  while (auto ev = parser_.next()) {
    if (ev->error != Error::None) {
      if (log_.enabled(LogLevel::Debug))
        log_.debug("line: " + std::string(to_string(ev->error)) + " at byte " +
                   std::to_string(ev->offset) + ": " + hex_bytes(ev->raw));
      continue;
    }
    if (observe_) observe_(ev->raw, now);
    if (auto r = on_telegram(ev->telegram, now)) last = std::move(r);
  }
  return last;
}

std::optional<Reply> SlaveFrontEnd::on_bytes(std::span<const std::uint8_t> bytes, Time now) {
  parser_.feed(bytes);
  return drain(now);
}

std::optional<Reply> SlaveFrontEnd::on_gap(Time now) {
  parser_.gap();
  return drain(now);
}

}  // namespace candp2::fdl
