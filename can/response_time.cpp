// Worst-case response times on one CAN bus (docs/can-bus.md "Response times"; Davis, Burns,
// Bril, Lukkien 2007, section 4: the revised analysis).
#include "can/response_time.hpp"

#include <algorithm>

#include "can/frame_bits.hpp"

namespace candp2::can {

namespace {

using std::chrono::nanoseconds;

// ceil(a / b) for a >= 0, b > 0.
std::int64_t ceil_div(std::int64_t a, std::int64_t b) {
  return a <= 0 ? 0 : (a + b - 1) / b;
}

struct Prepared {
  std::uint32_t key = 0;  // arbitration_key: smaller wins
  std::int64_t c = 0, t = 0, j = 0;
  std::uint32_t fifo = 0;  // RtaMessage::fifo
  // The priority it is analysed at: its own, or in a FIFO queue the lowest of the queue's (a
  // frame waits for the frames queued ahead of it, and those for every frame that beats them).
  std::uint32_t level = 0;
};

bool same_fifo(const Prepared& a, const Prepared& b) {
  return a.fifo != 0 && a.fifo == b.fifo;
}

// The iteration of one message m: the other messages that can win arbitration against it (hp),
// and the step budget.
class Iteration {
 public:
  Iteration(const std::vector<Prepared>& all, std::size_t m) : self_(all[m]) {
    for (std::size_t k = 0; k < all.size(); ++k)
      if (k != m && (all[k].key <= self_.level || same_fifo(all[k], self_))) hp_.push_back(all[k]);
  }

  // The share of the bus the messages of priority m and higher take.
  long double hep_utilisation() const {
    long double u = static_cast<long double>(self_.c) / self_.t;
    for (const auto& k : hp_) u += static_cast<long double>(k.c) / k.t;
    return u;
  }

  // Eq. 7: t = B + sum over hep(m) of ceil((t + J_k) / T_k) C_k, from t = C_m.
  std::optional<std::int64_t> busy_period(std::int64_t b) {
    std::int64_t t = self_.c;
    for (;;) {
      std::int64_t next = b + ceil_div(t + self_.j, self_.t) * self_.c;
      for (const auto& k : hp_) next += ceil_div(t + k.j, k.t) * k.c;
      if (next == t) return t;
      if (next > kRtaHorizon.count() || !step()) return std::nullopt;
      t = next;
    }
  }

  // Eq. 9: w(q) = B + q C_m + sum over hp(m) of ceil((w + J_k + tau_bit) / T_k) C_k, from `w`
  // (a lower bound: B + q C_m, or w(q - 1) + C_m since w grows with q).
  std::optional<std::int64_t> queuing_delay(std::int64_t b, std::uint64_t q, std::int64_t w,
                                            std::int64_t tau_bit) {
    const std::int64_t own = b + static_cast<std::int64_t>(q) * self_.c;
    for (;;) {
      std::int64_t next = own;
      for (const auto& k : hp_) next += ceil_div(w + k.j + tau_bit, k.t) * k.c;
      if (next == w) return w;
      if (next > kRtaHorizon.count() || !step()) return std::nullopt;
      w = next;
    }
  }

 private:
  bool step() { return ++steps_ <= kRtaMaxSteps; }

  const Prepared& self_;
  std::vector<Prepared> hp_;
  std::uint64_t steps_ = 0;
};

}  // namespace

bool RtaReport::schedulable() const {
  return std::all_of(messages.begin(), messages.end(), [](const auto& m) { return m.schedulable; });
}

RtaReport analyse_response_times(std::span<const RtaMessage> messages, std::uint32_t bitrate) {
  RtaReport r;
  r.bitrate = bitrate;
  std::vector<Prepared> all;
  for (const auto& m : messages) {
    const auto bits = frame_bits_worst(m.id.extended, m.remote, m.dlc);
    const auto key = arbitration_key(m.id, m.remote);
    all.push_back({key, bits_duration(bits, bitrate).count(), m.period.count(),
                   std::max<std::int64_t>(0, m.jitter.count()), m.fifo, key});
    RtaResult res;
    res.frame_bits = bits;
    res.transmission = nanoseconds(all.back().c);
    r.messages.push_back(res);
    if (m.period.count() > 0)
      r.utilisation += static_cast<double>(all.back().c) / static_cast<double>(m.period.count());
  }
  for (auto& p : all)
    for (const auto& k : all)
      if (same_fifo(p, k)) p.level = std::max(p.level, k.key);
  const bool analysable =
      bitrate > 0 && std::all_of(all.begin(), all.end(), [](const auto& p) { return p.t > 0; });
  if (!analysable) return r;
  // tau_bit: a frame queued up to one bit time after another's start of frame still loses
  // arbitration to it (the paper's eq. 3 and 9).
  const std::int64_t tau_bit = bits_duration(1, bitrate).count();

  for (std::size_t m = 0; m < all.size(); ++m) {
    RtaResult& res = r.messages[m];
    const Prepared& p = all[m];
    // Eq. 4: blocked by the longest frame of lower priority, which may have just won (lower than
    // the level the message is analysed at; its own queue's frames are interference).
    std::int64_t b = 0;
    for (const auto& k : all)
      if (k.key > p.level && !same_fifo(k, p)) b = std::max(b, k.c);
    res.blocking = nanoseconds(b);
    Iteration it(all, m);
    // The busy period converges only while the bus is not saturated at this priority.
    if (it.hep_utilisation() >= 1.0L) continue;
    const auto t = it.busy_period(b);
    if (!t) continue;
    res.busy_period = nanoseconds(*t);
    res.instances = static_cast<std::uint64_t>(ceil_div(*t + p.j, p.t));  // eq. 8
    std::int64_t worst = 0, w = b;
    bool bounded = true;
    for (std::uint64_t q = 0; q < res.instances; ++q) {
      const auto wq =
          it.queuing_delay(b, q, std::max(w, b + static_cast<std::int64_t>(q) * p.c), tau_bit);
      if (!wq) {
        bounded = false;
        break;
      }
      w = *wq;
      // Eq. 10: R(q) = J + w(q) - q T + C.
      const std::int64_t rq = p.j + w - static_cast<std::int64_t>(q) * p.t + p.c;
      if (q == 0) res.response_first = nanoseconds(rq);
      if (q == 0 || rq > worst) {
        worst = rq;
        res.worst_instance = q;
      }
    }
    if (!bounded) {
      res.response_first.reset();
      continue;
    }
    res.response = nanoseconds(worst);  // eq. 11
    res.schedulable = worst <= p.t;
  }
  return r;
}

}  // namespace candp2::can
