#include "replay/report.hpp"

#include <algorithm>
#include <cstdio>

namespace candp2::replay {

namespace {

std::string time_text(Time t) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%10.3f ms", static_cast<double>(t.count()) / 1000.0);
  return buf;
}

std::string seconds_text(Duration d) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6f", static_cast<double>(d.count()) / 1e6);
  return buf;
}

std::string xml_escape(std::string_view s) {
  std::string out;
  out.reserve(s.size());
  for (const char c : s) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&apos;";
        break;
      default:
        // XML 1.0 has no other control characters than tab, newline, carriage return.
        if (static_cast<unsigned char>(c) < 0x20 && c != '\t' && c != '\n' && c != '\r')
          out += '?';
        else
          out += c;
    }
  }
  return out;
}

std::string step_title(const StepResult& s) {
  return '#' + std::to_string(s.index) + " " + s.step->describe();
}

}  // namespace

std::string format_report(const Scenario& sc, const RunResult& r, const ReportOptions& o) {
  std::string out = "scenario: " + sc.name + " (" + sc.file + ")\n";
  if (!sc.description.empty()) out += "  " + sc.description + "\n";
  for (const auto& w : sc.warnings) out += "  warning: " + w.to_string() + "\n";
  std::size_t traffic = 0;
  for (const auto& s : r.steps) {
    const Step& st = *s.step;
    // time, result column, step, its note; a failure's reason on the next line.
    const char* mark = !s.passed ? "FAIL" : (s.expectation ? "ok  " : "    ");
    std::string line = time_text(s.start) + "  " + mark + "  " + step_title(s);
    if (s.passed && !s.detail.empty()) line += "  (" + s.detail + ")";
    if (!st.note.empty()) line += "  -- " + st.note;
    out += line + "\n";
    if (!s.passed) out += std::string(22, ' ') + "=> " + s.detail + "\n";
    if (o.verbose)
      for (std::size_t i = s.log_begin; i < s.log_end; ++i) {
        const auto& l = r.log[i];
        out += time_text(l.time) + "      " + std::string(to_string(l.level)) + " " + l.component +
               ": " + l.message + "\n";
      }
    if (o.traffic)
      for (; traffic < r.traffic.size() && r.traffic[traffic].time <= s.end; ++traffic) {
        const auto& t = r.traffic[traffic];
        out += time_text(t.time) + "      " +
               (t.from_gateway && sc.installation.gateways.size() > 1 ? t.gateway + " -> "
                : t.from_gateway                                      ? std::string("gateway -> ")
                : t.drive.empty()                                     ? std::string("replay  -> ")
                                                                      : t.drive + " -> ") +
               can::format_candump(t.frame) + "\n";
      }
  }
  const auto n = r.expectations();
  const auto f = r.failures();
  char summary[160];
  std::snprintf(summary, sizeof summary,
                "%s: %zu expectations, %zu passed, %zu failed; %.3f s virtual time, %zu CAN "
                "frames\n",
                f == 0 ? "PASS" : "FAIL", n, n - std::min(n, f), f,
                static_cast<double>(r.end.count()) / 1e6, r.traffic.size());
  return out + summary;
}

std::string format_junit(const Scenario& sc, const RunResult& r) {
  const auto n = r.expectations();
  const auto f = r.failures();
  const std::string name = xml_escape(sc.name);
  std::string out = "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n";
  out += "<testsuites name=\"candp2 replay\" tests=\"" + std::to_string(n) + "\" failures=\"" +
         std::to_string(f) + "\" errors=\"0\" time=\"" + seconds_text(r.end) + "\">\n";
  out += "  <testsuite name=\"" + name + "\" tests=\"" + std::to_string(n) + "\" failures=\"" +
         std::to_string(f) + "\" errors=\"0\" skipped=\"0\" time=\"" + seconds_text(r.end) +
         "\" file=\"" + xml_escape(sc.file) + "\">\n";
  for (const auto& s : r.steps) {
    // Actions that fail (at_ms in the past, a DB byte that does not exist) are reported as well.
    if (!s.expectation && s.passed) continue;
    out += "    <testcase classname=\"replay." + name + "\" name=\"" + xml_escape(step_title(s)) +
           "\" time=\"" + seconds_text(s.end - s.start) + "\"";
    if (s.passed) {
      out += "/>\n";
      continue;
    }
    out +=
        ">\n      <failure message=\"" + xml_escape(s.detail) + "\" type=\"expectation\">" +
        xml_escape(s.step->path + " at " + std::to_string(s.start.count()) + " us: " + s.detail) +
        "</failure>\n    </testcase>\n";
  }
  out += "    <system-out>" + xml_escape(format_report(sc, r)) + "</system-out>\n";
  out += "  </testsuite>\n</testsuites>\n";
  return out;
}

std::string format_junit_error(const std::string& file, const config::ConfigError& e) {
  std::string out = "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n";
  out += "<testsuites name=\"candp2 replay\" tests=\"1\" failures=\"0\" errors=\"1\">\n";
  out += "  <testsuite name=\"" + xml_escape(file) +
         "\" tests=\"1\" failures=\"0\" errors=\"1\" skipped=\"0\" time=\"0\">\n";
  out += "    <testcase classname=\"replay\" name=\"read scenario\" time=\"0\">\n";
  out += "      <error message=\"" + xml_escape(e.to_string()) + "\" type=\"scenario\"/>\n";
  out += "    </testcase>\n  </testsuite>\n</testsuites>\n";
  return out;
}

std::string format_can_log(const RunResult& r, const std::string& interface) {
  std::string out;
  for (const auto& t : r.traffic) {
    can::LogLine l;
    l.sec = t.time.count() / 1000000;
    l.usec = static_cast<std::uint32_t>(t.time.count() % 1000000);
    l.interface = interface;
    l.frame = t.frame;
    out += can::format_log_line(l) + "\n";
  }
  return out;
}

std::string format_can_log(const Scenario& sc, const RunResult& r) {
  std::string out;
  for (const auto& t : r.traffic) {
    can::LogLine l;
    l.sec = t.time.count() / 1000000;
    l.usec = static_cast<std::uint32_t>(t.time.count() % 1000000);
    l.interface = bus_interface(sc, t.bus);
    l.frame = t.frame;
    out += can::format_log_line(l) + "\n";
  }
  return out;
}

std::string bus_interface(const Scenario& sc, std::size_t bus) {
  const auto& b = sc.installation.buses.at(bus);
  return b.channel.empty() ? b.name : b.channel;
}

std::string log_interface(const Scenario& sc) {
  return bus_interface(sc, 0);
}

}  // namespace candp2::replay
