// The units' views for the faces (plant/unit_views.hpp).
#include "plant/unit_views.hpp"

#include "plant/plant.hpp"

namespace candp2::plant {

GatewayView GatewayUnit::view() const {
  const gw::Gateway& g = *gateway_;
  const auto& accepted = g.user_prm();
  return {.address = g.address(),
          .accepted = accepted.has_value(),
          .parameters = accepted ? *accepted : cfg_->parameters,
          .slot_config = g.slot_config(),
          .page_state = g.page_mode().state(),
          .pages_processed = g.page_mode().pages_processed(),
          .slot_stats = g.slot_engine().slot_stats()};
}

SlaveView SlaveUnit::view() const {
  const gsd_slave::GsdSlave& s = *slave_;
  return {.address = s.address(),
          .profile = s.profile(),
          .configuration = s.configuration(),
          .dp_state = s.dp().state(),
          .online = s.online(),
          .prm_fault_forced = s.prm_fault_forced(),
          .cfg_fault_forced = s.cfg_fault_forced(),
          .device_diagnosis = s.device_diagnosis(),
          .prm_problem = s.prm_problem(),
          .cfg_problem = s.cfg_problem(),
          .input_length = s.input_length(),
          .output_length = s.output_length(),
          .field_inputs = s.field_inputs(),
          .field_outputs = s.field_outputs(),
          .received_outputs = s.received_outputs()};
}

DriveStatus DriveUnit::status() const {
  const auto& d = drive_->drive();
  return {d.enabled(), d.control_mode(), d.speed_actual(), d.position_actual(), d.status()};
}

}  // namespace candp2::plant
