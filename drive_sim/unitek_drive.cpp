// The simulated Unitek drive (drive_sim/unitek_drive.hpp): construction, stored parameters,
// commands and reads received on the Rx ID, replies and status events sent on the Tx ID, the
// simulated inputs. The time grid and the motor model are in motor_model.cpp.
#include "drive_sim/unitek_drive.hpp"

#include <algorithm>
#include <cstdio>
#include <stdexcept>

#include "drive_sim/model_units.hpp"

namespace candp2::drive {

using namespace detail;

namespace {

std::string hex(std::uint32_t v, int digits) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "0x%0*X", digits, v);
  return buf;
}

// What the EEPROM write (0x84) stores: the RW registers of the list, except SPEED_CMD (0x31). The
// list marks it RW, but it is a set point: a drive restarted from its parameter memory must not
// start turning by itself.
bool is_persistent(const RegisterInfo& info) {
  return info.access == Access::RW && info.regid != reg::kSpeedCmd;
}

std::string reg_name(std::uint8_t regid) {
  return hex(regid, 2) + " (" + std::string(register_info(regid).name) + ")";
}

}  // namespace

std::string_view to_string(ControlMode m) {
  switch (m) {
    case ControlMode::Speed:
      return "speed";
    case ControlMode::Position:
      return "position";
    case ControlMode::Torque:
      return "torque";
  }
  return "?";
}

std::string describe(const can::Frame& frame) {
  return can::format_candump(frame);
}

UnitekDrive::UnitekDrive(Options options, LogSink* log, ParameterStore* store)
    : options_(std::move(options)), log_(log, "drive:" + options_.name), store_(store) {
  if (options_.rx_id > can::kMaxStdId || options_.tx_id > can::kMaxStdId)
    throw std::invalid_argument("drive Rx/Tx identifiers must be 11-bit values (0x000..0x7FF)");
  if (options_.reference_run_time.count() < 0)
    throw std::invalid_argument("drive reference run time must not be negative");
  for (const RegisterInfo& info : register_table()) regs_[info.regid] = info.default_value;
  regs_[reg::kCanIdRx] = options_.rx_id;
  regs_[reg::kCanIdTx] = options_.tx_id;
  if (store_) {
    std::string error;
    if (auto params = store_->load(&error))
      apply_parameters(*params, "state store");
    else if (!error.empty())
      log_.error(error + "; starting with the register list's defaults");
  }
  // The list's POS_ACTUAL default (a reading of a real drive) is where the simulated motor stands.
  pos_fine_ =
      static_cast<std::int64_t>(static_cast<std::int32_t>(regs_[reg::kPosActual])) * kPosDen;
  update_outputs();
  status_basis_ = regs_[reg::kStatus];
  errors_basis_ = errors_;
  log_.info("Unitek drive: Rx ID " + hex(rx_id(), 3) + ", Tx ID " + hex(tx_id(), 3) +
            (options_.status_16bit ? ", 16-bit status replies (manual V1 1011)" : ""));
}

std::int32_t UnitekDrive::reg_signed(std::uint8_t regid) const {
  if (register_info(regid).width == Width::W16) return as_i16(regs_[regid]);
  return static_cast<std::int32_t>(regs_[regid]);
}

bool UnitekDrive::enabled() const {
  return power_ok_ && errors_ == 0 && enable_input_ && !(regs_[reg::kMode] & mode::kDisable);
}

std::int32_t UnitekDrive::position_actual() const {
  return static_cast<std::int32_t>(regs_[reg::kPosActual]);
}

std::int16_t UnitekDrive::speed_actual() const {
  return as_i16(regs_[reg::kSpeedActual]);
}

Width UnitekDrive::reply_width(std::uint8_t regid) const {
  // FW 378 short description §3: upper byte 01 in REGID 0xDC makes every reply 6 bytes long.
  if (((regs_[reg::kDefineDac] >> 8) & 0xFFu) == 0x01) return Width::W32;
  if (options_.status_16bit && (regid == reg::kStatus || regid == reg::kErrBitmap))
    return Width::W16;
  return register_info(regid).width;
}

StoredParameters UnitekDrive::parameters() const {
  StoredParameters p;
  for (const RegisterInfo& info : register_table())
    if (is_persistent(info)) p.values[info.regid] = regs_[info.regid];
  return p;
}

void UnitekDrive::apply_parameters(const StoredParameters& params, std::string_view origin) {
  std::size_t applied = 0;
  for (const auto& [regid, value] : params.values) {
    const RegisterInfo& info = register_info(regid);
    if (!is_persistent(info)) {
      log_.warn("stored value for " + reg_name(regid) + " ignored: not a stored parameter");
      continue;
    }
    if (info.width == Width::W16 && value > 0xFFFFu) {
      log_.warn("stored value for " + reg_name(regid) + " ignored: wider than 16 bits");
      continue;
    }
    if ((regid == reg::kCanIdRx && (value < kRxIdMin || value > kRxIdMax)) ||
        (regid == reg::kCanIdTx && (value < kTxIdMin || value > kTxIdMax))) {
      log_.warn("stored CAN identifier " + reg_name(regid) + " = " + hex(value, 3) +
                " ignored: outside the manual's range");
      continue;
    }
    regs_[regid] = value;
    ++applied;
  }
  log_.info("loaded " + std::to_string(applied) + " parameters from the " + std::string(origin));
}

// ---------------------------------------------------------------------------------------------
// Events and replies

void UnitekDrive::check_events(can::FrameSink& out) {
  const bool events = regs_[reg::kMode] & mode::kStatusEvent;
  const std::uint32_t s = regs_[reg::kStatus];
  // CAN manual example 9: with MODE bit 4 the drive sends STATUS when a bit selected by
  // STATUS_MASK 0x52 changes.
  if (events && ((s ^ status_basis_) & regs_[reg::kStatusMask])) send_register(reg::kStatus, out);
  status_basis_ = s;
  // CAN manual example 9.2: a change of ERR_BITMAP1 is sent (the manual leaves the MODE bit open;
  // this product uses bit 4 as well).
  if (events && errors_ != errors_basis_) send_register(reg::kErrBitmap, out);
  errors_basis_ = errors_;
}

void UnitekDrive::send_register(std::uint8_t regid, can::FrameSink& out) {
  const Width width = reply_width(regid);
  std::uint32_t value = regs_[regid];
  // A 16-bit register widened by 0xDC travels sign-extended, like 16-bit data written to a
  // 32-bit register.
  if (width == Width::W32 && register_info(regid).width == Width::W16)
    value = static_cast<std::uint32_t>(static_cast<std::int32_t>(as_i16(value)));
  const can::Frame reply = encode_reply(tx_id(), regid, value, width);
  if (log_.enabled(LogLevel::Debug)) log_.debug("tx " + describe(reply));
  out.send(reply);
}

// ---------------------------------------------------------------------------------------------
// Commands

void UnitekDrive::on_frame(const can::Frame& frame, Time now, can::FrameSink& out) {
  advance(now, out);
  if (frame.id != rx_id()) return;
  const Decoded decoded = decode_command(frame);
  if (!decoded.command) {
    if (log_.enabled(LogLevel::Debug))
      log_.debug("ignored " + describe(frame) + ": " + std::string(to_string(decoded.reject)));
    return;
  }
  if (log_.enabled(LogLevel::Debug)) log_.debug("rx " + describe(frame));
  handle_command(*decoded.command, now_, out);
  update_outputs();
  check_events(out);
}

void UnitekDrive::handle_command(const Command& command, Time now, can::FrameSink& out) {
  if (command.regid == reg::kRead) {
    handle_read(command.byte(0), command.byte(1), now, out);
    return;
  }
  handle_write(command, out);
}

void UnitekDrive::handle_read(std::uint8_t regid, std::uint8_t time, Time now,
                              can::FrameSink& out) {
  if (time == kReadOnce) {
    send_register(regid, out);
    return;
  }
  if (time == kReadStop) {
    for (CyclicEntry& e : cyclic_) {
      if (e.state == CyclicEntry::State::Active && e.regid == regid) {
        e.state = CyclicEntry::State::Suspended;
        log_.info("cyclic transmission of " + reg_name(regid) + " suspended");
        return;
      }
    }
    log_.debug("stop request for " + reg_name(regid) + ": no cyclic transmission active");
    return;
  }
  // FW 378 §8: up to 8 time-triggered requests; suspended entries can be overwritten by newer
  // requests. A request for a REGID that already has an entry re-uses it.
  std::optional<std::size_t> slot;
  for (std::size_t i = 0; i < cyclic_.size() && !slot; ++i)
    if (cyclic_[i].state != CyclicEntry::State::Free && cyclic_[i].regid == regid) slot = i;
  for (std::size_t i = 0; i < cyclic_.size() && !slot; ++i)
    if (cyclic_[i].state == CyclicEntry::State::Free) slot = i;
  for (std::size_t i = 0; i < cyclic_.size() && !slot; ++i)
    if (cyclic_[i].state == CyclicEntry::State::Suspended) slot = i;
  if (!slot) {
    log_.warn("cyclic request for " + reg_name(regid) + " every " + std::to_string(time) +
              " ms refused: all " + std::to_string(kMaxCyclicEntries) +
              " cyclic entries are active (FW 378 §8); stop one with time byte 0xFF");
    return;
  }
  cyclic_[*slot] = {CyclicEntry::State::Active, regid, time, now + milliseconds(time)};
  log_.info("cyclic transmission of " + reg_name(regid) + " every " + std::to_string(time) +
            " ms (entry " + std::to_string(*slot) + ")");
  send_register(regid, out);  // the first reply at once, then every period
}

void UnitekDrive::set_control(ControlMode m) {
  if (referencing_) {
    after_reference_ = m;  // takes over when the reference run is done
    return;
  }
  control_ = m;
}

void UnitekDrive::handle_write(const Command& command, can::FrameSink& out) {
  const std::uint8_t regid = command.regid;
  const RegisterInfo& info = register_info(regid);
  const std::uint32_t value = value_for_register(command, info.width);
  if (info.access == Access::RO) {
    log_.debug("write to read-only " + reg_name(regid) + " ignored");
    return;
  }
  if (info.access == Access::FN) {
    handle_function(regid, value);
    return;
  }
  switch (regid) {
    case reg::kCanIdRx:
    case reg::kCanIdTx: {
      // CAN manual "Setting CAN-BUS": Rx 0x201..0x27F, Tx 0x181..0x1FF. Example 1: the new
      // identifier takes effect at once.
      const bool rx = regid == reg::kCanIdRx;
      if (rx ? (value < kRxIdMin || value > kRxIdMax) : (value < kTxIdMin || value > kTxIdMax)) {
        log_.warn("new " + std::string(rx ? "Rx" : "Tx") + " ID " + hex(value, 3) +
                  " refused: outside " + hex(rx ? kRxIdMin : kTxIdMin, 3) + ".." +
                  hex(rx ? kRxIdMax : kTxIdMax, 3) + " (CAN manual, Setting CAN-BUS)");
        return;
      }
      regs_[regid] = value;
      log_.info(std::string(rx ? "Rx" : "Tx") + " ID now " + hex(value, 3));
      return;
    }
    case reg::kMode: {
      const std::uint32_t old = regs_[reg::kMode];
      regs_[reg::kMode] = value;
      update_outputs();
      if (!(old & mode::kStatusEvent) && (value & mode::kStatusEvent)) {
        // Subscribing sends the current status once, so the master starts from a known state.
        status_basis_ = regs_[reg::kStatus];
        errors_basis_ = errors_;
        send_register(reg::kStatus, out);
      }
      return;
    }
    case reg::kSpeedCmd:
      regs_[regid] = value;
      set_control(ControlMode::Speed);
      return;
    case reg::kPosDest:
      regs_[regid] = value;
      set_control(ControlMode::Position);
      return;
    case reg::kTorqueCmd:
      regs_[regid] = value;
      set_control(ControlMode::Torque);
      return;
    default:
      regs_[regid] = value;
      return;
  }
}

void UnitekDrive::handle_function(std::uint8_t regid, std::uint32_t value) {
  switch (regid) {
    case reg::kRefStart:
      if (!enabled()) {
        log_.warn("reference run (0x78) refused: the drive is not enabled");
        return;
      }
      referencing_ = true;
      referenced_ = false;
      reference_ticks_ = 0;
      after_reference_.reset();
      log_.info("reference run started");
      return;
    case reg::kParaWrite: {
      // CAN manual example 7: EEPROM level in the data (0, 1, 2); all levels store the same set.
      if (!store_) {
        log_.warn("EEPROM write (0x84) without a state store: parameters are not persisted");
        return;
      }
      std::string error;
      if (store_->save(parameters(), &error))
        log_.info("EEPROM write (level " + std::to_string(value & 0xFFFFu) + "): parameters saved");
      else
        log_.error("EEPROM write (0x84) failed: " + error);
      return;
    }
    case reg::kParaRead: {
      if (!store_) {
        log_.warn("EEPROM read (0x83) without a state store: nothing to load");
        return;
      }
      std::string error;
      if (auto params = store_->load(&error))
        apply_parameters(*params, "state store (0x83)");
      else
        log_.error("EEPROM read (0x83): " + (error.empty() ? "nothing stored" : error));
      return;
    }
    case reg::kErrCancel:
      if (errors_) log_.info("error list cleared (0x8E), was " + hex(errors_, 8));
      errors_ = 0;
      return;
    default:
      log_.debug("function " + reg_name(regid) + " is not simulated; write ignored");
      return;
  }
}

// ---------------------------------------------------------------------------------------------
// Inputs

void UnitekDrive::set_enable_input(bool on, Time now, can::FrameSink& out) {
  advance(now, out);
  enable_input_ = on;
  update_outputs();
  check_events(out);
}

void UnitekDrive::set_limit_switch(LimitSwitch which, bool active, Time now, can::FrameSink& out) {
  advance(now, out);
  (which == LimitSwitch::Plus ? limit_plus_ : limit_minus_) = active;
  update_outputs();
  check_events(out);
}

void UnitekDrive::set_errors(std::uint32_t bitmap, Time now, can::FrameSink& out) {
  advance(now, out);
  if (bitmap != errors_) log_.warn("error bitmap (0x8F) now " + hex(bitmap, 8));
  errors_ = bitmap;
  update_outputs();
  check_events(out);
}

void UnitekDrive::set_power_ok(bool on, Time now, can::FrameSink& out) {
  advance(now, out);
  power_ok_ = on;
  update_outputs();
  check_events(out);
}

}  // namespace candp2::drive
