#include "can/socketcand_net.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>

#include <algorithm>
#include <cstdio>
#include <cstring>

#include "can/socketcand_protocol.hpp"

namespace candp2::can::socketcand_net {

std::string errno_text(int err) {
  return std::string(std::strerror(err));
}

bool is_printable_element(std::string_view e) {
  return std::all_of(e.begin(), e.end(), [](char ch) {
    const auto c = static_cast<unsigned char>(ch);
    return (c >= 0x20 && c < 0x7F) || c == '\t' || c == '\r' || c == '\n';
  });
}

std::string printable(std::string_view text) {
  std::string out;
  for (const char ch : text) {
    const auto c = static_cast<unsigned char>(ch);
    if (c >= 0x20 && c < 0x7F) {
      out += ch;
    } else {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\x%02X", c);
      out += buf;
    }
  }
  return out;
}

std::string address_text(const sockaddr* sa) {
  char host[INET6_ADDRSTRLEN] = "?";
  unsigned port = 0;
  if (sa->sa_family == AF_INET) {
    const auto* in = reinterpret_cast<const sockaddr_in*>(sa);
    ::inet_ntop(AF_INET, &in->sin_addr, host, sizeof host);
    port = ntohs(in->sin_port);
    return std::string(host) + ':' + std::to_string(port);
  }
  if (sa->sa_family == AF_INET6) {
    const auto* in6 = reinterpret_cast<const sockaddr_in6*>(sa);
    ::inet_ntop(AF_INET6, &in6->sin6_addr, host, sizeof host);
    port = ntohs(in6->sin6_port);
    return '[' + std::string(host) + "]:" + std::to_string(port);
  }
  return "?";
}

bool set_error(std::string* error, std::string message) {
  if (error) *error = std::move(message);
  return false;
}

bool valid_bus_name(std::string_view name) {
  return !name.empty() && name.size() <= socketcand::kMaxBusName &&
         std::none_of(name.begin(), name.end(),
                      [](char c) { return c <= ' ' || c == '<' || c == '>' || c > '~'; });
}

}  // namespace candp2::can::socketcand_net
