// One loop timer kept at a moving deadline: the plant's next deadline, a server's earliest idle
// expiry, a reconnection (docs/daemon.md "One event loop, no threads"). arm() re-arms the loop
// timer only when the deadline changes, so a caller may call it after every event; the callback
// runs once when the deadline is reached, after which the timer is disarmed.
#pragma once

#include <functional>
#include <optional>

#include "common/time.hpp"
#include "event_loop/event_loop.hpp"

namespace candp2 {

class DeadlineTimer {
 public:
  DeadlineTimer(EventLoop& loop, std::function<void()> on_deadline)
      : loop_(loop), on_deadline_(std::move(on_deadline)) {}
  ~DeadlineTimer() { disarm(); }
  DeadlineTimer(const DeadlineTimer&) = delete;
  DeadlineTimer& operator=(const DeadlineTimer&) = delete;

  // Fires at `at` (nullopt: never). `now` is the clock `at` is measured on: the loop's, or the
  // wall clock for an engine that runs on it.
  void arm(std::optional<Time> at, Time now) {
    if (at == at_ && (id_ || !at)) return;
    disarm();
    if (!at) return;
    at_ = at;
    id_ = loop_.add_timer(std::max(Duration(0), *at - now), [this] {
      id_ = 0;
      at_.reset();
      on_deadline_();
    });
  }
  // Armed only when `at` is earlier than the deadline armed now (or none is): for idle expiries,
  // which a request only moves later; a timer that fires early finds nothing due and re-arms.
  void arm_earlier(std::optional<Time> at, Time now) {
    if (at && (!at_ || *at < *at_)) arm(at, now);
  }
  void disarm() {
    if (id_) loop_.cancel_timer(id_);
    id_ = 0;
    at_.reset();
  }
  std::optional<Time> at() const { return at_; }

 private:
  EventLoop& loop_;
  std::function<void()> on_deadline_;
  EventLoop::TimerId id_ = 0;
  std::optional<Time> at_;
};

}  // namespace candp2
