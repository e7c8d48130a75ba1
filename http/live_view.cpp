#include "http/live_view.hpp"

#include <algorithm>

#include "profibus_sim/fdl/line_stats.hpp"

namespace candp2::http {

namespace {

// Slot rows refreshed in one step: a 48-slot gateway takes six steps.
constexpr std::size_t kRowsPerStep = 8;

// `{"a":1,"b":2}` → `"a":1,"b":2`: members of an object to splice into another.
std::string_view members(const std::string& object) {
  if (object.size() < 2) return {};
  return std::string_view(object).substr(1, object.size() - 2);
}

}  // namespace

LiveView::LiveView(StatusModel& model)
    : model_(model),
      tiles_(model.sources().gateways.size()),
      panels_(model.sources().gateways.size()),
      rows_(model.sources().gateways.size()),
      buses_(model.sources().buses.size()),
      traces_(model.sources().buses.size()),
      drives_(model.sources().drives.size()),
      panel_round_(model.sources().gateways.size(), 0),
      slave_tiles_(model.sources().slaves.size()),
      slave_panels_(model.sources().slaves.size()),
      slave_round_(model.sources().slaves.size(), 0) {}

namespace {

// Sorted, without duplicates and indices >= n.
std::vector<std::size_t> index_set(std::vector<std::size_t> v, std::size_t n) {
  std::sort(v.begin(), v.end());
  v.erase(std::unique(v.begin(), v.end()), v.end());
  std::erase_if(v, [&](std::size_t i) { return i >= n; });
  return v;
}

}  // namespace

void LiveView::start_round(Time now, std::vector<std::size_t> open,
                           std::vector<std::size_t> open_slaves) {
  Round r;
  r.number = next_round_++;
  r.started = now;
  open = index_set(std::move(open), tiles_.size());
  r.open_slaves = index_set(std::move(open_slaves), slave_tiles_.size());
  for (const auto g : open)
    if (const auto b = model_.bus_of(g)) r.buses.push_back(*b);
  r.buses = index_set(std::move(r.buses), buses_.size());
  r.open = std::move(open);
  round_ = std::move(r);
}

bool LiveView::in_round(std::size_t gateway) const {
  return round_ && std::binary_search(round_->open.begin(), round_->open.end(), gateway);
}

bool LiveView::slave_in_round(std::size_t slave) const {
  return round_ &&
         std::binary_search(round_->open_slaves.begin(), round_->open_slaves.end(), slave);
}

std::uint64_t LiveView::first_round_for(std::optional<std::size_t> gateway,
                                        std::optional<std::size_t> slave) const {
  if (!round_) return next_round_;
  // The running round serves it if it refreshes its panel (every round refreshes the tiles).
  const bool served = gateway ? in_round(*gateway) : !slave || slave_in_round(*slave);
  return served ? round_->number : round_->number + 1;
}

void LiveView::stage(Piece& p, std::string json) {
  if (p.round != 0 && p.json == json) return;
  round_->changed.emplace_back(&p, std::move(json));
}

bool LiveView::step(Time now) {
  if (!round_) return false;
  Round& r = *round_;
  // Each call refreshes one piece (or a few slot rows); moving on to the next phase is free.
  for (;;) switch (r.phase) {
      case Phase::Header: {
        nlohmann::json h;
        h["time_ms"] = static_cast<double>(now.count()) / 1000.0;
        h["cycle"] = model_.cycle_json();
        if (auto l = model_.line_json(); !l.is_null()) {
          // The page lists a station's counters in the table's order (docs/profibus.md "Line
          // statistics"); the document's objects have their keys sorted.
          if (l.contains("stations"))
            for (const auto& f : fdl::kStationCounters)
              l["counters"].push_back(std::string(f.name));
          h["line"] = std::move(l);
        }
        if (const auto m = model_.modbus_json(); !m.is_null()) h["modbus"] = m;
        h["http"] = model_.http_json();
        h["host_stalls"] = model_.host_stalls_json();
        h["gateway_count"] = tiles_.size();
        if (!slave_tiles_.empty()) h["slave_count"] = slave_tiles_.size();
        r.header = h.dump();
        r.phase = Phase::Tiles;
        return false;
      }
      case Phase::Tiles:
        if (r.index >= tiles_.size()) {
          r.index = 0;
          r.phase = Phase::SlaveTiles;
          continue;
        }
        stage(tiles_[r.index], model_.tile(r.index, now).dump());
        ++r.index;
        return false;
      case Phase::SlaveTiles:
        if (r.index >= slave_tiles_.size()) {
          r.index = 0;
          r.phase = Phase::Panel;
          continue;
        }
        stage(slave_tiles_[r.index], model_.slave_tile(r.index, now).dump());
        ++r.index;
        return false;
      case Phase::Panel: {
        if (r.index >= r.open.size()) {
          r.index = 0;
          r.phase = Phase::SlavePanels;
          continue;
        }
        const std::size_t g = r.open[r.index];
        stage(panels_[g], model_.gateway_head(g, now).dump());
        const std::size_t n = model_.slot_count(g);
        if (rows_[g].size() < n) rows_[g].resize(n);  // new rows are not composed before publish
        r.row_counts.emplace_back(g, n);
        r.row = 0;
        r.phase = Phase::Rows;
        return false;
      }
      case Phase::Rows: {
        const std::size_t g = r.open[r.index];
        const std::size_t n = r.row_counts.back().second;
        if (r.row >= n) {
          ++r.index;
          r.phase = Phase::Panel;
          continue;
        }
        for (std::size_t k = 0; k < kRowsPerStep && r.row < n; ++k, ++r.row)
          stage(rows_[g][r.row], model_.slot_json(g, r.row, now, false).dump());
        return false;
      }
      case Phase::SlavePanels: {
        if (r.index >= r.open_slaves.size()) {
          r.index = 0;
          r.phase = Phase::Bus;
          continue;
        }
        const std::size_t k = r.open_slaves[r.index++];
        stage(slave_panels_[k], model_.slave_json(k, now).dump());
        return false;
      }
      case Phase::Bus: {
        if (r.index >= r.buses.size()) {
          r.phase = Phase::Drives;
          continue;
        }
        const std::size_t b = r.buses[r.index++];
        stage(buses_[b], model_.bus_text(b, now, false));
        // A traced frame never changes: the text of one the last round had is taken from there.
        std::vector<Traced> frames;
        if (const auto* m = model_.sources().buses[b].monitor) {
          const auto& known = traces_[b];
          auto k = known.begin();
          for (const auto& t : m->trace()) {
            while (k != known.end() && k->seq < t.seq) ++k;
            frames.push_back({t.seq, k != known.end() && k->seq == t.seq
                                         ? k->json
                                         : model_.trace_frame(t).dump()});
          }
        }
        r.traces.emplace_back(b, std::move(frames));
        return false;
      }
      case Phase::Drives:
        // Only the drives on a bus of an open panel are shown (their speed plots).
        for (std::size_t d = 0; d < drives_.size(); ++d) {
          const auto& bus = model_.sources().drives[d].cfg->bus;
          for (const auto b : r.buses)
            if (model_.sources().buses[b].cfg->name == bus) {
              stage(drives_[d], model_.drive_json(d).dump());
              break;
            }
        }
        r.phase = Phase::Done;
        return false;
      case Phase::Done:
        publish(now);
        return true;
    }
}

void LiveView::publish(Time now) {
  Round& r = *round_;
  header_ = std::move(r.header);
  for (auto& [piece, json] : r.changed) {
    piece->json = std::move(json);
    piece->round = r.number;
  }
  for (auto& [b, frames] : r.traces) traces_[b] = std::move(frames);
  for (const auto& [g, n] : r.row_counts) {
    if (rows_[g].size() > n) rows_[g].resize(n);
    panel_round_[g] = r.number;
  }
  for (const auto k : r.open_slaves) slave_round_[k] = r.number;
  published_ = r.number;
  published_at_ = now;
  auto& counters = model_.http_counters();
  ++counters.snapshots;
  counters.last_build_us = static_cast<std::uint64_t>((now - r.started).count());
  round_.reset();
}

std::string LiveView::compose(Cursor& c) const {
  const bool full = c.round == 0;
  std::string out = "{\"full\":";
  out += full ? "true" : "false";
  out += ",\"round\":" + std::to_string(published_);
  if (!header_.empty()) {
    out += ',';
    out += members(header_);
  }
  auto list = [&](std::string_view name, auto&& each) {
    out += ",\"";
    out += name;
    out += "\":[";
    bool first = true;
    each([&](const std::string& json) {
      if (!first) out += ',';
      out += json;
      first = false;
    });
    out += ']';
  };
  auto changed = [&](const Piece& p) { return p.round > c.round && !p.json.empty(); };
  list("gateways", [&](auto emit) {
    for (const auto& t : tiles_)
      if (changed(t)) emit(t.json);
  });
  if (!slave_tiles_.empty())
    list("slaves", [&](auto emit) {
      for (const auto& t : slave_tiles_)
        if (changed(t)) emit(t.json);
    });
  if (c.slave && *c.slave < slave_panels_.size() && slave_round_[*c.slave]) {
    out += ",\"open_slave\":" + std::to_string(model_.sources().slaves[*c.slave].cfg->address);
    if (changed(slave_panels_[*c.slave])) {
      out += ",\"slave\":";
      out += slave_panels_[*c.slave].json;
    }
  }
  const std::optional<std::size_t> g =
      c.gateway && *c.gateway < panels_.size() && panel_round_[*c.gateway] ? c.gateway
                                                                           : std::nullopt;
  if (g) {
    out += ",\"open\":" + std::to_string(model_.sources().gateways[*g].cfg->dp_address());
    if (changed(panels_[*g])) {
      out += ",\"panel\":";
      out += panels_[*g].json;
    }
    list("slots", [&](auto emit) {
      for (const auto& row : rows_[*g])
        if (changed(row)) emit(row.json);
    });
    const auto bus = model_.bus_of(*g);
    list("buses", [&](auto emit) {
      if (bus && changed(buses_[*bus])) emit(buses_[*bus].json);
    });
    std::uint64_t seq = c.trace_seq;
    list("trace", [&](auto emit) {
      if (!bus) return;
      for (const auto& f : traces_[*bus])
        if (f.seq > c.trace_seq) {
          emit(f.json);
          seq = std::max(seq, f.seq);
        }
    });
    c.trace_seq = seq;
    list("drives", [&](auto emit) {
      if (!bus) return;
      const auto& name = model_.sources().buses[*bus].cfg->name;
      for (std::size_t d = 0; d < drives_.size(); ++d)
        if (model_.sources().drives[d].cfg->bus == name && changed(drives_[d]))
          emit(drives_[d].json);
    });
  }
  out += '}';
  c.round = published_;
  return out;
}

}  // namespace candp2::http
