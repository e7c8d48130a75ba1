// gsd_slave_pty: a test program that serves the generic slaves of a daemon configuration
// ($.slaves, docs/configuration.md) on its PROFIBUS line ($.profibus, role "slaves", normally
// "pty:PATH") with the FDL slave front end — what candp2d will do once the slaves are wired into
// it. It lets an independent master (tests/e2e/gsd_slave_e2e.py; pyprofibus, docs/slaves.md)
// drive an emulated slave over a real pseudo-terminal. The $.gateways of the file are not served.
//
// stdin, one command a line, each answered "ok LINE" when done:
//   inputs ADDR HEX      the field inputs of the slave at DP address ADDR (from byte 0)
//   offline ADDR / online ADDR
//   diag ADDR HEX / diag ADDR -     a diagnosis alarm (Ext_Diag) / none
//   ping                 nothing (everything received before it has been handled)
//   quit
// stdout, one event a line (flushed): "ready LINK", "state ADDR Data_Exch", "outputs ADDR HEX"
// (the field outputs whenever they change), "error TEXT" for a bad command. Log lines on stderr.
#include <unistd.h>

#include <cstdio>
#include <iostream>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <variant>

#include "common/hex.hpp"
#include "config/config.hpp"
#include "event_loop/event_loop.hpp"
#include "gsd_slave/gsd_slave.hpp"
#include "profibus_sim/fdl/fdl_slave.hpp"
#include "serial/serial_port.hpp"

namespace candp2 {
namespace {

class StderrLog final : public LogSink {
 public:
  explicit StderrLog(LogLevel min) : min_(min) {}
  bool enabled(LogLevel level) const override { return level >= min_; }
  void write(LogLevel level, std::string_view component, std::string_view message) override {
    std::cerr << to_string(level) << " " << component << ": " << message << "\n";
  }

 private:
  LogLevel min_;
};

void emit(const std::string& line) {
  std::cout << line << "\n" << std::flush;
}

struct Harness {
  EventLoop loop;
  StderrLog log;
  std::unique_ptr<serial::SerialPort> port;
  std::unique_ptr<fdl::SlaveFrontEnd> front;
  std::map<std::uint8_t, std::unique_ptr<gsd_slave::GsdSlave>> slaves;  // by configured address
  std::map<std::uint8_t, std::string> outputs;                          // last reported
  std::map<std::uint8_t, dp::SlaveState> states;
  std::vector<serial::RxByte> rx;
  EventLoop::TimerId gap_timer = 0, send_timer = 0;
  std::string stdin_buffer;

  explicit Harness(LogLevel level) : log(level) {}

  void report() {
    for (auto& [address, s] : slaves) {
      const auto st = s->dp().state();
      if (states[address] != st || !outputs.count(address)) {
        states[address] = st;
        emit("state " + std::to_string(address) + " " + std::string(dp::to_string(st)));
      }
      const std::string out = hex_bytes(s->field_outputs());
      if (!outputs.count(address) || outputs[address] != out) {
        outputs[address] = out;
        emit("outputs " + std::to_string(address) + " " + out);
      }
    }
  }

  void send(std::vector<std::uint8_t> bytes) {
    std::string error;
    if (!port->write(bytes.data(), bytes.size(), loop.now(), &error))
      log.write(LogLevel::Error, "pty", error);
  }

  void handle(std::optional<fdl::Reply> reply) {
    report();
    if (!reply) return;
    if (send_timer) loop.cancel_timer(send_timer);
    send_timer = 0;
    const Time now = loop.now();
    if (reply->not_before <= now) return send(std::move(reply->bytes));
    send_timer =
        loop.add_timer(reply->not_before - now, [this, b = std::move(reply->bytes)]() mutable {
          send_timer = 0;
          send(std::move(b));
        });
  }

  void on_readable() {
    rx.clear();
    std::string error;
    if (port->read(rx, loop.now(), &error) < 0) {
      log.write(LogLevel::Error, "pty", error);
      loop.stop();
      return;
    }
    auto& parser = front->parser();
    serial::split_parity(
        rx, [&](std::span<const std::uint8_t> run) { parser.feed(run); },
        [&](std::uint8_t bad) { parser.feed_bad_char(bad); });
    handle(front->on_bytes({}, loop.now()));
    if (gap_timer) loop.cancel_timer(gap_timer);
    gap_timer = 0;
    if (parser.buffered() > 0)  // TSYN = 33 bit times ends a partial telegram
      gap_timer = loop.add_timer(front->bit_times(33), [this] {
        gap_timer = 0;
        handle(front->on_gap(loop.now()));
      });
  }

  // Every command is answered "ok LINE" once done (or "error ..."), so a test knows that what
  // follows on the line meets the new state.
  void command(const std::string& line) {
    if (apply(line)) emit("ok " + line);
  }

  bool apply(const std::string& line) {
    std::istringstream in(line);
    std::string verb, hex;
    unsigned address = 0;
    in >> verb;
    if (verb == "quit") {
      loop.stop();
      return false;
    }
    if (verb == "ping") return true;
    in >> address;
    auto it = slaves.find(static_cast<std::uint8_t>(address));
    if (it == slaves.end()) {
      emit("error no slave at " + std::to_string(address) + ": " + line);
      return false;
    }
    gsd_slave::GsdSlave& s = *it->second;
    std::getline(in, hex);
    std::string err;
    const auto bytes = config::parse_hex(hex, &err);
    if (verb == "inputs" && bytes && s.write_inputs(0, *bytes)) return true;
    if (verb == "offline" || verb == "online") {
      s.set_online(verb == "online");
      return true;
    }
    if (verb == "diag" && hex.find('-') != std::string::npos) {
      s.clear_device_diag();
      return true;
    }
    if (verb == "diag" && bytes && s.set_device_diag(*bytes)) return true;
    emit("error bad command: " + line);
    return false;
  }

  void on_stdin() {
    char buf[512];
    const ssize_t n = ::read(STDIN_FILENO, buf, sizeof buf);
    if (n <= 0) {
      loop.stop();  // the test closed our stdin
      return;
    }
    stdin_buffer.append(buf, static_cast<std::size_t>(n));
    for (std::size_t nl; (nl = stdin_buffer.find('\n')) != std::string::npos;) {
      const std::string line = stdin_buffer.substr(0, nl);
      stdin_buffer.erase(0, nl + 1);
      if (!line.empty()) command(line);
    }
  }

  int run(const config::DaemonConfig& cfg) {
    if (!cfg.profibus || cfg.profibus->role != config::ProfibusRole::Slaves) {
      std::cerr << "gsd_slave_pty: the configuration needs $.profibus with role \"slaves\"\n";
      return 2;
    }
    const config::ProfibusConfig& pb = *cfg.profibus;
    fdl::SlaveFrontEndOptions o;
    o.baud = pb.baud;
    o.master_address = pb.master_address;
    o.default_min_tsdr_bits = pb.min_tsdr_bits;
    front = std::make_unique<fdl::SlaveFrontEnd>(o, &log);
    for (const auto& sc : cfg.slaves) {
      std::string error;
      auto s = gsd_slave::GsdSlave::create(sc.setup(&log), &error);
      if (!s || !front->add(s->dp())) {
        std::cerr << "gsd_slave_pty: " << sc.json_path << ": " << error << "\n";
        return 2;
      }
      slaves[sc.address] = std::move(s);
    }
    serial::SerialOptions so;
    so.port = pb.port;
    so.baud = pb.baud;
    so.log = &log;
    std::string error;
    port = serial::SerialPort::open(so, &error);
    if (!port) {
      std::cerr << "gsd_slave_pty: " << error << "\n";
      return 2;
    }
    loop.add_fd(port->fd(), EventLoop::kReadable, [this](std::uint32_t) { on_readable(); });
    loop.add_fd(STDIN_FILENO, EventLoop::kReadable, [this](std::uint32_t) { on_stdin(); });
    // The slaves' watchdogs.
    loop.add_periodic(milliseconds(5), [this] {
      for (auto& [a, s] : slaves) s->advance(loop.now());
      report();
    });
    emit("ready " + (port->is_pty() ? port->link_path() : pb.port));
    report();
    loop.run();
    return 0;
  }
};

}  // namespace
}  // namespace candp2

int main(int argc, char** argv) {
  using namespace candp2;
  if (argc < 2) {
    std::cerr << "usage: gsd_slave_pty CONFIG [debug]\n";
    return 2;
  }
  auto loaded = config::load_daemon(argv[1]);
  if (const auto* e = std::get_if<config::ConfigError>(&loaded)) {
    std::cerr << "gsd_slave_pty: " << e->to_string() << "\n";
    return 2;
  }
  Harness h(argc > 2 && std::string(argv[2]) == "debug" ? LogLevel::Debug : LogLevel::Info);
  return h.run(std::get<config::DaemonConfig>(loaded));
}
