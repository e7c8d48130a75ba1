// candp2 sniff PORT|FILE: FDL/DP telegrams of a PROFIBUS line, one readable line each, like
// can-utils' candump for CAN (docs/profibus.md). FILE is a raw capture (bytes exactly as
// on the wire; the line shows the byte offset of each telegram); PORT is a serial device or
// "pty:PATH" opened 8E1 at --baud (the line shows seconds since the first byte). On top of the
// generic DP decoding (profibus_sim/fdl/fdl_describe.hpp) the CAN-DP/2 payloads are decoded with
// the gateway's own decoders: Set_Prm user parameters (docs/dp-slave.md "User parameters"), Chk_Cfg
// slots with their comment bytes (docs/slots.md "Chk_Cfg slots") and the extended diagnosis bytes
// (docs/dp-slave.md "Diagnosis"). FILE may also be a pcapng capture (candp2d's, docs/capture.md):
// its PROFIBUS telegrams with their time stamps. --stats prints what an analyser counts
// (fdl::LineStatistics) instead of the telegrams. Exit status: 0 at end of file / after --count
// telegrams / on SIGINT, 2 when the source cannot be opened or read.
#include <poll.h>
#include <signal.h>
#include <sys/stat.h>

#include <array>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <iterator>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <variant>
#include <vector>

#include "capture/pcapng_read.hpp"
#include "capture/pcapng_tap.hpp"
#include "common/hex.hpp"
#include "common/line_physics.hpp"
#include "config/capture_config.hpp"
#include "gateway/slot_config.hpp"
#include "gateway/user_prm.hpp"
#include "profibus_sim/fdl/fdl.hpp"
#include "profibus_sim/fdl/fdl_describe.hpp"
#include "serial/serial_port.hpp"
#include "tools/candp2/commands.hpp"
#include "tools/candp2/sniff_stats.hpp"

namespace candp2::cli {

namespace {

struct SniffArgs {
  std::string source;
  std::uint32_t baud = 19200;
  bool errors = false;
  bool hex = false;
  bool generic = false;
  std::uint64_t count = 0;   // 0 = unlimited
  std::string pcapng;        // also write a pcapng capture (docs/capture.md)
  bool profibus_dl = false;  // ... with LINKTYPE_PROFIBUS_DL instead of exported PDUs
  bool stats = false;        // the line statistics instead of the telegrams (docs/sniff.md)
  bool json = false;         // ... as JSON
};

std::string hex2(std::uint8_t b) {
  return hex_bytes(std::array{b});
}

// docs/dp-slave.md "User parameters" user parameters, through gw::decode_user_prm.
std::string describe_user_prm(const gw::UserPrm& p) {
  std::string s =
      "CAN " + gw::bitrate_text(p.bitrate_index) + ", ModuleID " + std::to_string(p.module_id);
  auto flag = [&](bool on, const char* name) {
    if (on) s += std::string(", ") + name;
  };
  flag(p.comm_window, "Communication-Window");
  flag(p.page_mode, "Page-Mode");
  flag(p.canopen_slave, "CANopen-Slave");
  flag(p.canopen_master, "CANopen-Master");
  flag(p.start_frame, "Start-Frame");
  flag(!p.send_rtr, "no RTR");
  flag(p.can_diagnosis, "CAN-Diagnosis");
  flag(p.rx_counter, "Rx-Counter");
  flag(p.tx_counter, "Tx-Counter");
  s += ", wake-up " +
       (p.wakeup_s == gw::kWakeupKeep ? std::string("keep") : std::to_string(p.wakeup_s) + " s");
  s += ", SYNC " +
       (p.sync_ms == gw::kSyncKeep ? std::string("keep") : std::to_string(p.sync_ms) + " ms");
  return s;
}

// docs/slots.md "Chk_Cfg slots" slots, through gw::decode_slots.
std::string describe_slots(const gw::SlotConfig& c) {
  std::string s;
  for (const auto& slot : c.slots) {
    if (!s.empty()) s += "; ";
    s += "slot" + std::to_string(slot.index) + " " + std::string(gw::to_string(slot.kind));
    if (slot.id)
      s += " " + can::ident_text(*slot.id);
    else if (slot.kind == gw::SlotKind::Tx)
      s += " dummy";
    s += " " + std::to_string(slot.length) + "B";
    if (slot.counter) s += " +counter";
    if (slot.kind == gw::SlotKind::Rx || slot.kind == gw::SlotKind::Tx)
      s += " form " + hex2(slot.form);
    if (slot.cycle_ms && slot.kind == gw::SlotKind::Tx)
      s += " cycle " + std::to_string(slot.cycle_ms) + " ms";
    if (slot.cw_sync_ms) s += " SYNC " + std::to_string(slot.cw_sync_ms) + " ms";
    s += " @" + std::string(slot.is_input() ? "I" : "Q") + std::to_string(slot.offset);
  }
  return s.empty() ? "no slots" : s;
}

// The CAN-DP/2 layer of the sniffer: remembers each station's user parameters (the slots depend
// on Page-Mode, counters and the Communication Window flag).
class CanDp2Decoder {
 public:
  std::string decode(const fdl::Telegram& t, const fdl::Description& d) {
    const bool req = d.request;
    const std::uint8_t station = req ? t.da : t.sa;
    switch (d.service) {
      case fdl::Service::SetPrm: {
        if (!req || t.du.size() < dp::kPrmStdLen) return {};
        const auto std_part = dp::decode_prm_std(t.du);
        if (!std_part || std_part->ident_number != gw::kIdentNumber) {
          foreign_[station] = true;
          return {};
        }
        foreign_[station] = false;
        auto r = gw::decode_user_prm(t.du);
        if (auto* fault = std::get_if<dp::PrmFault>(&r))
          return "Prm fault: byte " + std::to_string(fault->byte) + ", correct value " +
                 hex2(fault->correct);
        prm_[station] = std::get<gw::UserPrm>(r);
        return describe_user_prm(prm_[station]);
      }
      case fdl::Service::ChkCfg:
      case fdl::Service::GetCfg: {
        if (req != (d.service == fdl::Service::ChkCfg) || t.du.empty() || foreign_[station])
          return {};
        auto it = prm_.find(station);
        const gw::UserPrm prm = it == prm_.end() ? gw::UserPrm{} : it->second;
        auto r = gw::decode_slots(t.du, prm);
        if (auto* fault = std::get_if<dp::CfgFault>(&r))
          return "Cfg fault: slot " + std::to_string(fault->slot) + ", code " +
                 std::to_string(fault->code) + " (" + std::string(gw::cfg_code_text(fault->code)) +
                 ")";
        return describe_slots(std::get<gw::SlotConfig>(r));
      }
      case fdl::Service::SlaveDiag: {
        if (req || t.du.size() < 11 || foreign_[station]) return {};
        if (t.du[4] != (gw::kIdentNumber >> 8) || t.du[5] != (gw::kIdentNumber & 0xFF)) return {};
        // docs/dp-slave.md "Diagnosis" bytes 8..10.
        const auto b = std::span(t.du).subspan(8, 3);
        if (b[0] == dp::kExtDiagPrmSap)
          return "Prm fault: byte " + std::to_string(b[1]) + ", correct value " + hex2(b[2]);
        if (b[0] == dp::kExtDiagCfgSap)
          return "Cfg fault: slot " + std::to_string(b[1]) + ", code " + std::to_string(b[2]) +
                 " (" + std::string(gw::cfg_code_text(b[2])) + ")";
        if (!(t.du[0] & dp::kDiag1ExtDiag)) return {};
        static constexpr const char* kBus[] = {"OK", "WARN", "ERROR_PASSIVE", "BUS_OFF"};
        return std::string("CAN bus ") + kBus[(b[0] >> 6) & 3] + ", IRQ_LOST " +
               std::to_string(b[1]) + ", MSG_LOST " + std::to_string(b[2]);
      }
      default:
        return {};
    }
  }

 private:
  std::map<std::uint8_t, gw::UserPrm> prm_;
  std::map<std::uint8_t, bool> foreign_;  // station's Set_Prm carried another Ident_Number
};

class Sniffer {
 public:
  // `capture`: also write every telegram (and abandoned candidate, with the parser's error as a
  // comment) to it, at the time `time_of` gives for the event. `observe`: the events go to it
  // instead of being printed (--stats).
  Sniffer(const SniffArgs& a, capture::PcapngTap* capture = nullptr,
          std::function<Time(const fdl::ParserEvent&)> time_of = {},
          std::function<void(const fdl::ParserEvent&)> observe = {})
      : args_(a), capture_(capture), time_of_(std::move(time_of)), observe_(std::move(observe)) {}

  // Prints the parser's pending events; `stamp` prefixes each line. False once --count is reached.
  bool print_events(fdl::StreamParser& p, const std::string* stamp) {
    while (auto ev = p.next()) {
      std::string line = stamp ? *stamp : offset_stamp(ev->offset);
      if (capture_)
        capture_->write_dp(time_of_(*ev), 0, args_.source, ev->raw, false,
                           ev->error == fdl::Error::None
                               ? std::string()
                               : "candp2 sniff: " + std::string(fdl::to_string(ev->error)));
      if (observe_) {
        observe_(*ev);
        if (ev->error == fdl::Error::None && args_.count && ++printed_ >= args_.count) return false;
        continue;
      }
      if (ev->error != fdl::Error::None) {
        if (!args_.errors) continue;
        line += " ERROR " + std::string(fdl::to_string(ev->error)) + ": " + hex_bytes(ev->raw);
        std::cout << line << "\n";
        continue;
      }
      if (args_.hex) line += " " + hex_bytes(ev->raw) + " |";
      const auto d = describer_.describe(ev->telegram);
      line += " " + d.text;
      if (!args_.generic) {
        const auto extra = candp2_.decode(ev->telegram, d);
        if (!extra.empty()) line += " | CAN-DP/2: " + extra;
      }
      std::cout << line << "\n";
      if (args_.count && ++printed_ >= args_.count) return false;
    }
    std::cout.flush();
    return true;
  }

 private:
  static std::string offset_stamp(std::uint64_t offset) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "@%06llu", static_cast<unsigned long long>(offset));
    return buf;
  }

  const SniffArgs& args_;
  capture::PcapngTap* capture_;
  std::function<Time(const fdl::ParserEvent&)> time_of_;
  std::function<void(const fdl::ParserEvent&)> observe_;
  fdl::Describer describer_;
  CanDp2Decoder candp2_;
  std::uint64_t printed_ = 0;
};

void print_stats(const fdl::ParserStats& s) {
  std::cout.flush();
  std::cerr << "candp2 sniff: " << s.telegrams << " telegrams, " << s.bytes << " bytes, "
            << s.fcs_errors << " FCS errors, " << s.framing_errors << " framing errors, "
            << s.parity_errors << " parity errors, " << s.garbage_bytes << " garbage bytes\n";
}

// --stats (docs/sniff.md "Line statistics: --stats"): the statistics of the telegrams read and
// their output. `times`: the source gives times (a port, a pcapng capture; not a raw file).
struct StatsOut {
  const SniffArgs& args;
  bool times;
  fdl::LineStatistics stats;
  // A parser's event: a telegram, or an abandoned candidate as an illegal telegram.
  void event(const fdl::ParserEvent& ev, Time t) {
    if (ev.error == fdl::Error::None)
      stats.observe(ev.raw, t);
    else
      stats.observe_illegal(t);
  }
  // `stamp`: a heading line for a table printed during the run.
  void print(const std::string* stamp = nullptr) const {
    if (args.json) {
      std::cout << stats_json(stats, times) << "\n";
    } else {
      if (stamp) std::cout << *stamp << "\n";
      std::cout << stats_table(stats, times);
    }
    std::cout.flush();
  }
};

std::string seconds_stamp(Duration d) {
  char stamp[40];
  std::snprintf(stamp, sizeof stamp, "(%.6f)", std::chrono::duration<double>(d).count());
  return stamp;
}

// Warnings and errors of the capture on stderr ("candp2 sniff: pcapng capture stopped: ...").
class StderrLog final : public LogSink {
 public:
  bool enabled(LogLevel level) const override { return level >= LogLevel::Warn; }
  void write(LogLevel, std::string_view, std::string_view message) override {
    std::cout.flush();
    std::cerr << "candp2 sniff: " << message << "\n";
  }
};
StderrLog g_log;

// The --pcapng capture (docs/capture.md): one file; `wall_offset` turns the sniffer's times
// (microseconds from its start) into wall-clock time.
std::unique_ptr<capture::PcapngTap> open_capture(const SniffArgs& a, Duration wall_offset) {
  if (a.pcapng.empty()) return nullptr;
  capture::PcapngTapOptions o;
  o.writer.path = a.pcapng;
  o.writer.application = "candp2 sniff";
  o.profibus = a.profibus_dl ? capture::ProfibusLinktype::ProfibusDl
                             : capture::ProfibusLinktype::WiresharkUpperPdu;
  o.wall_offset = wall_offset;
  return std::make_unique<capture::PcapngTap>(o, &g_log);
}

// A capture's modification time as microseconds since the Unix epoch (0 when unknown).
Duration file_mtime(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) return Duration(0);
  return seconds(st.st_mtim.tv_sec) + microseconds(st.st_mtim.tv_nsec / 1000);
}

int sniff_file(const SniffArgs& a, capture::PcapngTap* capture) {
  std::ifstream in(a.source, std::ios::binary);
  if (!in) {
    std::cerr << "candp2 sniff: " << a.source << ": cannot open: " << std::strerror(errno) << "\n";
    return 2;
  }
  fdl::StreamParser parser;
  // A raw file has no times: the statistics' token rotation is unknown.
  std::optional<StatsOut> st;
  if (a.stats) st.emplace(StatsOut{a, false, {}});
  // Capture time stamps: the file's modification time, plus the wire time of the bytes before
  // each telegram at --baud (11 bits a character), docs/sniff.md.
  Sniffer sniffer(
      a, capture,
      [baud = a.baud](const fdl::ParserEvent& ev) {
        // Time stamps of what was captured round down (docs/profibus.md "The line's physics").
        return phy::bits_to_timestamp(baud, phy::kBitsPerChar * ev.offset);
      },
      st ? std::function<void(const fdl::ParserEvent&)>(
               [&](const fdl::ParserEvent& ev) { st->event(ev, Time(0)); })
         : nullptr);
  std::vector<char> buf(4096);
  bool more = true;
  while (in && more) {
    in.read(buf.data(), static_cast<std::streamsize>(buf.size()));
    const auto n = static_cast<std::size_t>(in.gcount());
    if (n == 0) break;
    parser.feed(std::span(reinterpret_cast<const std::uint8_t*>(buf.data()), n));
    more = sniffer.print_events(parser, nullptr);
  }
  if (more && in.bad()) {
    std::cerr << "candp2 sniff: " << a.source << ": read error\n";
    return 2;
  }
  if (more) {
    parser.gap();  // end of file ends a partial telegram
    sniffer.print_events(parser, nullptr);
    if (a.errors) print_stats(parser.stats());
  }
  if (st) st->print();
  return 0;
}

// The PROFIBUS telegram a capture's packet carries: LINKTYPE_PROFIBUS_DL, or an exported PDU for
// the "fdl" dissector (docs/capture.md); nullopt for CAN frames, notes and anything else.
std::optional<std::span<const std::uint8_t>> profibus_telegram(const capture::pcapng::Interface& i,
                                                               const capture::pcapng::Packet& p) {
  if (i.linktype == capture::pcapng::kLinktypeProfibusDl) return std::span(p.data);
  if (i.linktype != capture::pcapng::kLinktypeWiresharkUpperPdu) return std::nullopt;
  const auto e = capture::pcapng::parse_exported_pdu(p.data);
  if (!e || e->dissector != "fdl") return std::nullopt;
  return e->pdu;
}

// A pcapng capture (candp2d's, or sniff --pcapng's; docs/capture.md): the telegrams of its first
// PROFIBUS interface with their time stamps; each packet is one telegram as the receiver framed
// it (a packet that does not decode is an illegal telegram).
int sniff_pcapng(const SniffArgs& a, capture::PcapngTap* capture,
                 const std::vector<std::uint8_t>& file) {
  const capture::pcapng::Capture c = capture::pcapng::read(file);
  if (c.sections == 0) {
    std::cerr << "candp2 sniff: " << a.source << ": not a pcapng capture: " << c.error << "\n";
    return 2;
  }
  if (!c.ok)
    std::cerr << "candp2 sniff: " << a.source << ": " << c.error
              << " (a capture still being written?): the packets before it are read\n";
  std::optional<StatsOut> st;
  if (a.stats) st.emplace(StatsOut{a, true, {}});
  Time now{0};   // the current packet's time, from the first telegram's
  Time wall{0};  // ... since the Unix epoch (for --pcapng)
  Sniffer sniffer(
      a, capture, [&](const fdl::ParserEvent&) { return wall; },
      st ? std::function<void(const fdl::ParserEvent&)>([](const fdl::ParserEvent&) {}) : nullptr);
  fdl::StreamParser parser;
  std::optional<std::uint32_t> line;
  std::optional<std::uint64_t> first_ns;
  std::uint64_t other = 0;
  for (const auto& p : c.packets) {
    const auto& i = c.interfaces[p.interface];
    const auto telegram = profibus_telegram(i, p);
    if (!telegram) continue;
    if (!line) line = p.interface;
    if (*line != p.interface) {
      ++other;
      continue;
    }
    const std::uint64_t ns = capture::pcapng::time_ns(i, p.time).value_or(0);
    if (!first_ns) first_ns = ns;
    now = Time(static_cast<std::int64_t>((ns - std::min(ns, *first_ns)) / 1000));
    wall = Time(static_cast<std::int64_t>(ns / 1000));
    if (st) st->stats.observe(*telegram, now);
    parser.feed(*telegram);
    parser.gap();  // a packet is one telegram
    const std::string stamp = seconds_stamp(now);
    if (!sniffer.print_events(parser, &stamp)) break;
  }
  if (other)
    std::cerr << "candp2 sniff: " << a.source << ": " << other
              << " packets of other PROFIBUS interfaces left out (only " << c.interfaces[*line].name
              << " is read)\n";
  if (a.errors) print_stats(parser.stats());
  if (st) st->print();
  return 0;
}

volatile sig_atomic_t g_stop = 0;
void on_signal(int) {
  g_stop = 1;
}

int sniff_port(const SniffArgs& a, capture::PcapngTap* capture) {
  serial::SerialOptions o;
  o.port = a.source;
  o.baud = a.baud;
  std::string error;
  auto port = serial::SerialPort::open(o, &error);
  if (!port) {
    std::cerr << "candp2 sniff: " << error << "\n";
    return 2;
  }
  if (port->is_pty())
    std::cerr << "candp2 sniff: listening on " << port->link_path() << " -> "
              << port->terminal_path() << "\n";
  struct sigaction sa {};
  sa.sa_handler = on_signal;
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);

  using Clock = std::chrono::steady_clock;
  const auto start = Clock::now();
  auto now = [&] { return std::chrono::duration_cast<Time>(Clock::now() - start); };
  // docs/profibus.md: idle ≥ TSYN ends a telegram; a timer, so rounded up.
  const Duration tsyn = phy::bits_to_time(a.baud, phy::kTsynBits);
  fdl::StreamParser parser;
  Time event_time{0};  // when the bytes that completed the current events arrived
  std::optional<Time> first;
  // --stats: times since the first byte; the statistics printed every second and at the end.
  std::optional<StatsOut> st;
  if (a.stats) st.emplace(StatsOut{a, true, {}});
  Time next_report = seconds(1), last_rx{0};
  Sniffer sniffer(
      a, capture, [&](const fdl::ParserEvent&) { return event_time; },
      st ? std::function<void(const fdl::ParserEvent&)>([&](const fdl::ParserEvent& ev) {
        st->event(ev, event_time - first.value_or(event_time));
      })
         : nullptr);
  std::vector<serial::RxByte> rx;
  int rc = 0;
  while (!g_stop) {
    pollfd pfd{port->fd(), POLLIN, 0};
    timespec ts{0, static_cast<long>(tsyn.count()) * 1000};
    bool wait = parser.buffered();
    if (st) {  // wake for the next report too
      const auto until = std::max(Duration(0), next_report - now());
      if (!wait || until < tsyn)
        ts = {static_cast<time_t>(until.count() / 1'000'000),
              static_cast<long>(until.count() % 1'000'000) * 1000};
      wait = true;
    }
    const int r = ppoll(&pfd, 1, wait ? &ts : nullptr, nullptr);
    if (r < 0) {
      if (errno == EINTR) continue;
      std::cerr << "candp2 sniff: poll: " << std::strerror(errno) << "\n";
      rc = 2;
      break;
    }
    const Time t = now();
    event_time = t;
    if (r == 0) {
      // Idle for TSYN (a timeout for a report may come sooner).
      if (!st || (parser.buffered() && t - last_rx >= tsyn)) parser.gap();
    } else {
      last_rx = t;
      rx.clear();
      if (port->read(rx, t, &error) < 0) {
        std::cerr << "candp2 sniff: " << error << "\n";
        rc = 2;
        break;
      }
      if (!rx.empty() && !first) first = t;
      serial::split_parity(
          rx, [&](std::span<const std::uint8_t> run) { parser.feed(run); },
          [&](std::uint8_t bad) { parser.feed_bad_char(bad); });
    }
    const std::string s = seconds_stamp(t - first.value_or(t));
    if (!sniffer.print_events(parser, &s)) break;
    if (st && t >= next_report) {
      st->print(&s);
      while (next_report <= t) next_report += seconds(1);
    }
  }
  if (a.errors) print_stats(parser.stats());
  if (st) st->print();
  return rc;
}

bool looks_like_port(const std::string& source) {
  if (source.rfind("pty:", 0) == 0 || source.rfind("/dev/", 0) == 0) return true;
  std::error_code ec;
  const auto st = std::filesystem::status(source, ec);
  return !ec && std::filesystem::is_character_file(st);
}

// The file's bytes when it is a pcapng capture (its first block a Section Header).
std::optional<std::vector<std::uint8_t>> read_pcapng(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  char magic[4] = {};
  if (!in.read(magic, 4) ||
      !capture::pcapng::is_pcapng(std::span(reinterpret_cast<const std::uint8_t*>(magic), 4)))
    return std::nullopt;
  in.seekg(0);
  return std::vector<std::uint8_t>(std::istreambuf_iterator<char>(in),
                                   std::istreambuf_iterator<char>());
}

int run_sniff(const SniffArgs& a) {
  const bool port = looks_like_port(a.source);
  const auto pcapng = port ? std::nullopt : read_pcapng(a.source);
  if (!a.pcapng.empty()) {
    if (const auto why = config::directory_not_writable(a.pcapng); !why.empty()) {
      std::cerr << "candp2 sniff: --pcapng " << a.pcapng << ": " << why << "\n";
      return 2;
    }
  }
  // Capture time stamps: a port's from the wall clock at start, a raw file's from its
  // modification time, a pcapng capture's its own (docs/sniff.md).
  auto capture = open_capture(a, port ? std::chrono::duration_cast<Duration>(
                                            std::chrono::system_clock::now().time_since_epoch())
                                 : pcapng ? Duration(0)
                                          : file_mtime(a.source));
  int rc = port     ? sniff_port(a, capture.get())
           : pcapng ? sniff_pcapng(a, capture.get(), *pcapng)
                    : sniff_file(a, capture.get());
  if (capture) {
    capture->sync();
    if (capture->stats().stopped) rc = 2;  // the message is on stderr already
  }
  return rc;
}

}  // namespace

void add_sniff(CLI::App& app, int& exit_code) {
  auto args = std::make_shared<SniffArgs>();
  auto* cmd = app.add_subcommand(
      "sniff",
      "Decode PROFIBUS FDL/DP telegrams from a serial line, a raw capture file or a pcapng "
      "capture, one line per telegram, or their line statistics (docs/sniff.md); exit 0 at end "
      "of file, 2 when the source cannot be opened");
  cmd->add_option(
         "SOURCE", args->source,
         "a serial device (/dev/ttyUSB0), pty:PATH, a raw capture file or a pcapng capture")
      ->required();
  cmd->add_option("--baud", args->baud, "bit rate of a serial line (default 19200)")
      ->check([](const std::string& v) -> std::string {
        try {
          if (phy::is_line_rate(static_cast<std::uint32_t>(std::stoul(v)))) return {};
        } catch (...) {
        }
        return "supported: " + phy::line_rates_text();
      });
  cmd->add_flag("--errors", args->errors,
                "also print parser errors (FCS, LE, ED, parity) and the line statistics");
  cmd->add_flag("-x,--hex", args->hex, "print each telegram's raw bytes before its description");
  cmd->add_flag("--generic", args->generic, "generic DP decoding only (no CAN-DP/2 payloads)");
  cmd->add_option("-n,--count", args->count, "exit after this many telegrams");
  cmd->add_option(
      "--pcapng", args->pcapng,
      "also write the telegrams to this pcapng capture for Wireshark (docs/capture.md)");
  cmd->add_flag("--profibus-dl", args->profibus_dl,
                "write the capture with LINKTYPE_PROFIBUS_DL (257) instead of exported PDUs for "
                "the candp2 dissector (252; Wireshark 4.0 opens only these)");
  auto* stats = cmd->add_flag(
      "--stats", args->stats,
      "print the line statistics per station instead of the telegrams: every second from a port, "
      "at the end (docs/sniff.md)");
  cmd->add_flag("--json", args->json, "--stats as one JSON document (a port: one a second)")
      ->needs(stats);
  cmd->callback([args, &exit_code] { exit_code = run_sniff(*args); });
}

}  // namespace candp2::cli
