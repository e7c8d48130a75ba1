// The CAN buses in time for `candp2 validate` (docs/validate.md "CAN buses").
#include "validate/buses.hpp"

#include <algorithm>
#include <cstdio>

#include "can/frame_bits.hpp"
#include "drive_sim/regid_protocol.hpp"
#include "drive_sim/registers.hpp"
#include "gateway/gateway.hpp"
#include "validate/validate.hpp"

namespace candp2::validate {

std::string_view to_string(BusSource s) {
  switch (s) {
    case BusSource::Outputs:
      return "outputs";
    case BusSource::Cycle:
      return "cycle";
    case BusSource::Sync:
      return "sync";
    case BusSource::Start:
      return "start";
    case BusSource::Rtr:
      return "rtr";
    case BusSource::Reply:
      return "reply";
  }
  return "?";
}

namespace {

using std::chrono::milliseconds;
using std::chrono::nanoseconds;

can::RtaMessage message_of(const can::Frame& f, nanoseconds period, nanoseconds jitter = {}) {
  return {
      .id = can::ident_of(f), .remote = f.remote, .dlc = f.dlc, .period = period, .jitter = jitter};
}

// The longest frame of the message on the wire, whatever its data (docs/validate.md "CAN buses":
// the load counts real frame lengths; a frame without data bits its exact length).
std::uint32_t longest_bits(const can::RtaMessage& m) {
  return can::frame_bits_longest(
      m.remote
          ? can::Frame::rtr(m.id.id, m.id.extended, m.dlc)
          : can::Frame::data_frame(m.id.id, m.id.extended,
                                   std::vector<std::uint8_t>(std::min<std::size_t>(m.dlc, 8))));
}

std::string ms_text(nanoseconds d) {
  char b[32];
  std::snprintf(b, sizeof b, "%.3f ms", static_cast<double>(d.count()) / 1e6);
  return b;
}

// The Rx slot whose identifier a remote frame asks for (the later slot wins, manual §5.2.1).
std::string rx_slot_path(const GatewayReport& g, const can::Ident& id) {
  std::string path = g.input.json_path;
  for (const auto& row : g.slots)
    if (row.slot && row.slot->kind == gw::SlotKind::Rx && row.slot->id == id) path = row.json_path;
  return path;
}

// The messages of one accepted gateway at the bus's bit rate: what its own tables say it sends.
void add_gateway(std::vector<BusMessage>& out, const GatewayReport& g, const BusInput& in) {
  const gw::UserPrm& prm = *g.prm;
  const std::string sender = "gateway " + g.input.name;
  gw::SlotConfig cfg;
  cfg.page_mode = prm.page_mode;
  const nanoseconds master_cycle = milliseconds(in.cycle_ms);
  std::uint64_t burst_bits = 0;  // the frames of one Data_Exchange, worst-case lengths
  for (const auto& row : g.slots) {
    if (!row.slot) continue;
    const gw::Slot& s = *row.slot;
    cfg.slots.push_back(s);
    if (s.kind != gw::SlotKind::Tx || !s.id) continue;  // 0x07F8: nothing is sent
    // docs/slots.md "Sending (Tx slots)": the slot's data bytes, on change (at most once per
    // Data_Exchange, every master cycle when the PLC changes them every cycle) and every `cycle`.
    const std::vector<std::uint8_t> data(s.data_len, 0);
    const can::Frame f = can::Frame::data_frame(s.id->id, s.id->extended, data);
    burst_bits += can::frame_bits_worst(f);
    out.push_back({sender, row.json_path, BusSource::Outputs, message_of(f, master_cycle)});
    if (s.cycle_ms)
      out.push_back(
          {sender, row.json_path, BusSource::Cycle, message_of(f, milliseconds(s.cycle_ms))});
  }
  // manual §5.3.3 command 20 note: a SYNC falling due during a Data_Exchange's frames waits until
  // they are out: released up to one burst late.
  if (g.sync_ms) {
    const can::Frame sync = can::Frame::std_data(0x080, {});
    out.push_back(
        {sender, g.input.json_path, BusSource::Sync,
         message_of(sync, milliseconds(g.sync_ms), can::bits_duration(burst_bits, in.bitrate))});
  }
  if (const auto start = gw::start_frame(prm))
    out.push_back(
        {sender, g.input.json_path, BusSource::Start, message_of(*start, kOncePeriod), true});
  if (gw::sends_rtr_frames(prm, cfg))
    for (const auto& f : gw::rtr_frames(cfg))
      out.push_back({sender, rx_slot_path(g, can::ident_of(f)), BusSource::Rtr,
                     message_of(f, kOncePeriod), true});
}

// A drive answers every command frame on its Rx identifier that its decoder takes (a READ 0x3D
// answers once; writes are not answered, so this is the worst case): one reply of the longest
// kind per command frame.
void add_drive(std::vector<BusMessage>& out, const DriveInput& d) {
  const std::size_t commands = out.size();
  for (std::size_t i = 0; i < commands; ++i) {
    const BusMessage& m = out[i];
    if (m.message.id != can::Ident{d.rx_id, false}) continue;
    std::vector<std::uint8_t> data(m.message.remote ? 0 : m.message.dlc, 0);
    if (!data.empty()) data[0] = drive::reg::kRead;
    const can::Frame cmd = m.message.remote ? can::Frame::rtr(d.rx_id, false, m.message.dlc)
                                            : can::Frame::std_data(d.rx_id, data);
    if (!drive::decode_command(cmd).command) continue;
    const std::uint8_t reply[drive::kReplyDlc32] = {};
    BusMessage r{"drive " + d.name,
                 d.json_path,
                 BusSource::Reply,
                 message_of(can::Frame::std_data(d.tx_id, reply), m.message.period),
                 m.once,
                 i};
    out.push_back(std::move(r));
  }
}

std::string message_name(const BusMessage& m) {
  return "identifier 0x" + can::ident_text(m.message.id) + (m.message.remote ? " (remote)" : "") +
         " (" + m.sender + ", " + std::string(to_string(m.source)) + ")";
}

}  // namespace

BusReport check_bus(const BusInput& in, const std::vector<GatewayReport>& gateways,
                    const std::vector<DriveInput>& drives) {
  BusReport r;
  r.name = in.name;
  r.json_path = in.json_path;
  r.bitrate = in.bitrate;
  r.cycle_ms = in.cycle_ms;
  for (const auto& g : gateways) {
    if (g.input.bus != in.name || !g.valid() || !g.prm) continue;
    const auto rate = gw::bitrate_bps(g.prm->bitrate_index);
    if (rate != in.bitrate) {
      r.problems.push_back({g.input.json_path + ".parameters.can_bitrate",
                            "gateway " + g.input.name + " sends at " +
                                gw::bitrate_text(g.prm->bitrate_index) + ", bus " + in.name +
                                " runs at " + gw::bitrate_text_bps(in.bitrate) +
                                ": its frames are errors on this bus and are not counted"});
      continue;
    }
    add_gateway(r.messages, g, in);
  }
  // docs/can-bus.md "Transmit queues": every node sends from one FIFO queue, so each sender's
  // messages share one (analysed at its lowest priority, docs/can-bus.md "Response times").
  for (const auto& d : drives)
    if (d.bus == in.name) add_drive(r.messages, d);
  std::uint32_t fifo = 0;
  for (std::size_t i = 0; i < r.messages.size(); ++i)
    r.messages[i].message.fifo =
        i > 0 && r.messages[i].sender == r.messages[i - 1].sender ? fifo : ++fifo;

  // A reply is released when its command frame has been received: from the command's earliest
  // end (its length after release) to its latest (its worst response), so its jitter is the
  // difference. Iterated until the jitters settle (Tindell and Clark's holistic analysis).
  std::vector<can::RtaMessage> set;
  for (const auto& m : r.messages) set.push_back(m.message);
  for (int round = 0; round < 16; ++round) {
    r.analysis = can::analyse_response_times(set, in.bitrate);
    bool changed = false;
    for (std::size_t i = 0; i < set.size(); ++i) {
      const auto& cmd = r.messages[i].reply_to;
      if (!cmd) continue;
      const auto& c = r.analysis.messages[*cmd];
      const nanoseconds jitter = c.response ? *c.response - c.transmission : set[i].period;
      changed = changed || jitter != set[i].jitter;
      set[i].jitter = jitter;
    }
    if (!changed) break;
  }
  for (std::size_t i = 0; i < set.size(); ++i) {
    r.messages[i].message = set[i];
    const auto& cmd = r.messages[i].reply_to;
    if (cmd && !r.analysis.messages[*cmd].response) {  // no bound on the command: none here
      r.analysis.messages[i].response.reset();
      r.analysis.messages[i].schedulable = false;
    }
  }

  // The load at the longest frames the messages can send (can::frame_bits_longest): the worst case
  // of real frames, which a bus reaches with data that stuffs the most. The analysis above keeps
  // Davis et al.'s bound, which no real frame reaches (docs/validate.md "CAN buses").
  double load = 0;
  for (std::size_t i = 0; i < r.messages.size(); ++i)
    if (!r.messages[i].once)
      load += static_cast<double>(can::bits_duration(longest_bits(set[i]), in.bitrate).count()) /
              static_cast<double>(set[i].period.count());
  r.load_pct = load * 100.0;

  char pct[32];
  std::snprintf(pct, sizeof pct, "%.1f %%", r.load_pct);
  if (r.load_pct > 100.0)
    r.problems.push_back({in.json_path, "bus " + in.name +
                                            " is overloaded: the predicted load is " + pct +
                                            " of its bit rate (worst-case frame lengths), frames "
                                            "queue without bound"});
  else if (r.load_pct > kBusLoadLimitPct)
    r.problems.push_back(
        {in.json_path, "bus " + in.name + ": the predicted load " + pct +
                           " (worst-case frame lengths) is above the design limit of 80 % "
                           "(docs/validate.md \"CAN buses\")"});
  for (std::size_t i = 0; i < r.messages.size(); ++i) {
    const BusMessage& m = r.messages[i];
    const can::RtaResult& a = r.analysis.messages[i];
    if (m.once || a.schedulable) continue;
    if (a.response)
      r.problems.push_back({m.json_path, message_name(m) + ": the worst-case response " +
                                             ms_text(*a.response) + " is longer than its period " +
                                             ms_text(m.message.period)});
    else
      r.problems.push_back({m.json_path, message_name(m) +
                                             ": no worst-case response: the frames of its "
                                             "priority and higher load the bus to 100 % or more"});
  }
  return r;
}

}  // namespace candp2::validate
