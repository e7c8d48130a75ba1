#include "profibus_sim/fdl/fdl_master.hpp"

#include <algorithm>

#include "common/hex.hpp"
#include "common/line_physics.hpp"
#include "profibus_sim/fdl/dp_wire.hpp"

namespace candp2::fdl {

// docs/profibus.md "The line's physics": a telegram is preceded by ≥ TSYN of idle.
using phy::kTsynBits;

// One remote station: the dp::SlaveLink the DP master uses, and the station's FCB state.
class FdlMaster::Remote final : public dp::SlaveLink {
 public:
  Remote(FdlMaster& master, std::uint8_t address) : master_(master), address_(address) {}
  std::uint8_t address() const override { return address_; }
  void request(dp::Request req, Time now, dp::Completion done) override {
    master_.enqueue({this, std::move(req), std::move(done)}, now);
  }

  bool known = false;  // answered FDL_Status since start or since it was lost
  FcbSequence fcb;     // FCB/FCV of the next new SRD
  MasterStationStats stats;

 private:
  FdlMaster& master_;
  std::uint8_t address_;
};

FdlMaster::FdlMaster(MasterStationOptions options, SendFn send, LogSink* log)
    : options_(options), send_(std::move(send)), log_(log, "fdl-master") {}

FdlMaster::~FdlMaster() = default;

dp::SlaveLink& FdlMaster::station(std::uint8_t address) {
  auto& slot = stations_[address];
  if (!slot) slot = std::make_unique<Remote>(*this, address);
  return *slot;
}

const MasterStationStats* FdlMaster::stats(std::uint8_t address) const {
  const auto it = stations_.find(address);
  return it == stations_.end() ? nullptr : &it->second->stats;
}

Duration FdlMaster::bit_times(std::uint64_t bits) const {
  return phy::bits_to_time(std::max<std::uint32_t>(options_.baud, 1), bits);
}

// ---------------------------------------------------------------- requests

void FdlMaster::enqueue(Pending p, Time now) {
  queue_.push_back(std::move(p));
  if (!current_ && !completing_) start_next(now);
}

void FdlMaster::start_next(Time now) {
  if (current_ || queue_.empty() || now < line_free_at_) return;
  Outstanding o;
  o.pending = std::move(queue_.front());
  queue_.pop_front();
  // docs/profibus.md: FDL_Status first, at start and after the station was lost.
  o.fdl_status = !o.pending.station->known;
  current_ = std::move(o);
  current_->bytes = build(*current_);
  transmit(now);
}

std::vector<std::uint8_t> FdlMaster::build(Outstanding& o) {
  Remote& st = *o.pending.station;
  // FDL_Status (SD1 FC 0x49, no FCB/FCV) before a station's first request; DP requests with the
  // station's FCB sequence, Global_Control as SDN (profibus_sim/fdl/dp_wire.hpp).
  const Telegram t = o.fdl_status
                         ? fdl_status_request(st.address(), options_.address)
                         : dp_request(o.pending.request, st.address(), options_.address, st.fcb);
  o.fc = t.fc;
  return encode(t);
}

void FdlMaster::transmit(Time now) {
  Outstanding& o = *current_;
  Remote& st = *o.pending.station;
  ++st.stats.telegrams_sent;
  if (o.fdl_status) ++st.stats.fdl_status;
  if (log_.enabled(LogLevel::Debug))
    log_.debug("station " + std::to_string(st.address()) + " <- " + hex_bytes(o.bytes) +
               (o.attempt ? " (retry " + std::to_string(o.attempt) + ")" : ""));
  // The slot time runs from the request's last character (docs/profibus.md "Timing").
  o.request_end = now + wire_time(o.bytes.size());
  o.deadline = o.request_end + bit_times(options_.slot_time_bits) + options_.latency_allowance;
  o.answer_started = false;
  const bool sdn = !o.fdl_status && o.pending.request.service == dp::Service::GlobalControl;
  const Time request_end = o.request_end;
  const std::vector<std::uint8_t> bytes = o.bytes;
  send_(bytes, now);  // an in-memory line may answer from inside: `o` may be gone after this
  if (sdn && current_) {
    // SDN: no answer to wait for; the line is free after the telegram and TSYN.
    line_free_at_ = request_end + bit_times(kTsynBits);
    finish({dp::Response::Status::Ok, {}, false}, now);
  }
}

void FdlMaster::finish(dp::Response r, Time now) {
  Pending p = std::move(current_->pending);
  current_.reset();
  completing_ = true;
  p.done(r, now);
  completing_ = false;
  start_next(now);
}

// ---------------------------------------------------------------- answers

void FdlMaster::on_bytes(std::span<const std::uint8_t> bytes, Time now) {
  if (current_ && !bytes.empty() && !current_->answer_started) {
    // The answer began within the slot time: wait for its last character.
    current_->answer_started = true;
    current_->deadline =
        std::max(current_->deadline, now + wire_time(kMaxTelegramLen) + options_.latency_allowance);
  }
  parser_.feed(bytes);
  drain(now);
}

void FdlMaster::on_bad_char(std::uint8_t byte, Time now) {
  parser_.feed_bad_char(byte);
  drain(now);
}

void FdlMaster::on_gap(Time now) {
  parser_.gap();
  drain(now);
}

void FdlMaster::drain(Time now) {
  while (auto ev = parser_.next()) {
    if (ev->error != Error::None) {
      // A bad FCS, framing or parity error: no answer; the slot timer runs on and the request is
      // repeated (docs/profibus.md). The parser counts it (line_stats()).
      log_.debug("line: " + std::string(to_string(ev->error)) + ": " + hex_bytes(ev->raw));
      if (drop_observe_) drop_observe_(ev->raw, now);
      continue;
    }
    if (observe_) observe_(ev->raw, now);
    on_telegram(ev->telegram, now);
  }
}

std::optional<dp::Response> FdlMaster::match(const Telegram& t) const {
  const Outstanding& o = *current_;
  const std::uint8_t station = o.pending.station->address();
  if (t.kind == Kind::SC) {
    // Short acknowledge: a positive answer without data; never to FDL_Status.
    if (o.fdl_status) return std::nullopt;
    return dp::Response{dp::Response::Status::Ok, {}, false};
  }
  if (t.kind == Kind::SD4 || t.is_request()) return std::nullopt;
  if (t.sa != station || t.da != options_.address) return std::nullopt;
  if (o.fdl_status) {
    if (t.kind != Kind::SD1) return std::nullopt;
    return dp::Response{dp::Response::Status::Ok, {}, false};
  }
  // An answer with SAPs has them swapped (docs/profibus.md): DSAP = our SSAP, SSAP = the DSAP.
  const auto dsap = dsap_of(o.pending.request.service);
  if (t.dsap && (!dsap || *t.dsap != kMasterSap)) return std::nullopt;
  if (t.ssap && (!dsap || *t.ssap != *dsap)) return std::nullopt;
  switch (t.function()) {
    case kFcOk:
    case kFcNr:
      return dp::Response{dp::Response::Status::Ok, t.du, false};
    case kFcDl:
    case kFcDh:
      return dp::Response{dp::Response::Status::Ok, t.du, t.function() == kFcDh};
    case kFcUe:
    case kFcRr:
    case kFcRs:
    case kFcRdl:
    case kFcRdh:
      return dp::Response{dp::Response::Status::Refused, {}, false};
    default:
      return std::nullopt;
  }
}

void FdlMaster::on_telegram(const Telegram& t, Time now) {
  if (!current_) {
    log_.debug("telegram with no request outstanding ignored: " + hex_bytes(encode(t)));
    return;
  }
  Outstanding& o = *current_;
  Remote& st = *o.pending.station;
  if (t.is_request() && t.sa == options_.address && t.kind != Kind::SC) return;  // own echo
  auto r = match(t);
  if (!r) {
    ++st.stats.invalid;
    log_.debug("station " + std::to_string(st.address()) +
               ": answer not taken: " + hex_bytes(encode(t)));
    return;  // as no answer: the slot timer decides
  }
  const Duration rt = std::max(Duration(0), now - o.request_end);
  auto& s = st.stats;
  if (s.responses == 0 || rt < s.rt_min) s.rt_min = rt;
  s.rt_max = std::max(s.rt_max, rt);
  s.rt_sum += rt;
  ++s.responses;
  std::size_t bucket = 0;
  while (bucket < kResponseBuckets.size() && rt.count() > kResponseBuckets[bucket]) ++bucket;
  ++s.rt_histogram[bucket];
  line_free_at_ = now + bit_times(kTsynBits);

  if (o.fdl_status) {
    // docs/profibus.md: the FCB sequence starts afresh after FDL_Status.
    st.known = true;
    st.fcb.restart();
    log_.info("station " + std::to_string(st.address()) + " answers FDL_Status (FC 0x" +
              hex_bytes(std::span(&t.fc, 1)) + ")");
    queue_.push_front(std::move(o.pending));
    current_.reset();
    start_next(now);  // the DP request follows after TSYN (advance())
    return;
  }
  st.fcb.advance();
  finish(std::move(*r), now);
}

// ---------------------------------------------------------------- time

std::optional<Time> FdlMaster::next_deadline() const {
  if (current_) return current_->deadline;
  if (!queue_.empty()) return line_free_at_;
  return std::nullopt;
}

void FdlMaster::advance(Time now) {
  if (current_ && now >= current_->deadline) expire(now);
  if (!current_ && !completing_) start_next(now);
}

void FdlMaster::expire(Time now) {
  Outstanding& o = *current_;
  Remote& st = *o.pending.station;
  ++st.stats.timeouts;
  if (o.attempt < options_.retries) {
    // docs/profibus.md: repeat up to max_retry_limit times, with the SAME FCB.
    ++o.attempt;
    log_.debug("station " + std::to_string(st.address()) +
               ": no answer within the slot time, retry " + std::to_string(o.attempt) + " of " +
               std::to_string(options_.retries));
    transmit(now);
    return;
  }
  if (st.known) {
    ++st.stats.lost;
    log_.warn("station " + std::to_string(st.address()) + ": no answer to " +
              (o.fdl_status ? std::string("FDL_Status")
                            : std::string(dp::to_string(o.pending.request.service))) +
              " after " + std::to_string(options_.retries) + " retries: station lost");
  }
  st.known = false;  // FDL_Status again before the next request
  line_free_at_ = now;
  finish({dp::Response::Status::NoResponse, {}, false}, now);
}

}  // namespace candp2::fdl
