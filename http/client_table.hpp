// Which HTTP connection to close (docs/daemon.md "HTTP connections"), the rule the Modbus server
// follows (common/idle_clients.hpp) adapted to HTTP, where a connection is either waiting for a
// request or busy with one (a response being written, a Server-Sent Events stream, a request
// parked until the next snapshot):
//
//   - a connection waits from its accept, and again from the end of each response, until the
//     header of its next request is complete; waiting for idle_timeout closes it, whether the
//     client is silent or sends its header a byte at a time (a trickling header is no request);
//   - at max_clients a new connection evicts the connection waiting longest; when none waits, the
//     busy connection that started its request first (the oldest stream).
//
// Pure: times passed in, ids chosen here (increasing, never reused); the server maps them to its
// connections.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <set>
#include <vector>

#include "common/idle_clients.hpp"
#include "common/time.hpp"

namespace candp2::http {

class ClientTable {
 public:
  using Id = std::uint64_t;
  // max_clients >= 1; idle_timeout 0 = waiting connections are never closed for it.
  ClientTable(std::size_t max_clients, Duration idle_timeout)
      : max_(max_clients ? max_clients : 1), waiting_(idle_timeout) {}

  struct Admission {
    Id id = 0;
    std::optional<Id> evict;         // close this one first (already removed from the table)
    bool evict_was_waiting = false;  // else it was the oldest busy connection
  };
  // A connection accepted at `now`: it waits for its first request.
  Admission admit(Time now) {
    Admission a;
    if (size() >= max_) {
      a.evict = waiting_.longest_idle();
      a.evict_was_waiting = a.evict.has_value();
      if (!a.evict && !busy_.empty()) a.evict = busy_.begin()->second;
      if (a.evict) remove(*a.evict);
    }
    a.id = next_id_++;
    waiting_.touch(a.id, now);
    return a;
  }
  // The header of a request is complete: busy until request_done().
  void request_started(Id id) {
    if (!waiting_.last_activity(id)) return;  // unknown, or busy already
    waiting_.remove(id);
    busy_order_[id] = next_order_;
    busy_.insert({next_order_++, id});
  }
  // The response was sent (the connection stays open for the next request).
  void request_done(Id id, Time now) {
    if (!erase_busy(id)) return;
    waiting_.touch(id, now);
  }
  void remove(Id id) {
    waiting_.remove(id);
    erase_busy(id);
  }

  bool contains(Id id) const { return waiting(id) || busy_order_.count(id) != 0; }
  bool waiting(Id id) const { return waiting_.last_activity(id).has_value(); }
  std::size_t size() const { return waiting_.size() + busy_.size(); }
  std::size_t busy() const { return busy_.size(); }
  std::size_t max_clients() const { return max_; }
  // Waiting connections that reached idle_timeout at `now` (not removed: the caller closes them).
  std::vector<Id> expired(Time now) const { return waiting_.expired(now); }
  std::optional<Time> next_expiry() const { return waiting_.next_expiry(); }
  std::optional<Time> waiting_since(Id id) const { return waiting_.last_activity(id); }

 private:
  bool erase_busy(Id id) {
    const auto it = busy_order_.find(id);
    if (it == busy_order_.end()) return false;
    busy_.erase({it->second, id});
    busy_order_.erase(it);
    return true;
  }

  std::size_t max_;
  IdleClients waiting_;
  // Busy connections by the order their request started, so the oldest is first.
  std::set<std::pair<std::uint64_t, Id>> busy_;
  std::map<Id, std::uint64_t> busy_order_;
  std::uint64_t next_order_ = 1;
  Id next_id_ = 1;
};

}  // namespace candp2::http
