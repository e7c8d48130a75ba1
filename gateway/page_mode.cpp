#include "gateway/page_mode.hpp"

#include <algorithm>
#include <cstring>

#include "common/hex.hpp"
#include "gateway/form.hpp"

namespace candp2::gw {

using page::Status;

std::string_view to_string(PageMode::State s) {
  switch (s) {
    case PageMode::State::WaitInit:
      return "waiting for page 0";
    case PageMode::State::TxConfig:
      return "Tx configuration";
    case PageMode::State::RxConfig:
      return "Rx configuration";
    case PageMode::State::Data:
      return "data exchange";
  }
  return "?";
}

// ---------------------------------------------------------------- configuration

void PageMode::configure(const SlotConfig& cfg) {
  std::vector<std::size_t> out, in;
  for (const auto& s : cfg.slots) {
    if (s.kind == SlotKind::SegmentOut) out.push_back(s.length);
    if (s.kind == SlotKind::SegmentIn) in.push_back(s.length);
  }
  out_ = page::Layout(std::move(out));
  in_ = page::Layout(std::move(in));
  comm_window_ = cfg.cw_in.has_value();
  reset();
}

void PageMode::clear_configuration() {
  tx_.clear();
  tx_idents_.clear();
  tx_index_.clear();
  rx_.clear();
  rx_index_.clear();
  tx_by_page_.clear();
  rx_by_page_.clear();
  data_pages_ = 0;
  next_config_page_ = page::kTxConfigFirst;
  last_data_fault_.clear();
}

void PageMode::reset() {
  clear_configuration();
  state_ = State::WaitInit;
  last_seq_.reset();
  torn_ = false;
  last_status_.reset();
  input_page_.assign(in_.size(), 0);
}

// ------------------------------------------------------ answers (docs/page-mode.md "Header bytes")

void PageMode::answer(std::uint16_t number, std::uint8_t seq, Status status, std::uint16_t w4,
                      std::uint16_t w6) {
  std::fill(input_page_.begin(), input_page_.end(), 0);
  if (in_.empty() || !in_.has_header()) return;  // decode_slots guarantees >= 32 input bytes
  std::span<std::uint8_t> p(input_page_);
  page::put_page_number(in_, p, number);
  p[page::kSeqByte] = seq;
  p[page::kStatusByte] = static_cast<std::uint8_t>(status);
  page::put_be16(p, page::kWord4, w4);
  page::put_be16(p, page::kWord6, w6);
  last_status_ = status;
}

void PageMode::fail(std::uint16_t number, std::uint8_t seq, Status status, std::uint16_t w6,
                    const std::string& why) {
  answer(number, seq, status, 0, w6);
  log_.warn("page " + std::to_string(number) + " (sequence " + std::to_string(seq) + "): status " +
            std::to_string(static_cast<int>(status)) + " " + std::string(page::to_string(status)) +
            ": " + why);
}

// ---------------------------------------------------------------- output pages

void PageMode::on_output_page(std::span<const std::uint8_t> page, Time now, TxPort& tx) {
  if (!out_.has_header() || page.size() < out_.size()) return;
  const auto number = page::page_number(out_, page);
  if (!number) {
    // docs/page-mode.md "Header bytes": a torn page is ignored until it is consistent.
    if (!torn_) {
      std::string numbers;
      for (std::size_t i = 0; i < out_.segments().size(); ++i) {
        const auto seg = page.subspan(out_.segment_offsets()[i], out_.segments()[i]);
        numbers += (i ? ", " : "") + hex_bytes(seg.first(std::min<std::size_t>(2, seg.size())));
      }
      log_.info("torn output page ignored: its segments start with different page numbers (" +
                numbers + ")");
    }
    torn_ = true;
    return;
  }
  torn_ = false;
  const std::uint8_t seq = page[page::kSeqByte];
  // docs/page-mode.md "Header bytes": each output page is processed once per sequence number.
  if (last_seq_ && *last_seq_ == seq) return;
  last_seq_ = seq;
  ++pages_processed_;
  if (log_.enabled(LogLevel::Debug))
    log_.debug("page " + std::to_string(*number) + " sequence " + std::to_string(seq) + ": " +
               hex_bytes(page.first(out_.size())));
  const std::uint16_t n = *number;
  if (n == page::kInitRequest) {
    on_init(seq);
  } else if (n >= page::kTxConfigFirst && n <= page::kTxConfigLast) {
    on_tx_config(n, seq, page);
  } else if (n >= page::kRxConfigFirst && n <= page::kRxConfigLast) {
    on_rx_config(n, seq, page);
  } else if (n >= page::kDataFirst) {
    on_data(n, seq, page, tx);
  } else {
    fail(n, seq, Status::Unexpected, 0, "pages 1..50 are not sent by the PLC (manual table 6.4.3)");
  }
  (void)now;
}

void PageMode::on_init(std::uint8_t seq) {
  // docs/page-mode.md "Pages": page 0 resets; answer page 1 with the page sizes.
  clear_configuration();
  state_ = State::TxConfig;
  answer(page::kInitAnswer, seq, Status::Ok, static_cast<std::uint16_t>(out_.size()),
         static_cast<std::uint16_t>(in_.size()));
  std::span<std::uint8_t> p(input_page_);
  p[page::kInitOutSegments] = static_cast<std::uint8_t>(out_.segments().size());
  p[page::kInitInSegments] = static_cast<std::uint8_t>(in_.segments().size());
  p[page::kInitCommWindow] = comm_window_ ? 1 : 0;
  log_.info("page 0: Page-Mode reset; page 1: output page " + std::to_string(out_.size()) +
            " bytes in " + std::to_string(out_.segments().size()) + " segments, input page " +
            std::to_string(in_.size()) + " bytes in " + std::to_string(in_.segments().size()) +
            " segments" + (comm_window_ ? ", Communication Window" : ""));
}

std::optional<page::ConfigPage> PageMode::accept_config_page(std::uint16_t n, std::uint8_t seq,
                                                             std::span<const std::uint8_t> page,
                                                             State expected, std::string_view dir,
                                                             std::uint16_t count) {
  // Configuration pages come in order 51, 52, ... (151, 152, ...): status 1 otherwise.
  if (state_ != expected || n != next_config_page_) {
    const std::string why = state_ == expected
                                ? "expecting " + std::string(dir) + " configuration page " +
                                      std::to_string(next_config_page_)
                                : "state is " + std::string(to_string(state_));
    fail(n, seq, Status::Unexpected, count, why);
    return std::nullopt;
  }
  page::ConfigPageFault fault;
  // Both directions' configuration pages are output pages (PLC -> gateway).
  auto decoded = page::decode_config_page(out_, page, &fault);
  if (!decoded)
    fail(n, seq, Status::BadEntry, count,
         fault.why + " (page byte " + std::to_string(fault.offset) + ")");
  return decoded;
}

void PageMode::on_tx_config(std::uint16_t n, std::uint8_t seq, std::span<const std::uint8_t> page) {
  const auto count = static_cast<std::uint16_t>(tx_.size());
  auto decoded = accept_config_page(n, seq, page, State::TxConfig, "Tx", count);
  if (!decoded) return;
  for (std::size_t i = 0; i < decoded->entries.size(); ++i) {
    const auto& e = decoded->entries[i];
    // A data-page entry (force + data) must fit into one output segment.
    if (1u + e.length > out_.max_entry())
      return fail(n, seq, Status::BadEntry, count,
                  "entry " + std::to_string(i + 1) + " (" + can::ident_text(e.id) + "): force + " +
                      std::to_string(e.length) + " data bytes exceed the largest output segment (" +
                      std::to_string(out_.max_entry()) + " payload bytes)");
  }
  if (tx_.size() + decoded->entries.size() > page::kMaxIdentifiers)
    return fail(n, seq, Status::TooMany, count,
                "more than " + std::to_string(page::kMaxIdentifiers) + " Tx identifiers");
  if (!decoded->complete && n == page::kTxConfigLast)
    return fail(n, seq, Status::TooMany, count,
                "DD marker on page 150: no further Tx configuration page exists");
  for (const auto& e : decoded->entries) {
    TxEntry t;
    t.def = e;
    const std::uint32_t key = ident_key(e.id);
    auto it = std::lower_bound(tx_index_.begin(), tx_index_.end(), std::make_pair(key, 0u));
    if (it == tx_index_.end() || it->first != key) {
      it = tx_index_.insert(it, {key, static_cast<std::uint32_t>(tx_idents_.size())});
      tx_idents_.emplace_back();
    }
    t.ident = it->second;
    tx_.push_back(t);
  }
  const auto total = static_cast<std::uint16_t>(tx_.size());
  answer(n, seq, Status::Ok, 0, total);
  if (decoded->complete) {
    state_ = State::RxConfig;
    next_config_page_ = page::kRxConfigFirst;
    log_.info("Tx configuration complete: " + std::to_string(total) + " identifiers on " +
              std::to_string(n - page::kTxConfigFirst + 1) + " page(s)");
  } else {
    ++next_config_page_;
    log_.debug("page " + std::to_string(n) + ": " + std::to_string(decoded->entries.size()) +
               " Tx identifiers, more pages follow");
  }
}

void PageMode::on_rx_config(std::uint16_t n, std::uint8_t seq, std::span<const std::uint8_t> page) {
  const auto count = static_cast<std::uint16_t>(rx_.size());
  auto decoded = accept_config_page(n, seq, page, State::RxConfig, "Rx", count);
  if (!decoded) return;
  for (std::size_t i = 0; i < decoded->entries.size(); ++i) {
    const auto& e = decoded->entries[i];
    const std::string what = "entry " + std::to_string(i + 1) + " (" + can::ident_text(e.id) + ")";
    if (1u + e.length > in_.max_entry())
      return fail(n, seq, Status::BadEntry, count,
                  what + ": count_in + data exceed the largest input segment");
    // manual §2.2: one identifier cannot be used for both Tx and Rx.
    const std::uint32_t key = ident_key(e.id);
    auto it = std::lower_bound(tx_index_.begin(), tx_index_.end(), std::make_pair(key, 0u));
    if (it != tx_index_.end() && it->first == key)
      return fail(n, seq, Status::BadEntry, count,
                  what + ": already configured as Tx identifier (manual §2.2)");
  }
  if (rx_.size() + decoded->entries.size() > page::kMaxIdentifiers)
    return fail(n, seq, Status::TooMany, count,
                "more than " + std::to_string(page::kMaxIdentifiers) + " Rx identifiers");
  if (!decoded->complete && n == page::kRxConfigLast)
    return fail(n, seq, Status::TooMany, count,
                "DD marker on page 250: no further Rx configuration page exists");
  for (const auto& e : decoded->entries) {
    RxEntry r;
    r.def = e;
    rx_.push_back(r);
  }
  if (!decoded->complete) {
    answer(n, seq, Status::Ok, 0, static_cast<std::uint16_t>(rx_.size()));
    ++next_config_page_;
    log_.debug("page " + std::to_string(n) + ": " + std::to_string(decoded->entries.size()) +
               " Rx identifiers, more pages follow");
    return;
  }
  finish_configuration(n, seq);
}

void PageMode::finish_configuration(std::uint16_t n, std::uint8_t seq) {
  std::vector<page::IdEntry> defs;
  defs.reserve(std::max(tx_.size(), rx_.size()));
  for (const auto& t : tx_) defs.push_back(t.def);
  const auto tx_places = page::pack_data(out_, defs);
  defs.clear();
  for (const auto& r : rx_) defs.push_back(r.def);
  const auto rx_places = page::pack_data(in_, defs);
  // docs/page-mode.md "Pages": N = max(Tx pages, Rx pages); at least one (empty) data page.
  const std::size_t pages =
      std::max<std::size_t>({1, page::pages_used(tx_places), page::pages_used(rx_places)});
  const auto count = static_cast<std::uint16_t>(rx_.size());
  if (pages > page::kMaxDataPages) {
    rx_.clear();
    next_config_page_ = page::kRxConfigFirst;
    return fail(n, seq, Status::TooMany, 0,
                std::to_string(pages) + " data pages needed, at most 65285 exist");
  }
  data_pages_ = pages;
  tx_by_page_.assign(pages, {});
  rx_by_page_.assign(pages, {});
  for (std::size_t i = 0; i < tx_.size(); ++i) {
    tx_[i].place = tx_places[i];
    tx_by_page_[tx_places[i].page].push_back(static_cast<std::uint32_t>(i));
  }
  rx_index_.clear();
  for (std::size_t i = 0; i < rx_.size(); ++i) {
    rx_[i].place = rx_places[i];
    rx_by_page_[rx_places[i].page].push_back(static_cast<std::uint32_t>(i));
    // manual §5.2.1 (docs/page-mode.md "Pages": the same Rx rules as slots): the later entry wins.
    const std::uint32_t key = ident_key(rx_[i].def.id);
    auto it = std::lower_bound(rx_index_.begin(), rx_index_.end(), std::make_pair(key, 0u));
    if (it != rx_index_.end() && it->first == key) {
      log_.warn("Rx identifier " + can::ident_text(rx_[i].def.id) + " configured twice: entry " +
                std::to_string(i + 1) + " wins, entry " + std::to_string(it->second + 1) +
                " is never updated (manual §5.2.1)");
      it->second = static_cast<std::uint32_t>(i);
    } else {
      rx_index_.insert(it, {key, static_cast<std::uint32_t>(i)});
    }
  }
  state_ = State::Data;
  answer(n, seq, Status::Ok, 0, count);
  log_.info("Rx configuration complete: " + std::to_string(count) +
            " identifiers; data exchange on " + std::to_string(pages) + " page(s) " +
            std::to_string(page::kDataFirst) + ".." + std::to_string(page::kDataFirst + pages - 1));
}

// ---------------------------------------------------------------- data pages

bool PageMode::send_due(TxEntry& e, std::uint8_t force, std::span<const std::uint8_t> data) const {
  // manual table 6.4.7 (docs/page-mode.md "Pages").
  switch (force) {
    case page::kForceNever:
      return false;
    case page::kForceAlways:
      return true;
    case page::kForceOnChange: {
      const TxIdent& id = tx_idents_[e.ident];
      return !id.sent || id.len != data.size() ||
             !std::equal(data.begin(), data.end(), id.last.begin());
    }
    case page::kForceToggleA:
    case page::kForceToggleB:
      // Once on every change into 3 or into 4; the state before the first page counts as neither.
      return e.last_force != force;
  }
  return false;
}

void PageMode::send(TxEntry& e, TxPort& tx) {
  if (!tx.tx_active()) {
    e.held = true;  // docs/canopen.md: held until release, the latest data goes out then
    return;
  }
  e.held = false;
  TxIdent& id = tx_idents_[e.ident];
  id.sent = true;
  id.len = e.def.length;
  id.last = e.data;
  can::Frame f;
  f.id = e.def.id.id;
  f.extended = e.def.id.extended;
  f.dlc = e.def.length;
  std::copy_n(e.data.begin(), e.def.length, f.data.begin());
  form_swap(std::span(f.data.data(), f.dlc), e.def.form);  // PLC (Motorola) -> CAN (Intel)
  tx.transmit(f);
}

void PageMode::on_data(std::uint16_t n, std::uint8_t seq, std::span<const std::uint8_t> page,
                       TxPort& tx) {
  if (state_ != State::Data)
    return fail(n, seq, Status::NotConfigured, 0,
                "state is " + std::string(to_string(state_)) + "; start again with page 0");
  const std::size_t index = n - page::kDataFirst;
  const auto pages = static_cast<std::uint16_t>(data_pages_);
  if (index >= data_pages_)
    return fail(n, seq, Status::Unexpected, pages,
                "data pages are 251.." + std::to_string(page::kDataFirst + data_pages_ - 1));
  Status status = Status::Ok;
  std::string bad;
  for (const std::uint32_t i : tx_by_page_[index]) {
    TxEntry& e = tx_[i];
    const std::uint8_t force = page[e.place.offset];
    const auto data = page.subspan(e.place.offset + 1u, e.def.length);
    std::copy(data.begin(), data.end(), e.data.begin());
    if (force > page::kForceMax) {
      // Not sent; the rest of the page is processed (status 2 tells the PLC).
      status = Status::BadEntry;
      if (bad.empty())
        bad = "Tx identifier " + can::ident_text(e.def.id) + ": force " + std::to_string(force) +
              " (0..4 allowed, manual table 6.4.7); not sent";
    } else if (send_due(e, force, data)) {
      send(e, tx);
    }
    e.last_force = force;
  }
  const auto& on_page = rx_by_page_[index];
  answer(n, seq, status, static_cast<std::uint16_t>(on_page.size()), pages);
  for (const std::uint32_t i : on_page) {
    const RxEntry& r = rx_[i];
    input_page_[r.place.offset] = r.count;
    std::copy_n(r.data.begin(), r.def.length, input_page_.begin() + r.place.offset + 1);
  }
  // One line per new fault, not one per page (a PLC repeating it would flood the log).
  if (status != Status::Ok && bad != last_data_fault_)
    log_.warn("page " + std::to_string(n) + " (sequence " + std::to_string(seq) + "): status 2 " +
              std::string(page::to_string(status)) + ": " + bad);
  last_data_fault_ = bad;
}

void PageMode::write_input_page(std::span<std::uint8_t> page) const {
  std::copy_n(input_page_.begin(), std::min(page.size(), input_page_.size()), page.begin());
}

bool PageMode::on_frame(const can::Frame& frame, Time) {
  // No remote frames (docs/slots.md "Data exchange in normal mode").
  if (frame.remote || state_ != State::Data) return false;
  const std::uint32_t key = ident_key(frame);
  auto it = std::lower_bound(rx_index_.begin(), rx_index_.end(), std::make_pair(key, 0u));
  if (it == rx_index_.end() || it->first != key) return false;
  RxEntry& r = rx_[it->second];
  // docs/slots.md "Data exchange in normal mode": min(DLC, n) bytes, the rest zero, form swap (CAN
  // Intel -> PLC Motorola).
  const std::size_t n = std::min<std::size_t>(frame.dlc, r.def.length);
  r.data.fill(0);
  std::copy_n(frame.data.begin(), n, r.data.begin());
  form_swap(std::span(r.data.data(), r.def.length), r.def.form);
  ++r.count;  // count_in modulo 256 (manual §6.4.7)
  return true;
}

void PageMode::on_release(Time, TxPort& tx) {
  for (TxEntry& e : tx_)
    if (e.held) send(e, tx);
}

std::vector<can::Ident> PageMode::rx_idents() const {
  std::vector<can::Ident> out;
  if (state_ != State::Data) return out;
  for (const auto& r : rx_)
    if (std::find(out.begin(), out.end(), r.def.id) == out.end()) out.push_back(r.def.id);
  return out;
}

}  // namespace candp2::gw
