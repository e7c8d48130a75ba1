// Linux ioctls of the serial PHY that need kernel headers which clash with glibc's <termios.h>
// (<asm/termbits.h> defines its own struct termios): isolated in serial_linux.cpp. Every function
// returns 0 or an errno value.
#pragma once

#include <cstdint>

namespace candp2::serial::detail {

// termios2 BOTHER (TCGETS2/TCSETS2): any bit rate the driver accepts, input and output.
int set_baud_termios2(int fd, std::uint32_t baud);
int get_baud_termios2(int fd, std::uint32_t* ispeed, std::uint32_t* ospeed);
// TIOCGSERIAL/TIOCSSERIAL ASYNC_LOW_LATENCY (ENOTTY/EINVAL: the driver does not offer it).
int set_low_latency(int fd);
// TIOCSRS485 with SER_RS485_ENABLED | SER_RS485_RTS_ON_SEND.
int set_rs485(int fd);

}  // namespace candp2::serial::detail
