// Only kernel headers here: <asm/termbits.h> (termios2, BOTHER) cannot share a translation unit
// with glibc's <termios.h>.
#include "serial/serial_linux.hpp"

#include <asm/ioctls.h>
#include <asm/termbits.h>
#include <errno.h>
#include <linux/serial.h>

#include <cstring>

extern "C" int ioctl(int fd, unsigned long request, ...);

namespace candp2::serial::detail {

int set_baud_termios2(int fd, std::uint32_t baud) {
  struct termios2 tio;
  if (ioctl(fd, TCGETS2, &tio) != 0) return errno;
  tio.c_cflag &= ~(CBAUD | (CBAUD << IBSHIFT));
  tio.c_cflag |= BOTHER | (BOTHER << IBSHIFT);
  tio.c_ispeed = baud;
  tio.c_ospeed = baud;
  if (ioctl(fd, TCSETS2, &tio) != 0) return errno;
  return 0;
}

int get_baud_termios2(int fd, std::uint32_t* ispeed, std::uint32_t* ospeed) {
  struct termios2 tio;
  if (ioctl(fd, TCGETS2, &tio) != 0) return errno;
  *ispeed = tio.c_ispeed;
  *ospeed = tio.c_ospeed;
  return 0;
}

int set_low_latency(int fd) {
  struct serial_struct ss;
  std::memset(&ss, 0, sizeof ss);
  if (ioctl(fd, TIOCGSERIAL, &ss) != 0) return errno;
  ss.flags |= ASYNC_LOW_LATENCY;
  if (ioctl(fd, TIOCSSERIAL, &ss) != 0) return errno;
  return 0;
}

int set_rs485(int fd) {
  struct serial_rs485 rs;
  std::memset(&rs, 0, sizeof rs);
  rs.flags = SER_RS485_ENABLED | SER_RS485_RTS_ON_SEND;
  if (ioctl(fd, TIOCSRS485, &rs) != 0) return errno;
  return 0;
}

}  // namespace candp2::serial::detail
