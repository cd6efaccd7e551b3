// LD_PRELOAD shim for LCM's Java tools (lcm-spy): every UDP socket the process opens gets a receive buffer of
// $OBJSCAN_UDP_RCVBUF bytes (default 4194304). LCM's Java UDPMulticastProvider never sets one, so the kernel's default
// (net.core.rmem_default, 208 KiB on Debian) holds less than one 640x480 RGB image: a 30 Hz camera shows up in
// lcm-spy at about 1 Hz. OBJSCAN_UDP_RCVBUF=0 leaves the sockets alone (to measure the difference). The kernel caps the size at net.core.rmem_max; when it gives less than asked the shim says
// so once on stderr with the command that raises the cap. Loaded by scripts/lcm-java; nothing else uses it.
#include <dlfcn.h>
#include <sys/socket.h>

#include <cstdio>
#include <cstdlib>

namespace {
using SocketFn = int (*)(int, int, int);
}  // namespace

extern "C" int socket(int domain, int type, int protocol) __THROW {
  static SocketFn real_socket = nullptr;
  static int warned = 0;
  if (!real_socket) real_socket = reinterpret_cast<SocketFn>(dlsym(RTLD_NEXT, "socket"));
  const int fd = real_socket(domain, type, protocol);
  if (fd < 0 || (domain != AF_INET && domain != AF_INET6) || (type & 0xf) != SOCK_DGRAM) return fd;
  const char* env = std::getenv("OBJSCAN_UDP_RCVBUF");
  int wanted = 4194304;
  if (env && *env) {
    char* end = nullptr;
    const long v = std::strtol(env, &end, 10);
    if (end && *end == '\0' && v == 0) return fd;
    if (end && *end == '\0' && v > 0 && v <= (1L << 30)) wanted = static_cast<int>(v);
  }
  int got = 0;
  socklen_t len = sizeof got;
  if (setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &wanted, sizeof wanted) != 0 ||
      getsockopt(fd, SOL_SOCKET, SO_RCVBUF, &got, &len) != 0 || got / 2 < wanted) {
    // Linux reports twice the size it granted (bookkeeping overhead).
    if (!warned) {
      warned = 1;
      std::fprintf(stderr,
              "[objscan] UDP receive buffer %d bytes instead of %d: images will be dropped; raise the cap with "
              "'sysctl -w net.core.rmem_max=%d'\n",
              got / 2, wanted, wanted);
    }
  }
  return fd;
}
