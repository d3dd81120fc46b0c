// FreePort(): a TCP port on the loopback interface that nothing listens on right now, for
// tests that start a real skimapd process. (The kernel picks it; another process could
// take it before the server binds: SkimapdProcess::Start then tries fresh ports.)
#ifndef TESTS_COMMON_FREE_PORT_H_
#define TESTS_COMMON_FREE_PORT_H_

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

namespace skimap::testing {

inline int FreePort() {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr);
  socklen_t len = sizeof addr;
  getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len);
  close(fd);
  return ntohs(addr.sin_port);
}

}  // namespace skimap::testing

#endif  // TESTS_COMMON_FREE_PORT_H_
