// Normal-mode slot traffic (manual §2.2, §3.2.3, §5.2.2-5.2.3;
// docs/slots.md "Data exchange in normal mode"): Tx on release, on change and every `cycle` ms; Rx
// into the input image with zero fill, form swap, Rx-Counter; "the later Rx slot wins". Pure; the
// input image is owned by the caller.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "common/time.hpp"
#include "gateway/slot_config.hpp"
#include "gateway/tx_port.hpp"

namespace candp2::gw {

class SlotEngine {
 public:
  void configure(const SlotConfig& cfg);
  void clear() { configure(SlotConfig{}); }

  // One Data_Exchange's output image: frames for Tx slots whose bytes changed (or that never sent
  // since release) go out when tx.tx_active(). `now` only stamps the slot statistics.
  void on_outputs(std::span<const std::uint8_t> outputs, TxPort& tx, Time now = Time{0});
  // A received frame: true when an input slot took it; the slot's bytes in `inputs` are updated.
  bool on_frame(const can::Frame& frame, std::span<std::uint8_t> inputs, Time now = Time{0});
  // Transmission released: every Tx slot that has data goes out once; cycle timers start now.
  void on_release(Time now, TxPort& tx);
  // Cyclic sends due at or before `now`.
  void advance(Time now, TxPort& tx);
  std::optional<Time> next_deadline() const;

  // True while a Tx slot with a CAN identifier has had no Data_Exchange yet: its first frame
  // waits for the outputs.
  bool tx_waiting_for_data() const;
  std::vector<can::Ident> rx_idents() const;
  std::size_t tx_slot_count() const { return tx_.size(); }
  std::size_t rx_slot_count() const { return rx_.size(); }

  // Per configured slot (SlotConfig::slots order; CW and segment slots stay zero): frames sent
  // (Tx) or taken (Rx) since configure(), and when the last one was. For the status page.
  struct SlotStats {
    std::uint32_t frames = 0;
    std::optional<Time> last;
  };
  const std::vector<SlotStats>& slot_stats() const { return stats_; }

 private:
  struct TxSlot {
    std::size_t slot = 0;  // index into stats_
    std::size_t offset = 0, length = 0, data_len = 0;
    std::optional<can::Ident> id;
    std::array<std::uint8_t, 8> perm{};  // form as a permutation (manual §5.2.2)
    std::uint16_t cycle_ms = 0;
    std::array<std::uint8_t, 9> last{};  // image bytes of the previous Data_Exchange
    bool have_data = false;              // a Data_Exchange delivered data
    bool sent_since_release = false;
    Time next_cycle{0};
  };
  struct RxSlot {
    std::size_t slot = 0;  // index into stats_
    std::size_t offset = 0, data_len = 0;
    bool counter = false;
    bool swap = false;
    std::array<std::uint8_t, 8> perm{};  // form as a permutation (manual §5.2.2)
    std::uint8_t count = 0;
  };
  void send(const TxSlot& s, TxPort& tx, Time now);

  std::vector<TxSlot> tx_;
  std::vector<RxSlot> rx_;
  std::vector<std::pair<std::uint32_t, std::uint16_t>> rx_index_;  // ident key -> rx_ index, sorted
  std::vector<can::Ident> rx_ids_;  // distinct Rx identifiers in slot order
  std::vector<SlotStats> stats_;
  bool released_ = false;
  // The earliest next_cycle of a cyclic Tx slot, kept as the timers move (on_release, advance):
  // the plant asks for it after every frame the gateway receives (docs/can-bus.md "Performance").
  std::optional<Time> next_cycle_;
  void recompute_next_cycle();
};

}  // namespace candp2::gw
