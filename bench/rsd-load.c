/* rsd-load: a small HTTP/1.1 load generator and SSE fan-out watcher that speaks over
 * TCP and over a Unix socket (wrk and h2load speak TCP only), for bench/run.
 *
 *   rsd-load http (--unix PATH | --tcp HOST:PORT) [--path /v1/devices] [-c 64] [-t 2] [-d 5]
 *       keep-alive GETs on -c connections from -t threads (epoll) for -d seconds;
 *       prints one JSON object: requests, errors, bytes, seconds, rps, p50/p90/p99/max ms
 *       (latency: request written -> whole response read, as wrk measures it).
 *
 *   rsd-load sse (--unix PATH | --tcp HOST:PORT) [--path /v1/events] [-c 100] [--timeout 10]
 *       opens -c event streams; prints {"connected": N} once every stream has its
 *       response headers (or the timeout passed), then one JSON line per event
 *       {"c": stream, "event": "...", "id": "...", "t": CLOCK_MONOTONIC seconds} taken
 *       when the event's closing blank line is read, and {"c": stream, "closed": true,
 *       "was_connected": bool} when the server closes one; exits when stdin closes.
 *
 * Plain C, no dependencies: bench/CMakeLists.txt builds it; bench/run compiles it with
 * cc when the build tree has no bench/.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <pthread.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/epoll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <time.h>
#include <unistd.h>

static const char* g_unix = NULL;
static struct sockaddr_storage g_addr;
static socklen_t g_addrlen;
static const char* g_path = NULL;
static char g_request[1024];
static size_t g_request_len;

static double now_s(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

static int connect_one(void) {
  int fd;
  if (g_unix) {
    fd = socket(AF_UNIX, SOCK_STREAM, 0);
  } else {
    fd = socket(g_addr.ss_family, SOCK_STREAM, 0);
  }
  if (fd < 0) return -1;
  if (connect(fd, (struct sockaddr*)&g_addr, g_addrlen) != 0) {
    close(fd);
    return -1;
  }
  if (!g_unix) {
    int one = 1;
    setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
  }
  fcntl(fd, F_SETFL, fcntl(fd, F_GETFL) | O_NONBLOCK);
  return fd;
}

/* ---- HTTP response parsing (Content-Length or chunked) ---------------------------- */

enum body_mode { BODY_LENGTH, BODY_CHUNKED, BODY_SSE };
enum chunk_state { CH_SIZE, CH_SIZE_LF, CH_DATA, CH_DATA_CR, CH_DATA_LF, CH_TRAILER, CH_TRAILER_LF, CH_DONE };

typedef struct {
  int fd;
  int in_headers;
  char head[16384];
  size_t head_len;
  enum body_mode mode;
  long long remaining;   /* BODY_LENGTH: bytes left; chunked: bytes left in this chunk */
  enum chunk_state ch;
  long long chunk_size;
  int trailer_empty;
  int close_after;
  int status;
  double sent_at;
  /* SSE */
  char line[65536];
  size_t line_len;
  char ev[64];
  char id[64];
  int connected;
  int sse_chunked; /* an event stream sent chunked: data bytes go to sse_bytes() */
  int sse_index;
  double sse_t;
} conn_t;

static void sse_bytes(conn_t* c, const char* p, size_t n);

static void reset_response(conn_t* c) {
  c->in_headers = 1;
  c->head_len = 0;
  c->close_after = 0;
}

/* Parses the header block; returns 0 on success. */
static int parse_headers(conn_t* c) {
  c->head[c->head_len] = 0;
  if (sscanf(c->head, "HTTP/1.%*d %d", &c->status) != 1) return -1;
  c->mode = BODY_LENGTH;
  c->remaining = 0;
  char* line = strstr(c->head, "\r\n");
  while (line && line[2] != '\r') {
    line += 2;
    if (strncasecmp(line, "content-length:", 15) == 0) {
      c->remaining = atoll(line + 15);
    } else if (strncasecmp(line, "transfer-encoding:", 18) == 0 && strcasestr(line, "chunked")) {
      c->mode = BODY_CHUNKED;
      c->ch = CH_SIZE;
      c->chunk_size = 0;
    } else if (strncasecmp(line, "connection:", 11) == 0 && strcasestr(line, "close")) {
      c->close_after = 1;
    } else if (strncasecmp(line, "content-type:", 13) == 0 && strcasestr(line, "text/event-stream")) {
      c->mode = BODY_SSE;
    }
    line = strstr(line, "\r\n");
  }
  return 0;
}

/* Feeds body bytes of a non-SSE response; returns bytes used, sets *done. */
static size_t feed_body(conn_t* c, const char* p, size_t n, int* done) {
  *done = 0;
  if (c->mode == BODY_LENGTH) {
    size_t take = (long long)n < c->remaining ? n : (size_t)c->remaining;
    c->remaining -= (long long)take;
    if (c->remaining == 0) *done = 1;
    return take;
  }
  size_t i = 0;
  while (i < n && !*done) {
    char b = p[i];
    switch (c->ch) {
      case CH_SIZE:
        if (b == '\r') c->ch = CH_SIZE_LF;
        else if (b == ';') c->ch = CH_SIZE_LF; /* extensions: skipped up to LF below */
        else {
          int v = (b >= '0' && b <= '9') ? b - '0' : (b >= 'a' && b <= 'f') ? b - 'a' + 10
                  : (b >= 'A' && b <= 'F') ? b - 'A' + 10 : -1;
          if (v < 0) return (size_t)-1;
          c->chunk_size = c->chunk_size * 16 + v;
        }
        i++;
        break;
      case CH_SIZE_LF:
        if (b == '\n') {
          if (c->chunk_size == 0) {
            c->ch = CH_TRAILER;
            c->trailer_empty = 1;
          } else {
            c->ch = CH_DATA;
            c->remaining = c->chunk_size;
          }
        }
        i++;
        break;
      case CH_DATA: {
        size_t take = (long long)(n - i) < c->remaining ? n - i : (size_t)c->remaining;
        if (c->sse_chunked) sse_bytes(c, p + i, take);
        c->remaining -= (long long)take;
        i += take;
        if (c->remaining == 0) c->ch = CH_DATA_CR;
        break;
      }
      case CH_DATA_CR:
        c->ch = CH_DATA_LF;
        i++;
        break;
      case CH_DATA_LF:
        c->ch = CH_SIZE;
        c->chunk_size = 0;
        i++;
        break;
      case CH_TRAILER:
        if (b == '\r') c->ch = CH_TRAILER_LF;
        else c->trailer_empty = 0;
        i++;
        break;
      case CH_TRAILER_LF:
        i++;
        if (c->trailer_empty) {
          c->ch = CH_DONE;
          *done = 1;
        } else {
          c->ch = CH_TRAILER;
          c->trailer_empty = 1;
        }
        break;
      case CH_DONE:
        *done = 1;
        break;
    }
  }
  return i;
}

/* ---- http mode --------------------------------------------------------------------- */

typedef struct {
  int conns;
  double duration;
  double start, end;
  unsigned long long requests, errors, bytes;
  uint32_t* lat; /* 0.1 us units */
  size_t lat_n, lat_cap;
} worker_t;

static void record(worker_t* w, double seconds) {
  if (w->lat_n == w->lat_cap) {
    w->lat_cap = w->lat_cap ? w->lat_cap * 2 : 65536;
    w->lat = realloc(w->lat, w->lat_cap * sizeof *w->lat);
  }
  double units = seconds * 1e7;
  w->lat[w->lat_n++] = units > 4e9 ? 4000000000u : (uint32_t)units;
}

static int send_request(conn_t* c) {
  ssize_t r = write(c->fd, g_request, g_request_len);
  if (r != (ssize_t)g_request_len) return -1;
  c->sent_at = now_s();
  reset_response(c);
  return 0;
}

static int open_conn(worker_t* w, int ep, conn_t* c) {
  (void)w;
  c->fd = connect_one();
  if (c->fd < 0) return -1;
  struct epoll_event e = {.events = EPOLLIN, .data.ptr = c};
  epoll_ctl(ep, EPOLL_CTL_ADD, c->fd, &e);
  return send_request(c);
}

static void* http_worker(void* arg) {
  worker_t* w = arg;
  int ep = epoll_create1(0);
  conn_t* conns = calloc((size_t)w->conns, sizeof *conns);
  static __thread char buf[1 << 17];
  for (int i = 0; i < w->conns; i++)
    if (open_conn(w, ep, &conns[i]) != 0) w->errors++;
  struct epoll_event events[256];
  double deadline = w->start + w->duration;
  for (;;) {
    double t = now_s();
    if (t >= deadline) break;
    int ms = (int)((deadline - t) * 1000) + 1;
    int n = epoll_wait(ep, events, 256, ms > 100 ? 100 : ms);
    for (int k = 0; k < n; k++) {
      conn_t* c = events[k].data.ptr;
      for (;;) {
        ssize_t r = read(c->fd, buf, sizeof buf);
        if (r < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) break;
        if (r <= 0) { /* closed mid-response or error: reconnect */
          w->errors++;
          epoll_ctl(ep, EPOLL_CTL_DEL, c->fd, NULL);
          close(c->fd);
          if (open_conn(w, ep, c) != 0) {
            c->fd = -1;
          }
          break;
        }
        w->bytes += (unsigned long long)r;
        size_t off = 0;
        int reopened = 0;
        while (off < (size_t)r) {
          if (c->in_headers) {
            size_t room = sizeof c->head - 1 - c->head_len;
            size_t take = (size_t)r - off < room ? (size_t)r - off : room;
            memcpy(c->head + c->head_len, buf + off, take);
            size_t old = c->head_len;
            c->head_len += take;
            c->head[c->head_len] = 0;
            char* end = strstr(c->head + (old > 3 ? old - 3 : 0), "\r\n\r\n");
            if (!end) {
              if (c->head_len >= sizeof c->head - 1) { w->errors++; off = (size_t)r; }
              else off += take;
              continue;
            }
            size_t used = (size_t)(end + 4 - c->head) - old;
            c->head_len = (size_t)(end + 4 - c->head);
            off += used;
            if (parse_headers(c) != 0) { w->errors++; off = (size_t)r; continue; }
            c->in_headers = 0;
            if (c->mode == BODY_LENGTH && c->remaining == 0) goto complete;
            continue;
          } else {
            int done = 0;
            size_t used = feed_body(c, buf + off, (size_t)r - off, &done);
            if (used == (size_t)-1) { w->errors++; off = (size_t)r; continue; }
            off += used;
            if (!done) continue;
          }
        complete: {
            double t2 = now_s();
            if (t2 <= deadline) {
              if (c->status == 200) {
                w->requests++;
                record(w, t2 - c->sent_at);
              } else {
                w->errors++;
              }
            }
            if (c->close_after) {
              epoll_ctl(ep, EPOLL_CTL_DEL, c->fd, NULL);
              close(c->fd);
              if (open_conn(w, ep, c) != 0) { w->errors++; c->fd = -1; }
              reopened = 1;
              off = (size_t)r;
            } else if (t2 < deadline) {
              if (send_request(c) != 0) w->errors++;
            }
          }
        }
        if (reopened) break;
      }
    }
  }
  w->end = now_s();
  for (int i = 0; i < w->conns; i++)
    if (conns[i].fd >= 0) close(conns[i].fd);
  close(ep);
  free(conns);
  return NULL;
}

static int cmp_u32(const void* a, const void* b) {
  uint32_t x = *(const uint32_t*)a, y = *(const uint32_t*)b;
  return x < y ? -1 : x > y;
}

static double pct(uint32_t* v, size_t n, double p) {
  if (!n) return -1;
  size_t i = (size_t)(p * (double)(n - 1) + 0.5);
  return v[i] / 1e4; /* ms */
}

static int run_http(int conns, int threads, double duration) {
  if (threads > conns) threads = conns;
  worker_t* ws = calloc((size_t)threads, sizeof *ws);
  pthread_t* ts = calloc((size_t)threads, sizeof *ts);
  double start = now_s();
  for (int i = 0; i < threads; i++) {
    ws[i].conns = conns / threads + (i < conns % threads);
    ws[i].duration = duration;
    ws[i].start = start;
    pthread_create(&ts[i], NULL, http_worker, &ws[i]);
  }
  unsigned long long req = 0, err = 0, bytes = 0;
  size_t total = 0;
  for (int i = 0; i < threads; i++) {
    pthread_join(ts[i], NULL);
    req += ws[i].requests;
    err += ws[i].errors;
    bytes += ws[i].bytes;
    total += ws[i].lat_n;
  }
  uint32_t* all = malloc((total ? total : 1) * sizeof *all);
  size_t k = 0;
  for (int i = 0; i < threads; i++) {
    memcpy(all + k, ws[i].lat, ws[i].lat_n * sizeof *all);
    k += ws[i].lat_n;
    free(ws[i].lat);
  }
  qsort(all, total, sizeof *all, cmp_u32);
  printf("{\"requests\": %llu, \"errors\": %llu, \"bytes\": %llu, \"seconds\": %.3f, \"rps\": %.1f, "
         "\"p50_ms\": %.4f, \"p90_ms\": %.4f, \"p99_ms\": %.4f, \"max_ms\": %.4f, \"connections\": %d, "
         "\"threads\": %d}\n",
         req, err, bytes, duration, (double)req / duration, pct(all, total, 0.50), pct(all, total, 0.90),
         pct(all, total, 0.99), total ? all[total - 1] / 1e4 : -1.0, conns, threads);
  free(all);
  free(ws);
  free(ts);
  return req > 0 ? 0 : 1;
}

/* ---- sse mode ---------------------------------------------------------------------- */

static void sse_line(conn_t* c, int index, double t) {
  c->line[c->line_len] = 0;
  if (c->line_len == 0) {
    if (c->ev[0] || c->id[0]) {
      printf("{\"c\": %d, \"event\": \"%s\", \"id\": \"%s\", \"t\": %.9f}\n", index, c->ev[0] ? c->ev : "message",
             c->id, t);
      fflush(stdout);
    }
    c->ev[0] = c->id[0] = 0;
  } else if (strncmp(c->line, "event:", 6) == 0) {
    const char* v = c->line + 6 + (c->line[6] == ' ');
    snprintf(c->ev, sizeof c->ev, "%s", v);
  } else if (strncmp(c->line, "id:", 3) == 0) {
    const char* v = c->line + 3 + (c->line[3] == ' ');
    snprintf(c->id, sizeof c->id, "%s", v);
  }
  c->line_len = 0;
}

static void sse_bytes(conn_t* c, const char* p, size_t n) {
  for (size_t k = 0; k < n; k++) {
    char b = p[k];
    if (b == '\n') {
      if (c->line_len && c->line[c->line_len - 1] == '\r') c->line_len--;
      sse_line(c, c->sse_index, c->sse_t);
    } else if (c->line_len < sizeof c->line - 1) {
      c->line[c->line_len++] = b;
    }
  }
}

static int run_sse(int n, double timeout) {
  int ep = epoll_create1(0);
  conn_t* conns = calloc((size_t)n, sizeof *conns);
  int connected = 0, announced = 0;
  for (int i = 0; i < n; i++) {
    conns[i].fd = connect_one();
    if (conns[i].fd < 0) continue;
    reset_response(&conns[i]);
    if (write(conns[i].fd, g_request, g_request_len) != (ssize_t)g_request_len) continue;
    struct epoll_event e = {.events = EPOLLIN, .data.u64 = (uint64_t)i};
    epoll_ctl(ep, EPOLL_CTL_ADD, conns[i].fd, &e);
  }
  struct epoll_event e = {.events = EPOLLIN, .data.u64 = (uint64_t)-1};
  epoll_ctl(ep, EPOLL_CTL_ADD, 0, &e);
  double deadline = now_s() + timeout;
  static char buf[1 << 16];
  struct epoll_event events[256];
  for (;;) {
    if (!announced && (connected == n || now_s() >= deadline)) {
      printf("{\"connected\": %d}\n", connected);
      fflush(stdout);
      announced = 1;
    }
    int m = epoll_wait(ep, events, 256, announced ? -1 : 20);
    for (int k = 0; k < m; k++) {
      if (events[k].data.u64 == (uint64_t)-1) {
        ssize_t r = read(0, buf, sizeof buf);
        if (r <= 0) goto out;
        continue;
      }
      int i = (int)events[k].data.u64;
      conn_t* c = &conns[i];
      ssize_t r = read(c->fd, buf, sizeof buf);
      if (r < 0 && errno == EAGAIN) continue;
      if (r <= 0) {
        epoll_ctl(ep, EPOLL_CTL_DEL, c->fd, NULL);
        close(c->fd);
        c->fd = -1;
        printf("{\"c\": %d, \"closed\": true, \"was_connected\": %s}\n", i, c->connected ? "true" : "false");
        if (c->connected) connected--;
        c->connected = 0;
        fflush(stdout);
        continue;
      }
      double t = now_s();
      size_t off = 0;
      if (c->in_headers) {
        size_t room = sizeof c->head - 1 - c->head_len;
        size_t take = (size_t)r < room ? (size_t)r : room;
        memcpy(c->head + c->head_len, buf, take);
        c->head_len += take;
        c->head[c->head_len] = 0;
        char* end = strstr(c->head, "\r\n\r\n");
        if (!end) continue;
        size_t hl = (size_t)(end + 4 - c->head);
        off = hl - (c->head_len - take);
        c->head_len = hl;
        parse_headers(c);
        c->in_headers = 0;
        {
          const char* te = strcasestr(c->head, "\ntransfer-encoding:");
          if (te && strcasestr(te, "chunked") && strcasestr(te, "chunked") < strstr(te + 1, "\n")) {
            c->sse_chunked = 1;
            c->ch = CH_SIZE;
            c->chunk_size = 0;
          }
        }
        if (c->status == 200) {
          c->connected = 1;
          connected++;
        }
      }
      c->sse_index = i;
      c->sse_t = t;
      if (c->sse_chunked) {
        int done = 0;
        feed_body(c, buf + off, (size_t)r - off, &done);
      } else {
        sse_bytes(c, buf + off, (size_t)r - off);
      }
    }
  }
out:
  for (int i = 0; i < n; i++)
    if (conns[i].fd >= 0) close(conns[i].fd);
  free(conns);
  return 0;
}

static void usage(void) {
  fprintf(stderr, "usage: rsd-load http|sse (--unix PATH | --tcp HOST:PORT) [--path P] [-c N] [-t N] [-d S] "
                  "[--timeout S]\n");
  exit(2);
}

int main(int argc, char** argv) {
  if (argc < 2) usage();
  const char* mode = argv[1];
  const char* tcp = NULL;
  int conns = strcmp(mode, "sse") == 0 ? 100 : 64, threads = 2;
  double duration = 5, timeout = 10;
  g_path = strcmp(mode, "sse") == 0 ? "/v1/events" : "/v1/devices";
  for (int i = 2; i < argc; i++) {
    if (i + 1 >= argc) usage();
    if (!strcmp(argv[i], "--unix")) g_unix = argv[++i];
    else if (!strcmp(argv[i], "--tcp")) tcp = argv[++i];
    else if (!strcmp(argv[i], "--path")) g_path = argv[++i];
    else if (!strcmp(argv[i], "-c")) conns = atoi(argv[++i]);
    else if (!strcmp(argv[i], "-t")) threads = atoi(argv[++i]);
    else if (!strcmp(argv[i], "-d")) duration = atof(argv[++i]);
    else if (!strcmp(argv[i], "--timeout")) timeout = atof(argv[++i]);
    else usage();
  }
  if (!!g_unix == !!tcp || conns < 1 || threads < 1) usage();
  if (g_unix) {
    struct sockaddr_un* un = (struct sockaddr_un*)&g_addr;
    un->sun_family = AF_UNIX;
    snprintf(un->sun_path, sizeof un->sun_path, "%s", g_unix);
    g_addrlen = sizeof *un;
  } else {
    char host[256];
    snprintf(host, sizeof host, "%s", tcp);
    char* colon = strrchr(host, ':');
    if (!colon) usage();
    *colon = 0;
    struct addrinfo hints = {.ai_socktype = SOCK_STREAM}, *ai;
    if (getaddrinfo(host, colon + 1, &hints, &ai) != 0) usage();
    memcpy(&g_addr, ai->ai_addr, ai->ai_addrlen);
    g_addrlen = ai->ai_addrlen;
    freeaddrinfo(ai);
  }
  int sse = strcmp(mode, "sse") == 0;
  g_request_len = (size_t)snprintf(g_request, sizeof g_request,
                                   "GET %s HTTP/1.1\r\nHost: localhost\r\nUser-Agent: rsd-load\r\n%s\r\n", g_path,
                                   sse ? "Accept: text/event-stream\r\n" : "");
  if (!strcmp(mode, "http")) return run_http(conns, threads, duration);
  if (sse) return run_sse(conns, timeout);
  usage();
  return 2;
}
