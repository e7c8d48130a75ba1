// The CAN buses in time for `candp2 validate` (docs/validate.md "CAN buses", docs/can-bus.md
// "Response times"): per timed bus (`buses.<name>.bitrate`) the messages the configuration puts on
// it, taken from the gateways' own tables (the slot table the gateway made of Chk_Cfg, its
// effective SYNC time, its release frames) and the drives' command decoding, the bus's worst-case
// load, and each message's worst-case response time (can/response_time.hpp). Pure: no files.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "can/response_time.hpp"

namespace candp2::validate {

struct GatewayReport;  // validate/validate.hpp

// The design limit of the predicted load (docs/validate.md "CAN buses"): Beckhoff's CANopen
// introduction ("PDO Parameterization") calls 80 % acceptable for purely cyclic synchronous traffic
// and too high for event-driven traffic; the prediction counts event-driven outputs at their
// highest rate, so 80 % is the limit here.
inline constexpr double kBusLoadLimitPct = 80.0;

// A simulated drive (docs/drive-simulator.md) on some bus.
struct DriveInput {
  std::string name;
  std::string json_path;  // "$.drives[0]"
  std::string bus;
  std::uint32_t rx_id = 0x201;  // commands (11-bit)
  std::uint32_t tx_id = 0x181;  // replies (11-bit)
};

// Why a message is on the bus.
enum class BusSource : std::uint8_t {
  Outputs,  // a Tx slot's frame on change, at most once per Data_Exchange (the master cycle)
  Cycle,    // a Tx slot's cyclic frame (comment bytes' cycle, manual §5.2.3)
  Sync,     // the CANopen master's SYNC (manual §5.3.3)
  Start,    // the NMT start frame, once at the release (docs/canopen.md)
  Rtr,      // a remote frame on an Rx identifier, once at the release (manual table 5.1.2)
  Reply,    // a drive's reply to a command frame (docs/drive-simulator.md)
};
std::string_view to_string(BusSource s);  // "outputs", "cycle", "sync", "start", "rtr", "reply"

struct BusMessage {
  std::string sender;     // "gateway gw3", "drive axis1"
  std::string json_path;  // where in the configuration it comes from
  BusSource source = BusSource::Outputs;
  can::RtaMessage message;  // once-only messages carry kOncePeriod
  bool once = false;        // sent once at the release: no period, no deadline
  // Reply: the message whose frames it answers (its release is that frame's end, so its jitter is
  // the command's worst response less its length).
  std::optional<std::size_t> reply_to{};
};

// A once-only frame counts as a message of this period: it meets one busy period, and adds no load.
inline constexpr std::chrono::nanoseconds kOncePeriod = can::kRtaHorizon;

struct BusProblem {
  std::string json_path;
  std::string message;
};

struct BusReport {
  std::string name;
  std::string json_path;  // "$.buses.can0.bitrate"
  std::uint32_t bitrate = 0;
  std::uint32_t cycle_ms = 0;  // the master cycle the outputs are counted at
  std::vector<BusMessage> messages;
  can::RtaReport analysis;           // per message, in the order of `messages`
  double load_pct = 0;               // periodic messages' worst-case lengths, % of the bit rate
  std::vector<BusProblem> problems;  // warnings
};

struct BusInput {
  std::string name;
  std::string json_path;  // "$.buses.can0.bitrate"
  std::uint32_t bitrate = 0;
  std::uint32_t cycle_ms = 10;
  std::string cycle_path = "$.master.cycle_ms";
};

// The bus `in`: the messages of the accepted gateways on it (a gateway at another CAN bit rate
// sends nothing it can receive: a warning) and of the drives answering their commands, analysed.
BusReport check_bus(const BusInput& in, const std::vector<GatewayReport>& gateways,
                    const std::vector<DriveInput>& drives);

}  // namespace candp2::validate
