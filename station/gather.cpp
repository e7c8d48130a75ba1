#include "station/gather.hpp"

#include "plant/master_line.hpp"

namespace candp2::station {

Status::Line line_status(const plant::LineStatus& l) {
  Status::Line out;
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
    if (auto l = line->status(address)) in.line = line_status(*l);
  } else if (auto* master_line = plant.master_line()) {
    in.line = line_status(master_line->status(address, plant.master()));
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

}  // namespace candp2::station
