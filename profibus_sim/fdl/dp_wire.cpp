// DP services as FDL telegrams (EN 50170 vol. 2 DP over IEC 61158-4-3 FDL; docs/decisions.md
// "FDL on the wire").
#include "profibus_sim/fdl/dp_wire.hpp"

namespace candp2::fdl {

std::optional<std::uint8_t> dsap_of(dp::Service s) {
  switch (s) {
    case dp::Service::SlaveDiag:
      return kSapSlaveDiag;
    case dp::Service::SetPrm:
      return kSapSetPrm;
    case dp::Service::ChkCfg:
      return kSapChkCfg;
    case dp::Service::GetCfg:
      return kSapGetCfg;
    case dp::Service::GlobalControl:
      return kSapGlobalControl;
    case dp::Service::DataExchange:
      return std::nullopt;  // the default SAP: no address extension
    case dp::Service::SetSlaveAdd:
      return kSapSetSlaveAdd;
    case dp::Service::RdInp:
      return kSapRdInp;
    case dp::Service::RdOutp:
      return kSapRdOutp;
  }
  return std::nullopt;
}

void fdl_status_request_to(Telegram& out, std::uint8_t station, std::uint8_t master) {
  out.assign(Kind::SD1, station, master, request_fc(kFcFdlStatus));
}

Telegram fdl_status_request(std::uint8_t station, std::uint8_t master) {
  Telegram t;
  fdl_status_request_to(t, station, master);
  return t;
}

void dp_request_to(Telegram& out, const dp::Request& req, std::uint8_t station, std::uint8_t master,
                   const FcbSequence& seq) {
  if (req.service == dp::Service::GlobalControl) {
    // Global_Control is SDN (no answer) to DSAP 58; SDN carries no FCB/FCV.
    return out.assign_with_data(station, master, request_fc(kFcSdnHigh), kSapGlobalControl,
                                kMasterSap, req.data);
  }
  const std::uint8_t fc = request_fc(kFcSrdHigh, seq.fcb, seq.fcv);
  const auto dsap = dsap_of(req.service);
  if (!dsap && req.data.empty()) return out.assign(Kind::SD1, station, master, fc);
  out.assign_with_data(station, master, fc, dsap, dsap ? std::optional(kMasterSap) : std::nullopt,
                       req.data);
}

Telegram dp_request(const dp::Request& req, std::uint8_t station, std::uint8_t master,
                    const FcbSequence& seq) {
  Telegram t;
  dp_request_to(t, req, station, master, seq);
  return t;
}

namespace {

void short_answer_to(Telegram& out, const Telegram& request, std::uint8_t function) {
  out.assign(Kind::SD1, request.sa, request.da, response_fc(function));
}

void data_answer_to(Telegram& out, const Telegram& request, std::uint8_t function,
                    std::span<const std::uint8_t> data) {
  if (!request.dsap && !request.ssap && data.empty())
    return short_answer_to(out, request, function);
  out.assign_with_data(request.sa, request.da, response_fc(function), request.ssap, request.dsap,
                       data);
}

void data_exchange_answer_to(Telegram& out, const Telegram& request,
                             std::span<const std::uint8_t> inputs, bool diag_pending) {
  const std::uint8_t fn = diag_pending ? kFcDh : kFcDl;
  if (inputs.empty())
    return diag_pending ? short_answer_to(out, request, fn) : out.assign(Kind::SC, 0, 0, 0);
  out.assign_with_data(request.sa, request.da, response_fc(fn), std::nullopt, std::nullopt, inputs);
}

}  // namespace

Telegram short_answer(const Telegram& request, std::uint8_t function) {
  Telegram t;
  short_answer_to(t, request, function);
  return t;
}

Telegram data_answer(const Telegram& request, std::uint8_t function,
                     std::span<const std::uint8_t> data) {
  Telegram t;
  data_answer_to(t, request, function, data);
  return t;
}

Telegram data_exchange_answer(const Telegram& request, std::span<const std::uint8_t> inputs,
                              bool diag_pending) {
  Telegram t;
  data_exchange_answer_to(t, request, inputs, diag_pending);
  return t;
}

bool dp_answer_to(Telegram& out, const Telegram& request, dp::Service service,
                  const dp::Response& response) {
  using Status = dp::Response::Status;
  if (service == dp::Service::GlobalControl || response.status == Status::NoResponse) return false;
  // A refusal: the service's SAP is not active (docs/decisions.md "FDL on the wire").
  if (response.status == Status::Refused) {
    short_answer_to(out, request, kFcRs);
    return true;
  }
  switch (service) {
    case dp::Service::SetPrm:
    case dp::Service::ChkCfg:
    case dp::Service::SetSlaveAdd:
      out.assign(Kind::SC, 0, 0, 0);
      return true;
    case dp::Service::DataExchange:
      data_exchange_answer_to(out, request, response.data, response.diag_pending);
      return true;
    case dp::Service::SlaveDiag:
    case dp::Service::GetCfg:
    case dp::Service::GlobalControl:
    case dp::Service::RdInp:
    case dp::Service::RdOutp:
      break;
  }
  data_answer_to(out, request, kFcDl, response.data);
  return true;
}

std::optional<Telegram> dp_answer(const Telegram& request, dp::Service service,
                                  const dp::Response& response) {
  Telegram t;
  if (!dp_answer_to(t, request, service, response)) return std::nullopt;
  return t;
}

// ---------------------------------------------------------------- WireImageLink

void WireImageLink::report(const Telegram& t, bool from_master, Time now) {
  buf_.clear();
  encode_to(t, buf_);
  if (!buf_.empty() && observer_) observer_(buf_, from_master, now);
}

void WireImageLink::request(dp::Request req, Time now, dp::Completion done) {
  const std::uint8_t station = inner_.address();
  const std::uint8_t master = req.master;
  if (!known_) {
    // A master asks a station for its FDL status before its first DP request; the FCB
    // sequence starts afresh after it.
    const Telegram status = fdl_status_request(station, master);
    report(status, true, now);
    report(short_answer(status, kFcOk), false, now);
    known_ = true;
    seq_.restart();
  }
  const dp::Service service = req.service;
  Telegram telegram = dp_request(req, station, master, seq_);
  report(telegram, true, now);
  inner_.request(std::move(req), now,
                 [this, telegram = std::move(telegram), service, done = std::move(done)](
                     const dp::Response& r, Time at) {
                   if (r.status == dp::Response::Status::NoResponse) {
                     known_ = false;  // the station is lost: FDL_Status again next time
                   } else if (auto answer = dp_answer(telegram, service, r)) {
                     report(*answer, false, at);
                     seq_.advance();
                   }
                   done(r, at);
                 });
}

}  // namespace candp2::fdl
