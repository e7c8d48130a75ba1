// The PLC-side Page-Mode driver: what esd's function block FB2 does in an S7 (manual §6.5, §8.2),
// as a PlcProgram the simulated DP master runs once per cycle.
//
// It initializes with page 0/1, sends the Tx identifier list of WRITE_CONFIG_DB (DB94) on pages
// 51.., the Rx identifier list of READ_CONFIG_DB (DB95) on pages 151.., then cycles the data pages
// 251 .. 250+N: Tx data (länge, force, data) from WRITE_DB (DB96) out, Rx data (count_in, data)
// into READ_DB (DB97). The data blocks are laid out exactly as manual tables 6.5.2-6.5.6 and may be
// split over several DBs chained by DD markers (the end marked EE). RET_VALUE reports the page type
// in progress (table 6.5.7).
//
// Handshake (docs/page-mode.md "Header bytes"): every page carries a new sequence number in byte 2;
// the driver waits until the input page answers that page number with that sequence number. Like
// FB2 it works in two phases, one per PLC cycle: write a page, then read its answer — a page takes
// two PLC cycles (manual §6.1), a full rotation over N data pages 2 × N cycles.
//
// Pure: time passed in, no I/O; the PLC process image is the master's.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "common/log.hpp"
#include "common/time.hpp"
#include "gateway/page/page_format.hpp"
#include "profibus_sim/master/dp_master.hpp"

namespace candp2::plc {

using page::IdEntry;
using DataBlock = std::vector<std::uint8_t>;
// Data blocks in processing order: a DD marker at the end of one continues in the next, EE ends.
using DbChain = std::vector<DataBlock>;

// Where an entry of a DB chain lives: DB index and byte offset.
struct DbPos {
  std::size_t db = 0;
  std::size_t offset = 0;
  friend bool operator==(const DbPos&, const DbPos&) = default;
};

// WRITE_CONFIG_DB / READ_CONFIG_DB (manual tables 6.5.2/6.5.3): 6 bytes per identifier (identifier
// big-endian, form, länge), then DD DD DD DD (next DB) or EE EE EE EE (end). The entries verbatim,
// or nullopt and *why for a chain without a proper end.
std::optional<std::vector<page::RawEntry>> parse_config_chain(const DbChain& chain,
                                                              std::string* why);
// WRITE_DB / READ_DB (manual tables 6.5.4/6.5.6): per identifier länge (= data bytes + 1),
// force / count_in, data; then DD (next DB) or EE (end). The position of each identifier's länge
// byte, checked against the configured lengths; nullopt and *why when the layout does not match.
std::optional<std::vector<DbPos>> locate_data_entries(const DbChain& chain,
                                                      std::span<const IdEntry> ids,
                                                      std::string* why);

// Builders, as a PLC programmer fills the DBs: `per_db` identifiers per DB (0 = all in one).
DbChain make_config_chain(std::span<const IdEntry> ids, std::size_t per_db = 0);
DbChain make_data_chain(std::span<const IdEntry> ids, std::size_t per_db = 0);

// FB2's RET_VALUE (manual table 6.5.7).
enum class RetValue : std::uint16_t {
  None = 0,
  Reserved = 1,
  TxConfig = 2,
  RxConfig = 3,
  Data = 4
};

struct PageDriverOptions {
  std::uint16_t write_address = 0;  // WRITE_ADDRESS: PLC Q address of the first output segment
  std::uint16_t read_address = 0;   // READ_ADDRESS: PLC I address of the first input segment
  std::size_t output_page_len = 0;  // bytes of all output segments (consecutive addresses)
  // Wait after page 1 before the first configuration page. FB2 users wait ~5 s (manual §6.4.4);
  // the emulated gateway is ready at once.
  Duration init_delay{0};
  Duration ack_timeout = milliseconds(1000);  // no answer: start again with page 0
  Duration retry_delay = milliseconds(1000);  // after an error status: wait, then page 0 again
};

class PageDriver final : public dp::PlcProgram {
 public:
  enum class State : std::uint8_t {
    Init,      // write page 0
    InitWait,  // wait for page 1
    Ready,     // initialized; waiting for FREIGABE (and init_delay)
    TxSend,
    TxWait,
    RxSend,
    RxWait,
    DataSend,
    DataWait,
    Error,  // wait retry_delay, then page 0 again
  };

  explicit PageDriver(PageDriverOptions options, LogSink* log = nullptr);

  // FB2 parameters (manual table 6.5.1). FREIGABE = 0: initialization only (page 0/1);
  // 1: configuration and data exchange. Going back to 0 starts again with page 0.
  void set_freigabe(bool on) { freigabe_ = on; }
  bool freigabe() const { return freigabe_; }
  DbChain& write_config_db() { return write_config_; }  // DB94
  DbChain& read_config_db() { return read_config_; }    // DB95
  DbChain& write_db() { return write_db_; }             // DB96
  DbChain& read_db() { return read_db_; }               // DB97
  const DbChain& write_config_db() const { return write_config_; }
  const DbChain& read_config_db() const { return read_config_; }
  const DbChain& write_db() const { return write_db_; }
  const DbChain& read_db() const { return read_db_; }
  RetValue ret_value() const;

  void scan(dp::ProcessImage& image, Time now) override;

  State state() const { return state_; }
  std::size_t data_pages() const { return data_pages_; }  // N
  std::uint16_t current_page() const { return page_; }    // last page written
  std::uint64_t rotations() const { return rotations_; }  // completed data rotations
  std::uint64_t scans() const { return scans_; }          // PLC cycles seen
  std::uint64_t restarts() const { return restarts_; }    // times page 0 was sent
  const std::string& last_error() const { return last_error_; }
  const page::Layout& output_layout() const { return out_; }
  const page::Layout& input_layout() const { return in_; }

 private:
  struct Answer {
    std::uint8_t status;
    std::uint16_t w4, w6;
  };
  void go(State next, std::string_view why);
  void restart(std::string_view why);
  void error(Time now, const std::string& why);
  std::span<std::uint8_t> out_page(dp::ProcessImage& image);
  std::span<const std::uint8_t> in_page(const dp::ProcessImage& image, std::size_t len) const;
  void write_page(dp::ProcessImage& image, std::uint16_t number, Time now);
  std::optional<Answer> answered(const dp::ProcessImage& image, std::uint16_t number);
  bool check_status(const Answer& a, Time now);

  void on_init_answer(const dp::ProcessImage& image, Time now);
  bool load_configuration(Time now);
  void send_config(dp::ProcessImage& image, Time now, bool tx);
  void on_config_answer(const Answer& a, Time now, bool tx);
  bool start_data(Time now);
  void send_data(dp::ProcessImage& image, Time now);
  void on_data_answer(const dp::ProcessImage& image, const Answer& a, Time now);

  PageDriverOptions options_;
  Logger log_;
  bool freigabe_ = false;
  DbChain write_config_, read_config_, write_db_, read_db_;

  State state_ = State::Init;
  std::uint8_t seq_ = 0;
  std::uint16_t page_ = 0;
  Time sent_at_{0};
  Time ready_at_{0};
  Time retry_at_{0};
  page::Layout out_, in_;

  std::vector<page::RawEntry> tx_raw_, rx_raw_;
  std::vector<IdEntry> tx_, rx_;
  std::size_t cursor_ = 0;     // configuration entries acknowledged so far
  std::size_t pending_ = 0;    // entries on the configuration page in flight
  bool pending_last_ = false;  // that page carries EE
  std::vector<page::DataPlace> tx_places_, rx_places_;
  std::size_t data_pages_ = 0;
  std::size_t data_index_ = 0;

  std::uint64_t rotations_ = 0, scans_ = 0, restarts_ = 0;
  std::string last_error_;
};

std::string_view to_string(PageDriver::State s);

}  // namespace candp2::plc
