// The plant's pcapng capture (docs/capture.md): a plant::Tap that writes what it is told into a
// capture file (ring) Wireshark opens, one timeline for both buses of every gateway:
//  - one interface per CAN bus, LINKTYPE_CAN_SOCKETCAN (227), named after the bus's interface;
//    a bus in time states its bit rate (if_speed) and its frames are stamped at their start of
//    frame (docs/can-bus.md "In the plant");
//  - one interface per PROFIBUS side (the in-process master's, the `profibus` line), carrying
//    each FDL telegram as on the wire: as exported PDUs for the "fdl" dissector of
//    tools/wireshark/candp2.lua (LINKTYPE_WIRESHARK_UPPER_PDU, 252; the default, Wireshark 4.0
//    opens it) or bare (LINKTYPE_PROFIBUS_DL, 257, for tools that know it);
//  - one interface "candp2 notes" whose packets are the operator's notes (fault injections, power
//    cycles, re-parameterizations), each also as the packet's comment.
// Direction (epb_flags): what the emulated equipment sent is outbound, what it received inbound.
// Interfaces are numbered in the order they first appear. Time stamps: the plant's time plus
// `wall_offset`, in nanoseconds since the Unix epoch.
//
// Runs in the plant's thread (the event loop) and never waits: the blocks go to a CaptureWriter
// (capture_writer.hpp), whose thread writes them. A write error is logged once and the capture
// stops; packets the writer cannot take in time are dropped and counted (stats(), and a log line
// when a run of drops ends).
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "can/virtual_bus.hpp"
#include "capture/capture_writer.hpp"
#include "capture/pcapng.hpp"
#include "common/log.hpp"
#include "common/time.hpp"
#include "plant/tap.hpp"

namespace candp2::plant {
class Plant;
}

namespace candp2::capture {

enum class ProfibusLinktype : std::uint8_t {
  WiresharkUpperPdu,  // 252, exported PDU for the "fdl" dissector (docs/decisions.md)
  ProfibusDl,         // 257, the telegram alone
};

struct PcapngTapOptions {
  WriterOptions writer;
  ProfibusLinktype profibus = ProfibusLinktype::WiresharkUpperPdu;
  // Plant time + wall_offset = microseconds since the Unix epoch. candp2d: CLOCK_REALTIME minus
  // CLOCK_MONOTONIC, taken once at start; replay: any epoch the report names.
  Duration wall_offset{0};
  // By bus index (CanRecord::bus): the bit rate of a bus in time, stated as its interface's
  // if_speed; 0 or missing: an ideal bus, whose interface states none (docs/capture.md).
  std::vector<std::uint32_t> can_bitrates{};
};

struct PcapngTapStats {
  std::uint64_t packets = 0;  // handed to the writer
  std::uint64_t dropped = 0;  // the writer's queue was full
  bool stopped = false;       // a write error stopped the capture
};

class PcapngTap final : public plant::Tap {
 public:
  // `fs` replaces the file system in tests (posix_files() when null).
  PcapngTap(PcapngTapOptions options, LogSink* log, std::unique_ptr<FileSystem> fs = nullptr);
  ~PcapngTap() override;

  void on_can(const plant::CanRecord& record) override;
  void on_dp(const plant::DpRecord& record) override;
  void on_note(const plant::NoteRecord& record) override;

  // A packet (sniff): a telegram on the PROFIBUS side `line` named `line_name` at `time`, with an
  // optional comment (e.g. the parser's error for an abandoned candidate).
  void write_dp(Time time, std::uint16_t line, std::string_view line_name,
                std::span<const std::uint8_t> telegram, bool from_emulation,
                std::string_view comment, std::uint32_t baud = 0);

  // Errors on the plant's buses in time as SocketCAN error frames on their interfaces
  // (docs/capture.md "Error frames"); unwatch before the tap goes while the plant stays.
  void watch_bus_errors(plant::Plant& plant);
  void unwatch_bus_errors(plant::Plant& plant);
  void write_can_error(Time time, std::uint16_t bus, std::string_view interface_name,
                       const can::BusError& error);

  PcapngTapStats stats() const;
  // Waits until every packet so far is in the file (tests and shutdown; never the event loop).
  void sync() { writer_.sync(); }
  CaptureWriter& writer() { return writer_; }

 private:
  enum class Side : std::uint8_t { Can, Dp, Notes };
  // The interface's id, announcing it first; nullopt when it could not be announced now.
  std::optional<std::uint32_t> interface(Side side, std::uint16_t index, std::string_view name,
                                         std::uint64_t speed, std::uint64_t time_ns);
  void packet(std::uint32_t interface_id, std::uint64_t time_ns, std::span<const std::uint8_t> data,
              pcapng::Direction direction, std::string_view comment);
  void check_writer();
  void write_can(Time time, std::uint16_t bus, std::string_view interface_name,
                 std::span<const std::uint8_t> data, pcapng::Direction dir);
  std::uint64_t time_ns(Time t) const;

  PcapngTapOptions options_;
  Logger log_;
  CaptureWriter writer_;
  std::map<std::pair<Side, std::uint16_t>, std::uint32_t> interfaces_;
  std::uint32_t next_interface_ = 0;
  std::vector<std::uint8_t> block_;    // reused for every block
  std::vector<std::uint8_t> payload_;  // reused for exported PDUs
  std::uint64_t dropped_run_ = 0;      // drops since the last packet the writer took
  std::uint64_t not_announced_ = 0;    // packets lost because their interface could not be added
};

}  // namespace candp2::capture
