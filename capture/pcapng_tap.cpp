#include "capture/pcapng_tap.hpp"

#include "plant/plant.hpp"

namespace candp2::capture {

namespace {

// The Lua dissector's names (tools/wireshark/candp2.lua): "fdl" for PROFIBUS telegrams, "candp2"
// for the emulator's own records (notes).
constexpr std::string_view kFdlDissector = "fdl";
constexpr std::string_view kNoteDissector = "candp2";
constexpr std::string_view kNotesInterface = "candp2 notes";

pcapng::Direction direction(bool from_emulation) {
  return from_emulation ? pcapng::Direction::Outbound : pcapng::Direction::Inbound;
}

std::span<const std::uint8_t> bytes_of(std::string_view s) {
  return {reinterpret_cast<const std::uint8_t*>(s.data()), s.size()};
}

}  // namespace

PcapngTap::PcapngTap(PcapngTapOptions options, LogSink* log, std::unique_ptr<FileSystem> fs)
    : options_(std::move(options)), log_(log, "capture"), writer_(options_.writer, std::move(fs)) {
  log_.info("pcapng capture to " + options_.writer.path +
            (options_.writer.max_bytes
                 ? " (ring: " + std::to_string(options_.writer.max_bytes) + " bytes per file, " +
                       (options_.writer.files ? std::to_string(options_.writer.files) + " files"
                                              : std::string("all files kept")) +
                       ")"
                 : std::string()));
}

PcapngTap::~PcapngTap() {
  writer_.sync();
  check_writer();
  if (dropped_run_)
    log_.warn("pcapng capture: " + std::to_string(dropped_run_) +
              " packets dropped at the end (the writer was behind)");
}

std::uint64_t PcapngTap::time_ns(Time t) const {
  const auto us = (t + options_.wall_offset).count();
  return us < 0 ? 0 : static_cast<std::uint64_t>(us) * 1000u;
}

void PcapngTap::check_writer() {
  if (auto failure = writer_.take_failure())
    log_.error("pcapng capture stopped: " + *failure +
               "; nothing more is captured, everything else goes on");
}

std::optional<std::uint32_t> PcapngTap::interface(Side side, std::uint16_t index,
                                                  std::string_view name, std::uint64_t speed,
                                                  std::uint64_t ns) {
  const auto key = std::pair(side, index);
  if (const auto it = interfaces_.find(key); it != interfaces_.end()) return it->second;
  std::vector<std::uint8_t> idb;
  switch (side) {
    case Side::Can:
      idb = pcapng::interface_description(pcapng::kLinktypeCanSocketcan, name,
                                          "CAN bus " + std::to_string(index), speed);
      break;
    case Side::Dp:
      idb = pcapng::interface_description(options_.profibus == ProfibusLinktype::ProfibusDl
                                              ? pcapng::kLinktypeProfibusDl
                                              : pcapng::kLinktypeWiresharkUpperPdu,
                                          name, "PROFIBUS side " + std::to_string(index), speed);
      break;
    case Side::Notes:
      idb = pcapng::interface_description(pcapng::kLinktypeWiresharkUpperPdu, kNotesInterface,
                                          "operator notes");
      break;
  }
  if (!writer_.add_header(idb, ns)) return std::nullopt;
  interfaces_.emplace(key, next_interface_);
  return next_interface_++;
}

void PcapngTap::packet(std::uint32_t interface_id, std::uint64_t ns,
                       std::span<const std::uint8_t> data, pcapng::Direction dir,
                       std::string_view comment) {
  block_.clear();
  pcapng::enhanced_packet(block_, interface_id, ns, data, dir, comment);
  if (writer_.add_packet(block_, ns)) {
    if (dropped_run_) {
      log_.warn("pcapng capture: " + std::to_string(dropped_run_) +
                " packets dropped (the writer was behind)");
      dropped_run_ = 0;
    }
  } else if (!writer_.stopped()) {
    ++dropped_run_;
  }
  check_writer();
}

void PcapngTap::write_can(Time time, std::uint16_t bus, std::string_view interface_name,
                          std::span<const std::uint8_t> data, pcapng::Direction dir) {
  if (writer_.stopped()) return check_writer();
  const std::uint64_t ns = time_ns(time);
  const std::uint32_t bitrate = bus < options_.can_bitrates.size() ? options_.can_bitrates[bus] : 0;
  const auto id = interface(Side::Can, bus, interface_name, bitrate, ns);
  if (!id) {
    ++not_announced_;
    return;
  }
  packet(*id, ns, data, dir, {});
}

void PcapngTap::on_can(const plant::CanRecord& r) {
  const auto data = pcapng::socketcan(r.frame);
  write_can(r.time, r.bus, r.interface.empty() ? r.bus_name : r.interface, data,
            direction(r.from_emulation));
}

void PcapngTap::write_can_error(Time time, std::uint16_t bus, std::string_view interface_name,
                                const can::BusError& error) {
  const auto data = pcapng::socketcan_error(error);
  write_can(time, bus, interface_name, data, pcapng::Direction::Unknown);
}

// docs/capture.md "Error frames": only buses in time have errors; the interface is the one the
// bus's frames go to (plant::BusUnit::interface(), as the plant's tap names it).
void PcapngTap::watch_bus_errors(plant::Plant& plant) {
  for (auto& b : plant.buses()) {
    can::VirtualBus* v = b->virtual_bus();
    if (!v || !v->timed()) continue;
    const plant::BusUnit* unit = b.get();
    v->set_error_tap([this, unit](const can::BusError& e) {
      write_can_error(e.time, unit->index(), unit->interface(), e);
    });
  }
}

void PcapngTap::unwatch_bus_errors(plant::Plant& plant) {
  for (auto& b : plant.buses())
    if (can::VirtualBus* v = b->virtual_bus()) v->set_error_tap(nullptr);
}

void PcapngTap::write_dp(Time time, std::uint16_t line, std::string_view line_name,
                         std::span<const std::uint8_t> telegram, bool from_emulation,
                         std::string_view comment, std::uint32_t baud) {
  if (writer_.stopped()) return check_writer();
  const std::uint64_t ns = time_ns(time);
  const auto id = interface(Side::Dp, line, line_name, baud, ns);
  if (!id) {
    ++not_announced_;
    return;
  }
  if (options_.profibus == ProfibusLinktype::ProfibusDl) {
    packet(*id, ns, telegram, direction(from_emulation), comment);
    return;
  }
  payload_.clear();
  pcapng::exported_pdu(payload_, kFdlDissector, telegram);
  packet(*id, ns, payload_, direction(from_emulation), comment);
}

void PcapngTap::on_dp(const plant::DpRecord& r) {
  write_dp(r.time, r.line, r.line_name, r.telegram, r.from_emulation, {}, r.baud);
}

void PcapngTap::on_note(const plant::NoteRecord& r) {
  if (writer_.stopped()) return check_writer();
  const std::uint64_t ns = time_ns(r.time);
  const auto id = interface(Side::Notes, 0, kNotesInterface, 0, ns);
  if (!id) {
    ++not_announced_;
    return;
  }
  payload_.clear();
  pcapng::exported_pdu(payload_, kNoteDissector, bytes_of(r.text), "candp2");
  packet(*id, ns, payload_, pcapng::Direction::Unknown, r.text);
}

PcapngTapStats PcapngTap::stats() const {
  return {writer_.packets(), writer_.dropped() + not_announced_, writer_.stopped()};
}

}  // namespace candp2::capture
