#include "plc/page_driver.hpp"

#include <algorithm>
#include <tuple>

#include "common/hex.hpp"

namespace candp2::plc {

// ---------------------------------------------------------------- data blocks

std::optional<std::vector<page::RawEntry>> parse_config_chain(const DbChain& chain,
                                                              std::string* why) {
  std::vector<page::RawEntry> out;
  auto bad = [&](std::string text) -> std::optional<std::vector<page::RawEntry>> {
    if (why) *why = std::move(text);
    return std::nullopt;
  };
  for (std::size_t d = 0; d < chain.size(); ++d) {
    const DataBlock& db = chain[d];
    std::size_t pos = 0;
    while (true) {
      if (pos + page::kMarkerLen > db.size())
        return bad("DB " + std::to_string(d + 1) + " ends at byte " + std::to_string(pos) +
                   " without DD DD DD DD or EE EE EE EE (manual table 6.5.2 \"endekonfig\")");
      const auto m = page::marker_at(std::span(db).subspan(pos, page::kMarkerLen));
      if (m == page::Marker::End) return out;
      if (m == page::Marker::More) {
        if (d + 1 == chain.size())
          return bad("DB " + std::to_string(d + 1) + " ends with DD DD DD DD but no DB follows");
        break;
      }
      if (pos + page::kEntryLen > db.size())
        return bad("DB " + std::to_string(d + 1) + ": entry at byte " + std::to_string(pos) +
                   " is cut off");
      page::RawEntry e;
      std::copy_n(db.begin() + static_cast<std::ptrdiff_t>(pos), page::kEntryLen, e.begin());
      out.push_back(e);
      pos += page::kEntryLen;
    }
  }
  return bad(chain.empty() ? "no data block" : "no EE EE EE EE end marker");
}

std::optional<std::vector<DbPos>> locate_data_entries(const DbChain& chain,
                                                      std::span<const IdEntry> ids,
                                                      std::string* why) {
  std::vector<DbPos> out;
  out.reserve(ids.size());
  auto bad = [&](std::string text) -> std::optional<std::vector<DbPos>> {
    if (why) *why = std::move(text);
    return std::nullopt;
  };
  std::size_t d = 0, pos = 0;
  // Follows DD markers to the next DB; false when the chain ends.
  auto next_byte = [&]() -> bool {
    while (d < chain.size()) {
      if (pos < chain[d].size() && chain[d][pos] != page::kMarkerMore) return true;
      if (pos >= chain[d].size()) return false;  // a DB must end with DD or EE
      ++d;                                       // DD: continue with the next DB
      pos = 0;
    }
    return false;
  };
  for (std::size_t i = 0; i < ids.size(); ++i) {
    const std::string what = "identifier " + std::to_string(i + 1);
    if (!next_byte()) return bad(what + ": data blocks end before it (no DD/EE where expected)");
    const std::uint8_t laenge = chain[d][pos];
    if (laenge == page::kMarkerEnd) return bad(what + ": EE end marker before it");
    if (laenge != ids[i].length + 1u)
      return bad(what + " (DB " + std::to_string(d + 1) + " byte " + std::to_string(pos) +
                 "): länge " + std::to_string(laenge) + ", the configuration says " +
                 std::to_string(ids[i].length) + " data bytes + 1");
    if (pos + 2u + ids[i].length > chain[d].size())
      return bad(what + ": cut off at the end of DB " + std::to_string(d + 1));
    out.push_back({d, pos});
    pos += 2u + ids[i].length;
  }
  if (!next_byte() || chain[d][pos] != page::kMarkerEnd)
    return bad("no EE after the last identifier (manual table 6.5.4 \"endedata\")");
  return out;
}

namespace {

// Splits `ids` into data blocks of at most `per_db` entries (0 = one block); `entry` appends one
// identifier's bytes, `marker` closes a block (last = no further block follows).
template <typename Entry, typename Marker>
DbChain split_chain(std::span<const IdEntry> ids, std::size_t per_db, Entry entry, Marker marker) {
  DbChain chain;
  std::size_t i = 0;
  do {
    DataBlock db;
    const std::size_t n = per_db == 0 ? ids.size() : std::min(per_db, ids.size() - i);
    for (std::size_t k = 0; k < n; ++k, ++i) entry(db, ids[i]);
    marker(db, i == ids.size());
    chain.push_back(std::move(db));
  } while (i < ids.size());
  return chain;
}

}  // namespace

DbChain make_config_chain(std::span<const IdEntry> ids, std::size_t per_db) {
  return split_chain(
      ids, per_db,
      [](DataBlock& db, const IdEntry& id) {
        const auto e = page::encode_entry(id);
        db.insert(db.end(), e.begin(), e.end());
      },
      [](DataBlock& db, bool last) {
        db.insert(db.end(), page::kMarkerLen, last ? page::kMarkerEnd : page::kMarkerMore);
      });
}

DbChain make_data_chain(std::span<const IdEntry> ids, std::size_t per_db) {
  return split_chain(
      ids, per_db,
      [](DataBlock& db, const IdEntry& id) {
        db.push_back(static_cast<std::uint8_t>(id.length + 1));  // länge = data bytes + 1
        db.push_back(0);                                         // force / count_in
        db.insert(db.end(), id.length, 0);
      },
      [](DataBlock& db, bool last) { db.push_back(last ? page::kMarkerEnd : page::kMarkerMore); });
}

// ---------------------------------------------------------------- driver

std::string_view to_string(PageDriver::State s) {
  switch (s) {
    case PageDriver::State::Init:
      return "page 0";
    case PageDriver::State::InitWait:
      return "waiting for page 1";
    case PageDriver::State::Ready:
      return "initialized";
    case PageDriver::State::TxSend:
      return "Tx configuration (send)";
    case PageDriver::State::TxWait:
      return "Tx configuration (answer)";
    case PageDriver::State::RxSend:
      return "Rx configuration (send)";
    case PageDriver::State::RxWait:
      return "Rx configuration (answer)";
    case PageDriver::State::DataSend:
      return "data (send)";
    case PageDriver::State::DataWait:
      return "data (answer)";
    case PageDriver::State::Error:
      return "error";
  }
  return "?";
}

PageDriver::PageDriver(PageDriverOptions options, LogSink* log)
    : options_(options), log_(log, "page-driver") {}

RetValue PageDriver::ret_value() const {
  // manual table 6.5.7: 0 while FREIGABE = 0; else the page type in progress.
  if (!freigabe_) return RetValue::None;
  switch (state_) {
    case State::TxSend:
    case State::TxWait:
      return RetValue::TxConfig;
    case State::RxSend:
    case State::RxWait:
      return RetValue::RxConfig;
    case State::DataSend:
    case State::DataWait:
      return RetValue::Data;
    default:
      return RetValue::None;
  }
}

void PageDriver::go(State next, std::string_view why) {
  if (next == state_) return;
  // Send/answer alternation in the data phase is logged at debug level only.
  const bool routine = (state_ == State::DataSend && next == State::DataWait) ||
                       (state_ == State::DataWait && next == State::DataSend) ||
                       (state_ == State::TxSend && next == State::TxWait) ||
                       (state_ == State::TxWait && next == State::TxSend) ||
                       (state_ == State::RxSend && next == State::RxWait) ||
                       (state_ == State::RxWait && next == State::RxSend);
  log_.log(routine ? LogLevel::Debug : LogLevel::Info, std::string(to_string(state_)) + " -> " +
                                                           std::string(to_string(next)) + " (" +
                                                           std::string(why) + ")");
  state_ = next;
}

void PageDriver::restart(std::string_view why) {
  go(State::Init, why);
}

void PageDriver::error(Time now, const std::string& why) {
  if (why != last_error_) log_.error(why);
  last_error_ = why;
  retry_at_ = now + options_.retry_delay;
  go(State::Error,
     "retry with page 0 in " + std::to_string(options_.retry_delay.count() / 1000) + " ms");
}

std::span<std::uint8_t> PageDriver::out_page(dp::ProcessImage& image) {
  return std::span(image.outputs).subspan(options_.write_address, options_.output_page_len);
}

std::span<const std::uint8_t> PageDriver::in_page(const dp::ProcessImage& image,
                                                  std::size_t len) const {
  return std::span(image.inputs).subspan(options_.read_address, len);
}

void PageDriver::write_page(dp::ProcessImage& image, std::uint16_t number, Time now) {
  auto p = out_page(image);
  page::put_page_number(out_, p, number);
  // docs/page-mode.md "Header bytes": a new sequence number for every page; bytes 3-7 zero.
  p[page::kSeqByte] = ++seq_;
  std::fill_n(p.begin() + page::kStatusByte, page::kHeaderLen - page::kStatusByte, 0);
  page_ = number;
  sent_at_ = now;
}

std::optional<PageDriver::Answer> PageDriver::answered(const dp::ProcessImage& image,
                                                       std::uint16_t number) {
  // Before page 1 only the header of the first input segment is known.
  const std::size_t len = in_.empty() ? page::kInitCommWindow + 1 : in_.size();
  const auto p = in_page(image, len);
  const std::optional<std::uint16_t> got =
      in_.empty() ? std::optional<std::uint16_t>(page::get_be16(p, 0)) : page::page_number(in_, p);
  if (!got || *got != number || p[page::kSeqByte] != seq_) return std::nullopt;
  return Answer{p[page::kStatusByte], page::get_be16(p, page::kWord4),
                page::get_be16(p, page::kWord6)};
}

bool PageDriver::check_status(const Answer& a, Time now) {
  if (a.status == static_cast<std::uint8_t>(page::Status::Ok)) return true;
  const auto status = static_cast<page::Status>(a.status);
  const std::string text = "gateway answered page " + std::to_string(page_) + " with status " +
                           std::to_string(a.status) + " (" + std::string(page::to_string(status)) +
                           ")";
  if (status == page::Status::NotConfigured) {
    // The gateway lost its configuration (power cycle, new Chk_Cfg): configure it again.
    log_.warn(text + "; starting again with page 0");
    restart("gateway not configured");
  } else {
    error(now, text);
  }
  return false;
}

void PageDriver::scan(dp::ProcessImage& image, Time now) {
  ++scans_;
  if (options_.output_page_len < page::kHeaderLen ||
      options_.write_address + options_.output_page_len > dp::kImageSize ||
      options_.read_address + page::kSegmentLen > dp::kImageSize) {
    if (state_ != State::Error)
      error(now, "WRITE_ADDRESS/READ_ADDRESS or the output page length do not fit the " +
                     std::to_string(dp::kImageSize) + "-byte process image");
    return;
  }
  // FREIGABE = 0 means initialization only (manual §6.5.1).
  if (!freigabe_ && state_ != State::Init && state_ != State::InitWait && state_ != State::Ready &&
      state_ != State::Error)
    restart("FREIGABE = 0");
  const bool waiting = state_ == State::InitWait || state_ == State::TxWait ||
                       state_ == State::RxWait || state_ == State::DataWait;
  if (waiting && now - sent_at_ >= options_.ack_timeout) {
    log_.warn("no answer to page " + std::to_string(page_) + " (sequence " + std::to_string(seq_) +
              ") within " + std::to_string(options_.ack_timeout.count() / 1000) +
              " ms; starting again");
    restart("acknowledge timeout");
  }
  switch (state_) {
    case State::Error:
      if (now < retry_at_) return;
      restart("retry");
      [[fallthrough]];
    case State::Init: {
      // Page 0 over the whole output page (every segment must carry page 0,
      // docs/page-mode.md "Header bytes"); the segment layout is not known before page 1, so all of
      // it is zeroed first.
      auto p = out_page(image);
      std::fill(p.begin(), p.end(), 0);
      out_ = page::Layout({options_.output_page_len});  // page number at byte 0 only
      in_ = page::Layout();
      write_page(image, page::kInitRequest, now);
      ++restarts_;
      go(State::InitWait, "page 0 sent");
      return;
    }
    case State::InitWait:
      if (auto a = answered(image, page::kInitAnswer)) {
        if (check_status(*a, now)) on_init_answer(image, now);
      }
      return;
    case State::Ready:
      if (!freigabe_ || now < ready_at_) return;
      if (!load_configuration(now)) return;
      go(State::TxSend, "FREIGABE = 1");
      send_config(image, now, true);
      return;
    case State::TxSend:
      send_config(image, now, true);
      return;
    case State::RxSend:
      send_config(image, now, false);
      return;
    case State::TxWait:
    case State::RxWait:
      if (auto a = answered(image, page_)) {
        if (check_status(*a, now)) on_config_answer(*a, now, state_ == State::TxWait);
      }
      return;
    case State::DataSend:
      send_data(image, now);
      return;
    case State::DataWait:
      if (auto a = answered(image, page_)) {
        if (check_status(*a, now)) on_data_answer(image, *a, now);
      }
      return;
  }
}

void PageDriver::on_init_answer(const dp::ProcessImage& image, Time now) {
  const auto p = in_page(image, page::kInitCommWindow + 1);
  const std::size_t out_len = page::get_be16(p, page::kWord4);
  const std::size_t in_len = page::get_be16(p, page::kWord6);
  const std::size_t out_segs = p[page::kInitOutSegments];
  const std::size_t in_segs = p[page::kInitInSegments];
  auto out = page::Layout::from_sizes(out_len, out_segs);
  auto in = page::Layout::from_sizes(in_len, in_segs);
  if (!out || !in || !out->has_header() || !in->has_header())
    return error(now, "page 1 reports an impossible layout: output " + std::to_string(out_len) +
                          " bytes / " + std::to_string(out_segs) + " segments, input " +
                          std::to_string(in_len) + " / " + std::to_string(in_segs));
  if (out_len != options_.output_page_len)
    return error(now, "page 1: the gateway's output page is " + std::to_string(out_len) +
                          " bytes, the driver writes " + std::to_string(options_.output_page_len) +
                          " bytes from WRITE_ADDRESS " + std::to_string(options_.write_address));
  if (options_.read_address + in_len > dp::kImageSize)
    return error(now, "page 1: the input page (" + std::to_string(in_len) +
                          " bytes) does not fit the process image at READ_ADDRESS");
  out_ = std::move(*out);
  in_ = std::move(*in);
  ready_at_ = now + options_.init_delay;
  log_.info("page 1: output page " + std::to_string(out_len) + " bytes in " +
            std::to_string(out_segs) + " segments, input page " + std::to_string(in_len) +
            " bytes in " + std::to_string(in_segs) + " segments" +
            (p[page::kInitCommWindow] ? ", Communication Window" : ""));
  go(State::Ready, "page 1 received");
}

bool PageDriver::load_configuration(Time now) {
  std::string why;
  auto tx = parse_config_chain(write_config_, &why);
  if (!tx) {
    error(now, "WRITE_CONFIG_DB: " + why);
    return false;
  }
  auto rx = parse_config_chain(read_config_, &why);
  if (!rx) {
    error(now, "READ_CONFIG_DB: " + why);
    return false;
  }
  tx_raw_ = std::move(*tx);
  rx_raw_ = std::move(*rx);
  cursor_ = 0;
  return true;
}

void PageDriver::send_config(dp::ProcessImage& image, Time now, bool tx) {
  const auto& raw = tx ? tx_raw_ : rx_raw_;
  const std::uint16_t first = tx ? page::kTxConfigFirst : page::kRxConfigFirst;
  // Pages in order: the number follows from how many pages went before.
  const std::uint16_t number = cursor_ == 0 ? first : static_cast<std::uint16_t>(page_ + 1);
  auto p = out_page(image);
  pending_ = page::encode_config_page(out_, std::span(raw).subspan(cursor_), p);
  pending_last_ = cursor_ + pending_ == raw.size();
  if (pending_ == 0 && !pending_last_)
    return error(now, std::string(tx ? "Tx" : "Rx") +
                          " configuration: the output page cannot hold one identifier entry "
                          "and the end marker");
  write_page(image, number, now);
  go(tx ? State::TxWait : State::RxWait, "page " + std::to_string(number) + " sent");
}

void PageDriver::on_config_answer(const Answer& a, Time now, bool tx) {
  cursor_ += pending_;
  if (a.w6 != cursor_)
    return error(now, "page " + std::to_string(page_) + ": the gateway counts " +
                          std::to_string(a.w6) + " identifiers, the driver sent " +
                          std::to_string(cursor_));
  if (!pending_last_) {
    go(tx ? State::TxSend : State::RxSend, "page " + std::to_string(page_) + " acknowledged");
    return;
  }
  log_.info(std::string(tx ? "Tx" : "Rx") + " configuration complete: " + std::to_string(cursor_) +
            " identifiers");
  cursor_ = 0;
  if (tx) {
    go(State::RxSend, "Tx configuration complete");
    return;
  }
  if (start_data(now)) go(State::DataSend, "Rx configuration complete");
}

bool PageDriver::start_data(Time now) {
  tx_.clear();
  rx_.clear();
  for (auto* list : {&tx_raw_, &rx_raw_}) {
    for (const auto& raw : *list) {
      std::string why;
      auto e = page::decode_entry(raw, &why);
      if (!e) {
        error(now, "configuration entry " + hex_bytes(raw) + ": " + why);
        return false;
      }
      (list == &tx_raw_ ? tx_ : rx_).push_back(*e);
    }
  }
  tx_places_ = page::pack_data(out_, tx_);
  rx_places_ = page::pack_data(in_, rx_);
  data_pages_ =
      std::max<std::size_t>({1, page::pages_used(tx_places_), page::pages_used(rx_places_)});
  std::string why;
  for (auto [chain, ids, name] :
       {std::tuple{&write_db_, &tx_, "WRITE_DB"}, std::tuple{&read_db_, &rx_, "READ_DB"}}) {
    if (!locate_data_entries(*chain, *ids, &why)) {
      error(now, std::string(name) + ": " + why);
      return false;
    }
  }
  data_index_ = 0;
  log_.info("data exchange: " + std::to_string(tx_.size()) + " Tx / " + std::to_string(rx_.size()) +
            " Rx identifiers on " + std::to_string(data_pages_) + " page(s)");
  return true;
}

void PageDriver::send_data(dp::ProcessImage& image, Time now) {
  std::string why;
  const auto pos = locate_data_entries(write_db_, tx_, &why);
  if (!pos) return error(now, "WRITE_DB: " + why);
  auto p = out_page(image);
  for (const auto& r : out_.regions())
    std::fill_n(p.begin() + static_cast<std::ptrdiff_t>(r.offset), r.length, 0);
  for (std::size_t i = 0; i < tx_.size(); ++i) {
    if (tx_places_[i].page != data_index_) continue;
    // WRITE_DB: länge, force, data (manual table 6.5.4) -> page: force, data (table 6.4.6).
    const auto& db = write_db_[(*pos)[i].db];
    const auto from = db.begin() + static_cast<std::ptrdiff_t>((*pos)[i].offset + 1);
    std::copy(from, from + 1 + tx_[i].length, p.begin() + tx_places_[i].offset);
  }
  write_page(image, static_cast<std::uint16_t>(page::kDataFirst + data_index_), now);
  go(State::DataWait, "page " + std::to_string(page_) + " sent");
}

void PageDriver::on_data_answer(const dp::ProcessImage& image, const Answer& a, Time now) {
  if (a.w6 != data_pages_)
    return error(now, "page " + std::to_string(page_) + ": the gateway has " +
                          std::to_string(a.w6) + " data pages, the driver " +
                          std::to_string(data_pages_));
  std::string why;
  const auto pos = locate_data_entries(read_db_, rx_, &why);
  if (!pos) return error(now, "READ_DB: " + why);
  const auto p = in_page(image, in_.size());
  for (std::size_t i = 0; i < rx_.size(); ++i) {
    if (rx_places_[i].page != data_index_) continue;
    // page: count_in, data (table 6.4.8) -> READ_DB: länge, count_in, data (table 6.5.6).
    auto& db = read_db_[(*pos)[i].db];
    const auto from = p.begin() + rx_places_[i].offset;
    std::copy(from, from + 1 + rx_[i].length,
              db.begin() + static_cast<std::ptrdiff_t>((*pos)[i].offset + 1));
  }
  if (++data_index_ == data_pages_) {
    data_index_ = 0;
    ++rotations_;
  }
  go(State::DataSend, "page " + std::to_string(page_) + " acknowledged");
}

}  // namespace candp2::plc
