// Ports for the servers that tests start on loopback.
#pragma once

#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cstdio>
#include <random>

namespace oaipp::server::testing {

// A port of 127.0.0.1 that is free now and lies below the kernel's
// ephemeral range (ip_local_port_range), so that no outgoing connection of
// another test is given it while a server is down between restarts. 0 when
// none could be had.
inline int FreePort() {
  int ephemeral_low = 32768;
  if (FILE* range = std::fopen("/proc/sys/net/ipv4/ip_local_port_range", "r")) {
    if (std::fscanf(range, "%d", &ephemeral_low) != 1) ephemeral_low = 32768;
    std::fclose(range);
  }
  const int low = 10000;
  if (ephemeral_low <= low + 1000) ephemeral_low = 65536;  // an odd range: any port then
  std::random_device seed;
  for (int attempt = 0; attempt < 64; ++attempt) {
    const int port = low + static_cast<int>(seed() % static_cast<unsigned>(ephemeral_low - low));
    const int fd = socket(AF_INET, SOCK_STREAM, 0);
    if (fd < 0) return 0;
    sockaddr_in sa{};
    sa.sin_family = AF_INET;
    sa.sin_port = htons(static_cast<uint16_t>(port));
    sa.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    const bool free = bind(fd, reinterpret_cast<sockaddr*>(&sa), sizeof(sa)) == 0;
    close(fd);
    if (free) return port;
  }
  return 0;
}

}  // namespace oaipp::server::testing
