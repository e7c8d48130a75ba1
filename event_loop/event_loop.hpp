// The daemon's one event loop: epoll over descriptors, timers, signals and deferred work.
//
// Single-threaded by design (no locks): every callback runs on the thread that calls run() or
// run_once(), one at a time. Callbacks may add or remove descriptors, timers, signals and deferred
// hooks, including their own, at any moment; a removed descriptor or cancelled timer is never
// called again, even if it was already ready in the current round.
//
// Timers are kept in an ordered queue and turned into the epoll_pwait2() timeout (microsecond
// resolution; falls back to epoll_wait() with the timeout rounded up to whole milliseconds when the
// kernel lacks epoll_pwait2), so they cost no descriptors. Deadlines are on CLOCK_MONOTONIC. Timers
// due at the same time fire in the order they were armed. A periodic timer keeps its phase
// (deadline += period, no drift); ticks missed while the loop was busy are skipped, not replayed.
//
// Signals arrive through a signalfd: add_signal() blocks the signal for the calling thread (create
// the loop and add signals before starting any other thread) and the callback runs inside the loop
// like any other event. The destructor drains pending signals and unblocks those it blocked.
//
// Deferred hooks run after every dispatched callback and at the start of every run_once(): this is
// where the daemon drains in-process channels that have no descriptor (VirtualBus endpoints). A
// hook returns true when it did work; hooks are repeated until none did (at most 64 rounds, then
// the next wait does not block), so frames bounced between in-process endpoints settle in one
// dispatch.
#pragma once

#include <signal.h>

#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "common/log.hpp"
#include "common/time.hpp"

namespace candp2 {

class EventLoop {
 public:
  // Event bits for add_fd()/modify_fd() and the callback argument.
  static constexpr std::uint32_t kReadable = 1;  // EPOLLIN
  static constexpr std::uint32_t kWritable = 2;  // EPOLLOUT
  static constexpr std::uint32_t kHangup = 4;    // EPOLLERR / EPOLLHUP / EPOLLRDHUP (reported only)

  using FdCallback = std::function<void(std::uint32_t events)>;
  using TimerCallback = std::function<void()>;
  using SignalCallback = std::function<void(int signo)>;
  using Deferred = std::function<bool()>;  // returns true when it did some work
  using TimerId = std::uint64_t;           // never 0
  using DeferredId = std::uint64_t;        // never 0

  // Throws std::system_error when the epoll descriptor cannot be created.
  explicit EventLoop(LogSink* log = nullptr);
  ~EventLoop();
  EventLoop(const EventLoop&) = delete;
  EventLoop& operator=(const EventLoop&) = delete;

  // Level-triggered. A descriptor can be added once; false (and *error) when epoll refuses it
  // (e.g. a regular file) or it is already watched.
  bool add_fd(int fd, std::uint32_t events, FdCallback callback, std::string* error = nullptr);
  bool modify_fd(int fd, std::uint32_t events);
  bool remove_fd(int fd);  // call before closing the descriptor
  bool watching(int fd) const { return fds_.count(fd) != 0; }

  // One-shot after `delay` (<= 0: in the next round, after the ones already due).
  TimerId add_timer(Duration delay, TimerCallback callback);
  // Every `period` (> 0, else 0 is returned and nothing is armed); first tick after one period.
  TimerId add_periodic(Duration period, TimerCallback callback);
  bool cancel_timer(TimerId id);  // false when unknown, already fired (one-shot) or cancelled
  std::size_t timer_count() const { return timers_.size(); }

  // SIGINT, SIGTERM, SIGHUP, ...: one callback per signal number (a second call replaces it).
  bool add_signal(int signo, SignalCallback callback, std::string* error = nullptr);

  DeferredId add_deferred(Deferred hook);
  bool remove_deferred(DeferredId id);

  // Dispatches until stop(). Returns at once (and clears the request) if stop() came first.
  void run();
  // Ends run() after the current callback returns; safe to call from any callback.
  void stop() { stop_requested_ = true; }
  bool stop_requested() const { return stop_requested_; }
  // Waits at most `timeout` (negative: without limit) for events, dispatches what is ready and the
  // timers that are due, and returns how many callbacks ran (deferred hooks count when they did
  // work).
  std::size_t run_once(Duration timeout);
  // For tests and tools: runs until done() is true (checked before every round) or the timeout
  // passes. Returns done().
  bool run_until(const std::function<bool()>& done, Duration timeout);

  // CLOCK_MONOTONIC in microseconds (origin: boot); the time protocol engines are given.
  Time now() const { return monotonic_now(); }
  static Time monotonic_now();
  // CLOCK_REALTIME in microseconds since the Unix epoch: only for stamps humans or peers read
  // (socketcand `< frame >` lines, candump logs), never for deadlines.
  static Time wall_now();

 private:
  struct FdEntry {
    int fd;
    std::uint64_t token;
    std::uint32_t events;
    std::shared_ptr<FdCallback> callback;
  };
  struct Timer {
    Time deadline;
    std::uint64_t seq;  // arming order; key in the queue together with the deadline
    Duration period;    // zero for one-shot
    std::shared_ptr<TimerCallback> callback;
  };
  using TimerKey = std::pair<Time, std::uint64_t>;

  TimerId arm(TimerId id, Time deadline, Duration period, std::shared_ptr<TimerCallback> cb);
  std::size_t dispatch_timers();
  std::size_t dispatch_signals();
  std::size_t run_deferred();
  int wait(Duration timeout, void* events, int max_events);

  Logger log_;
  int epoll_fd_ = -1;
  int signal_fd_ = -1;
  sigset_t signal_mask_{};    // signals routed to signal_fd_
  sigset_t blocked_by_us_{};  // to unblock on destruction
  std::unordered_map<int, SignalCallback> signal_callbacks_;

  std::unordered_map<int, std::shared_ptr<FdEntry>> fds_;
  std::unordered_map<std::uint64_t, std::shared_ptr<FdEntry>> by_token_;
  std::uint64_t next_token_ = 16;  // tokens below 16 are internal (the signalfd)

  std::map<TimerKey, TimerId> queue_;
  std::unordered_map<TimerId, Timer> timers_;
  std::uint64_t next_seq_ = 1;
  TimerId next_timer_id_ = 1;

  std::vector<std::pair<DeferredId, std::shared_ptr<Deferred>>> deferred_;
  DeferredId next_deferred_id_ = 1;
  bool deferred_pending_ = false;  // hooks still had work after the round limit
  bool in_deferred_ = false;

  bool stop_requested_ = false;
  bool have_pwait2_ = true;
};

}  // namespace candp2
