// Rigs for the DP master/slave link contract (link_contract_test.cpp): the
// same master/slave behaviour over every dp::SlaveLink.
//  - InProcessRig: dp::InProcessLink straight into the gateway's DpSlave;
//  - FdlRig: fdl::FdlMaster ↔ an in-memory byte pipe (virtual time, configurable delay, optional
//    byte loss/corruption) ↔ fdl::SlaveFrontEnd ↔ the gateway's DpSlave (docs/profibus.md).
// Both can "pull the cable" of a station (it stops answering) to show Station_Non_Existent.
#pragma once

#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <vector>

#include "profibus_sim/fdl/fdl_master.hpp"
#include "profibus_sim/fdl/fdl_slave.hpp"
#include "profibus_sim/master/dp_master.hpp"

namespace candp2::dp::test {

// A link that stops answering while its cable is pulled (the in-process stand-in for a station
// that is switched off).
class CableLink final : public SlaveLink {
 public:
  explicit CableLink(DpSlave& slave) : inner_(slave) {}
  std::uint8_t address() const override { return inner_.address(); }
  void request(Request req, Time now, Completion done) override {
    if (pulled) return done(Response{Response::Status::NoResponse, {}, false}, now);
    inner_.request(std::move(req), now, std::move(done));
  }
  bool pulled = false;

 private:
  InProcessLink inner_;
};

struct InProcessRig {
  static constexpr const char* kName = "in-process";
  void add(DpMaster& master, DpSlave& slave, SlaveParameters p) {
    links_.push_back(std::make_unique<CableLink>(slave));
    master.add_slave(*links_.back(), std::move(p));
  }
  void pull_cable(std::uint8_t address, bool pulled) {
    for (auto& l : links_)
      if (l->address() == address) l->pulled = pulled;
  }
  std::optional<Time> next_deadline() const { return std::nullopt; }
  void advance(Time) {}
  std::vector<std::unique_ptr<CableLink>> links_;
};

// The line between the FDL master and the slaves, in virtual time: bytes written at `t` arrive
// complete at t + their wire time + `delay`.
struct BytePipe {
  Duration delay{50};
  std::uint32_t drop_every = 0;     // every n-th telegram is lost (0 = none)
  std::uint32_t corrupt_every = 0;  // every n-th telegram has one byte flipped (0 = none)
  std::uint32_t telegrams = 0;
  std::multimap<Time, std::function<void(Time)>> events;

  // `bytes` start on the line at `start`; each character takes `char_time`. The first character
  // arrives on its own (so a master sees an answer begin within its slot time), the rest when the
  // last character is through.
  void carry(std::vector<std::uint8_t> bytes, Time start, Duration char_time,
             std::function<void(std::span<const std::uint8_t>, Time)> to) {
    ++telegrams;
    if (drop_every && telegrams % drop_every == 0) return;
    if (corrupt_every && telegrams % corrupt_every == 0 && bytes.size() > 1)
      bytes[bytes.size() - 2] ^= 0x5A;  // the FCS (or the only data byte) goes wrong
    const auto n = static_cast<std::int64_t>(bytes.size());
    std::vector<std::uint8_t> first(bytes.begin(), bytes.begin() + 1);
    std::vector<std::uint8_t> rest(bytes.begin() + 1, bytes.end());
    events.emplace(start + char_time + delay, [first, to](Time t) { to(first, t); });
    if (!rest.empty())
      events.emplace(start + char_time * n + delay, [rest, to](Time t) { to(rest, t); });
  }
  std::optional<Time> next() const {
    return events.empty() ? std::nullopt : std::optional(events.begin()->first);
  }
  void run(Time now) {
    while (!events.empty() && events.begin()->first <= now) {
      auto fn = std::move(events.begin()->second);
      const Time t = events.begin()->first;
      events.erase(events.begin());
      fn(t);
    }
  }
};

struct FdlRig {
  static constexpr const char* kName = "fdl";
  static constexpr std::uint32_t kBaud = 187500;  // docs/profibus.md bit rates

  explicit FdlRig(std::uint32_t baud = kBaud)
      : line({.address = 2, .baud = baud, .slot_time_bits = 100, .retries = 1},
             [this](std::span<const std::uint8_t> b, Time now) { to_slaves(b, now); }),
        front({.baud = baud, .master_address = std::nullopt, .default_min_tsdr_bits = 11}) {}

  void add(DpMaster& master, DpSlave& slave, SlaveParameters p) {
    front.add(slave);
    master.add_slave(line.station(slave.info().address), std::move(p));
  }
  void pull_cable(std::uint8_t address, bool pulled) {
    if (pulled)
      unplugged.insert(address);
    else
      unplugged.erase(address);
  }
  std::optional<Time> next_deadline() const {
    auto a = pipe.next();
    auto b = line.next_deadline();
    if (a && b) return std::min(*a, *b);
    return a ? a : b;
  }
  void advance(Time now) {
    pipe.run(now);
    line.advance(now);
  }

  void to_slaves(std::span<const std::uint8_t> b, Time now) {
    std::vector<std::uint8_t> bytes(b.begin(), b.end());
    sent.push_back(bytes);
    if (observe) observe(bytes, true);
    // A pulled cable: the station never sees its requests.
    if (bytes.size() > 2 &&
        unplugged.count(bytes[0] == fdl::kSD2 ? bytes[4] & 0x7F : bytes[1] & 0x7F))
      return;
    pipe.carry(
        std::move(bytes), now, line.wire_time(1), [this](std::span<const std::uint8_t> in, Time t) {
          auto reply = front.on_bytes(in, t);
          if (!reply) return;
          if (observe) observe(reply->bytes, false);
          const Time start = std::max(t, reply->not_before);
          pipe.carry(
              std::move(reply->bytes), start, line.wire_time(1),
              [this](std::span<const std::uint8_t> back, Time at) { line.on_bytes(back, at); });
        });
  }

  fdl::FdlMaster line;
  fdl::SlaveFrontEnd front;
  BytePipe pipe;
  std::set<std::uint8_t> unplugged;
  std::vector<std::vector<std::uint8_t>> sent;  // every telegram the master put on the line
  // Every telegram on the line in order: the master's (true) and the slaves' answers (false).
  std::function<void(std::span<const std::uint8_t>, bool from_master)> observe;
};

}  // namespace candp2::dp::test
