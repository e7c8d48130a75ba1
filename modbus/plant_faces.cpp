#include "modbus/plant_faces.hpp"

#include <algorithm>

#include "plant/master_line.hpp"
#include "plant/slave_line.hpp"

namespace candp2::modbus {

namespace {
constexpr std::string_view kOrigin = "over Modbus";
}

StatusInputs::Line line_inputs(const plant::LineStatus& l) {
  StatusInputs::Line out;
  out.role = l.role;
  out.telegrams = l.telegrams;
  out.fcs_errors = l.fcs_errors;
  out.other_errors = l.other_errors;
  out.requests = l.requests;
  out.retries = l.retries;
  out.response_us = l.response_us;
  out.response_max_us = l.response_max_us;
  out.present = l.present;
  return out;
}

// ------------------------------------------------------------------------------ local gateway

StatusBlock PlantGatewayFace::status(Time now) {
  const gw::Gateway& gw = unit_.gateway();
  StatusInputs in;
  in.gateway = gw.status();
  in.diag = unit_.gateway().dp().slave_diag(now);
  in.dp_address = gw.address();
  if (bitrate_)
    if (auto b = bitrate_(unit_.index())) in.bitrate = *b;
  if (const auto view = plant_.master().slave(gw.address())) {
    in.master_state = view->state;
    in.parameterizations = view->parameterizations;
    in.addressed = view->addressed;
  }
  if (auto* line = plant_.slave_line())
    if (auto l = line->status(gw.address())) in.line = line_inputs(*l);
  const auto& f = unit_.faults();
  in.forced_state = f.forced_code();
  in.tx_suppressed = f.tx_suppressed();
  in.rx_suppressed = f.rx_suppressed();
  in.rx_drop_remaining = f.drop_remaining();
  in.reconnects = unit_.reconnects();
  in.cycles_missed = plant_.cycle_stats().missed();
  return encode_status(in);
}

void PlantGatewayFace::control(Control command, Time now) {
  const std::uint8_t address = unit_.gateway().address();
  switch (command) {
    case Control::None:
      return;
    case Control::PowerCycle:
      plant_.power_cycle(unit_, now, kOrigin);
      return;
    case Control::Reparameterize:
      plant_.reparameterize(address, now, kOrigin);
      return;
    case Control::MasterStops:
    case Control::MasterResumes:
      plant_.set_addressed(address, command == Control::MasterResumes, now, kOrigin);
      return;
  }
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
  StatusInputs in;
  in.dp_address = address_;
  const auto& master = plant_.master();
  if (const auto v = master.slave(address_)) {
    in.master_state = v->state;
    in.parameterizations = v->parameterizations;
    if (v->last_diag) in.diag = *v->last_diag;
    // The slave's DP state as the master knows it (docs/profibus.md role master).
    switch (v->state) {
      case dp::MasterSlaveState::DataExch:
        in.gateway.dp_state = dp::SlaveState::DataExch;
        break;
      case dp::MasterSlaveState::ChkCfg:
        in.gateway.dp_state = dp::SlaveState::WaitCfg;
        break;
      default:
        in.gateway.dp_state = dp::SlaveState::WaitPrm;
    }
    in.gateway.data_exchanges = v->data_exchanges;
    in.addressed = v->addressed;
  }
  if (auto* line = plant_.master_line()) in.line = line_inputs(line->status(address_, master));
  in.cycles_missed = plant_.cycle_stats().missed();
  return encode_status(in);
}

void RemoteStationFace::control(Control command, Time now) {
  switch (command) {
    case Control::Reparameterize:
      plant_.reparameterize(address_, now, kOrigin);
      break;
    case Control::MasterStops:  // docs/faults.md: the PLC stops addressing the station
    case Control::MasterResumes:
      plant_.set_addressed(address_, command == Control::MasterResumes, now, kOrigin);
      break;
    case Control::None:
    case Control::PowerCycle:  // refused before (refuses())
      return;
  }
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

// ------------------------------------------------------------------------------------- all

std::vector<GatewayFace*> PlantFaces::gateway_list() const {
  std::vector<GatewayFace*> out;
  for (const auto& g : gateways) out.push_back(g.get());
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
  } else {
    for (auto& g : plant.gateways())
      f.gateways.push_back(std::make_unique<PlantGatewayFace>(plant, *g, bitrate));
  }
  for (auto& d : plant.drives())
    if (d->config().modbus_unit) f.drives.push_back(std::make_unique<PlantDriveFace>(plant, *d));
  return f;
}

}  // namespace candp2::modbus
