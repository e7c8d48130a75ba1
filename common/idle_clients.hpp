// Which connection to close when a server is full or a connection idles too long: idle clients
// cannot lock others out (docs/configuration.md, `max_clients`, `idle_timeout_s`). The policy
// many Modbus/TCP devices use: when the limit is reached, a new connection evicts the one idle
// longest; a connection without traffic for idle_timeout is closed. Pure: times passed in; the
// Modbus and socketcand servers each hold one.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <vector>

#include "common/time.hpp"

namespace candp2 {

class IdleClients {
 public:
  using Id = std::uint64_t;
  // idle_timeout 0 = never close for idleness.
  explicit IdleClients(Duration idle_timeout = Duration(0)) : timeout_(idle_timeout) {}

  // A connection was accepted or showed traffic (a request, a command).
  void touch(Id id, Time now) { last_[id] = now; }
  void remove(Id id) { last_.erase(id); }
  std::size_t size() const { return last_.size(); }

  // The connection idle longest (earliest last activity; the lowest id among equals).
  std::optional<Id> longest_idle() const {
    std::optional<Id> best;
    Time best_time{};
    for (const auto& [id, t] : last_)
      if (!best || t < best_time) {
        best = id;
        best_time = t;
      }
    return best;
  }

  // Connections idle for idle_timeout or longer at `now`.
  std::vector<Id> expired(Time now) const {
    std::vector<Id> out;
    if (timeout_.count() <= 0) return out;
    for (const auto& [id, t] : last_)
      if (now - t >= timeout_) out.push_back(id);
    return out;
  }

  // When the next connection becomes idle too long (nullopt: none, or no timeout).
  std::optional<Time> next_expiry() const {
    if (timeout_.count() <= 0) return std::nullopt;
    std::optional<Time> next;
    for (const auto& [id, t] : last_)
      if (!next || t + timeout_ < *next) next = t + timeout_;
    return next;
  }

  std::optional<Time> last_activity(Id id) const {
    const auto it = last_.find(id);
    if (it == last_.end()) return std::nullopt;
    return it->second;
  }

 private:
  Duration timeout_;
  std::map<Id, Time> last_;
};

}  // namespace candp2
