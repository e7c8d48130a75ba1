#include "event_loop/event_loop.hpp"

#include <errno.h>
#include <sys/epoll.h>
#include <sys/signalfd.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cstring>
#include <system_error>

namespace candp2 {

namespace {

constexpr std::uint64_t kSignalToken = 1;
constexpr int kMaxEvents = 64;
constexpr int kMaxDeferredRounds = 64;

std::uint32_t to_epoll(std::uint32_t events) {
  std::uint32_t e = 0;
  if (events & EventLoop::kReadable) e |= EPOLLIN | EPOLLRDHUP;
  if (events & EventLoop::kWritable) e |= EPOLLOUT;
  return e;
}

std::uint32_t from_epoll(std::uint32_t e) {
  std::uint32_t events = 0;
  if (e & EPOLLIN) events |= EventLoop::kReadable;
  if (e & EPOLLOUT) events |= EventLoop::kWritable;
  if (e & (EPOLLERR | EPOLLHUP | EPOLLRDHUP)) events |= EventLoop::kHangup;
  return events;
}

Time clock_us(clockid_t clock) {
  timespec ts{};
  ::clock_gettime(clock, &ts);
  return Time(static_cast<std::int64_t>(ts.tv_sec) * 1000000 + ts.tv_nsec / 1000);
}

bool set_error(std::string* error, std::string message) {
  if (error) *error = std::move(message);
  return false;
}

}  // namespace

Time EventLoop::monotonic_now() {
  return clock_us(CLOCK_MONOTONIC);
}
Time EventLoop::wall_now() {
  return clock_us(CLOCK_REALTIME);
}

EventLoop::EventLoop(LogSink* log) : log_(log, "event-loop") {
  epoll_fd_ = ::epoll_create1(EPOLL_CLOEXEC);
  if (epoll_fd_ < 0) throw std::system_error(errno, std::generic_category(), "epoll_create1");
  sigemptyset(&signal_mask_);
  sigemptyset(&blocked_by_us_);
}

EventLoop::~EventLoop() {
  if (signal_fd_ >= 0) {
    // Consume what is pending so that unblocking does not deliver it with the default action.
    signalfd_siginfo info;
    while (::read(signal_fd_, &info, sizeof info) == static_cast<ssize_t>(sizeof info)) {
    }
    ::close(signal_fd_);
    ::sigprocmask(SIG_UNBLOCK, &blocked_by_us_, nullptr);
  }
  ::close(epoll_fd_);
}

bool EventLoop::add_fd(int fd, std::uint32_t events, FdCallback callback, std::string* error) {
  if (fds_.count(fd))
    return set_error(error, "descriptor " + std::to_string(fd) + " is already watched");
  auto entry = std::make_shared<FdEntry>();
  entry->fd = fd;
  entry->token = next_token_++;
  entry->events = events;
  entry->callback = std::make_shared<FdCallback>(std::move(callback));
  epoll_event ev{};
  ev.events = to_epoll(events);
  ev.data.u64 = entry->token;
  if (::epoll_ctl(epoll_fd_, EPOLL_CTL_ADD, fd, &ev) < 0)
    return set_error(error,
                     "cannot watch descriptor " + std::to_string(fd) + ": " + std::strerror(errno));
  by_token_[entry->token] = entry;
  fds_[fd] = std::move(entry);
  return true;
}

bool EventLoop::modify_fd(int fd, std::uint32_t events) {
  const auto it = fds_.find(fd);
  if (it == fds_.end()) return false;
  epoll_event ev{};
  ev.events = to_epoll(events);
  ev.data.u64 = it->second->token;
  if (::epoll_ctl(epoll_fd_, EPOLL_CTL_MOD, fd, &ev) < 0) {
    log_.error("cannot change events of descriptor " + std::to_string(fd) + ": " +
               std::strerror(errno));
    return false;
  }
  it->second->events = events;
  return true;
}

bool EventLoop::remove_fd(int fd) {
  const auto it = fds_.find(fd);
  if (it == fds_.end()) return false;
  ::epoll_ctl(epoll_fd_, EPOLL_CTL_DEL, fd, nullptr);  // fails harmlessly if already closed
  by_token_.erase(it->second->token);
  fds_.erase(it);
  return true;
}

EventLoop::TimerId EventLoop::arm(TimerId id, Time deadline, Duration period,
                                  std::shared_ptr<TimerCallback> cb) {
  const std::uint64_t seq = next_seq_++;
  timers_[id] = Timer{deadline, seq, period, std::move(cb)};
  queue_.emplace(TimerKey{deadline, seq}, id);
  return id;
}

EventLoop::TimerId EventLoop::add_timer(Duration delay, TimerCallback callback) {
  return arm(next_timer_id_++, now() + std::max(delay, Duration(0)), Duration(0),
             std::make_shared<TimerCallback>(std::move(callback)));
}

EventLoop::TimerId EventLoop::add_periodic(Duration period, TimerCallback callback) {
  if (period <= Duration(0)) {
    log_.error("periodic timer with period <= 0 refused");
    return 0;
  }
  return arm(next_timer_id_++, now() + period, period,
             std::make_shared<TimerCallback>(std::move(callback)));
}

bool EventLoop::cancel_timer(TimerId id) {
  const auto it = timers_.find(id);
  if (it == timers_.end()) return false;
  queue_.erase(TimerKey{it->second.deadline, it->second.seq});
  timers_.erase(it);
  return true;
}

bool EventLoop::add_signal(int signo, SignalCallback callback, std::string* error) {
  sigset_t one;
  sigemptyset(&one);
  if (sigaddset(&one, signo) < 0)
    return set_error(error, "invalid signal number " + std::to_string(signo));
  sigset_t previous;
  if (::sigprocmask(SIG_BLOCK, &one, &previous) < 0)
    return set_error(error,
                     "cannot block signal " + std::to_string(signo) + ": " + std::strerror(errno));
  if (!sigismember(&previous, signo)) sigaddset(&blocked_by_us_, signo);
  sigaddset(&signal_mask_, signo);
  const int fd = ::signalfd(signal_fd_, &signal_mask_, SFD_NONBLOCK | SFD_CLOEXEC);
  if (fd < 0) return set_error(error, std::string("signalfd failed: ") + std::strerror(errno));
  if (signal_fd_ < 0) {
    signal_fd_ = fd;
    epoll_event ev{};
    ev.events = EPOLLIN;
    ev.data.u64 = kSignalToken;
    if (::epoll_ctl(epoll_fd_, EPOLL_CTL_ADD, signal_fd_, &ev) < 0)
      return set_error(error, std::string("cannot watch the signalfd: ") + std::strerror(errno));
  }
  signal_callbacks_[signo] = std::move(callback);
  return true;
}

EventLoop::DeferredId EventLoop::add_deferred(Deferred hook) {
  const DeferredId id = next_deferred_id_++;
  deferred_.emplace_back(id, std::make_shared<Deferred>(std::move(hook)));
  return id;
}

bool EventLoop::remove_deferred(DeferredId id) {
  const auto it = std::find_if(deferred_.begin(), deferred_.end(),
                               [id](const auto& d) { return d.first == id; });
  if (it == deferred_.end()) return false;
  deferred_.erase(it);
  return true;
}

std::size_t EventLoop::run_deferred() {
  if (in_deferred_ || deferred_.empty()) return 0;  // a hook's own work does not recurse
  in_deferred_ = true;
  struct Reset {
    bool& flag;
    ~Reset() { flag = false; }  // also when a hook throws
  } reset{in_deferred_};
  std::size_t worked = 0;
  bool any = true;
  int rounds = 0;
  while (any && rounds < kMaxDeferredRounds) {
    any = false;
    ++rounds;
    const auto snapshot = deferred_;  // hooks may add or remove hooks
    for (const auto& entry : snapshot) {
      const DeferredId id = entry.first;
      const bool still_there = std::any_of(deferred_.begin(), deferred_.end(),
                                           [id](const auto& d) { return d.first == id; });
      if (still_there && (*entry.second)()) {
        any = true;
        ++worked;
      }
    }
  }
  deferred_pending_ = any;
  if (any) log_.debug("deferred hooks still busy after 64 rounds; polling again without waiting");
  return worked;
}

std::size_t EventLoop::dispatch_timers() {
  const Time t = now();
  // Snapshot the due timers: timers armed by these callbacks wait for the next round.
  std::vector<std::pair<TimerId, std::uint64_t>> due;
  for (auto it = queue_.begin(); it != queue_.end() && it->first.first <= t; ++it)
    due.emplace_back(it->second, it->first.second);
  std::size_t fired = 0;
  for (const auto& [id, seq] : due) {
    const auto it = timers_.find(id);
    if (it == timers_.end() || it->second.seq != seq) continue;  // cancelled meanwhile
    Timer timer = it->second;
    queue_.erase(TimerKey{timer.deadline, timer.seq});
    if (timer.period > Duration(0)) {
      Time next = timer.deadline + timer.period;
      if (next <= t) next += timer.period * ((t - next) / timer.period + 1);  // skip missed ticks
      arm(id, next, timer.period, timer.callback);
    } else {
      timers_.erase(it);
    }
    (*timer.callback)();
    ++fired;
    fired += run_deferred();
    if (stop_requested_) break;
  }
  return fired;
}

std::size_t EventLoop::dispatch_signals() {
  std::size_t n = 0;
  for (;;) {
    signalfd_siginfo info;
    const ssize_t r = ::read(signal_fd_, &info, sizeof info);
    if (r != static_cast<ssize_t>(sizeof info)) {
      if (r < 0 && errno == EINTR) continue;
      break;
    }
    const int signo = static_cast<int>(info.ssi_signo);
    const auto it = signal_callbacks_.find(signo);
    if (it == signal_callbacks_.end()) continue;
    const SignalCallback cb = it->second;  // a copy: the callback may replace itself
    log_.info(std::string("signal ") + ::strsignal(signo));
    cb(signo);
    ++n;
    n += run_deferred();
  }
  return n;
}

int EventLoop::wait(Duration timeout, void* events_raw, int max_events) {
  auto* events = static_cast<epoll_event*>(events_raw);
  if (have_pwait2_) {
    timespec ts{};
    const timespec* tsp = nullptr;
    if (timeout >= Duration(0)) {
      ts.tv_sec = static_cast<time_t>(timeout.count() / 1000000);
      ts.tv_nsec = static_cast<long>((timeout.count() % 1000000) * 1000);
      tsp = &ts;
    }
    const int n = ::epoll_pwait2(epoll_fd_, events, max_events, tsp, nullptr);
    if (n >= 0 || errno != ENOSYS) return n;
    have_pwait2_ = false;
    log_.info("epoll_pwait2 unavailable; timers have millisecond resolution");
  }
  int ms = -1;
  if (timeout >= Duration(0)) {
    const auto rounded_up = (timeout.count() + 999) / 1000;
    ms = static_cast<int>(std::min<std::int64_t>(rounded_up, 24 * 3600 * 1000));
  }
  return ::epoll_wait(epoll_fd_, events, max_events, ms);
}

std::size_t EventLoop::run_once(Duration timeout) {
  std::size_t dispatched = run_deferred();
  Duration wait_for = timeout;
  if (deferred_pending_ || dispatched > 0) wait_for = Duration(0);
  if (!queue_.empty()) {
    const Duration until_timer = std::max(Duration(0), queue_.begin()->first.first - now());
    if (wait_for < Duration(0) || until_timer < wait_for) wait_for = until_timer;
  }
  epoll_event events[kMaxEvents];
  const int n = wait(wait_for, events, kMaxEvents);
  if (n < 0 && errno != EINTR)
    log_.error(std::string("epoll wait failed: ") + std::strerror(errno));
  for (int i = 0; i < n && !stop_requested_; ++i) {
    const std::uint64_t token = events[i].data.u64;
    if (token == kSignalToken) {
      dispatched += dispatch_signals();
      continue;
    }
    const auto it = by_token_.find(token);
    if (it == by_token_.end()) continue;  // removed by an earlier callback in this round
    const auto entry = it->second;        // keeps the callback alive if it removes itself
    (*entry->callback)(from_epoll(events[i].events));
    ++dispatched;
    dispatched += run_deferred();
  }
  if (!stop_requested_) dispatched += dispatch_timers();
  return dispatched;
}

void EventLoop::run() {
  while (!stop_requested_) run_once(Duration(-1));
  stop_requested_ = false;
}

bool EventLoop::run_until(const std::function<bool()>& done, Duration timeout) {
  const Time deadline = now() + timeout;
  while (!done()) {
    const Time t = now();
    if (t >= deadline) return done();
    run_once(deadline - t);
  }
  return true;
}

}  // namespace candp2
