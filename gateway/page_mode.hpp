// Page-Mode (manual §6, docs/page-mode.md): more CAN identifiers than one DP telegram holds, moved
// in pages over segment slots.
//
// candp2::gw::PageMode — the gateway's Page-Mode engine: pages 0/1, Tx configuration pages 51..150,
// Rx configuration pages 151..250, data pages 251.. with force 0-4 and count_in, the
// sequence-number acknowledge, torn pages ignored, status codes in input byte 3. Pure: frames out
// through a TxPort, time passed in, no I/O. The page wire format itself is
// gateway/page/page_format.hpp (gw::page).
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "can/frame.hpp"
#include "common/log.hpp"
#include "common/time.hpp"
#include "gateway/page/page_format.hpp"
#include "gateway/slot_config.hpp"
#include "gateway/tx_port.hpp"

namespace candp2::gw {

// The page wire format lives one layer down (gateway/page/page_format.hpp); gw::page names it.
namespace page = ::candp2::page;

// The gateway's Page-Mode engine (docs/page-mode.md).
class PageMode {
 public:
  enum class State : std::uint8_t {
    WaitInit,  // no page 0 since the configuration (power-on, Chk_Cfg)
    TxConfig,  // page 0 processed; expecting Tx configuration page 51 + n
    RxConfig,  // Tx configuration complete; expecting Rx configuration page 151 + n
    Data,      // Rx configuration complete: data pages 251 .. 250 + N
  };

  void set_logger(Logger log) { log_ = std::move(log); }

  // The segment layout (already checked by decode_slots: Cfg code 9). Resets the Page-Mode state.
  void configure(const SlotConfig& cfg);
  // Back to the state after configure(): nothing configured, input page zero.
  void reset();
  // The power-on state: no segments, and pages_processed() back to 0 (docs/faults.md).
  void power_on() {
    configure(SlotConfig{});
    pages_processed_ = 0;
  }
  // The output page: the concatenated output segments of this Data_Exchange.
  void on_output_page(std::span<const std::uint8_t> page, Time now, TxPort& tx);
  // The input page: the concatenated input segments the PLC reads.
  void write_input_page(std::span<std::uint8_t> page) const;
  // A received frame on a configured Rx identifier: true when taken.
  bool on_frame(const can::Frame& frame, Time now);
  // CAN transmission (re)released: data-page sends held back meanwhile go out now.
  void on_release(Time now, TxPort& tx);
  // Distinct Rx identifiers in configuration order (empty until the configuration is complete).
  std::vector<can::Ident> rx_idents() const;

  std::size_t output_page_len() const { return out_.size(); }
  std::size_t input_page_len() const { return in_.size(); }
  const page::Layout& output_layout() const { return out_; }
  const page::Layout& input_layout() const { return in_; }

  State state() const { return state_; }
  std::size_t tx_count() const { return tx_.size(); }
  std::size_t rx_count() const { return rx_.size(); }
  std::size_t data_pages() const { return data_pages_; }  // N, once the configuration is complete
  std::optional<page::Status> last_status() const { return last_status_; }
  std::uint64_t pages_processed() const { return pages_processed_; }

 private:
  struct TxEntry {
    page::IdEntry def;
    page::DataPlace place;
    std::size_t ident = 0;           // index into tx_idents_ (the same identifier twice shares)
    std::uint8_t last_force = 0xFF;  // force on the last processed page; 0xFF = none yet
    bool held = false;               // a send fell due while transmission was not released
    std::array<std::uint8_t, 8> data{};
  };
  struct TxIdent {
    bool sent = false;  // "first time: send" (force 2)
    std::uint8_t len = 0;
    std::array<std::uint8_t, 8> last{};  // data last sent on this identifier (PLC byte order)
  };
  struct RxEntry {
    page::IdEntry def;
    page::DataPlace place;
    std::uint8_t count = 0;  // count_in, modulo 256
    std::array<std::uint8_t, 8> data{};
  };

  // The answer to a page: page number in every input segment, header bytes 2-7.
  void answer(std::uint16_t number, std::uint8_t seq, page::Status status, std::uint16_t w4,
              std::uint16_t w6);
  void fail(std::uint16_t number, std::uint8_t seq, page::Status status, std::uint16_t w6,
            const std::string& why);
  void clear_configuration();
  void on_init(std::uint8_t seq);
  // Order and decoding checks shared by Tx and Rx configuration pages; nullopt after answering
  // the fault.
  std::optional<page::ConfigPage> accept_config_page(std::uint16_t number, std::uint8_t seq,
                                                     std::span<const std::uint8_t> page,
                                                     State expected, std::string_view dir,
                                                     std::uint16_t count);
  void on_tx_config(std::uint16_t number, std::uint8_t seq, std::span<const std::uint8_t> page);
  void on_rx_config(std::uint16_t number, std::uint8_t seq, std::span<const std::uint8_t> page);
  void on_data(std::uint16_t number, std::uint8_t seq, std::span<const std::uint8_t> page,
               TxPort& tx);
  bool send_due(TxEntry& e, std::uint8_t force, std::span<const std::uint8_t> data) const;
  void send(TxEntry& e, TxPort& tx);
  void finish_configuration(std::uint16_t number, std::uint8_t seq);

  Logger log_;
  page::Layout out_, in_;
  bool comm_window_ = false;
  State state_ = State::WaitInit;
  std::optional<std::uint8_t> last_seq_;  // sequence number of the last processed page
  bool torn_ = false;                     // the last Data_Exchange carried a torn page
  std::uint16_t next_config_page_ = 0;
  std::vector<TxEntry> tx_;
  std::vector<TxIdent> tx_idents_;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> tx_index_;  // ident key -> tx_idents_
  std::vector<RxEntry> rx_;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> rx_index_;  // ident key -> rx_ (sorted)
  std::vector<std::vector<std::uint32_t>> tx_by_page_, rx_by_page_;
  std::size_t data_pages_ = 0;
  std::vector<std::uint8_t> input_page_;
  std::optional<page::Status> last_status_;
  std::string last_data_fault_;  // logged once until it changes
  std::uint64_t pages_processed_ = 0;
};

std::string_view to_string(PageMode::State s);

}  // namespace candp2::gw
