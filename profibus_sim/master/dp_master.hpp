// The simulated DP master (class 1) with its PLC process image (docs/modbus.md).
//
// Per slave: Slave_Diag → Set_Prm → Chk_Cfg → Slave_Diag → cyclic Data_Exchange, retrying the
// parameterization while the slave reports a fault; every transition and the diagnosis it saw are
// logged (the pyprofibus master's discipline: a table of state → name and handler). The master owns
// one PLC process image (I and Q, 8192 bytes each) shared by all slaves, as in a PLC; slot bytes
// are copied between the image and each slave's DP data at the PLC addresses of the configuration.
//
// The diagnosis may be 6..244 bytes (IEC 61158-6-3); the CAN-DP/2 always sends 11
// (docs/dp-slave.md "Diagnosis"). Each slave is reached through a dp::SlaveLink
// (profibus_sim/dp/slave_link.hpp): in-process (a DpSlave in the same process, answers at once) or
// over FDL (fdl::FdlMaster, answers later). One request per slave is outstanding at a time; a slave
// whose answer has not come yet is skipped in that cycle. A station that does not answer shows
// Station_Non_Existent (diag byte 0 bit 0) in the diagnosis the master exposes and is parameterized
// again from Init when it answers again, as a real master's diagnosis shows it; a malformed answer
// shows Invalid_Slave_Response (bit 5). Pure: time passed in; the daemon calls cycle() every
// cycle_ms.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "common/log.hpp"
#include "common/time.hpp"
#include "profibus_sim/dp/dp_slave.hpp"
#include "profibus_sim/dp/slave_link.hpp"

namespace candp2::dp {

inline constexpr std::size_t kImageSize = 8192;  // docs/modbus.md: registers 0..4095 x 2 bytes

struct ProcessImage {
  std::array<std::uint8_t, kImageSize> inputs{};   // PLC I bytes (slave → PLC)
  std::array<std::uint8_t, kImageSize> outputs{};  // PLC Q bytes (PLC → slave)
};

// A PLC program run once per master cycle before the Data_Exchanges (reads I, writes Q), e.g. the
// Page-Mode driver (FB2 equivalent).
class PlcProgram {
 public:
  virtual ~PlcProgram() = default;
  virtual void scan(ProcessImage& image, Time now) = 0;
};

// Where a Chk_Cfg entry's bytes live in the PLC image (the addresses of the SIMATIC dialog).
struct EntryAddress {
  std::optional<std::uint16_t> input;   // PLC I address of the entry's input bytes
  std::optional<std::uint16_t> output;  // PLC Q address of the entry's output bytes
};

struct SlaveParameters {
  std::vector<std::uint8_t> prm;        // the whole Set_Prm telegram
  std::vector<std::uint8_t> cfg;        // Chk_Cfg data
  std::vector<EntryAddress> addresses;  // one per Chk_Cfg entry (missing = not mapped)
  std::string name;
};

// Where a slave's DP data bytes live in the PLC process image: one piece per mapped Chk_Cfg entry
// (the addresses of the SIMATIC dialog). The built-in master copies through it; a profibus line
// in role slaves mirrors the wire into the image through it (docs/profibus.md).
struct ImageMapping {
  std::size_t dp_offset;      // offset in the slave's output (or input) data
  std::uint16_t plc_address;  // PLC Q (or I) byte address
  std::size_t length;
};
struct ImageMap {
  std::vector<ImageMapping> out, in;
  std::size_t out_len = 0, in_len = 0;  // the slave's whole output / input data length
};
// Entries that would leave the 8192-byte image are not mapped; `skipped(entry, address, length)`
// hears of each.
ImageMap map_image(
    const SlaveParameters& params,
    const std::function<void(std::size_t, std::uint16_t, std::size_t)>& skipped = {});

enum class MasterSlaveState : std::uint8_t {
  Init,       // read the diagnosis to see whether the slave is there
  SetPrm,     // send Set_Prm
  ChkCfg,     // send Chk_Cfg
  CheckDiag,  // read the diagnosis: ready for Data_Exchange?
  DataExch,   // cyclic Data_Exchange
  Retry,      // a fault was reported; wait, then start again
};
std::string_view to_string(MasterSlaveState s);

struct MasterOptions {
  std::uint8_t address = 1;
  Duration retry_delay = milliseconds(1000);  // between parameterization attempts after a fault
  // A lost station (no answer) is parameterized again after retry_delay too (a line in time,
  // docs/profibus.md "The line in time"); false: from the next cycle on (the ideal line).
  bool lost_waits_retry = false;
  // Slave_Diag → Set_Prm → Chk_Cfg → Slave_Diag → Data_Exchange one after the other, each as soon
  // as the last one was answered (a line in time: a parameterization spread over several slow
  // rotations would let a short watchdog expire between Set_Prm and Chk_Cfg); false: one step a
  // cycle (the ideal line).
  bool parameterize_in_one_go = false;
};

class DpMaster {
 public:
  DpMaster(MasterOptions options, LogSink* log = nullptr);

  // A slave reached through `link` (at link.address()); the link must outlive the master.
  // Returns the slave's index.
  std::size_t add_slave(SlaveLink& link, SlaveParameters params);
  // Convenience: a DpSlave in this process, through an InProcessLink the master owns. The slave
  // must outlive the master.
  std::size_t add_slave(DpSlave& slave, SlaveParameters params);
  void set_program(PlcProgram* program) { program_ = program; }

  // One bus cycle: the PLC program scans, then each slave's state machine takes one step
  // (a Data_Exchange for slaves in Data_Exch).
  void cycle(Time now);

  // Start parameterization of a slave again (Modbus control register 8192 = 2).
  void reparameterize(std::uint8_t slave_address, Time now);

  // Stop addressing a slave (addressed = false; Modbus control 8192 = 3: the PLC stops, the slave's
  // watchdog expires if it has one) or address it again (true; 8192 = 4): the master starts over
  // with Slave_Diag → Set_Prm → Chk_Cfg, as a real master does with a slave back in Wait_Prm.
  void set_addressed(std::uint8_t slave_address, bool addressed, Time now);

  ProcessImage& image() { return image_; }
  const ProcessImage& image() const { return image_; }

  struct SlaveView {
    std::uint8_t address;
    MasterSlaveState state;
    // The first 11 bytes of the last diagnosis, zero-padded (the CAN-DP/2's whole diagnosis).
    std::optional<DpSlave::Diag> last_diag;
    std::uint32_t data_exchanges;
    std::uint32_t parameterizations;
    std::uint32_t station_lost = 0;  // times the station stopped answering
    bool addressed = true;
    std::vector<std::uint8_t> diag_bytes;  // the last diagnosis as received (6..244 bytes)
  };
  std::vector<SlaveView> slaves() const;
  std::optional<SlaveView> slave(std::uint8_t address) const;
  std::uint8_t address() const { return options_.address; }

 private:
  struct Entry {
    SlaveLink* link = nullptr;
    std::unique_ptr<InProcessLink> owned;  // add_slave(DpSlave&)
    SlaveParameters params;
    ImageMap map;
    std::vector<std::uint8_t> out_buf;
    MasterSlaveState state = MasterSlaveState::Init;
    std::optional<DpSlave::Diag> last_diag;
    std::vector<std::uint8_t> diag_bytes;
    Time retry_at{0};
    std::uint32_t data_exchanges = 0;
    std::uint32_t parameterizations = 0;
    std::uint32_t station_lost = 0;
    bool busy = false;             // a request is outstanding on the link
    bool diag_due = false;         // Data_Exchange answered DH: read the diagnosis next
    std::uint32_t generation = 0;  // bumped by reparameterize(): older answers are dropped
    std::uint8_t address() const { return link->address(); }
    bool addressed = true;
  };
  using Handler = void (DpMaster::*)(Entry&, Time);
  struct StateRow {
    MasterSlaveState state;
    Handler step;
  };
  static const StateRow kStates[];
  using OnAnswer = void (DpMaster::*)(Entry&, const Response&, Time);

  void step(Entry& e, Time now);
  void on_retry(Entry& e, Time now);
  void on_init(Entry& e, Time now);
  void on_set_prm(Entry& e, Time now);
  void on_chk_cfg(Entry& e, Time now);
  void on_check_diag(Entry& e, Time now);
  void on_data_exch(Entry& e, Time now);

  void send(Entry& e, Service service, std::vector<std::uint8_t> data, Time now, OnAnswer then);
  void init_answered(Entry& e, const Response& r, Time now);
  void set_prm_answered(Entry& e, const Response& r, Time now);
  void chk_cfg_answered(Entry& e, const Response& r, Time now);
  void check_diag_answered(Entry& e, const Response& r, Time now);
  void diag_due_answered(Entry& e, const Response& r, Time now);
  void exchange_answered(Entry& e, const Response& r, Time now);
  void refused_diag_answered(Entry& e, const Response& r, Time now);

  // Shared answer handling: NoResponse → station lost; a Slave_Diag answer shorter than 6 or longer
  // than 244 bytes → Invalid_Slave_Response. False when the answer was consumed that way.
  bool answered(Entry& e, const Response& r, Time now, std::string_view what);
  bool take_diag(Entry& e, const Response& r, Time now);
  void go(Entry& e, MasterSlaveState next, std::string_view why);
  void set_diag(Entry& e, std::vector<std::uint8_t> d);
  void fault(Entry& e, Time now, std::string_view why);
  void lost(Entry& e, Time now, std::string_view what);
  void invalid(Entry& e, Time now, std::string_view why);

  MasterOptions options_;
  Logger log_;
  ProcessImage image_;
  PlcProgram* program_ = nullptr;
  std::vector<std::unique_ptr<Entry>> entries_;
};

// "02 05 00 FF 04 A4 05 04 00 00 00" decoded into words, for logs and reports:
// "Station_Not_Ready Prm_Req master=none ident=04A4 ext=00 00 00". Bytes 8..10 of an 11-byte
// diagnosis with Ident_Number 04A4 are read as the CAN-DP/2's (manual table 3.4.5); any other
// Ext_Diag_Data is shown as "ext=" and its bytes.
std::string describe_diag(std::span<const std::uint8_t> d);

}  // namespace candp2::dp
