#include "gateway/gateway.hpp"

#include <algorithm>
#include <cstring>

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

}  // namespace

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

std::uint32_t frame_bits(const can::Frame& f) {
  // SOF..EOF without stuff bits plus 3 bits intermission: 47 (11-bit) or 67 (29-bit) + 8 per byte.
  const std::uint32_t overhead = f.extended ? 67 : 47;
  return overhead + (f.remote ? 0u : 8u * f.dlc);
}

Gateway::Gateway(GatewayOptions options, can::FrameSink& can_tx, Time power_on)
    : log_(options.log, "gw" + std::to_string(clamp_address(options.address))),
      address_(clamp_address(options.address)),
      options_(options),
      can_tx_(can_tx),
      slave_(
          dp::SlaveInfo{clamp_address(options.address), kIdentNumber, kUserPrmLen, kExtDiagHeader},
          *this, options.log),
      power_on_(power_on),
      stored_wakeup_s_(options.stored_wakeup_s),
      stored_sync_ms_(options.stored_sync_ms) {
  if (address_ != options.address)
    log_.warn("station address " + std::to_string(options.address) + " clamped to " +
              std::to_string(address_) + " (manual §2.1: 3..124)");
  cw_.reset();
}

// ---------------------------------------------------------------- DP slave application

std::optional<dp::PrmFault> Gateway::on_set_prm(std::span<const std::uint8_t> telegram, Time now) {
  auto decoded = decode_user_prm(telegram);
  if (auto* fault = std::get_if<dp::PrmFault>(&decoded)) return *fault;
  const UserPrm& p = std::get<UserPrm>(decoded);
  const bool role_changed = !prm_ || prm_->role() != p.role() || prm_->module_id != p.module_id;
  prm_ = p;
  // manual table 5.1.2: without a CANopen role, wake-up, RTR, Start-Frame and SYNC are ignored.
  if (p.role() != CanopenRole::None) {
    if (p.wakeup_s != kWakeupKeep) stored_wakeup_s_ = p.wakeup_s;
    if (p.sync_ms != kSyncKeep) stored_sync_ms_ = p.sync_ms;
  }
  sync_ms_ = p.role() == CanopenRole::Master ? stored_sync_ms_ : 0;
  if (role_changed) {
    released_ = false;
    boot_sent_ = false;
    nmt_ = NmtState::Initialising;
  }
  log_.info(std::string("parameters: ") + std::to_string(kBitrates[p.bitrate_index] / 1000) +
            " kbit/s, CANopen " + std::string(to_string(p.role())) +
            (p.page_mode ? ", Page-Mode" : "") + (p.comm_window ? ", Communication Window" : ""));
  update_release(now);
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
  // the input image are kept, as frames received meanwhile updated them (emulator-spec §4).
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
      if (s->cw_sync_ms != 0) set_sync_time(s->cw_sync_ms, now);
  }
  log_.info("configuration: " + std::to_string(cfg_->slots.size()) + " slots, " +
            std::to_string(cfg_->input_len) + " input / " + std::to_string(cfg_->output_len) +
            " output bytes");
  return std::nullopt;
}

void Gateway::on_enter_data_exchange(Time now) {
  update_release(now);
  // Slot traffic resumes (after a watchdog drop, too): every Tx slot once, cycle timers restart.
  if (released_) {
    if (cfg_ && cfg_->page_mode)
      page_.on_release(now, *this);
    else
      slots_.on_release(now, *this);
  }
}

void Gateway::on_leave_data_exchange(Time) {
  // emulator-spec §1: Tx on CAN stops (tx_active() is false), the input image keeps its values.
}

void Gateway::on_data_exchange(std::span<const std::uint8_t> outputs,
                               std::span<std::uint8_t> inputs, Time now) {
  ++data_exchanges_;
  const std::uint32_t tx_before = tx_frames_;
  burst_bits_ = 0;
  if (cfg_->page_mode) {
    page_.on_output_page(outputs.first(page_.output_page_len()), now, *this);
  } else {
    slots_.on_outputs(outputs, *this);
  }
  if (cfg_->cw_out) {
    const Slot& s = cfg_->slots[*cfg_->cw_out];
    cw_.on_write(outputs.subspan(s.offset, kCwLen), now, *this);
  }
  // The frames of this Data_Exchange occupy the bus from now on; a SYNC falling due meanwhile waits
  // until they are out (manual §5.3.3, command 20 note).
  if (tx_frames_ != tx_before && prm_) {
    const std::uint64_t bitrate = kBitrates[prm_->bitrate_index];
    const auto busy = microseconds((std::uint64_t{burst_bits_} * 1000000u + bitrate - 1) / bitrate);
    bus_busy_until_ = now + busy;
    busy_from_ = now;
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
    // manual table 3.4.5: bus state, IRQ_LOST, MSG_LOST (both saturate at 255, emulator-spec §3).
    d.bytes = {bus_state_code(bus_state_),
               static_cast<std::uint8_t>(std::min<std::uint32_t>(irq_lost_, 255)),
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

void Gateway::on_can_frame(const can::Frame& frame, Time now) {
  ++rx_frames_;
  if (log_.enabled(LogLevel::Debug)) log_.debug("rx " + can::format_candump(frame));
  if (role() == CanopenRole::Slave && !frame.extended && !frame.remote && frame.id == kNmtId) {
    handle_nmt(frame, now);
    return;
  }
  // emulator-spec §4: identifiers enabled in the CW take precedence over input slots.
  if (cw_.on_frame(frame)) return;
  if (!cfg_) return;
  if (cfg_->page_mode)
    page_.on_frame(frame, now);
  else
    slots_.on_frame(frame, input_image_);
}

void Gateway::set_controller_status(can::BusState state, std::uint32_t rx_lost_total) {
  if (state != bus_state_)
    log_.warn("CAN bus state " + std::string(can::to_string(bus_state_)) + " -> " +
              std::string(can::to_string(state)));
  bus_state_ = state;
  irq_lost_ = rx_lost_total;
}

// ---------------------------------------------------------------- release, CANopen (emulator-spec
// §7)

void Gateway::update_release(Time now) {
  if (released_) return;
  const bool configured = cfg_.has_value() && slave_.state() == dp::SlaveState::DataExch;
  const Time wake = power_on_ + seconds(stored_wakeup_s_);
  switch (role()) {
    case CanopenRole::None:
      // Layer-2 mode: released when Data_Exch is first entered.
      if (configured) release(now, "Data_Exch entered (layer-2 mode)");
      break;
    case CanopenRole::Master:
      if (configured && now >= wake) release(now, "wake-up time elapsed (CANopen master)");
      break;
    case CanopenRole::Slave:
      if (!boot_sent_ && prm_ && now >= wake) {
        send_boot_frame();
        boot_sent_ = true;
        nmt_ = NmtState::PreOperational;
      }
      break;
  }
}

void Gateway::release(Time now, std::string_view why) {
  released_ = true;
  log_.info("CAN transmission released: " + std::string(why));
  if (role() == CanopenRole::Master && prm_->start_frame) {
    // emulator-spec §7: NMT start-all, ID 0, DLC 2, 01 00.
    const std::uint8_t start[] = {kNmtStart, 0x00};
    transmit(can::Frame::std_data(kNmtId, start));
  }
  if (cfg_ && tx_active()) {
    if (cfg_->page_mode)
      page_.on_release(now, *this);
    else
      slots_.on_release(now, *this);
  }
  if (role() != CanopenRole::None && prm_->send_rtr) {
    // One remote frame per Rx identifier (manual table 5.1.2 "RTR-Frames auf RxId senden").
    const auto ids = cfg_ && cfg_->page_mode ? page_.rx_idents() : slots_.rx_idents();
    for (const auto& id : ids) {
      std::uint8_t dlc = 0;
      if (cfg_)
        for (const auto& s : cfg_->slots)
          if (s.kind == SlotKind::Rx && s.id == id) dlc = static_cast<std::uint8_t>(s.data_len);
      transmit(can::Frame::rtr(id.id, id.extended, dlc));
    }
  }
  schedule_sync(now);
}

void Gateway::halt(std::string_view why) {
  if (released_) log_.info("CAN transmission halted: " + std::string(why));
  released_ = false;
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
  if (frame.dlc < 2) return;
  const std::uint8_t cmd = frame.data[0];
  const std::uint8_t node = frame.data[1];
  if (node != 0 && node != prm_->module_id) return;
  if (!boot_sent_) return;  // still initialising (wake-up time)
  switch (cmd) {
    case kNmtStart:
      nmt_ = NmtState::Operational;
      if (!released_) release(now, "NMT start (CANopen slave)");
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
      halt("NMT reset");
      send_boot_frame();
      nmt_ = NmtState::PreOperational;
      break;
    default:
      log_.debug("NMT command " + hex_bytes(std::array{cmd}) + " ignored");
  }
}

bool Gateway::set_sync_time(std::uint16_t ms, Time now) {
  if (role() != CanopenRole::Master) return false;
  // manual §5.1.2 note: Prm bytes 14-15, CW comment bytes 4-5 and command 20 are equal sources;
  // the last one written wins.
  sync_ms_ = ms;
  stored_sync_ms_ = ms;
  log_.info("SYNC time " + std::to_string(ms) + " ms");
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
  if (next_sync_) {
    Time due = *next_sync_;
    if (due >= busy_from_ && due < bus_busy_until_) due = bus_busy_until_;
    if (due <= now) {
      if (tx_active()) transmit(can::Frame::std_data(kSyncId, {}));
      const auto period = milliseconds(sync_ms_);
      while (*next_sync_ <= now) *next_sync_ += period;
    }
  }
}

std::optional<Time> Gateway::next_deadline() const {
  std::optional<Time> next = slave_.next_deadline();
  auto consider = [&](std::optional<Time> t) {
    if (t && (!next || *t < *next)) next = t;
  };
  consider(slots_.next_deadline());
  if (next_sync_) {
    Time due = *next_sync_;
    if (due >= busy_from_ && due < bus_busy_until_) due = bus_busy_until_;
    consider(due);
  }
  const Time wake = power_on_ + seconds(stored_wakeup_s_);
  if (!released_ && role() == CanopenRole::Master && cfg_) consider(wake);
  if (!boot_sent_ && role() == CanopenRole::Slave) consider(wake);
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
  page_.configure(SlotConfig{});
  input_image_.clear();
  power_on_ = now;
  released_ = false;
  boot_sent_ = false;
  nmt_ = NmtState::Initialising;
  sync_ms_ = 0;
  next_sync_.reset();
  bus_busy_until_ = busy_from_ = Time{0};
  rx_frames_ = tx_frames_ = data_exchanges_ = 0;
}

GatewayStatus Gateway::status() const {
  GatewayStatus s;
  s.dp_state = slave_.state();
  s.bus_state = bus_state_;
  s.released = released_;
  s.nmt = nmt_;
  s.rx_frames = rx_frames_;
  s.tx_frames = tx_frames_;
  s.irq_lost = irq_lost_;
  s.msg_lost = cw_.msg_lost();
  s.fifo_level = static_cast<std::uint32_t>(cw_.fifo_level());
  s.fifo_high_water = static_cast<std::uint32_t>(cw_.fifo_high_water());
  s.sync_ms = sync_ms_;
  s.wakeup_s = stored_wakeup_s_;
  s.data_exchanges = data_exchanges_;
  return s;
}

}  // namespace candp2::gw
