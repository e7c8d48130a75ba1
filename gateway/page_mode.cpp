// STUB: completed by the Page-Mode work (issue 4). Answers nothing yet.
#include "gateway/page_mode.hpp"

#include <algorithm>

namespace candp2::gw {

void PageMode::configure(const SlotConfig& cfg) {
  out_segments_.clear();
  in_segments_.clear();
  out_len_ = in_len_ = 0;
  for (const auto& s : cfg.slots) {
    if (s.kind == SlotKind::SegmentOut) {
      out_segments_.push_back(s.length);
      out_len_ += s.length;
    } else if (s.kind == SlotKind::SegmentIn) {
      in_segments_.push_back(s.length);
      in_len_ += s.length;
    }
  }
  reset();
}

void PageMode::reset() {
  input_page_.assign(in_len_, 0);
}

void PageMode::on_output_page(std::span<const std::uint8_t>, Time, TxPort&) {}

void PageMode::write_input_page(std::span<std::uint8_t> page) const {
  std::copy_n(input_page_.begin(), std::min(page.size(), input_page_.size()), page.begin());
}

bool PageMode::on_frame(const can::Frame&, Time) {
  return false;
}

void PageMode::on_release(Time, TxPort&) {}

std::vector<can::Ident> PageMode::rx_idents() const {
  return {};
}

}  // namespace candp2::gw
