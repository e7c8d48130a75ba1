// STUB: completed by the Communication Window work (issue 3). Keeps the read window in its idle
// state.
#include "gateway/comm_window.hpp"

#include <algorithm>

namespace candp2::gw {

void CommWindow::reset() {
  read_ = {};
  read_[0] = read_[1] = 0xEE;
  last_counter_ = 0;
  armed_ = false;
  enabled_.clear();
  fifo_.clear();
  fifo_high_water_ = 0;
  msg_lost_ = 0;
}

void CommWindow::on_write(std::span<const std::uint8_t>, Time, CwHost&) {}

void CommWindow::read(std::span<std::uint8_t> window) const {
  std::copy(read_.begin(), read_.end(), window.begin());
}

bool CommWindow::on_frame(const can::Frame&) {
  return false;
}

bool CommWindow::is_enabled(const can::Ident& id) const {
  return std::find(enabled_.begin(), enabled_.end(), ident_key(id)) != enabled_.end();
}

void cw_encode_ident(const can::Ident& id, std::span<std::uint8_t> b) {
  b[0] = static_cast<std::uint8_t>((id.id >> 8) & 0xFF);
  b[1] = static_cast<std::uint8_t>(id.id & 0xFF);
  b[2] = id.extended ? static_cast<std::uint8_t>(0x20 | (id.id >> 24)) : 0;
  b[3] = id.extended ? static_cast<std::uint8_t>((id.id >> 16) & 0xFF) : 0;
}

std::optional<can::Ident> cw_decode_ident(std::span<const std::uint8_t> b) {
  if (b[2] & 0x20) {
    return can::Ident{((std::uint32_t{b[2]} & 0x1F) << 24) | (std::uint32_t{b[3]} << 16) |
                          (std::uint32_t{b[0]} << 8) | b[1],
                      true};
  }
  if (b[2] != 0 || b[3] != 0) return std::nullopt;
  const std::uint32_t id = (std::uint32_t{b[0]} << 8) | b[1];
  if (id > can::kMaxStdId) return std::nullopt;
  return can::Ident{id, false};
}

}  // namespace candp2::gw
