#define _GNU_SOURCE /* memmem */
/* The floor of a cold `rs-discover list` (bench/run's cli_cold): a bare C program that
 * connects to the daemon's Unix socket, asks one path and writes the answer's body to
 * stdout, with nothing else a process could skip: no C++ runtime, no JSON, no table.
 *
 *     rsd-bench-cold-floor SOCKET PATH
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

int main(int argc, char** argv) {
  if (argc != 3) {
    fprintf(stderr, "usage: %s SOCKET PATH\n", argv[0]);
    return 2;
  }
  struct sockaddr_un addr = {.sun_family = AF_UNIX};
  strncpy(addr.sun_path, argv[1], sizeof addr.sun_path - 1);
  int fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0 || connect(fd, (struct sockaddr*)&addr, sizeof addr) != 0) {
    perror(argv[1]);
    return 3;
  }
  char request[4096];
  int n = snprintf(request, sizeof request, "GET %s HTTP/1.1\r\nHost: localhost\r\nConnection: close\r\n\r\n", argv[2]);
  if (n <= 0 || (size_t)n >= sizeof request || write(fd, request, (size_t)n) != n) return 3;
  /* The whole answer, then the body past the head (the daemon closes after it). */
  size_t size = 0, cap = 1 << 16;
  char* buf = malloc(cap);
  for (ssize_t got; buf && (got = read(fd, buf + size, cap - size)) > 0;) {
    size += (size_t)got;
    if (size == cap) buf = realloc(buf, cap *= 2);
  }
  close(fd);
  if (!buf) return 3;
  const char* body = memmem(buf, size, "\r\n\r\n", 4);
  const int ok = body && size >= 12 && strncmp(buf, "HTTP/1.1 200", 12) == 0;
  if (ok) fwrite(body + 4, 1, size - (size_t)(body + 4 - buf), stdout);
  free(buf); /* freed, so a sanitizer build's leak check passes */
  return ok ? 0 : 4;
}
