// The emulated CAN-DP/2: its DP slave face (profibus_sim DpSlave) and its firmware behaviour
// (slots, Communication Window, Page-Mode, CANopen release rules, diagnosis).
//
// Pure and deterministic: frames in through on_can_frame(), frames out through the FrameSink given
// at construction, DP services through dp(), time passed in with every call, timers fired by
// advance(now) at the times next_deadline() announces. No sockets, threads, globals or clock.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "can/channel.hpp"
#include "common/log.hpp"
#include "common/time.hpp"
#include "gateway/comm_window.hpp"
#include "gateway/page_mode.hpp"
#include "gateway/slot_config.hpp"
#include "gateway/slot_engine.hpp"
#include "gateway/user_prm.hpp"
#include "profibus_sim/dp/dp_slave.hpp"

namespace candp2::gw {

struct GatewayOptions {
  std::uint8_t address = 3;          // rotary switches; clamped to 3..124 (manual §2.1)
  bool cia301_bootup = false;        // CANopen slave boot frame 0x700+ID instead of 0x80+ID
  std::uint8_t stored_wakeup_s = 0;  // the gateway's stored values
                                     // (docs/dp-slave.md "User parameters")
  std::uint16_t stored_sync_ms = 0;
  LogSink* log = nullptr;
  // The configuration's name: log lines carry it ("g666", "g666.dp", "g666.cw"); empty: "gwN".
  std::string name{};
};

// CANopen NMT state of the gateway as a CANopen slave (docs/canopen.md).
enum class NmtState : std::uint8_t { Initialising, PreOperational, Operational, Stopped };
std::string_view to_string(NmtState s);

// Diagnosis byte 8 with CAN-Diagnosis on (manual §3.4.2 table 3.4.5): 00 OK, 40 WARN,
// 80 ERROR_PASSIVE, C0 BUS_OFF in bits 7..6.
std::uint8_t bus_state_code(can::BusState s);
inline constexpr std::uint8_t kBusStateMask = 0xC0;

// CAN-side counters and state, for the Modbus status block and logs.
struct GatewayStatus {
  dp::SlaveState dp_state = dp::SlaveState::WaitPrm;
  can::BusState bus_state = can::BusState::Ok;
  bool released = false;
  NmtState nmt = NmtState::Initialising;
  std::uint32_t rx_frames = 0;
  std::uint32_t tx_frames = 0;
  std::uint32_t irq_lost = 0;
  std::uint32_t msg_lost = 0;
  std::uint32_t fifo_level = 0;
  std::uint32_t fifo_high_water = 0;
  std::uint16_t sync_ms = 0;  // effective SYNC time
  std::uint8_t wakeup_s = 0;  // stored wake-up time
  std::uint32_t data_exchanges = 0;
};

class Gateway final : private dp::SlaveApplication, private CwHost {
 public:
  Gateway(GatewayOptions options, can::FrameSink& can_tx, Time power_on);
  Gateway(const Gateway&) = delete;
  Gateway& operator=(const Gateway&) = delete;

  // The DP services (Set_Prm, Chk_Cfg, Slave_Diag, Get_Cfg, Data_Exchange, Global_Control).
  dp::DpSlave& dp() { return slave_; }
  const dp::DpSlave& dp() const { return slave_; }
  std::uint8_t address() const { return address_; }

  // A frame received from the CAN bus. True when what the gateway waits for (next_deadline()) may
  // have moved: an NMT command to a CANopen slave (release, halt, reset). A frame into a slot, a
  // page or the CW leaves it as it was, and its holder need not ask again (docs/can-bus.md
  // "Performance").
  bool on_can_frame(const can::Frame& frame, Time now);
  // Controller state and the transport's cumulative lost-frame count (IRQ_LOST).
  void set_controller_status(can::BusState state, std::uint32_t rx_lost_total);

  void advance(Time now);
  std::optional<Time> next_deadline() const;

  // Power cycle: everything back to power-on state; stored wake-up/SYNC values survive.
  void power_cycle(Time now);

  GatewayStatus status() const;
  const std::optional<UserPrm>& user_prm() const { return prm_; }
  const std::optional<SlotConfig>& slot_config() const { return cfg_; }
  const CommWindow& comm_window() const { return cw_; }
  const SlotEngine& slot_engine() const { return slots_; }
  const PageMode& page_mode() const { return page_; }
  std::uint8_t stored_wakeup_s() const { return stored_wakeup_s_; }
  std::uint16_t stored_sync_ms() const { return stored_sync_ms_; }

 private:
  // dp::SlaveApplication
  std::optional<dp::PrmFault> on_set_prm(std::span<const std::uint8_t> telegram, Time now) override;
  std::optional<dp::CfgFault> on_chk_cfg(std::span<const std::uint8_t> cfg, Time now) override;
  void on_enter_data_exchange(Time now) override;
  void on_leave_data_exchange(Time now) override;
  void on_data_exchange(std::span<const std::uint8_t> outputs, std::span<std::uint8_t> inputs,
                        Time now) override;
  std::size_t output_length() const override { return cfg_ ? cfg_->output_len : 0; }
  std::size_t input_length() const override { return cfg_ ? cfg_->input_len : 0; }
  dp::DeviceDiag device_diag() const override;

  // TxPort / CwHost
  bool tx_active() const override;
  void transmit(const can::Frame& frame) override;
  bool can_released() const override { return released_; }
  bool set_sync_time(std::uint16_t ms, Time now) override;

  CanopenRole role() const { return prm_ ? prm_->role() : CanopenRole::None; }
  Time wake_time() const { return power_on_ + seconds(stored_wakeup_s_); }
  void boot_if_due(Time now);
  void update_release(Time now);
  void release(Time now, std::string_view why);
  void send_rtr_frames();
  void halt(std::string_view why);
  void send_boot_frame();
  void handle_nmt(const can::Frame& frame, Time now);
  void schedule_sync(Time now);
  std::optional<Time> sync_due() const;  // next SYNC, deferred behind a Data_Exchange burst
  void fire_sync(Time now);

  Logger log_;
  std::uint8_t address_;
  GatewayOptions options_;
  can::FrameSink& can_tx_;
  dp::DpSlave slave_;

  std::optional<UserPrm> prm_;
  std::optional<SlotConfig> cfg_;
  std::vector<std::uint8_t> accepted_cfg_;  // Chk_Cfg bytes of cfg_
  std::optional<UserPrm> accepted_prm_;     // the parameters cfg_ was accepted with
  SlotEngine slots_;
  CommWindow cw_;
  PageMode page_;
  std::vector<std::uint8_t> input_image_;

  // CAN release (docs/canopen.md).
  Time power_on_{0};
  bool released_ = false;
  bool rtr_pending_ = false;  // the release's RTR frames wait for the Tx slots' first data
  NmtState nmt_ = NmtState::Initialising;
  bool boot_sent_ = false;
  std::uint8_t stored_wakeup_s_ = 0;
  std::uint16_t stored_sync_ms_ = 0;
  std::uint16_t sync_ms_ = 0;      // effective SYNC time (last written source wins)
  std::optional<Time> next_sync_;  // SYNC grid point (a deferred SYNC does not move the grid)
  // The frames of Data_Exchanges occupy the bus in [busy_from_, bus_busy_until_); bursts that
  // overlap merge into one window (manual §5.3.3 command 20 note).
  Time bus_busy_until_{0};
  Time busy_from_{0};
  std::uint32_t burst_bits_ = 0;

  // Counters.
  can::BusState bus_state_ = can::BusState::Ok;
  // IRQ_LOST = the transport's cumulative lost-frame count since the last power cycle.
  std::uint32_t irq_lost_total_ = 0;  // the transport's count, as last reported
  std::uint32_t irq_lost_base_ = 0;   // its value at the last power cycle
  std::uint32_t irq_lost() const { return irq_lost_total_ - irq_lost_base_; }
  std::uint32_t rx_frames_ = 0;
  std::uint32_t tx_frames_ = 0;
  std::uint32_t data_exchanges_ = 0;
};

// What a release sends besides the Tx slots (docs/canopen.md), for the gateway and for `candp2
// validate`'s bus prediction: the CANopen master's NMT start frame when Start-Frame is on; whether
// RTR-Frames applies, and the remote frames, one per distinct Rx identifier in slot order.
std::optional<can::Frame> start_frame(const UserPrm& prm);
bool sends_rtr_frames(const UserPrm& prm, const SlotConfig& cfg);
std::vector<can::Frame> rtr_frames(const SlotConfig& cfg);

// Bits a classic CAN frame occupies on the bus without stuff bits (incl. 3 bit intermission):
// used to model how long a Data_Exchange burst keeps the bus busy (SYNC deferral, manual §5.3.3).
std::uint32_t frame_bits(const can::Frame& f);

}  // namespace candp2::gw
