// Page-Mode, gateway side (manual §6, emulator-spec §6): pages 0/1, Tx configuration pages 51..150,
// Rx configuration pages 151..250, data pages 251.. with force 0-4 and count_in. Pure.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "common/time.hpp"
#include "gateway/slot_config.hpp"
#include "gateway/tx_port.hpp"

namespace candp2::gw {

class PageMode {
 public:
  // The segment layout (already checked by decode_slots: Cfg code 9).
  void configure(const SlotConfig& cfg);
  void reset();
  // The output page: the concatenated output segments of this Data_Exchange.
  void on_output_page(std::span<const std::uint8_t> page, Time now, TxPort& tx);
  // The input page: the concatenated input segments the PLC reads.
  void write_input_page(std::span<std::uint8_t> page) const;
  // A received frame on a configured Rx identifier: true when taken.
  bool on_frame(const can::Frame& frame, Time now);
  void on_release(Time now, TxPort& tx);
  std::vector<can::Ident> rx_idents() const;

  std::size_t output_page_len() const { return out_len_; }
  std::size_t input_page_len() const { return in_len_; }

 private:
  std::vector<std::size_t> out_segments_, in_segments_;
  std::size_t out_len_ = 0, in_len_ = 0;
  std::vector<std::uint8_t> input_page_;
};

}  // namespace candp2::gw
