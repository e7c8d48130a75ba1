// Readable FDL/DP telegram lines (docs/profibus.md, DP-V0 payloads per EN 50170 vol. 2 and
// docs/dp-slave.md "Diagnosis" for the diagnosis header).
#include "profibus_sim/fdl/fdl_describe.hpp"

#include <array>
#include <cstdio>
#include <string>

#include "common/hex.hpp"
#include "profibus_sim/dp/dp_telegram.hpp"

namespace candp2::fdl {

std::optional<dp::Service> dp_service(Service s) {
  switch (s) {
    case Service::DataExchange:
      return dp::Service::DataExchange;
    case Service::SetSlaveAdd:
      return dp::Service::SetSlaveAdd;
    case Service::RdInp:
      return dp::Service::RdInp;
    case Service::RdOutp:
      return dp::Service::RdOutp;
    case Service::GlobalControl:
      return dp::Service::GlobalControl;
    case Service::GetCfg:
      return dp::Service::GetCfg;
    case Service::SlaveDiag:
      return dp::Service::SlaveDiag;
    case Service::SetPrm:
      return dp::Service::SetPrm;
    case Service::ChkCfg:
      return dp::Service::ChkCfg;
    case Service::Unknown:
    case Service::FdlStatus:
    case Service::OtherSap:
    case Service::Token:
    case Service::Ack:
      break;
  }
  return std::nullopt;
}

std::string_view to_string(Service s) {
  if (const auto dp = dp_service(s)) return dp::to_string(*dp);
  switch (s) {
    case Service::FdlStatus:
      return "FDL_Status";
    case Service::OtherSap:
      return "SAP";
    case Service::Token:
      return "Token";
    case Service::Ack:
      return "Ack";
    default:
      break;
  }
  return "?";
}

std::string fc_name(std::uint8_t fc) {
  const std::uint8_t fn = fc & kFcFuncMask;
  if (fc & kFcReq) {
    switch (fn) {
      case kFcTimeEvent:
        return "Time_Event";
      case kFcSdaLow:
        return "SDA_low";
      case kFcSdnLow:
        return "SDN_low";
      case kFcSdaHigh:
        return "SDA_high";
      case kFcSdnHigh:
        return "SDN_high";
      case kFcMsrd:
        return "MSRD";
      case kFcFdlStatus:
        return "FDL_Status";
      case kFcSrdLow:
        return "SRD_low";
      case kFcSrdHigh:
        return "SRD_high";
      case kFcIdent:
        return "Ident";
      case kFcLsapStatus:
        return "LSAP_Status";
      default:
        return "req_fn" + std::to_string(fn);
    }
  }
  std::string s;
  switch (fn) {
    case kFcOk:
      s = "OK";
      break;
    case kFcUe:
      s = "UE";
      break;
    case kFcRr:
      s = "RR";
      break;
    case kFcRs:
      s = "RS";
      break;
    case kFcDl:
      s = "DL";
      break;
    case kFcNr:
      s = "NR";
      break;
    case kFcDh:
      s = "DH";
      break;
    case kFcRdl:
      s = "RDL";
      break;
    case kFcRdh:
      s = "RDH";
      break;
    default:
      s = "rsp_fn" + std::to_string(fn);
      break;
  }
  switch (fc & kFcStationTypeMask) {
    case kStationMasterNotReady:
      s += " master-not-ready";
      break;
    case kStationMasterReady:
      s += " master-ready";
      break;
    case kStationMasterInRing:
      s += " master-in-ring";
      break;
    default:
      break;
  }
  if (fc & 0x80) s += " (FC bit 7 set)";
  return s;
}

namespace {

Service service_of_sap(std::uint8_t sap) {
  switch (sap) {
    case kSapSetSlaveAdd:
      return Service::SetSlaveAdd;
    case kSapRdInp:
      return Service::RdInp;
    case kSapRdOutp:
      return Service::RdOutp;
    case kSapGlobalControl:
      return Service::GlobalControl;
    case kSapGetCfg:
      return Service::GetCfg;
    case kSapSlaveDiag:
      return Service::SlaveDiag;
    case kSapSetPrm:
      return Service::SetPrm;
    case kSapChkCfg:
      return Service::ChkCfg;
    default:
      return Service::OtherSap;
  }
}

Service service_of_request(const Telegram& r) {
  if (r.function() == kFcFdlStatus) return Service::FdlStatus;
  if (r.dsap) return service_of_sap(*r.dsap);
  return Service::DataExchange;
}

void append_flag(std::string& out, bool on, std::string_view name) {
  if (!on) return;
  if (!out.empty()) out += ' ';
  out += name;
}

std::string hex_or_none(std::span<const std::uint8_t> b) {
  return b.empty() ? "-" : hex_bytes(b);
}

}  // namespace

bool answers(const Telegram& response, const Telegram& request) {
  if (!request.is_request()) return false;
  if (response.kind == Kind::SC) return true;
  if (response.kind == Kind::SD4 || response.is_request()) return false;
  return response.da == request.sa && response.sa == request.da;
}

Service service_of(const Telegram& t, const Telegram* request) {
  if (t.kind == Kind::SD4) return Service::Token;
  if (t.kind != Kind::SC && t.is_request()) return service_of_request(t);
  if (request && answers(t, *request)) return service_of_request(*request);
  if (t.kind == Kind::SC) return Service::Ack;
  // A response without its request: the slave's SAP (SSAP) names the service.
  if (t.ssap) return service_of_sap(*t.ssap);
  const std::uint8_t fn = t.function();
  if (!t.du.empty() && (fn == kFcDl || fn == kFcDh)) return Service::DataExchange;
  return Service::Unknown;
}

std::string describe_set_prm(std::span<const std::uint8_t> du) {
  const auto p = dp::decode_prm_std(du);
  if (!p) return "short Set_Prm " + hex_or_none(du);
  std::string s;
  if (p->wd_on())
    s = "WD on " + std::to_string(p->watchdog_ms()) + " ms (" + std::to_string(p->wd_fact_1) + "x" +
        std::to_string(p->wd_fact_2) + ")";
  else
    s = "WD off";
  std::string flags;
  append_flag(flags, p->station_status & dp::kPrmLockReq, "Lock_Req");
  append_flag(flags, p->station_status & dp::kPrmUnlockReq, "Unlock_Req");
  append_flag(flags, p->sync_req(), "Sync_Req");
  append_flag(flags, p->freeze_req(), "Freeze_Req");
  if (!flags.empty()) s += ", " + flags;
  char ident[8];
  std::snprintf(ident, sizeof ident, "%04X", p->ident_number);
  s += ", min_TSDR " + std::to_string(p->min_tsdr) + ", ident " + ident + ", group " +
       hex_bytes(std::array{p->group_ident});
  const auto user = du.subspan(dp::kPrmStdLen);
  s += ", user " + hex_or_none(user);
  return s;
}

std::string describe_cfg(std::span<const std::uint8_t> cfg) {
  const auto r = dp::decode_chk_cfg(cfg);
  std::string s;
  for (std::size_t i = 0; i < r.entries.size(); ++i) {
    const auto& e = r.entries[i];
    if (!s.empty()) s += "; ";
    s += "slot" + std::to_string(i) + " ";
    auto unit = [](std::uint8_t n, bool words) { return std::to_string(n) + (words ? "w" : "B"); };
    switch (e.io) {
      case dp::CfgIo::Empty:
        s += "empty";
        break;
      case dp::CfgIo::Input:
        s += "in " + unit(e.count, e.words);
        break;
      case dp::CfgIo::Output:
        s += "out " + unit(e.count, e.words);
        break;
      case dp::CfgIo::InputOutput:
        s += "out " + unit(e.count, e.words) + " in " + unit(e.in_count, e.in_words);
        break;
    }
    if (e.consistent) s += " cons";
    if (!e.special) s += " general";
    if (!e.manufacturer.empty()) s += " [" + hex_bytes(e.manufacturer) + "]";
  }
  if (r.error) s += (s.empty() ? "" : "; ") + std::string("error: ") + r.error->message;
  if (s.empty()) s = "no entries";
  return s;
}

std::string describe_diag(std::span<const std::uint8_t> d) {
  if (d.size() < 6) return "short diagnosis " + hex_or_none(d);
  std::string s;
  // Station_Status_1 (manual table 3.4.3 / dp_telegram.hpp).
  append_flag(s, d[0] & dp::kDiag1StationNonExistent, "Station_Non_Existent");
  append_flag(s, d[0] & dp::kDiag1StationNotReady, "Station_Not_Ready");
  append_flag(s, d[0] & dp::kDiag1CfgFault, "Cfg_Fault");
  append_flag(s, d[0] & dp::kDiag1ExtDiag, "Ext_Diag");
  append_flag(s, d[0] & dp::kDiag1NotSupported, "Not_Supported");
  append_flag(s, d[0] & dp::kDiag1InvalidSlaveResponse, "Invalid_Slave_Response");
  append_flag(s, d[0] & dp::kDiag1PrmFault, "Prm_Fault");
  append_flag(s, d[0] & dp::kDiag1MasterLock, "Master_Lock");
  // Station_Status_2 (manual table 3.4.4).
  append_flag(s, d[1] & dp::kDiag2PrmReq, "Prm_Req");
  append_flag(s, d[1] & dp::kDiag2StatDiag, "Stat_Diag");
  append_flag(s, d[1] & dp::kDiag2WdOn, "WD_On");
  append_flag(s, d[1] & dp::kDiag2FreezeMode, "Freeze_Mode");
  append_flag(s, d[1] & dp::kDiag2SyncMode, "Sync_Mode");
  append_flag(s, d[1] & dp::kDiag2Deactivated, "Deactivated");
  if (!(d[1] & dp::kDiag2AlwaysOne)) append_flag(s, true, "(status2 bit2 clear)");
  append_flag(s, d[2] & 0x80, "Ext_Diag_Overflow");
  if (s.empty()) s = "OK";
  s += ", master " + (d[3] == dp::kNoMaster ? std::string("none") : std::to_string(d[3]));
  char ident[8];
  std::snprintf(ident, sizeof ident, "%02X%02X", d[4], d[5]);
  s += ", ident " + std::string(ident);
  if (d.size() > 6) s += ", ext " + hex_bytes(d.subspan(6));
  return s;
}

std::string describe_global_control(std::span<const std::uint8_t> du) {
  if (du.empty()) return "no control byte";
  std::string s;
  // Global_Control control command (EN 50170 vol. 2 DP): bit1 Clear_Data, bit2 Unfreeze,
  // bit3 Freeze, bit4 Unsync, bit5 Sync.
  append_flag(s, du[0] & 0x02, "Clear_Data");
  append_flag(s, du[0] & 0x04, "Unfreeze");
  append_flag(s, du[0] & 0x08, "Freeze");
  append_flag(s, du[0] & 0x10, "Unsync");
  append_flag(s, du[0] & 0x20, "Sync");
  if (s.empty()) s = "no command";
  if (du.size() > 1) s += ", group " + hex_bytes(du.subspan(1, 1));
  return s;
}

Description describe(const Telegram& t, const Telegram* request) {
  Description d;
  d.service = service_of(t, request);
  if (t.kind == Kind::SC) {
    d.text = "SC";
    if (request && answers(t, *request))
      d.text += " " + std::string(to_string(d.service)) + ".res " + std::to_string(request->da) +
                "->" + std::to_string(request->sa);
    return d;
  }
  if (t.kind == Kind::SD4) {
    d.text = "SD4 " + std::to_string(t.sa) + "->" + std::to_string(t.da) + " token";
    return d;
  }
  d.request = t.is_request();
  std::string& s = d.text;
  s = std::string(to_string(t.kind)) + " " + std::to_string(t.sa) + "->" + std::to_string(t.da);
  if (t.dsap || t.ssap) {
    s += " [";
    s += t.ssap ? std::to_string(*t.ssap) : std::string("-");
    s += "->";
    s += t.dsap ? std::to_string(*t.dsap) : std::string("-");
    s += "]";
  }
  const std::uint8_t fn = t.function();
  if (!(d.request && fn == kFcFdlStatus)) {  // else the service says it
    s += ' ';
    s += fc_name(t.fc);
  }
  if (d.request && fn != kFcFdlStatus && fn != kFcSdnLow && fn != kFcSdnHigh) {
    s += t.fcb() ? " FCB=1" : " FCB=0";
    s += t.fcv() ? " FCV=1" : " FCV=0";
  }
  if (t.da == kBroadcast && d.request) s += " broadcast";
  std::string service(to_string(d.service));
  if (d.service == Service::OtherSap) {
    const auto sap = d.request ? t.dsap : t.ssap;
    if (sap) service += std::to_string(*sap);
  }
  s += " " + service + (d.request ? ".req" : ".res");
  if (!d.request && !t.du.empty() && t.function() != kFcDl && t.function() != kFcDh &&
      t.function() != kFcRdl && t.function() != kFcRdh) {
    s += ": " + hex_bytes(t.du);
    return d;
  }
  if (t.du.empty()) return d;
  std::string payload;
  switch (d.service) {
    case Service::SetPrm:
      payload = d.request ? describe_set_prm(t.du) : hex_bytes(t.du);
      break;
    case Service::ChkCfg:
      payload = d.request ? describe_cfg(t.du) : hex_bytes(t.du);
      break;
    case Service::GetCfg:
      payload = d.request ? hex_bytes(t.du) : describe_cfg(t.du);
      break;
    case Service::SlaveDiag:
      payload = d.request ? hex_bytes(t.du) : describe_diag(t.du);
      break;
    case Service::GlobalControl:
      payload = describe_global_control(t.du);
      break;
    case Service::DataExchange:
    case Service::RdInp:
      payload = std::string(d.request ? "out " : "in ") + hex_bytes(t.du);
      break;
    case Service::RdOutp:
      payload = "out " + hex_bytes(t.du);
      break;
    default:
      payload = hex_bytes(t.du);
      break;
  }
  s += ": " + payload;
  return d;
}

Description Describer::describe(const Telegram& t) {
  const Telegram* req = last_request_ ? &*last_request_ : nullptr;
  Description d = fdl::describe(t, req);
  if (d.request) last_request_ = t;
  return d;
}

}  // namespace candp2::fdl
