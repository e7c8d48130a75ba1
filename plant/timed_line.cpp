// The in-process PROFIBUS line in time (docs/profibus.md "The line in time").
#include "plant/timed_line.hpp"

#include <algorithm>

namespace candp2::plant {

using fdl::kBitsPerChar;
using fdl::kMinTsdrBits;

class TimedLine::Station final : public dp::SlaveLink {
 public:
  Station(TimedLine& line, dp::SlaveLink& inner, const dp::DpSlave& slave,
          std::optional<std::uint32_t> max_tsdr)
      : line_(line), inner_(inner), slave_(slave), max_tsdr_(max_tsdr) {}
  TimedLine& line_;
  std::uint8_t address() const override { return inner_.address(); }
  void request(dp::Request req, Time now, dp::Completion done) override {
    line_.enqueue(Job{this, std::move(req), std::move(done)}, now);
  }
  std::uint32_t tsdr() const {
    const std::uint32_t t = std::max<std::uint32_t>(min_tsdr_, kMinTsdrBits);
    return max_tsdr_ ? std::min(t, *max_tsdr_) : t;
  }

  dp::SlaveLink& inner_;
  const dp::DpSlave& slave_;
  std::optional<std::uint32_t> max_tsdr_;
  std::uint32_t min_tsdr_ = kMinTsdrBits;  // IEC 61158-6-3: until Set_Prm sets another
  bool known_ = false;                     // FDL_Status answered since the start or the last loss
  fdl::FcbSequence seq_;

  // The fault on cue (docs/faults.md "Line faults") and how far it has gone.
  LineFault fault_;
  std::uint32_t remaining_ = 0;
  std::uint64_t received_ = 0;  // requests received since it was injected
  Time until_{0};
  // The fault the answer to a request received at `t` gets (None: none).
  fdl::StationFault applies(Time t) {
    if (fault_.kind == LineFaultKind::None) return fdl::StationFault::None;
    if (fault_.duration && t >= until_) {
      fault_.kind = LineFaultKind::None;
      return fdl::StationFault::None;
    }
    const std::uint64_t n = received_++;
    if (n % std::max<std::uint32_t>(fault_.every, 1) != 0) return fdl::StationFault::None;
    const fdl::StationFault kind = station_fault(fault_.kind);
    if (!fault_.duration && --remaining_ == 0) fault_.kind = LineFaultKind::None;
    return kind;
  }
};

TimedLine::TimedLine(std::uint32_t baud, fdl::BusParameters params, std::uint8_t master,
                     Time origin, LogSink* log)
    : baud_(baud),
      params_(params),
      master_(master),
      origin_(origin),
      log_(log, "line"),
      gap_next_(static_cast<std::uint8_t>(master + 1)) {}

TimedLine::~TimedLine() = default;

dp::SlaveLink& TimedLine::add_station(dp::SlaveLink& inner, const dp::DpSlave& slave,
                                      std::optional<std::uint32_t> max_tsdr_bits) {
  auto s = std::make_unique<Station>(*this, inner, slave, max_tsdr_bits);
  Station& ref = *s;
  stats_.configure(inner.address());
  stations_[inner.address()] = std::move(s);
  return ref;
}

void TimedLine::restarted(std::uint8_t address) {
  if (const auto it = stations_.find(address); it != stations_.end()) {
    it->second->known_ = false;
    it->second->min_tsdr_ = kMinTsdrBits;
  }
}

bool TimedLine::inject(const LineFault& fault, Time now) {
  const auto it = stations_.find(fault.station);
  if (it == stations_.end()) return false;
  Station& s = *it->second;
  s.fault_ = fault;
  s.remaining_ = fault.count;
  s.received_ = 0;
  s.until_ = fault.duration ? now + *fault.duration : Time{0};
  if (fault.kind == LineFaultKind::Noise || (!fault.duration && fault.count == 0))
    s.fault_.kind = LineFaultKind::None;
  return true;
}

void TimedLine::noise(Duration duration, Time now) {
  noise_from_ = now;
  noise_until_ = now + duration;
}

TimedLine::FaultState TimedLine::fault(std::uint8_t address, Time now) const {
  const auto it = stations_.find(address);
  if (it == stations_.end()) return {};
  const Station& s = *it->second;
  if (s.fault_.kind == LineFaultKind::None) return {};
  const fdl::StationFault kind = station_fault(s.fault_.kind);
  if (s.fault_.duration) {
    if (now >= s.until_) return {};
    return {kind, 0, s.fault_.every, s.until_ - now};
  }
  return {kind, s.remaining_, s.fault_.every, Duration(0)};
}

bool TimedLine::noisy(std::uint64_t bit) const {
  const Time t = time_of(bit);
  return t >= noise_from_ && t < noise_until_;
}

std::uint32_t TimedLine::tsdr_bits(std::uint8_t address) const {
  const auto it = stations_.find(address);
  return it == stations_.end() ? kMinTsdrBits : it->second->tsdr();
}

std::uint64_t TimedLine::start_bit(Time t) const {
  if (t <= time_of(free_bit_)) return free_bit_;
  return fdl::time_to_bits(baud_, t - origin_);
}

// ---------------------------------------------------------------------------------- rotation

void TimedLine::OnLine::begin() {
  job.reset();
  fdl_status = false;
  attempt = 0;
  answer.status = dp::Response::Status::NoResponse;
  answer.data.clear();
  answer.diag_pending = false;
  stored = handed_over = false;
  deaf = illegal = false;
  late.clear();
}

void TimedLine::begin_rotation(Time /*now*/) {
  rotating_ = true;
  token_sent_ = false;
  rotation_start_.reset();
  holding_ = true;
  sorted_from_ = queue_.size();
}

void TimedLine::end_issue(Time now) {
  holding_ = false;
  // docs/profibus.md "The line in time": the master polls its stations in address order.
  const auto by_address = [](const Job& a, const Job& b) {
    return a.station->address() < b.station->address();
  };
  const auto first = queue_.begin() + static_cast<std::ptrdiff_t>(std::max(sorted_from_, head_));
  if (!std::is_sorted(first, queue_.end(), by_address))  // the master issues them in order
    std::stable_sort(first, queue_.end(), by_address);
  if (phase_ == Phase::Idle) start_next(start_bit(now));
  advance(now);  // a request that starts now shows on the tap now
}

void TimedLine::enqueue(Job job, Time now) {
  if (answering_ && job.station == answering_) {
    // docs/profibus.md "The line in time": the next step of the station follows its answer at once.
    queue_.insert(queue_.begin() + static_cast<std::ptrdiff_t>(head_), std::move(job));
    if (sorted_from_ > head_) ++sorted_from_;
  } else {
    queue_.push_back(std::move(job));
  }
  if (holding_ || phase_ != Phase::Idle) return;
  start_next(start_bit(now));
  advance(now);
}

std::optional<std::uint8_t> TimedLine::next_gap_address() {
  // The GAP: the addresses above the master's own up to HSA that are not in the ring.
  const unsigned first = master_ + 1u, hsa = std::min<unsigned>(params_.hsa, 126);
  if (first > hsa) return std::nullopt;
  const unsigned span = hsa - first + 1;
  for (unsigned i = 0; i < span; ++i) {
    unsigned a = gap_next_ < first || gap_next_ > hsa ? first : gap_next_;
    a = first + (a - first + i) % span;
    if (stations_.count(static_cast<std::uint8_t>(a))) continue;
    gap_next_ = static_cast<std::uint8_t>(a + 1);
    return static_cast<std::uint8_t>(a);
  }
  return std::nullopt;
}

void TimedLine::start_next(std::uint64_t at_bit) {
  if (phase_ != Phase::Idle) return;
  OnLine& o = current_;
  if (head_ < queue_.size()) {
    o.begin();
    o.job = std::move(queue_[head_++]);
    if (head_ == queue_.size()) {  // all taken: the vector starts again (its storage stays)
      queue_.clear();
      head_ = sorted_from_ = 0;
    }
    Station& s = *o.job->station;
    o.fdl_status = !s.known_;
    if (o.fdl_status)
      fdl::fdl_status_request_to(o.telegram, s.address(), master_);
    else
      fdl::dp_request_to(o.telegram, o.job->request, s.address(), master_, s.seq_);
    return put_request(at_bit);
  }
  if (!rotating_ || token_sent_) return;
  o.begin();
  // Every gap_factor rotations one FDL_Status into the GAP (docs/profibus.md), then the token.
  const std::uint32_t g = std::max<std::uint32_t>(params_.gap_factor, 1);
  if (!gap_done_ && rotations_ % g == g - 1) {
    gap_done_ = true;
    if (const auto a = next_gap_address()) {
      ++gap_polls_;
      fdl::fdl_status_request_to(o.telegram, *a, master_);
      return put_request(at_bit);
    }
  }
  token_sent_ = true;
  o.telegram.assign(fdl::Kind::SD4, master_, master_, 0);
  put_request(at_bit);
}

void TimedLine::put_request(std::uint64_t at_bit) {
  OnLine& o = current_;
  o.request.clear();
  fdl::encode_to(o.telegram, o.request);
  if (late_ && std::max(at_bit, free_bit_) != late_->bit) flush_late();
  const std::uint64_t start = std::max(at_bit, free_bit_);
  if (rotating_ && !rotation_start_) rotation_start_ = start;
  if (rotating_ && o.job &&
      (o.fdl_status || o.job->request.service == dp::Service::SetPrm ||
       o.job->request.service == dp::Service::ChkCfg))
    parameterizes_ = true;
  request_start_ = start;
  request_end_ = start + kBitsPerChar * o.request.size();
  // docs/faults.md "Line faults": noise garbles it; a late answer starting with it collides.
  if (noisy(start)) {
    o.request = fdl::garble(o.request, start);
    o.deaf = true;
  }
  if (late_) {
    const fdl::Superposed both = fdl::superpose(o.request, late_->bytes, 0);
    late_.reset();
    o.request = both.bytes;
    request_end_ = start + both.bits;
    o.deaf = true;
  }
  event_bit_ = start;
  phase_ = Phase::Sync;
  // docs/profibus.md "The line in time": an idle shorter than the event loop's timer slack is
  // not waited for on its own: the telegram goes to the tap now, stamped with its first bit.
  if (merged(start - std::min(start, at_bit))) on_request_start();
}

void TimedLine::on_request_start() {
  // Its first character: the tap sees it now, stamped with this bit (docs/capture.md).
  emit(current_.request, true, request_start_, request_end_,
       current_.deaf ? nullptr : &current_.telegram);  // garbled: decoded from the bytes
  phase_ = Phase::Request;
  event_bit_ = request_end_;
}

// ------------------------------------------------------------------------------------ events

Time TimedLine::event_time() const {
  if (event_bit_ != deadline_bit_) {  // asked often an event: one division then
    deadline_bit_ = event_bit_;
    deadline_time_ = time_of(event_bit_);
  }
  return deadline_time_;
}

std::optional<Time> TimedLine::next_deadline() const {
  if (phase_ == Phase::Idle) return std::nullopt;
  return std::max(event_time(), handled_ + step_);
}

void TimedLine::advance(Time now) {
  now_ = std::max(now_, now);
  // An event is due when its stamp, the first µs at or after its bit, is not after `now`.
  auto is_due = [&] { return phase_ != Phase::Idle && event_time() <= now; };
  if (is_due()) handled_ = now;
  while (is_due()) {
    holding_ = true;
    switch (phase_) {
      case Phase::Sync:
        on_request_start();
        break;
      case Phase::Request:
        on_request_end();
        break;
      case Phase::Tsdr:
        on_response_start();
        break;
      case Phase::Response:
        on_response_end();
        break;
      case Phase::SlotTime:
        on_slot_expired();
        break;
      case Phase::Unanswered:
        on_unanswered_end();
        break;
      case Phase::Idle:
        break;
    }
    holding_ = false;
    if (phase_ == Phase::Idle) start_next(event_bit_);
    if (late_) flush_late();  // nothing started with it
  }
}

void TimedLine::flush_late() {
  // A late answer alone on the line: nothing started with it (docs/faults.md "Line faults").
  Late l = std::move(*late_);
  late_.reset();
  const std::uint64_t end = l.bit + kBitsPerChar * l.bytes.size();
  emit(l.bytes, false, l.bit, end);
  free_bit_ = std::max(free_bit_, end + fdl::kTsynBits);
}

void TimedLine::emit(std::span<const std::uint8_t> bytes, bool from_master, std::uint64_t start,
                     std::uint64_t end, const fdl::Telegram* decoded) {
  if (record_)
    recorded_.push_back(
        {start, end, from_master, std::vector<std::uint8_t>(bytes.begin(), bytes.end())});
  const Time at = time_of(start);
  stats_.observe(bytes, at, decoded);
  if (tap_) tap_(bytes, from_master, at);
}

void TimedLine::on_request_end() {
  OnLine& o = current_;
  const std::uint64_t end = event_bit_;
  if (!o.job) {
    if (o.telegram.kind == fdl::Kind::SD4) {  // the token: nobody answers; TID2
      phase_ = Phase::Unanswered;
      event_bit_ = end + fdl::tid2_bits(params_);
    } else {  // FDL_Status into the GAP: nobody there; the slot time runs out
      phase_ = Phase::SlotTime;
      event_bit_ = end + params_.slot_time_bits;
    }
    return;
  }
  Station& s = *o.job->station;
  const bool sdn = !o.fdl_status && o.job->request.service == dp::Service::GlobalControl;
  // A garbled request reaches nobody; a silent station answers nothing (docs/faults.md).
  const fdl::StationFault fault = o.deaf ? fdl::StationFault::None : s.applies(time_of(end));
  if (o.deaf || fault == fdl::StationFault::Silent) {
    phase_ = sdn ? Phase::Unanswered : Phase::SlotTime;
    event_bit_ = end + (sdn ? fdl::tid2_bits(params_) : params_.slot_time_bits);
    if (sdn) o.answer = dp::Response{};  // nobody got it
    return;
  }
  bool answered = false;
  if (o.fdl_status) {
    if (!s.slave_.offline()) {
      o.answer_telegram = fdl::short_answer(o.telegram, fdl::kFcOk);
      answered = true;
    }
  } else {
    const dp::Service service = o.job->request.service;
    if (!o.stored) {
      dp::Request& req = o.job->request;
      // It went to the station before without an answer (offline): its bytes again, from the
      // telegram they travel in (the request itself was handed over).
      if (o.handed_over) req.data.assign(o.telegram.du.begin(), o.telegram.du.end());
      if (service == dp::Service::SetPrm && req.data.size() > 3 && req.data[3] != 0)
        s.min_tsdr_ = req.data[3];  // min_TSDR, Set_Prm byte 3 (IEC 61158-6-3)
      // The station gets the request now: its last character has arrived. Its answer goes
      // into the exchange's own (no answer: NoResponse, as begin() left it).
      dp::Response& a = o.answer;
      o.handed_over = true;
      s.inner_.request(std::move(req), time_of(end), [&a](const dp::Response& resp, Time /*at*/) {
        a.status = resp.status;
        a.data.assign(resp.data.begin(), resp.data.end());
        a.diag_pending = resp.diag_pending;
      });
    }
    answered = fdl::dp_answer_to(o.answer_telegram, o.telegram, service, o.answer);
    if (sdn) {  // SDN: no answer; TID2
      phase_ = Phase::Unanswered;
      event_bit_ = end + fdl::tid2_bits(params_);
      return;
    }
    // It answered: a repeat of this request gets the same answer, as FCB repetition says.
    o.stored = answered;
  }
  if (!answered) {
    phase_ = Phase::SlotTime;
    event_bit_ = end + params_.slot_time_bits;
    return;
  }
  o.response.clear();
  fdl::encode_to(o.answer_telegram, o.response);
  o.response_bits = kBitsPerChar * o.response.size();
  o.illegal = false;
  switch (fault) {
    case fdl::StationFault::Corrupt:
      o.response = fdl::corrupt_fcs(o.response);
      o.illegal = true;
      break;
    case fdl::StationFault::DoubleAddress: {
      const fdl::Superposed both = fdl::superpose(o.response, o.response, fdl::kTwinOffsetBits);
      o.response = both.bytes;
      o.response_bits = both.bits;
      o.illegal = true;
      break;
    }
    case fdl::StationFault::Late:  // it starts when the slot time has expired
      o.late = std::move(o.response);
      o.response.clear();
      phase_ = Phase::SlotTime;
      event_bit_ = end + params_.slot_time_bits;
      return;
    default:
      break;
  }
  response_start_ = end + s.tsdr();
  if (noisy(response_start_)) {
    o.response = fdl::garble(o.response, response_start_);
    o.illegal = true;
  }
  event_bit_ = response_start_;
  phase_ = Phase::Tsdr;
  if (merged(response_start_ - end)) on_response_start();
}

void TimedLine::on_response_start() {
  phase_ = Phase::Response;
  event_bit_ = response_start_ + current_.response_bits;
  emit(current_.response, false, response_start_, event_bit_,
       current_.illegal ? nullptr : &current_.answer_telegram);
}

void TimedLine::on_response_end() {
  OnLine& o = current_;
  phase_ = Phase::Idle;
  if (o.illegal) return unanswered(event_bit_ + fdl::tid1_bits(params_));
  free_bit_ = event_bit_ + fdl::tid1_bits(params_);
  Station& s = *o.job->station;
  if (o.fdl_status) {
    // Known now: the DP request follows after TID1, its FCB sequence starts afresh.
    s.known_ = true;
    s.seq_.restart();
    o.fdl_status = false;
    o.attempt = 0;
    fdl::dp_request_to(o.telegram, o.job->request, s.address(), master_, s.seq_);
    return put_request(free_bit_);
  }
  s.seq_.advance();
  complete(o.answer, event_bit_);  // the next exchange begins after it
}

void TimedLine::complete(const dp::Response& r, std::uint64_t at_bit) {
  OnLine& o = current_;
  answering_ = o.job->station;
  o.job->done(r, time_of(at_bit));
  answering_ = nullptr;
}

void TimedLine::on_slot_expired() {
  OnLine& o = current_;
  phase_ = Phase::Idle;
  // A late answer starts now, with whatever the master sends next (docs/faults.md).
  if (!o.late.empty()) late_ = Late{event_bit_, std::move(o.late)};
  if (!o.job) {  // the GAP: nobody answered; the token follows
    free_bit_ = event_bit_;
    return;
  }
  unanswered(event_bit_);  // the line has been idle for the slot time (> TSYN)
}

void TimedLine::unanswered(std::uint64_t free_bit) {
  OnLine& o = current_;
  free_bit_ = free_bit;
  if (o.attempt < params_.retry_limit) {
    ++o.attempt;
    ++retries_;
    o.deaf = o.illegal = false;
    return put_request(free_bit_);
  }
  // Retries exhausted: the station is lost; FDL_Status again before its next request.
  o.job->station->known_ = false;
  if (log_.enabled(LogLevel::Debug))
    log_.debug("station " + std::to_string(o.job->station->address()) + ": no valid answer after " +
               std::to_string(params_.retry_limit) + " retries");
  complete(dp::Response{}, free_bit_);
}

void TimedLine::on_unanswered_end() {
  OnLine& o = current_;
  phase_ = Phase::Idle;
  free_bit_ = event_bit_;
  if (o.job) {  // Global_Control: done when the idle after it has passed
    o.job->done(o.answer, time_of(event_bit_));
    return;
  }
  // The token: the rotation ends with its TID2.
  rotating_ = false;
  gap_done_ = false;
  ++rotations_;
  if (rotation_start_)  // docs/daemon.md "Statistics of the steady line"
    (parameterizes_ ? parameterizing_ : cycles_)
        .add(fdl::bits_to_time(baud_, event_bit_ - *rotation_start_));
  parameterizes_ = false;
}

}  // namespace candp2::plant
