#include "modbus/plant_faces.hpp"

#include <algorithm>

#include "plant/master_line.hpp"
#include "plant/slave_line.hpp"
#include "plant/station_status.hpp"

namespace candp2::modbus {

namespace {
constexpr std::string_view kOrigin = "over Modbus";
}  // namespace

namespace {

// The commands every station takes alike (docs/faults.md): 2 re-parameterize, 3 / 4 the master
// stops / resumes addressing it; the others (0 nothing, 1 power cycle) are not done here.
void station_control(plant::Plant& plant, std::uint8_t address, Control command, Time now) {
  switch (command) {
    case Control::Reparameterize:
      plant.reparameterize(address, now, kOrigin);
      return;
    case Control::MasterStops:
    case Control::MasterResumes:
      plant.set_addressed(address, command == Control::MasterResumes, now, kOrigin);
      return;
    case Control::None:
    case Control::PowerCycle:
      return;
  }
}

}  // namespace

// ------------------------------------------------------------------------------ local gateway

StatusBlock PlantGatewayFace::status(Time now) {
  return encode_status(station::gateway_status(plant_, unit_, now, bitrate_));
}

std::vector<std::uint8_t> PlantGatewayFace::diagnosis(Time now) {
  return station::gateway_diagnosis(unit_, now);
}

void PlantGatewayFace::control(Control command, Time now) {
  if (command == Control::PowerCycle)
    plant_.power_cycle(unit_, now, kOrigin);
  else
    station_control(plant_, unit_.view().address, command, now);
}

bool PlantGatewayFace::force_bus_state(std::uint16_t code, Time now) {
  return plant_.force_can_state(unit_, code, now, kOrigin);
}

void PlantGatewayFace::drop_received(std::uint16_t n, Time now) {
  plant_.drop_rx(unit_, n, now, kOrigin);
}

std::uint16_t PlantGatewayFace::drop_remaining() const {
  return static_cast<std::uint16_t>(
      std::min<std::uint32_t>(unit_.faults().drop_remaining(), 0xFFFF));
}

// ----------------------------------------------------------------------------- remote station

StatusBlock RemoteStationFace::status(Time) {
  return encode_status(station::remote_status(plant_, address_));
}

void RemoteStationFace::control(Control command, Time now) {
  // A power cycle is refused before (refuses()).
  station_control(plant_, address_, command, now);
}

std::vector<std::uint8_t> RemoteStationFace::diagnosis(Time) {
  const auto v = plant_.master().slave(address_);
  return v ? v->diag_bytes : std::vector<std::uint8_t>{};
}

std::optional<std::string> RemoteStationFace::refuses(Control command) const {
  if (command != Control::PowerCycle) return std::nullopt;
  Logger(plant_.log_sink(), "daemon")
      .warn(name_ +
            ": power cycle requested over Modbus refused: a remote station cannot be "
            "power-cycled over PROFIBUS (write 2 to re-parameterize it)");
  return "power cycle of remote station " + std::to_string(address_) +
         " (profibus role master): not possible over PROFIBUS";
}

// ------------------------------------------------------------------------------ generic slave

StatusBlock GenericSlaveFace::status(Time now) {
  return encode_status(station::slave_status(plant_, unit_, now));
}

std::vector<std::uint8_t> GenericSlaveFace::diagnosis(Time now) {
  return station::slave_diagnosis(unit_, now);
}

void GenericSlaveFace::control(Control command, Time now) {
  if (command == Control::PowerCycle)
    plant_.power_cycle(unit_, now, kOrigin);
  else
    station_control(plant_, dp_address(), command, now);
}

std::uint16_t GenericSlaveFace::slave_fault(std::uint16_t offset) const {
  const plant::SlaveView s = unit_.view();
  switch (offset) {
    case kSlaveOnBus:
      return s.online ? 1 : 0;
    case kSlavePrmFault:
      return s.prm_fault_forced ? 1 : 0;
    case kSlaveCfgFault:
      return s.cfg_fault_forced ? 1 : 0;
    case kSlaveAlarmLength:
      return static_cast<std::uint16_t>(s.device_diagnosis ? s.device_diagnosis->size() : 0);
    default: {
      const std::size_t i = offset - kSlaveAlarmBytes;
      const auto& d = s.device_diagnosis;
      if (!d) return alarm_[i];
      const std::uint8_t hi = 2 * i < d->size() ? (*d)[2 * i] : 0;
      const std::uint8_t lo = 2 * i + 1 < d->size() ? (*d)[2 * i + 1] : 0;
      return static_cast<std::uint16_t>(hi << 8 | lo);
    }
  }
}

std::optional<DecodeFailure> GenericSlaveFace::write_slave_faults(
    std::uint16_t offset, std::span<const std::uint16_t> values, Time now) {
  // Checked first, applied after: all or nothing.
  for (std::size_t i = 0; i < values.size(); ++i) {
    const std::size_t o = offset + i;
    const bool flag = o == kSlaveOnBus || o == kSlavePrmFault || o == kSlaveCfgFault;
    if (flag && values[i] > 1)
      return DecodeFailure{Exception::IllegalDataValue,
                           "slave fault register " + std::to_string(kSlaveFaultBase + o) +
                               ": 0 or 1, got " + std::to_string(values[i])};
    if (o == kSlaveAlarmLength && values[i] > kSlaveAlarmMax)
      return DecodeFailure{Exception::IllegalDataValue, "diagnosis alarm length " +
                                                            std::to_string(values[i]) + " (0.." +
                                                            std::to_string(kSlaveAlarmMax) + ")"};
  }
  std::optional<std::uint16_t> length;
  for (std::size_t i = 0; i < values.size(); ++i) {
    const std::size_t o = offset + i;
    if (o >= kSlaveAlarmBytes) alarm_[o - kSlaveAlarmBytes] = values[i];
    if (o == kSlaveAlarmLength) length = values[i];
  }
  for (std::size_t i = 0; i < values.size(); ++i) {
    const std::size_t o = offset + i;
    const bool on = values[i] == 1;
    const plant::SlaveView s = unit_.view();  // as the writes before this one left it
    if (o == kSlaveOnBus && on != s.online) plant_.set_slave_online(unit_, on, now, kOrigin);
    if (o == kSlavePrmFault && on != s.prm_fault_forced)
      plant_.force_slave_fault(unit_, true, on, now, kOrigin);
    if (o == kSlaveCfgFault && on != s.cfg_fault_forced)
      plant_.force_slave_fault(unit_, false, on, now, kOrigin);
  }
  if (length) {
    std::vector<std::uint8_t> bytes;
    for (std::size_t k = 0; k < *length; ++k)
      bytes.push_back(static_cast<std::uint8_t>(k % 2 ? alarm_[k / 2] & 0xFF : alarm_[k / 2] >> 8));
    plant_.set_slave_alarm(unit_, std::move(bytes), now, kOrigin);
  }
  return std::nullopt;
}

// ------------------------------------------------------------------------------------ line

LineBlock PlantLineAccess::block(std::uint8_t address, Time) const {
  LineBlock b{};
  auto put32 = [&b](std::uint16_t at, std::uint64_t v) {
    const std::uint32_t x = station::sat32(v);
    b[at] = static_cast<std::uint16_t>(x >> 16);
    b[at + 1] = static_cast<std::uint16_t>(x & 0xFFFF);
  };
  const fdl::LineStatistics* st = plant_.line_statistics();
  if (!st) return b;
  std::uint16_t at = line::kCounters;
  for (const auto& f : fdl::kStationCounters) {
    put32(at, st->station(address).*f.member);
    at = static_cast<std::uint16_t>(at + 2);
  }
  b[line::kLive] = static_cast<std::uint16_t>(st->live(address));
  if (const plant::TimedLine* tl = plant_.timed_line()) {
    const auto& c = tl->bus_cycle();
    const std::uint64_t values[] = {static_cast<std::uint64_t>(c.last.count()),
                                    static_cast<std::uint64_t>(c.min.count()),
                                    static_cast<std::uint64_t>(c.mean().count()),
                                    static_cast<std::uint64_t>(c.max.count()), c.count};
    for (std::size_t i = 0; i < std::size(values); ++i)
      put32(static_cast<std::uint16_t>(line::kBusCycle + 2 * i), values[i]);
  }
  return b;
}

std::uint16_t PlantLineAccess::fault_register(std::uint8_t address, std::uint16_t offset,
                                              Time now) const {
  const plant::TimedLine* tl = plant_.timed_line();
  if (!tl) return 0;
  const auto f = tl->fault(address, now);
  switch (offset) {
    case line::kFaultKind:
      return static_cast<std::uint16_t>(f.kind);
    case line::kFaultCount:
      return static_cast<std::uint16_t>(station::sat16(f.remaining));
    case line::kFaultEvery:
      return static_cast<std::uint16_t>(f.kind == fdl::StationFault::None ? 0 : f.every);
    case line::kFaultForMs:
      return static_cast<std::uint16_t>(station::sat16(f.remaining_time.count() / 1000));
    case line::kNoiseForMs:
      return static_cast<std::uint16_t>(station::sat16(tl->noise_remaining(now).count() / 1000));
    default:
      return 0;
  }
}

std::optional<DecodeFailure> PlantLineAccess::write_faults(std::uint8_t address,
                                                           std::uint16_t offset,
                                                           std::span<const std::uint16_t> values,
                                                           Time now) {
  if (!plant_.timed_line())
    return DecodeFailure{Exception::ServerDeviceFailure,
                         "line faults need the line in time ($.master.baud, docs/faults.md)"};
  // Checked first, applied after: all or nothing (docs/modbus.md "Line block").
  Pending p = pending_.at(address);
  std::optional<std::uint16_t> kind, noise;
  for (std::size_t i = 0; i < values.size(); ++i) {
    const std::uint16_t v = values[i];
    switch (offset + i) {
      case line::kFaultKind:
        if (v >= fdl::kStationFaultNames.size())
          return DecodeFailure{Exception::IllegalDataValue,
                               "line fault kind " + std::to_string(v) +
                                   " (0 none, 1 corrupt, 2 silent, 3 late, 4 double_address)"};
        kind = v;
        break;
      case line::kFaultCount:
        p.count = v;
        break;
      case line::kFaultEvery:
        if (v == 0)
          return DecodeFailure{Exception::IllegalDataValue,
                               "line fault every: one answer in every 1..65535 requests, got 0"};
        p.every = v;
        break;
      case line::kFaultForMs:
        p.for_ms = v;
        break;
      default:
        noise = v;
        break;
    }
  }
  if (kind && *kind != 0 && p.count == 0 && p.for_ms == 0)
    return DecodeFailure{Exception::IllegalDataValue,
                         "line fault: give a count (8401) or for_ms (8403) above 0"};
  pending_.at(address) = p;
  if (kind) {
    plant::LineFault f{.kind = plant::line_fault_kind(static_cast<fdl::StationFault>(*kind)),
                       .station = address,
                       .count = p.count,
                       .every = p.every,
                       .duration = std::nullopt};
    if (p.for_ms) f.duration = milliseconds(p.for_ms);
    plant_.line_fault(f, now, kOrigin);
  }
  if (noise)
    plant_.line_fault({.kind = plant::LineFaultKind::Noise, .duration = milliseconds(*noise)}, now,
                      kOrigin);
  return std::nullopt;
}

// ----------------------------------------------------------- CAN fault block (docs/modbus.md)

std::uint16_t PlantCanFaults::fault_register(std::uint8_t address, std::uint16_t offset) const {
  const Registers& r = registers_.at(address);
  const std::array<std::uint16_t, can_fault::kRegisters> values{r.kind, r.count, r.every, r.for_ms};
  return offset < values.size() ? values[offset] : 0;
}

std::optional<DecodeFailure> PlantCanFaults::write_faults(std::uint8_t address,
                                                          std::uint16_t offset,
                                                          std::span<const std::uint16_t> values,
                                                          Time now) {
  const auto bus = buses_.find(address);
  if (bus == buses_.end())
    return DecodeFailure{Exception::IllegalDataAddress, "no gateway on a bus in time here"};
  // Checked first, applied after: all or nothing (docs/modbus.md "CAN fault block").
  Registers r = registers_.at(address);
  std::optional<std::uint16_t> kind;
  for (std::size_t i = 0; i < values.size(); ++i) {
    const std::uint16_t v = values[i];
    const std::size_t at = offset + i;
    if (at == can_fault::kKind && v >= plant::kCanFaultNames.size())
      return DecodeFailure{Exception::IllegalDataValue,
                           "CAN fault kind " + std::to_string(v) +
                               " (0 none, 1 error_frames, 2 unplugged, 3 wrong_bitrate, 4 noise)"};
    if (at == can_fault::kEvery && v == 0)
      return DecodeFailure{Exception::IllegalDataValue,
                           "CAN fault every: one frame in every 1..65535, got 0"};
    if (at == can_fault::kKind) kind = v;
    if (at == can_fault::kCount) r.count = v;
    if (at == can_fault::kEvery) r.every = v;
    if (at == can_fault::kForMs) r.for_ms = v;
  }
  plant::CanFault f;
  f.kind = static_cast<plant::CanFaultKind>(kind.value_or(0));
  f.bus = bus->second;
  if (kind && f.kind == plant::CanFaultKind::Noise && r.for_ms == 0)
    return DecodeFailure{Exception::IllegalDataValue, "CAN noise needs for_ms (8413) above 0"};
  if (kind && f.kind != plant::CanFaultKind::None && r.count == 0 && r.for_ms == 0)
    return DecodeFailure{Exception::IllegalDataValue,
                         "CAN fault: give a count (8411) or for_ms (8413) above 0"};
  if (kind) {
    if (f.kind != plant::CanFaultKind::Noise) f.node.gateway = address;
    f.count = r.count;
    f.every = r.every;
    if (r.for_ms) f.duration = milliseconds(r.for_ms);
    if (!control_.can_fault(f, now, kOrigin))
      return DecodeFailure{Exception::ServerDeviceFailure,
                           "the plant refused the CAN fault (its log says why)"};
    r.kind = *kind;
  }
  registers_.at(address) = r;
  return std::nullopt;
}

// ------------------------------------------------------------------------------------- all

std::vector<GatewayFace*> PlantFaces::gateway_list() const {
  std::vector<GatewayFace*> out;
  for (const auto& g : gateways) out.push_back(g.get());
  return out;
}

std::vector<FieldFace*> PlantFaces::field_list() const {
  std::vector<FieldFace*> out;
  for (const auto& f : fields) out.push_back(f.get());
  return out;
}

std::vector<DriveFace*> PlantFaces::drive_list() const {
  std::vector<DriveFace*> out;
  for (const auto& d : drives) out.push_back(d.get());
  return out;
}

PlantFaces make_faces(plant::Plant& plant, BitrateFn bitrate) {
  PlantFaces f;
  if (plant.master_line()) {
    for (const auto& gc : plant.config().gateways)
      f.gateways.push_back(std::make_unique<RemoteStationFace>(plant, gc.dp_address(), gc.name));
    for (const auto& sc : plant.config().slaves)
      f.gateways.push_back(std::make_unique<RemoteStationFace>(plant, sc.address, sc.name));
  } else {
    std::map<std::uint8_t, std::string> timed;  // docs/modbus.md "CAN fault block"
    for (const auto& g : plant.gateways())
      for (const auto& b : plant.config().buses)
        if (b.name == g->config().bus && b.timed_bitrate) timed[g->config().dp_address()] = b.name;
    if (!timed.empty()) f.can_faults = std::make_unique<PlantCanFaults>(plant, timed);
    for (auto& g : plant.gateways()) {
      f.gateways.push_back(std::make_unique<PlantGatewayFace>(plant, *g, bitrate));
      if (timed.contains(g->config().dp_address()))
        f.gateways.back()->set_can_faults(f.can_faults.get());
    }
    for (auto& s : plant.slaves()) {
      f.gateways.push_back(std::make_unique<GenericSlaveFace>(plant, *s));
      if (s->config().field_unit) f.fields.push_back(std::make_unique<SlaveFieldFace>(*s));
    }
  }
  for (auto& d : plant.drives())
    if (d->config().modbus_unit) f.drives.push_back(std::make_unique<PlantDriveFace>(plant, *d));
  if (plant.line_statistics()) {  // docs/modbus.md "Line block"
    f.line = std::make_unique<PlantLineAccess>(plant);
    for (auto& g : f.gateways) g->set_line(f.line.get());
  }
  return f;
}

}  // namespace candp2::modbus
