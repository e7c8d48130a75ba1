// In-process virtual CAN bus: several endpoints, deterministic delivery order, injected time,
// explicit fault injection. Used by the daemon's embedded default, the replay runner and tests.
//
// Semantics follow SocketCAN raw sockets where they matter to users:
//  - an endpoint does not receive its own frames unless it asked to (CAN_RAW_RECV_OWN_MSGS);
//  - every other endpoint receives every frame, in send order (one bus = one total order);
//  - each endpoint has a bounded receive queue; a frame arriving at a full queue is dropped and
//    counted in that endpoint's rx_lost() (SO_RXQ_OVFL).
// Ideal by default: a frame is delivered the moment it is sent. With a bit rate (set_bitrate) it is
// a bus in time (can/timed_bus.hpp, docs/can-bus.md "The bus in time"): a sent frame waits in its
// endpoint's transmit queue, wins arbitration, and is delivered at its end; the owner of the clock
// advances the bus at next_deadline().
// Not thread-safe by design: one event loop owns the bus.
#pragma once

#include <cstddef>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "can/channel.hpp"
#include "can/timed_bus.hpp"
#include "common/ring.hpp"
#include "common/time.hpp"

namespace candp2::can {

class VirtualBus;

// What a controller on a bus in time reports as an error (docs/capture.md "Error frames"): a
// frame that ended in an error frame (at the first bit of its error flag, `error` why), or a
// node's change of confinement state (`state`, at the end of the frame that changed it or at its
// bus-off recovery). `node` is the endpoint's name (the sender of the frame in error), tec and
// rec its counters: at an error frame as they stand before it counts, at a change of state after.
struct BusError {
  Time time{0};
  TimedBus::Error error = TimedBus::Error::None;  // None: a change of state
  BusState state = BusState::Ok;                  // the new state (error None)
  bool recovered = false;                         // bus-off recovery (error None)
  std::uint32_t tec = 0, rec = 0;
  std::string_view node{};
};

// An endpoint's transmit queue on a bus in time (docs/can-bus.md "Transmit queues").
struct TxQueue {
  std::size_t depth = 4096;
  // A frame lost past the full queue counts in rx_lost() (the gateway's IRQ_LOST counts frames the
  // controller lost, "receive or send", manual §3.4.2), else in tx_dropped().
  bool loss_is_irq_lost = false;
};
// The CAN-DP/2's controller: the manual names a 255-frame FIFO for received frames (§5.3.3.2) and
// none for sending; the emulator gives the sending side the same depth.
inline constexpr TxQueue kGatewayTxQueue{255, true};
// A simulated drive: its manual names no transmit buffer; 16 frames (an emulator's choice).
inline constexpr TxQueue kDriveTxQueue{16, false};
// A socketcand client of the daemon's export: what a SocketCAN interface queues for sending
// (Linux CAN devices' default txqueuelen, 10); past it the write fails (ENOBUFS).
inline constexpr TxQueue kSocketcandTxQueue{10, false};
// The replay tester's node and endpoints by default: deep enough that a scenario's burst is never
// lost on its own.
inline constexpr TxQueue kTesterTxQueue{4096, false};

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
  // The transmit queue on a bus in time (ideal bus: no effect).
  void set_tx_queue(TxQueue q);
  // Fault injection: pretend the controller lost n frames (an RX overrun).
  void inject_rx_lost(std::uint32_t n);
  // Fault injection for this endpoint's controller only; nullopt follows the bus state.
  void set_bus_state_override(std::optional<BusState> s);

  // ---- on a bus in time (docs/can-bus.md "Error confinement"; ideal bus: no effect) ---------
  // The node's error confinement (nullptr on an ideal bus or a detached endpoint).
  const TimedBus::Confinement* confinement() const;
  std::size_t timed_node() const { return node_; }
  // Faults on cue: the node unplugged, at a wrong bit rate; clear_faults() cancels them and the
  // error frames on cue on this node.
  void set_unplugged(bool on);
  void set_wrong_bitrate(bool on);
  void clear_faults();
  // The bit rate the node's controller was set to (a gateway's Set_Prm); one other than the bus's
  // makes it a node at a wrong bit rate, as on a real bus. nullopt: not set (no effect).
  void set_own_bitrate(std::optional<std::uint32_t> bitrate);
  // False: the node receives but never acknowledges (a listen-only analyser).
  void set_acknowledges(bool on);

 private:
  friend class VirtualBus;
  VirtualEndpoint(VirtualBus* bus, std::string name, bool receive_own, std::size_t limit);
  void deliver(const Frame& frame);

  VirtualBus* bus_;
  std::size_t node_ = 0;  // on a bus in time
  TxQueue tx_queue_;
  std::string name_;
  bool receive_own_;
  std::size_t limit_;
  Ring<Frame> queue_;
  std::uint32_t rx_lost_ = 0;
  std::uint32_t tx_dropped_ = 0;
  std::optional<BusState> state_override_;
  bool wrong_bitrate_cue_ = false, wrong_bitrate_own_ = false;
  bool acknowledges_ = true;
  // On a bus in time: the node's confinement state, given by the bus at each change (bus_state()
  // is asked for every frame sent and received: docs/can-bus.md "Performance").
  BusState confined_ = BusState::Ok;
  void apply_wrong_bitrate();
};

class VirtualBus {
 public:
  struct Options {
    std::size_t rx_queue_limit = 4096;  // per endpoint; at least 1 (a full queue holds frames)
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
  // Observer of the errors of a bus in time (a capture's SocketCAN error frames); one at a time,
  // an empty function detaches it. Never called on an ideal bus.
  using ErrorTap = std::function<void(const BusError&)>;
  void set_error_tap(ErrorTap tap) { error_tap_ = std::move(tap); }

  // Fault injection: the state every controller on the bus sees. In BusOff, nothing is sent.
  void set_bus_state(BusState s) {
    state_ = s;
    changed();
  }
  BusState bus_state() const { return state_; }
  // Grows with every frame sent and every change of a bus or endpoint state: while it stands
  // still, no endpoint's queue, bus state or lost count changed (the plant skips quiet buses).
  std::uint64_t changes() const { return changes_; }
  // The changes but the frames that ended on a bus in time: while it stands still, no endpoint's
  // bus state or lost count changed but by the frames it took (the plant gives a gateway its
  // controller state again only then: docs/can-bus.md "Performance").
  std::uint64_t state_changes() const { return state_changes_; }
  // Also counts them in `*shared` (the plant's count over all its buses); null: not.
  void count_changes_in(std::uint64_t* shared) { shared_changes_ = shared; }
  // And calls `hook(state)` at each (the plant marks this bus's gateways for delivery); empty:
  // none. `state` false: only frames ended on the bus in time (state_changes() stood still), and
  // each endpoint they reached holds frames (taken, or counted lost on a full queue).
  void on_changed(std::function<void(bool state)> hook) { changed_hook_ = std::move(hook); }

  std::uint64_t frames_sent() const { return frames_sent_; }

  // ---- in time -----------------------------------------------------------------------------
  // Makes this a bus in time at `bitrate` bit/s from `origin` (before its first frame).
  void set_bitrate(std::uint32_t bitrate, Time origin);
  // The engine (statistics); nullptr on an ideal bus.
  const TimedBus* timed() const { return timed_.get(); }
  // The endpoints attached (the plant's gateways and drives, exports, clients, testers).
  std::size_t endpoint_count() const { return endpoints_.size(); }
  // Error frames on cue on the bus in time (docs/can-bus.md "Error confinement"); false on an
  // ideal bus. A fault on a node names its endpoint's timed_node().
  bool inject_errors(const TimedBus::ErrorFault& fault);
  // Cancels every fault on the bus in time (error frames, noise, nodes unplugged or at a wrong
  // bit rate on cue).
  void clear_faults();
  // When the bus in time next needs advancing; nullopt on an ideal bus.
  std::optional<Time> next_deadline() const {
    return timed_ ? timed_->next_deadline() : std::nullopt;
  }
  // Called when next_deadline() may have moved (TimedBus::on_moved); nothing on an ideal bus.
  void on_deadline_moved(std::function<void()> hook) {
    if (timed_) timed_->on_moved(std::move(hook));
  }
  // Starts and ends every frame due at or before `now` (taps at each start of frame, receivers at
  // each end).
  void advance(Time now) {
    if (!timed_) return;
    timed_->advance(now);
    // The frames that ended are one change (their receivers are looked at after the advance:
    // docs/can-bus.md "Performance").
    if (ended_) {
      ended_ = false;
      changed(false);
    }
  }

 private:
  friend class VirtualEndpoint;
  void transmit(VirtualEndpoint* from, const Frame& frame);
  void detach(VirtualEndpoint* ep);
  void attach_timed(VirtualEndpoint* ep);
  void started(const TimedBus::OnBus& f);
  // A frame in error to the error tap (out of line: started() is the path of every frame).
  [[gnu::noinline, gnu::cold]] void started_in_error(const TimedBus::OnBus& f);
  void ended(const TimedBus::OnBus& f);
  void state_changed(std::size_t node, BusState s);
  void deliver_all(VirtualEndpoint* from, const Frame& frame);

  Options options_;
  std::vector<VirtualEndpoint*> endpoints_;
  std::vector<Tap> taps_;
  ErrorTap error_tap_;
  // The frame on the bus (between started() and ended()) and its end: a change of state in
  // between comes at its end.
  bool in_frame_ = false;
  Time frame_end_{0};
  BusState state_ = BusState::Ok;
  std::uint64_t changes_ = 0, state_changes_ = 0;
  std::uint64_t* shared_changes_ = nullptr;
  std::function<void(bool)> changed_hook_;
  void changed(bool state = true) {
    ++changes_;
    if (state) ++state_changes_;
    if (shared_changes_) ++*shared_changes_;
    if (changed_hook_) changed_hook_(state);
  }
  Time now_{0};
  const Time* clock_ = nullptr;
  std::uint64_t frames_sent_ = 0;
  std::unique_ptr<TimedBus> timed_;
  bool ended_ = false;                   // a frame ended in this advance()
  std::vector<VirtualEndpoint*> nodes_;  // by TimedBus node; null when detached
};

}  // namespace candp2::can
