// The plant's observers (docs/architecture.md "The plant"): the one tap every CAN frame, DP
// telegram and operator note goes to, with the sender's kind and index. Part of plant::Plant
// (plant/plant.hpp).
#include <algorithm>

#include "plant/plant.hpp"

namespace candp2::plant {

void Plant::add_tap(Tap* tap) {
  taps_.push_back(tap);
}

void Plant::remove_tap(Tap* tap) {
  std::erase(taps_, tap);
}

void Plant::tap_can(const BusUnit& bus, const can::Frame& frame, std::string_view sender,
                    Time time) {
  if (taps_.empty()) return;
  const auto [kind, index] = known_sender(bus, sender);
  const CanRecord r{.time = time,
                    .bus = bus.index(),
                    .bus_name = bus.name(),
                    .interface = bus.interface(),
                    .frame = frame,
                    .sender = sender,
                    .sender_kind = kind,
                    .sender_index = index,
                    .from_emulation = kind != SenderKind::Outside};
  for (Tap* t : taps_) t->on_can(r);
}

std::pair<SenderKind, std::size_t> Plant::known_sender(const BusUnit& bus,
                                                       std::string_view sender) const {
  // The sending endpoint's own name (the same characters at the same address): one of the bus's.
  for (const auto& k : bus.known_senders_)
    if (k.name.data() == sender.data() && k.name.size() == sender.size()) return k.who;
  return sender_of(sender);
}

std::pair<SenderKind, std::size_t> Plant::sender_of(std::string_view sender) const {
  // One lookup in the index add_gateway()/add_drive() fill (docs/can-bus.md "Performance").
  const auto it = senders_.find(sender);
  return it == senders_.end() ? std::pair{SenderKind::Outside, std::size_t{0}} : it->second;
}

void Plant::tap_line(std::span<const std::uint8_t> telegram, bool from_emulation, Time time) {
  if (taps_.empty()) return;
  const DpRecord r{.time = time,
                   .line = 1,
                   .line_name = config_.profibus->port,
                   .telegram = telegram,
                   .from_emulation = from_emulation};
  for (Tap* t : taps_) t->on_dp(r);
}

void Plant::tap_in_process(std::span<const std::uint8_t> telegram, Time time, std::uint32_t baud) {
  if (taps_.empty()) return;
  // docs/decisions.md "pcapng captures": in-process both ends are emulated.
  const DpRecord r{.time = time,
                   .line = 0,
                   .line_name = "in-process",
                   .telegram = telegram,
                   .from_emulation = true,
                   .baud = baud};
  for (Tap* tap : taps_) tap->on_dp(r);
}

void Plant::tap_note(std::string text, Time now) {
  if (taps_.empty()) return;
  const NoteRecord r{.time = now, .text = text};
  for (Tap* t : taps_) t->on_note(r);
}

}  // namespace candp2::plant
