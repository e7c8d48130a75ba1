#include "gateway/slot_engine.hpp"

#include <algorithm>
#include <cstring>

#include "gateway/form.hpp"

namespace candp2::gw {

void SlotEngine::configure(const SlotConfig& cfg) {
  tx_.clear();
  rx_.clear();
  rx_index_.clear();
  rx_ids_.clear();
  released_ = false;
  next_cycle_.reset();
  stats_.assign(cfg.slots.size(), SlotStats{});
  for (std::size_t i = 0; i < cfg.slots.size(); ++i) {
    const Slot& s = cfg.slots[i];
    if (s.kind == SlotKind::Tx) {
      TxSlot t;
      t.slot = i;
      t.offset = s.offset;
      t.length = s.length;
      t.data_len = s.data_len;
      t.id = s.id;
      t.perm = form_permutation(s.form, s.data_len);
      t.cycle_ms = s.cycle_ms;
      tx_.push_back(t);
    } else if (s.kind == SlotKind::Rx) {
      RxSlot r;
      r.slot = i;
      r.offset = s.offset;
      r.data_len = s.data_len;
      r.counter = s.counter;
      r.swap = s.form != kFormNone;
      r.perm = form_permutation(s.form, s.data_len);
      const auto key = ident_key(*s.id);
      // manual §5.2.1: the same Rx identifier on two slots - the later slot wins.
      auto it = std::find_if(rx_index_.begin(), rx_index_.end(),
                             [&](const auto& e) { return e.first == key; });
      if (it != rx_index_.end())
        it->second = static_cast<std::uint16_t>(rx_.size());
      else {
        rx_index_.emplace_back(key, static_cast<std::uint16_t>(rx_.size()));
        rx_ids_.push_back(*s.id);
      }
      rx_.push_back(r);
    }
  }
  std::sort(rx_index_.begin(), rx_index_.end());
}

void SlotEngine::send(const TxSlot& s, TxPort& tx, Time now) {
  if (!s.id) return;  // manual §5.1.4: 0x07F8 dummy output, nothing is sent
  can::Frame f;
  f.id = s.id->id;
  f.extended = s.id->extended;
  f.dlc = static_cast<std::uint8_t>(s.data_len);  // without the Tx-Counter byte (manual §5.1.2)
  for (std::size_t i = 0; i < s.data_len; ++i) f.data[i] = s.last[s.perm[i]];
  tx.transmit(f);
  auto& st = stats_[s.slot];
  ++st.frames;
  st.last = now;
}

void SlotEngine::on_outputs(std::span<const std::uint8_t> outputs, TxPort& tx, Time now) {
  const bool active = tx.tx_active();
  for (TxSlot& s : tx_) {
    const std::uint8_t* bytes = outputs.data() + s.offset;
    // docs/slots.md "Data exchange in normal mode": data bytes or the Tx-Counter byte differ from
    // the previous Data_Exchange.
    const bool changed = !s.have_data || std::memcmp(s.last.data(), bytes, s.length) != 0;
    if (changed) std::memcpy(s.last.data(), bytes, s.length);
    s.have_data = true;
    if (active && (changed || !s.sent_since_release)) {
      send(s, tx, now);
      s.sent_since_release = true;
    }
  }
}

bool SlotEngine::on_frame(const can::Frame& frame, std::span<std::uint8_t> inputs, Time now) {
  // Remote frames never update slots (docs/slots.md "Data exchange in normal mode").
  if (frame.remote) return false;
  const auto key = ident_key(frame);
  auto it =
      std::lower_bound(rx_index_.begin(), rx_index_.end(), std::make_pair(key, std::uint16_t{0}));
  if (it == rx_index_.end() || it->first != key) return false;
  RxSlot& s = rx_[it->second];
  std::uint8_t* dst = inputs.data() + s.offset;
  const std::size_t n = std::min<std::size_t>(frame.dlc, s.data_len);
  std::array<std::uint8_t, 8> bytes{};  // the rest of the slot's data bytes are zero
  std::memcpy(bytes.data(), frame.data.data(), n);
  if (s.swap) {
    for (std::size_t i = 0; i < s.data_len; ++i) dst[i] = bytes[s.perm[i]];
  } else {
    std::memcpy(dst, bytes.data(), s.data_len);
  }
  if (s.counter) dst[s.data_len] = ++s.count;  // Rx-Counter: modulo 256 (manual §5.1.2)
  auto& st = stats_[s.slot];
  ++st.frames;
  st.last = now;
  return true;
}

void SlotEngine::on_release(Time now, TxPort& tx) {
  released_ = true;
  for (TxSlot& s : tx_) {
    s.sent_since_release = false;
    // docs/slots.md "Data exchange in normal mode": the cycle timer runs freely from release.
    s.next_cycle = now + milliseconds(s.cycle_ms);
    if (s.have_data && tx.tx_active()) {
      send(s, tx, now);
      s.sent_since_release = true;
    }
  }
  recompute_next_cycle();
}

void SlotEngine::advance(Time now, TxPort& tx) {
  if (!released_ || !next_cycle_ || *next_cycle_ > now) return;
  const bool active = tx.tx_active();
  for (TxSlot& s : tx_) {
    if (s.cycle_ms == 0) continue;
    const auto period = milliseconds(s.cycle_ms);
    if (s.next_cycle > now) continue;
    // One send per due time; a late call catches up by skipping missed periods (a real CAN
    // controller would not queue a burst of stale cyclic frames either).
    if (active && s.have_data) {
      send(s, tx, now);
      s.sent_since_release = true;
    }
    const auto missed = (now - s.next_cycle) / period;
    s.next_cycle += period * (missed + 1);
  }
  recompute_next_cycle();
}

void SlotEngine::recompute_next_cycle() {
  next_cycle_.reset();
  for (const TxSlot& s : tx_)
    if (s.cycle_ms && (!next_cycle_ || s.next_cycle < *next_cycle_)) next_cycle_ = s.next_cycle;
}

std::optional<Time> SlotEngine::next_deadline() const {
  return released_ ? next_cycle_ : std::nullopt;
}

bool SlotEngine::tx_waiting_for_data() const {
  return std::any_of(tx_.begin(), tx_.end(), [](const TxSlot& s) { return s.id && !s.have_data; });
}

std::vector<can::Ident> SlotEngine::rx_idents() const {
  return rx_ids_;
}

}  // namespace candp2::gw
