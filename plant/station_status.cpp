#include "plant/station_status.hpp"

#include "plant/master_line.hpp"

namespace candp2::station {

Status common_status(plant::Plant& plant, std::uint8_t address) {
  Status in;
  in.dp_address = address;
  if (const auto view = plant.master().slave(address)) {
    in.master_state = view->state;
    in.parameterizations = view->parameterizations;
    in.addressed = view->addressed;
    in.gateway.data_exchanges = view->data_exchanges;
  }
  if (auto* line = plant.slave_line()) {
    in.line = line->status(address);
  } else if (auto* master_line = plant.master_line()) {
    in.line = master_line->status(address, plant.master());
  }
  in.cycles_missed = plant.cycle_stats().missed();
  return in;
}

void add_gateway(Status& s, const plant::GatewayUnit& unit) {
  s.gateway = unit.gateway().status();
  const auto& f = unit.faults();
  s.forced_state = f.forced_code();
  s.tx_suppressed = f.tx_suppressed();
  s.rx_suppressed = f.rx_suppressed();
  s.rx_drop_remaining = f.drop_remaining();
  s.reconnects = unit.reconnects();
}

Status gateway_status(plant::Plant& plant, plant::GatewayUnit& unit, Time now,
                      const BitrateFn& bitrate) {
  Status s = common_status(plant, unit.gateway().address());
  add_gateway(s, unit);
  s.diag = unit.gateway().dp().slave_diag(now);
  if (bitrate)
    if (auto b = bitrate(unit.index())) s.bitrate = *b;
  return s;
}

Status remote_status(plant::Plant& plant, std::uint8_t address) {
  Status s = common_status(plant, address);
  if (const auto v = plant.master().slave(address)) {
    if (v->last_diag) s.diag = *v->last_diag;
    // The slave's DP state as the master knows it (docs/profibus.md role master).
    switch (v->state) {
      case dp::MasterSlaveState::DataExch:
        s.gateway.dp_state = dp::SlaveState::DataExch;
        break;
      case dp::MasterSlaveState::ChkCfg:
        s.gateway.dp_state = dp::SlaveState::WaitCfg;
        break;
      default:
        s.gateway.dp_state = dp::SlaveState::WaitPrm;
    }
  }
  return s;
}

Status slave_status(plant::Plant& plant, plant::SlaveUnit& unit, Time now) {
  auto& dp = unit.slave().dp();
  Status s = common_status(plant, dp.info().address);
  s.leds = false;  // docs/slaves.md "Modbus": a generic slave has no CAN-DP/2 front plate
  s.gateway.dp_state = dp.state();
  s.diag = dp.slave_diag(now);
  return s;
}

std::vector<std::uint8_t> slave_diagnosis(plant::SlaveUnit& unit, Time now) {
  return unit.slave().dp().diagnosis(now);
}

std::vector<std::uint8_t> gateway_diagnosis(plant::GatewayUnit& unit, Time now) {
  return unit.gateway().dp().diagnosis(now);
}

}  // namespace candp2::station
