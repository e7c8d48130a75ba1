// In-process virtual CAN bus: several endpoints, deterministic delivery order, injected time,
// explicit fault injection. Used by the daemon's embedded default, the replay runner and tests.
//
// Semantics follow SocketCAN raw sockets where they matter to users:
//  - an endpoint does not receive its own frames unless it asked to (CAN_RAW_RECV_OWN_MSGS);
//  - every other endpoint receives every frame, in send order (one bus = one total order);
//  - each endpoint has a bounded receive queue; a frame arriving at a full queue is dropped and
//    counted in that endpoint's rx_lost() (SO_RXQ_OVFL).
// Not thread-safe by design: one event loop owns the bus.
#pragma once

#include <cstddef>
#include <deque>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "can/channel.hpp"
#include "common/time.hpp"

namespace candp2::can {

class VirtualBus;

class VirtualEndpoint final : public Channel {
 public:
  ~VirtualEndpoint() override;
  VirtualEndpoint(const VirtualEndpoint&) = delete;
  VirtualEndpoint& operator=(const VirtualEndpoint&) = delete;

  void send(const Frame& frame) override;
  std::optional<Frame> receive() override;
  BusState bus_state() const override;
  std::uint32_t rx_lost() const override { return rx_lost_; }
  std::uint32_t tx_dropped() const override { return tx_dropped_; }
  std::string_view name() const override { return name_; }

  std::size_t pending() const { return queue_.size(); }
  // Fault injection: pretend the controller lost n frames (an RX overrun).
  void inject_rx_lost(std::uint32_t n);
  // Fault injection for this endpoint's controller only; nullopt follows the bus state.
  void set_bus_state_override(std::optional<BusState> s);

 private:
  friend class VirtualBus;
  VirtualEndpoint(VirtualBus* bus, std::string name, bool receive_own, std::size_t limit);
  void deliver(const Frame& frame);

  VirtualBus* bus_;
  std::string name_;
  bool receive_own_;
  std::size_t limit_;
  std::deque<Frame> queue_;
  std::uint32_t rx_lost_ = 0;
  std::uint32_t tx_dropped_ = 0;
  std::optional<BusState> state_override_;
};

class VirtualBus {
 public:
  struct Options {
    std::size_t rx_queue_limit = 4096;  // per endpoint
  };
  // Observer of every frame that reached the bus (for candump logs and test traces).
  using Tap = std::function<void(const Frame&, Time, std::string_view sender)>;

  VirtualBus() : VirtualBus(Options{}) {}
  explicit VirtualBus(Options options);
  ~VirtualBus();

  // Endpoints must not outlive the bus.
  std::unique_ptr<VirtualEndpoint> endpoint(std::string name, bool receive_own = false);

  // Time stamps passed to taps; the owner of the clock advances it.
  void set_now(Time now) { now_ = now; }
  // Or reads the owner's clock itself (the plant's time; null: set_now()).
  void use_clock(const Time* clock) { clock_ = clock; }
  Time now() const { return clock_ ? *clock_ : now_; }

  void add_tap(Tap tap) { taps_.push_back(std::move(tap)); }

  // Fault injection: the state every controller on the bus sees. In BusOff, nothing is sent.
  void set_bus_state(BusState s) {
    state_ = s;
    changed();
  }
  BusState bus_state() const { return state_; }
  // Grows with every frame sent and every change of a bus or endpoint state: while it stands
  // still, no endpoint's queue, bus state or lost count changed (the plant skips quiet buses).
  std::uint64_t changes() const { return changes_; }
  // Also counts them in `*shared` (the plant's count over all its buses); null: not.
  void count_changes_in(std::uint64_t* shared) { shared_changes_ = shared; }

  std::uint64_t frames_sent() const { return frames_sent_; }

 private:
  friend class VirtualEndpoint;
  void transmit(VirtualEndpoint* from, const Frame& frame);
  void detach(VirtualEndpoint* ep);

  Options options_;
  std::vector<VirtualEndpoint*> endpoints_;
  std::vector<Tap> taps_;
  BusState state_ = BusState::Ok;
  std::uint64_t changes_ = 0;
  std::uint64_t* shared_changes_ = nullptr;
  void changed() {
    ++changes_;
    if (shared_changes_) ++*shared_changes_;
  }
  Time now_{0};
  const Time* clock_ = nullptr;
  std::uint64_t frames_sent_ = 0;
};

}  // namespace candp2::can
