#include "gateway/gateway.hpp"

#include <algorithm>
#include <cstring>

#include "can/frame_bits.hpp"
#include "common/hex.hpp"

namespace candp2::gw {

namespace {

std::uint8_t clamp_address(std::uint8_t a) {
  // manual §2.1: below 3 counts as 3, above 124 as 124.
  return std::clamp<std::uint8_t>(a, 3, 124);
}

// manual §9 / CiA 301: NMT on identifier 0, SYNC on 0x080.
constexpr std::uint32_t kNmtId = 0x000;
constexpr std::uint32_t kSyncId = 0x080;
constexpr std::uint8_t kNmtStart = 0x01;
constexpr std::uint8_t kNmtStop = 0x02;
constexpr std::uint8_t kNmtPreOperational = 0x80;
constexpr std::uint8_t kNmtResetNode = 0x81;
constexpr std::uint8_t kNmtResetComm = 0x82;
constexpr std::uint32_t kBootIdManual = 0x080;  // manual table 5.1.2: "128 dez + Module-No."
constexpr std::uint32_t kBootIdCia301 = 0x700;  // CiA 301 boot-up (NMT error control)

}  // namespace

std::uint8_t bus_state_code(can::BusState s) {
  // manual table 3.4.5, byte 8.
  switch (s) {
    case can::BusState::Ok:
      return 0x00;
    case can::BusState::Warning:
      return 0x40;
    case can::BusState::ErrorPassive:
      return 0x80;
    case can::BusState::BusOff:
      return 0xC0;
  }
  return 0x00;
}

std::string_view to_string(NmtState s) {
  switch (s) {
    case NmtState::Initialising:
      return "initialising";
    case NmtState::PreOperational:
      return "pre-operational";
    case NmtState::Operational:
      return "operational";
    case NmtState::Stopped:
      return "stopped";
  }
  return "?";
}

namespace {
// The log component of a gateway: its configured name, else "gwN" (N = the clamped DP address).
std::string log_name(const GatewayOptions& o) {
  return o.name.empty() ? "gw" + std::to_string(clamp_address(o.address)) : o.name;
}
}  // namespace

std::uint32_t frame_bits(const can::Frame& f) {
  // SOF..EOF without stuff bits plus 3 bits intermission (docs/can-bus.md "Frames on the wire").
  return can::frame_bits_unstuffed(f);
}

Gateway::Gateway(GatewayOptions options, can::FrameSink& can_tx, Time power_on)
    : log_(options.log, log_name(options)),
      address_(clamp_address(options.address)),
      options_(options),
      can_tx_(can_tx),
      slave_(dp::SlaveInfo{.address = clamp_address(options.address),
                           .ident_number = kIdentNumber,
                           .user_prm_len = kUserPrmLen,
                           .ext_diag_header = kExtDiagHeader,
                           .log_name = options.name.empty() ? "" : options.name + ".dp"},
             *this, options.log),
      power_on_(power_on),
      stored_wakeup_s_(options.stored_wakeup_s),
      stored_sync_ms_(options.stored_sync_ms) {
  if (address_ != options.address)
    log_.warn("station address " + std::to_string(options.address) + " clamped to " +
              std::to_string(address_) + " (manual §2.1: 3..124)");
  cw_.set_logger(Logger(options.log, log_name(options) + ".cw"));
  page_.set_logger(Logger(options.log, log_name(options) + ".page"));
}

// ---------------------------------------------------------------- DP slave application

std::optional<dp::PrmFault> Gateway::on_set_prm(std::span<const std::uint8_t> telegram, Time now) {
  auto decoded = decode_user_prm(telegram);
  if (auto* fault = std::get_if<dp::PrmFault>(&decoded)) return *fault;
  const UserPrm& p = std::get<UserPrm>(decoded);
  // The ModuleID matters to the CANopen slave only (boot frame, NMT addressing).
  const bool role_changed = !prm_ || prm_->role() != p.role() ||
                            (p.role() == CanopenRole::Slave && prm_->module_id != p.module_id);
  prm_ = p;
  // manual table 5.1.2: without a CANopen role, wake-up, RTR, Start-Frame and SYNC are ignored.
  if (p.role() != CanopenRole::None) {
    if (p.wakeup_s != kWakeupKeep) stored_wakeup_s_ = p.wakeup_s;
    if (p.sync_ms != kSyncKeep) stored_sync_ms_ = p.sync_ms;
  }
  sync_ms_ = p.role() == CanopenRole::Master ? stored_sync_ms_ : 0;
  if (role_changed) {
    // The new role's release rules start from scratch (docs/canopen.md).
    halt("CANopen role or ModuleID changed");
    boot_sent_ = false;
    nmt_ = NmtState::Initialising;
  }
  schedule_sync(now);  // manual §5.1.2 note: the SYNC time written last is valid from now on
  log_.info("parameters: " + bitrate_text(p.bitrate_index) + ", CANopen " +
            std::string(to_string(p.role())) + (p.page_mode ? ", Page-Mode" : "") +
            (p.comm_window ? ", Communication Window" : ""));
  // Only the boot frame here: the DP slave still is in its old state (Data_Exch, maybe) until this
  // Set_Prm is accepted; release waits for the new Chk_Cfg.
  boot_if_due(now);
  return std::nullopt;
}

std::optional<dp::CfgFault> Gateway::on_chk_cfg(std::span<const std::uint8_t> cfg, Time now) {
  if (!prm_) return dp::CfgFault{0, kCfgWrongIoType};  // cannot happen: the slave checks Wait_Prm
  auto decoded = decode_slots(cfg, *prm_);
  if (auto* fault = std::get_if<dp::CfgFault>(&decoded)) {
    log_.warn("Chk_Cfg slot " + std::to_string(fault->slot) + ": " +
              std::string(cfg_code_text(fault->code)));
    return *fault;
  }
  // The same configuration again (re-parameterization after a watchdog drop): slot buffers and
  // the input image are kept, as frames received meanwhile updated them
  // (docs/slots.md "Data exchange in normal mode").
  const bool same = cfg_ && accepted_prm_ == prm_ && accepted_cfg_.size() == cfg.size() &&
                    std::equal(cfg.begin(), cfg.end(), accepted_cfg_.begin());
  cfg_ = std::move(std::get<SlotConfig>(decoded));
  accepted_cfg_.assign(cfg.begin(), cfg.end());
  accepted_prm_ = prm_;
  if (!same) {
    input_image_.assign(cfg_->input_len, 0);
    slots_.configure(*cfg_);
    cw_.reset();
    page_.configure(*cfg_);
  }
  if (cfg_->cw_in) {
    const Slot& cw = cfg_->slots[*cfg_->cw_in];
    const Slot& cw_out = cfg_->slots[*cfg_->cw_out];
    // manual §5.1.2 note: CW comment bytes 4-5 are an equal SYNC source (00 00 = not given).
    for (const Slot* s : {&cw, &cw_out})
      if (s->cw_sync_ms != 0 && !set_sync_time(s->cw_sync_ms, now))
        log_.info("CW comment bytes 4-5: SYNC time " + std::to_string(s->cw_sync_ms) +
                  " ms ignored (not a CANopen master, manual table 5.1.2)");
  }
  log_.info("configuration: " + std::to_string(cfg_->slots.size()) + " slots, " +
            std::to_string(cfg_->input_len) + " input / " + std::to_string(cfg_->output_len) +
            " output bytes");
  return std::nullopt;
}

void Gateway::on_enter_data_exchange(Time now) {
  if (!released_) {
    update_release(now);  // the first release: start frame, every Tx slot once, RTR frames
    return;
  }
  // Slot traffic resumes after a watchdog drop or a re-parameterization: every Tx slot once, cycle
  // timers restart (docs/dp-slave.md, docs/slots.md "Data exchange in normal mode").
  if (cfg_->page_mode)
    page_.on_release(now, *this);
  else
    slots_.on_release(now, *this);
}

void Gateway::on_leave_data_exchange(Time) {
  // docs/dp-slave.md: Tx on CAN stops (tx_active() is false), the input image keeps its values.
}

void Gateway::on_data_exchange(std::span<const std::uint8_t> outputs,
                               std::span<std::uint8_t> inputs, Time now) {
  ++data_exchanges_;
  fire_sync(now);  // a SYNC already due goes out before this exchange's frames
  const std::uint32_t tx_before = tx_frames_;
  burst_bits_ = 0;
  if (cfg_->page_mode) {
    page_.on_output_page(outputs.first(page_.output_page_len()), now, *this);
  } else {
    slots_.on_outputs(outputs, *this, now);
    if (rtr_pending_ && tx_active()) {  // after the release's Tx slots (docs/canopen.md)
      rtr_pending_ = false;
      send_rtr_frames();
    }
  }
  if (cfg_->cw_out) {
    const Slot& s = cfg_->slots[*cfg_->cw_out];
    cw_.on_write(outputs.subspan(s.offset, kCwLen), now, *this);
  }
  // The frames of this Data_Exchange occupy the bus from now on; a SYNC falling due meanwhile waits
  // until they are out (manual §5.3.3, command 20 note).
  if (tx_frames_ != tx_before && prm_) {
    const std::uint64_t bitrate = bitrate_bps(prm_->bitrate_index).value();  // Set_Prm checked it
    const auto busy = microseconds((std::uint64_t{burst_bits_} * 1000000u + bitrate - 1) / bitrate);
    if (now >= bus_busy_until_) {
      busy_from_ = now;
      bus_busy_until_ = now + busy;
    } else {
      bus_busy_until_ += busy;  // queued behind the previous burst still on the wire
    }
  }
  std::copy(input_image_.begin(), input_image_.end(), inputs.begin());
  if (cfg_->page_mode) page_.write_input_page(inputs.first(page_.input_page_len()));
  if (cfg_->cw_in) {
    const Slot& s = cfg_->slots[*cfg_->cw_in];
    cw_.read(inputs.subspan(s.offset, kCwLen));
  }
}

dp::DeviceDiag Gateway::device_diag() const {
  dp::DeviceDiag d;
  if (prm_ && prm_->can_diagnosis) {
    // manual table 3.4.5: bus state, IRQ_LOST, MSG_LOST (both saturate at 255,
    // docs/dp-slave.md "Diagnosis").
    d.bytes = {bus_state_code(bus_state_),
               static_cast<std::uint8_t>(std::min<std::uint32_t>(irq_lost(), 255)),
               static_cast<std::uint8_t>(std::min<std::uint32_t>(cw_.msg_lost(), 255))};
    d.ext_diag = bus_state_ != can::BusState::Ok;
  }
  return d;
}

// ---------------------------------------------------------------- CAN side

bool Gateway::tx_active() const {
  return released_ && slave_.state() == dp::SlaveState::DataExch;
}

void Gateway::transmit(const can::Frame& frame) {
  ++tx_frames_;
  burst_bits_ += frame_bits(frame);
  if (log_.enabled(LogLevel::Debug)) log_.debug("tx " + can::format_candump(frame));
  can_tx_.send(frame);
}

bool Gateway::on_can_frame(const can::Frame& frame, Time now) {
  ++rx_frames_;
  if (log_.enabled(LogLevel::Debug)) log_.debug("rx " + can::format_candump(frame));
  if (role() == CanopenRole::Slave && !frame.extended && !frame.remote && frame.id == kNmtId) {
    handle_nmt(frame, now);
    return true;
  }
  // docs/slots.md "Data exchange in normal mode": identifiers enabled in the CW take precedence
  // over input slots.
  if (cw_.on_frame(frame) || !cfg_) return false;
  if (cfg_->page_mode)
    page_.on_frame(frame, now);
  else
    slots_.on_frame(frame, input_image_, now);
  return false;
}

void Gateway::set_controller_status(can::BusState state, std::uint32_t rx_lost_total) {
  if (state != bus_state_)
    log_.warn("CAN bus state " + std::string(can::to_string(bus_state_)) + " -> " +
              std::string(can::to_string(state)));
  bus_state_ = state;
  // The transport counts from its own start; a power cycle restarts IRQ_LOST at 0
  // (docs/faults.md "Power cycle and re-parameterization"). A total below the base means the
  // transport restarted its count: it counts from there.
  if (rx_lost_total < irq_lost_base_) irq_lost_base_ = 0;
  irq_lost_total_ = rx_lost_total;
}

// -------------------------------------------------------------- release, CANopen (docs/canopen.md)

void Gateway::boot_if_due(Time now) {
  // CANopen slave: the boot frame once the wake-up time is over, then pre-operational (manual
  // table 5.1.2 "nach Wake-Up-Time sendet das Modul automatisch 128 dez + Module-No.").
  if (role() == CanopenRole::Slave && !boot_sent_ && now >= wake_time()) {
    send_boot_frame();
    boot_sent_ = true;
    nmt_ = NmtState::PreOperational;
    log_.info("CANopen slave: boot frame sent, NMT pre-operational");
  }
}

void Gateway::update_release(Time now) {
  boot_if_due(now);
  // Every role needs the whole configuration (Set_Prm, Chk_Cfg) and Data_Exch: the Tx slots and
  // the Rx identifiers for the RTR frames come from it.
  if (released_ || !cfg_ || slave_.state() != dp::SlaveState::DataExch) return;
  switch (role()) {
    case CanopenRole::None:
      release(now, "Data_Exch entered (layer-2 mode)");
      break;
    case CanopenRole::Master:
      if (now >= wake_time()) release(now, "CANopen master: wake-up time over, Data_Exch");
      break;
    case CanopenRole::Slave:
      if (nmt_ == NmtState::Operational) release(now, "CANopen slave: NMT start, Data_Exch");
      break;
  }
}

void Gateway::release(Time now, std::string_view why) {
  released_ = true;
  log_.info("CAN transmission released: " + std::string(why));
  if (const auto start = start_frame(*prm_)) transmit(*start);
  // Then every Tx slot once (docs/canopen.md).
  if (cfg_->page_mode)
    page_.on_release(now, *this);
  else
    slots_.on_release(now, *this);
  // manual table 5.1.2: RTR-Frames only with a CANopen role (ignored in layer-2 mode). They follow
  // the Tx slots (docs/canopen.md "CANopen master"): a Tx slot still without data sends with the
  // first Data_Exchange's outputs, and the remote frames wait for it.
  if (sends_rtr_frames(*prm_, *cfg_)) {
    if (slots_.tx_waiting_for_data())
      rtr_pending_ = true;
    else
      send_rtr_frames();
  }
  schedule_sync(now);
}

void Gateway::send_rtr_frames() {
  for (const auto& f : rtr_frames(*cfg_)) transmit(f);
}

std::optional<can::Frame> start_frame(const UserPrm& prm) {
  if (prm.role() != CanopenRole::Master || !prm.start_frame) return std::nullopt;
  // docs/canopen.md: NMT start-all, ID 0, DLC 2, 01 00 (manual §9).
  const std::uint8_t start[] = {kNmtStart, 0x00};
  return can::Frame::std_data(kNmtId, start);
}

bool sends_rtr_frames(const UserPrm& prm, const SlotConfig& cfg) {
  // manual table 5.1.2: RTR-Frames only with a CANopen role (ignored in layer-2 mode); Page-Mode
  // never combines with a CANopen role, so only slots have Rx identifiers.
  return prm.role() != CanopenRole::None && prm.send_rtr && !cfg.page_mode;
}

std::vector<can::Frame> rtr_frames(const SlotConfig& cfg) {
  // manual table 5.1.2 "RTR-Frames auf RxId senden": one remote frame per Rx identifier, in slot
  // order. DLC = the data length the slot expects (CiA 301: a remote frame carries the DLC of the
  // requested data frame); with one identifier on two slots the later slot wins (manual §5.2.1).
  std::vector<std::pair<can::Ident, std::uint8_t>> rtr;
  for (const Slot& s : cfg.slots) {
    if (s.kind != SlotKind::Rx || !s.id) continue;
    const auto dlc = static_cast<std::uint8_t>(s.data_len);
    auto it = std::find_if(rtr.begin(), rtr.end(), [&](const auto& e) { return e.first == *s.id; });
    if (it != rtr.end())
      it->second = dlc;
    else
      rtr.emplace_back(*s.id, dlc);
  }
  std::vector<can::Frame> frames;
  for (const auto& [id, dlc] : rtr) frames.push_back(can::Frame::rtr(id.id, id.extended, dlc));
  return frames;
}

void Gateway::halt(std::string_view why) {
  if (released_) log_.info("CAN transmission halted: " + std::string(why));
  released_ = false;
  rtr_pending_ = false;
  next_sync_.reset();
}

void Gateway::send_boot_frame() {
  const std::uint8_t id = prm_->module_id;
  if (options_.cia301_bootup) {
    const std::uint8_t zero[] = {0x00};
    transmit(can::Frame::std_data(kBootIdCia301 + id, zero));
  } else {
    transmit(can::Frame::std_data(kBootIdManual + id, {}));
  }
}

void Gateway::handle_nmt(const can::Frame& frame, Time now) {
  // manual §9: NMT on identifier 0, DLC 2: command, node (0 = all).
  if (frame.dlc < 2) {
    log_.info("NMT frame " + can::format_candump(frame) + " ignored: DLC below 2");
    return;
  }
  const std::uint8_t cmd = frame.data[0];
  const std::uint8_t node = frame.data[1];
  if (node != 0 && node != prm_->module_id) return;  // addressed to another node
  if (!boot_sent_) {
    log_.info("NMT frame " + can::format_candump(frame) + " ignored: still in the wake-up time");
    return;
  }
  const NmtState before = nmt_;
  switch (cmd) {
    case kNmtStart:
      nmt_ = NmtState::Operational;
      update_release(now);  // now when in Data_Exch, else when Data_Exch is entered
      break;
    case kNmtStop:
      nmt_ = NmtState::Stopped;
      halt("NMT stop");
      break;
    case kNmtPreOperational:
      nmt_ = NmtState::PreOperational;
      halt("NMT enter pre-operational");
      break;
    case kNmtResetNode:
    case kNmtResetComm:
      // docs/canopen.md: a reset repeats the boot frame; the node is pre-operational again.
      halt("NMT reset");
      send_boot_frame();
      nmt_ = NmtState::PreOperational;
      break;
    default:
      log_.info("NMT command " + hex_bytes(std::array{cmd}) + " ignored (manual §9: 01 80 81 82)");
      return;
  }
  log_.info("NMT " + hex_bytes(std::array{cmd}) + ": " + std::string(to_string(before)) + " -> " +
            std::string(to_string(nmt_)));
}

bool Gateway::set_sync_time(std::uint16_t ms, Time now) {
  if (role() != CanopenRole::Master) return false;
  if (ms == kSyncKeep) {
    // Outside the range 0..FFFE (manual §5.3.3 command 20); read as Prm bytes 14-15 read it.
    log_.info("SYNC time FFFF: the stored value " + std::to_string(stored_sync_ms_) +
              " ms is kept");
    return true;
  }
  // manual §5.1.2 note: Prm bytes 14-15, CW comment bytes 4-5 and command 20 are equal sources;
  // the last one written wins, and it is the gateway's stored value
  // (docs/dp-slave.md "User parameters").
  sync_ms_ = ms;
  stored_sync_ms_ = ms;
  log_.info("SYNC time " + std::to_string(ms) + " ms" + (ms == 0 ? " (off)" : ""));
  schedule_sync(now);
  return true;
}

void Gateway::schedule_sync(Time now) {
  if (role() == CanopenRole::Master && released_ && sync_ms_ != 0)
    next_sync_ = now + milliseconds(sync_ms_);
  else
    next_sync_.reset();
}

// ---------------------------------------------------------------- time

void Gateway::advance(Time now) {
  slave_.advance(now);
  update_release(now);
  slots_.advance(now, *this);
  fire_sync(now);
}

std::optional<Time> Gateway::sync_due() const {
  if (!next_sync_) return std::nullopt;
  Time due = *next_sync_;
  // manual §5.3.3 command 20 note: the SYNC cannot interrupt the frames of a Data_Exchange; one
  // falling due meanwhile waits until they are out.
  if (due >= busy_from_ && due < bus_busy_until_) due = bus_busy_until_;
  return due;
}

void Gateway::fire_sync(Time now) {
  const auto due = sync_due();
  if (!due || *due > now) return;
  // docs/canopen.md: SYNC ID 0x080, DLC 0. Like every cyclic send, only in Data_Exch
  // (docs/dp-slave.md).
  if (tx_active()) transmit(can::Frame::std_data(kSyncId, {}));
  // The grid keeps its phase: a deferred SYNC does not move the next one, and grid points passed
  // meanwhile are not sent late (manual: "geringe Zeitverschiebungen").
  const auto period = milliseconds(sync_ms_);
  const auto behind = (now - *next_sync_) / period;
  *next_sync_ += period * (behind + 1);
}

std::optional<Time> Gateway::next_deadline() const {
  std::optional<Time> next = slave_.next_deadline();
  auto consider = [&](std::optional<Time> t) {
    if (t && (!next || *t < *next)) next = t;
  };
  consider(slots_.next_deadline());
  consider(sync_due());
  // Only deadlines that will act: the master releases at the wake-up time only in Data_Exch (it is
  // released at once when Data_Exch comes later); the slave's boot frame needs Set_Prm.
  if (!released_ && role() == CanopenRole::Master && cfg_ &&
      slave_.state() == dp::SlaveState::DataExch)
    consider(wake_time());
  if (!boot_sent_ && role() == CanopenRole::Slave) consider(wake_time());
  return next;
}

void Gateway::power_cycle(Time now) {
  log_.info("power cycle");
  slave_.reset(now);
  prm_.reset();
  cfg_.reset();
  accepted_cfg_.clear();
  accepted_prm_.reset();
  slots_.clear();
  cw_.reset();
  page_.power_on();
  input_image_.clear();
  power_on_ = now;
  released_ = false;
  rtr_pending_ = false;
  boot_sent_ = false;
  nmt_ = NmtState::Initialising;
  sync_ms_ = 0;
  next_sync_.reset();
  bus_busy_until_ = busy_from_ = Time{0};
  burst_bits_ = 0;
  rx_frames_ = tx_frames_ = data_exchanges_ = 0;
  irq_lost_base_ = irq_lost_total_;  // IRQ_LOST starts at 0 (the CW's MSG_LOST: cw_.reset())
}

GatewayStatus Gateway::status() const {
  GatewayStatus s;
  s.dp_state = slave_.state();
  s.bus_state = bus_state_;
  s.released = released_;
  s.nmt = nmt_;
  s.rx_frames = rx_frames_;
  s.tx_frames = tx_frames_;
  s.irq_lost = irq_lost();
  s.msg_lost = cw_.msg_lost();
  s.fifo_level = static_cast<std::uint32_t>(cw_.fifo_level());
  s.fifo_high_water = static_cast<std::uint32_t>(cw_.fifo_high_water());
  s.sync_ms = sync_ms_;
  s.wakeup_s = stored_wakeup_s_;
  s.data_exchanges = data_exchanges_;
  return s;
}

}  // namespace candp2::gw
