#include "gateway/comm_window.hpp"

#include <algorithm>
#include <cstdio>

#include "common/hex.hpp"

namespace candp2::gw {

namespace {

std::string command_text(const CwRequest& r) {
  return "CW command " + std::to_string(r.command) + " (counter " + std::to_string(r.counter) + ")";
}

}  // namespace

std::string_view cw_error_text(std::uint8_t error) {
  switch (error) {
    case kCwOk:
      return "ok";
    case kCwErrLength:
      return "invalid length";
    case kCwErrIdentifier:
      return "invalid identifier";
    case kCwErrCommand:
      return "unknown command";
    case kCwErrSyncUnavailable:
      return "SYNC unavailable";
    case kCwErrNotReleased:
      return "CAN not yet released";
  }
  return "?";
}

// ---------------------------------------------------------------- identifier bytes 0..3

void cw_encode_ident(const can::Ident& id, std::span<std::uint8_t> b) {
  b[0] = static_cast<std::uint8_t>((id.id >> 8) & 0xFF);
  b[1] = static_cast<std::uint8_t>(id.id & 0xFF);
  if (id.extended) {
    b[2] = static_cast<std::uint8_t>(kCwIdExtended | ((id.id >> 24) & 0x1F));
    b[3] = static_cast<std::uint8_t>((id.id >> 16) & 0xFF);
  } else {
    b[2] = b[3] = 0;  // manual table 5.3.1: 11-bit, bytes 2 and 3 always 0
  }
}

std::optional<can::Ident> cw_decode_ident(std::span<const std::uint8_t> b) {
  if (b[2] & kCwIdExtended) {
    // Byte 2 holds identifier bits 28..24 below the flag; bits 7-6 would be bits 31-30.
    if (b[2] & 0xC0) return std::nullopt;
    return can::Ident{((std::uint32_t{b[2]} & 0x1F) << 24) | (std::uint32_t{b[3]} << 16) |
                          (std::uint32_t{b[0]} << 8) | b[1],
                      true};
  }
  if (b[2] != 0 || b[3] != 0) return std::nullopt;
  const std::uint32_t id = (std::uint32_t{b[0]} << 8) | b[1];
  if (id > can::kMaxStdId) return std::nullopt;
  return can::Ident{id, false};
}

// ---------------------------------------------------------------- write window (table 5.3.1)

CwRequest decode_cw_request(std::span<const std::uint8_t, kCwLen> w) {
  CwRequest r;
  std::copy_n(w.begin() + kCwIdent, r.ident.size(), r.ident.begin());
  std::copy_n(w.begin() + kCwData, r.data.size(), r.data.begin());
  r.length = w[kCwLength];
  r.counter = w[kCwCounter];
  r.sub_command = w[kCwSubCommand];
  r.command = w[kCwCommand];
  return r;
}

std::array<std::uint8_t, kCwLen> encode_cw_request(const CwRequest& r) {
  std::array<std::uint8_t, kCwLen> w{};
  std::copy(r.ident.begin(), r.ident.end(), w.begin() + kCwIdent);
  std::copy(r.data.begin(), r.data.end(), w.begin() + kCwData);
  w[kCwLength] = r.length;
  w[kCwCounter] = r.counter;
  w[kCwSubCommand] = r.sub_command;
  w[kCwCommand] = r.command;
  return w;
}

// ---------------------------------------------------------------- read window (table 5.3.2)

std::array<std::uint8_t, kCwLen> encode_cw_reply(const CwReply& r) {
  std::array<std::uint8_t, kCwLen> w{};
  if (r.frame) {
    cw_encode_ident(can::ident_of(*r.frame), std::span(w).subspan(kCwIdent, 4));
    const auto payload = r.frame->payload();
    std::copy(payload.begin(), payload.end(), w.begin() + kCwData);
    w[kCwLength] = static_cast<std::uint8_t>(payload.size());
  } else {
    // docs/communication-window.md: EE EE 00 00, data 0, byte 12 = 0.
    w[kCwIdent] = w[kCwIdent + 1] = kCwNoFrame;
  }
  w[kCwCounter] = r.counter;
  w[kCwSubCommand] = r.sub_command;
  w[kCwError] = r.error;
  return w;
}

std::optional<CwReply> decode_cw_reply(std::span<const std::uint8_t, kCwLen> w) {
  CwReply r;
  r.counter = w[kCwCounter];
  r.sub_command = w[kCwSubCommand];
  r.error = w[kCwError];
  const auto frame_bytes = w.subspan(kCwIdent + 2, kCwCounter - 2);  // bytes 2..12
  if (w[0] == kCwNoFrame && w[1] == kCwNoFrame && w[2] == 0 && w[3] == 0) {
    // No frame: the rest must be zero. (A 29-bit id ending in EEEE has the flag in byte 2.)
    if (std::any_of(frame_bytes.begin(), frame_bytes.end(), [](auto b) { return b != 0; }))
      return std::nullopt;
    return r;
  }
  const auto id = cw_decode_ident(w.subspan(kCwIdent, 4));
  const std::uint8_t len = w[kCwLength];
  if (!id || len > can::kMaxDlc) return std::nullopt;
  const auto data = w.subspan(kCwData, 8);
  if (std::any_of(data.begin() + len, data.end(), [](auto b) { return b != 0; }))
    return std::nullopt;
  r.frame = can::Frame::data_frame(id->id, id->extended, data.first(len));
  return r;
}

// ---------------------------------------------------------------- the window state machine

void CommWindow::reset() {
  reply_ = CwReply{};
  read_ = encode_cw_reply(reply_);
  last_counter_ = 0;
  armed_ = false;
  dropping_ = false;
  enabled_.clear();
  fifo_.clear();
  fifo_high_water_ = 0;
  msg_lost_ = 0;
}

void CommWindow::on_write(std::span<const std::uint8_t> window, Time now, CwHost& host) {
  if (window.size() != kCwLen) {
    // Cannot happen through the Gateway (decode_slots enforces 16 bytes, manual §5.3.1).
    log_.error("CW write of " + std::to_string(window.size()) + " bytes ignored (must be 16)");
    return;
  }
  const CwRequest req = decode_cw_request(window.first<kCwLen>());
  // docs/communication-window.md / manual §5.3.3 "Achtung": a command runs once, when the loop
  // counter differs from the last executed value (initially 0).
  if (req.counter == last_counter_) return;
  last_counter_ = req.counter;
  if (log_.enabled(LogLevel::Debug))
    log_.debug(command_text(req) + ": " + hex_bytes(window.first<kCwLen>()));
  armed_ = false;  // a new command replaces a read still waiting for its frame
  reply_ = CwReply{std::nullopt, req.counter, req.sub_command, kCwOk};
  reply_.error = execute(req, now, host);
  read_ = encode_cw_reply(reply_);
}

void CommWindow::read(std::span<std::uint8_t> window) const {
  std::copy_n(read_.begin(), std::min(window.size(), read_.size()), window.begin());
}

std::uint8_t CommWindow::fail(const CwRequest& req, std::uint8_t error,
                              std::string_view why) const {
  log_.warn(command_text(req) + ": error " + std::to_string(error) + " (" +
            std::string(cw_error_text(error)) + "): " + std::string(why));
  return error;
}

std::uint8_t CommWindow::execute(const CwRequest& req, Time now, CwHost& host) {
  // Checks in window byte order (identifier bytes 0-3, then length byte 12), then the gateway
  // state; a command with an error has no effect at all.
  const bool uses_ident = req.command == kCwSend || req.command == kCwEnable ||
                          req.command == kCwDisable || req.command == kCwSendRtr ||
                          req.command == kCwEnableAndRtr;
  const bool uses_length =
      req.command == kCwSend || req.command == kCwSendRtr || req.command == kCwEnableAndRtr;
  const bool transmits = uses_length;
  switch (req.command) {
    case kCwNop:
    case kCwSend:
    case kCwRead:
    case kCwEnable:
    case kCwDisable:
    case kCwSendRtr:
    case kCwEnableAndRtr:
    case kCwSyncTime:
      break;
    default:
      return fail(req, kCwErrCommand, "not one of 0, 1, 3, 4, 5, 6, 7, 20 (manual table 5.4.3)");
  }
  std::optional<can::Ident> id;
  if (uses_ident) {
    id = req.identifier();
    if (!id)
      return fail(req, kCwErrIdentifier,
                  "bytes 0-3 " + hex_bytes(req.ident) +
                      " are no 11-bit (<= 07 FF 00 00) or 29-bit (byte 2 bit 5) identifier");
  }
  if (uses_length && req.length > can::kMaxDlc)
    return fail(req, kCwErrLength, "length " + std::to_string(req.length) + " > 8");
  if (transmits && !host.can_released())
    return fail(req, kCwErrNotReleased, "CAN transmission not yet released (docs/canopen.md)");

  switch (req.command) {
    case kCwNop:
      break;
    case kCwSend:
      host.transmit(
          can::Frame::data_frame(id->id, id->extended, std::span(req.data.data(), req.length)));
      break;
    case kCwRead:
      // docs/communication-window.md: the oldest FIFO frame at once, else the next frame that
      // arrives.
      if (auto f = fifo_.pop()) {
        reply_.frame = *f;
        dropping_ = false;
      } else {
        armed_ = true;
      }
      break;
    case kCwEnable:
      enable(*id);
      break;
    case kCwDisable:
      disable(*id);
      break;
    case kCwSendRtr:
    case kCwEnableAndRtr:
      if (req.command == kCwEnableAndRtr) enable(*id);
      // The manual asks for command 4 first; without it the answer just is not received.
      if (!is_enabled(*id))
        log_.info(command_text(req) + ": remote frame on " + can::ident_text(*id) +
                  ", which is not enabled for reception (command 4)");
      host.transmit(can::Frame::rtr(id->id, id->extended, req.length));
      break;
    case kCwSyncTime:
      if (!host.set_sync_time(req.sync_ms(), now))
        return fail(req, kCwErrSyncUnavailable, "the gateway is not a CANopen master");
      break;
  }
  return kCwOk;
}

void CommWindow::enable(const can::Ident& id) {
  const auto key = ident_key(id);
  auto it = std::lower_bound(enabled_.begin(), enabled_.end(), key);
  if (it != enabled_.end() && *it == key) return;
  enabled_.insert(it, key);
  log_.info("CW: reception enabled on " + can::ident_text(id));
}

void CommWindow::disable(const can::Ident& id) {
  const auto key = ident_key(id);
  auto it = std::lower_bound(enabled_.begin(), enabled_.end(), key);
  if (it == enabled_.end() || *it != key) return;  // not enabled: nothing to do, no error
  enabled_.erase(it);
  // Frames already in the FIFO stay there: they were received while enabled.
  log_.info("CW: reception disabled on " + can::ident_text(id));
}

bool CommWindow::is_enabled(const can::Ident& id) const {
  return std::binary_search(enabled_.begin(), enabled_.end(), ident_key(id));
}

std::vector<can::Ident> CommWindow::enabled() const {
  std::vector<can::Ident> out;
  out.reserve(enabled_.size());
  for (auto key : enabled_) out.push_back(can::Ident{key & 0x7FFFFFFFu, (key & 0x80000000u) != 0});
  return out;
}

bool CommWindow::on_frame(const can::Frame& frame) {
  // Remote frames carry no data to deliver; they fall through like at slots
  // (docs/slots.md "Data exchange in normal mode").
  if (frame.remote || enabled_.empty()) return false;
  if (!std::binary_search(enabled_.begin(), enabled_.end(), ident_key(frame))) return false;
  deliver(frame);
  return true;
}

void CommWindow::deliver(const can::Frame& frame) {
  if (armed_) {
    // docs/communication-window.md: an armed command 3 takes the next frame straight into the
    // window; it keeps the echo of that command 3.
    armed_ = false;
    reply_.frame = frame;
    read_ = encode_cw_reply(reply_);
    return;
  }
  if (fifo_.push(frame)) {
    dropping_ = false;
    fifo_high_water_ = std::max(fifo_high_water_, fifo_.size());
    return;
  }
  // manual table 3.4.5 byte 10: a full FIFO drops the new frame and counts MSG_LOST.
  ++msg_lost_;
  if (!dropping_)
    log_.warn("CW: receive FIFO full (255 frames), " + can::format_candump(frame) +
              " dropped, MSG_LOST " + std::to_string(msg_lost_) +
              " (further drops are counted, not logged, until the PLC reads)");
  dropping_ = true;
}

}  // namespace candp2::gw
