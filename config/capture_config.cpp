#include "config/capture_config.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <vector>

#include "config/json_reader.hpp"

namespace candp2::config {

using namespace json_reader;

std::string directory_not_writable(const std::string& file_path) {
  namespace fs = std::filesystem;
  fs::path dir = fs::path(file_path).parent_path();
  if (dir.empty()) dir = ".";
  std::error_code ec;
  const auto st = fs::status(dir, ec);
  if (ec || !fs::exists(st)) return "the directory " + dir.string() + " does not exist";
  if (!fs::is_directory(st)) return dir.string() + " is not a directory";
  // Try it: access(W_OK) says yes to root on a read-only file system or a sysfs directory.
  std::string probe = (dir / ".candp2-capture-XXXXXX").string();
  std::vector<char> name(probe.begin(), probe.end());
  name.push_back('\0');
  const int fd = mkostemp(name.data(), O_CLOEXEC);
  if (fd < 0) return "cannot create a file in " + dir.string() + ": " + std::strerror(errno);
  ::close(fd);
  ::unlink(name.data());
  return {};
}

CaptureConfig parse_capture(const json& j, const std::string& path, const std::string& file) {
  CaptureConfig c;
  c.json_path = path;
  const Object o(j, path, {"pcapng", "max_mb", "files", "profibus_linktype"});
  std::string p = as_string(o.at("pcapng"), o.path("pcapng"), "a capture file name");
  if (p.back() == '/')
    fail(o.path("pcapng"),
         "expected a file name like \"/var/lib/candp2/capture.pcapng\", got "
         "the directory \"" +
             p + "\"");
  c.pcapng = relative_to(file, p);
  c.max_mb = get_uint<std::uint32_t>(o, "max_mb", 0, 0, 1'000'000, "MB");
  c.files = get_uint<std::uint32_t>(o, "files", 0, 0, 100'000, "(files kept)");
  if (c.files && !c.max_mb)
    fail(o.path("files"),
         "a ring of files needs \"max_mb\" (the size at which the next file "
         "starts), like dumpcap's -b files needs -b filesize");
  if (const json* l = o.find("profibus_linktype")) {
    const std::string v =
        as_string(*l, o.path("profibus_linktype"), "\"wireshark_upper_pdu\" or \"profibus_dl\"");
    if (v == "wireshark_upper_pdu")
      c.profibus_linktype = CaptureProfibusLinktype::WiresharkUpperPdu;
    else if (v == "profibus_dl")
      c.profibus_linktype = CaptureProfibusLinktype::ProfibusDl;
    else
      fail(o.path("profibus_linktype"),
           "expected one of \"wireshark_upper_pdu\", \"profibus_dl\", got " + kind_of(*l));
  }
  if (const std::string why = directory_not_writable(c.pcapng); !why.empty())
    fail(o.path("pcapng"), "expected a file in a directory candp2d can write to: " + why);
  return c;
}

}  // namespace candp2::config
