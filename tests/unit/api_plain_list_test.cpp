// read_plain_list: which requests the daemon answers past httplib (PlainList).
// Everything it takes must be a request httplib reads the same way; everything
// else (whatever could change the answer's bytes) must be left to httplib.
#include "api/plain_list.hpp"

#include <gtest/gtest.h>

namespace {

using rsd::api::read_plain_list;

TEST(PlainList, APollersRequestIsOne) {
  auto p = read_plain_list("GET /v1/devices HTTP/1.1\r\nHost: localhost:8035\r\nUser-Agent: curl/7.88.1\r\n"
                           "Accept: */*\r\nIf-None-Match:  \"12\" \r\nconnection: close\r\n\r\n");
  ASSERT_TRUE(p);
  EXPECT_EQ(p->host, "localhost:8035");
  EXPECT_EQ(p->if_none_match, "\"12\"");
  EXPECT_TRUE(p->close);
  p = read_plain_list("GET /v1/devices HTTP/1.1\r\n\r\n");
  ASSERT_TRUE(p);
  EXPECT_EQ(p->host, "");
  EXPECT_FALSE(p->close);
  EXPECT_TRUE(read_plain_list("GET /v1/devices HTTP/1.1\r\nConnection: keep-alive\r\n\r\n"));
  // The project's own clients and Python's http.client say they take no encoding.
  EXPECT_TRUE(read_plain_list("GET /v1/devices HTTP/1.1\r\nHost: localhost\r\nAccept: application/json\r\n"
                              "Accept-Encoding: identity\r\nUser-Agent: rsdiscovery/0.9.0\r\n\r\n"));
}

TEST(PlainList, AnythingThatCouldChangeTheAnswerIsNot) {
  for (const char* request : {
           "GET /v1/devices?domain=0 HTTP/1.1\r\n\r\n",          // a filter
           "GET /v1/devices/ HTTP/1.1\r\n\r\n",                  // another path
           "GET /v1/devices HTTP/1.0\r\n\r\n",                   // keep-alive rules differ
           "HEAD /v1/devices HTTP/1.1\r\n\r\n",                  // no body
           "GET  /v1/devices HTTP/1.1\r\n\r\n",                  // odd spacing
           "GET /v1/devices HTTP/1.1\n\n",                       // bare LF
           "GET /v1/devices HTTP/1.1\r\nAccept-Encoding: gzip\r\n\r\n",
           "GET /v1/devices HTTP/1.1\r\nAccept-Encoding: identity, gzip\r\n\r\n",
           "GET /v1/devices HTTP/1.1\r\nRange: bytes=0-1\r\n\r\n",
           "GET /v1/devices HTTP/1.1\r\nContent-Length: 0\r\n\r\n",
           "GET /v1/devices HTTP/1.1\r\nTransfer-Encoding: chunked\r\n\r\n0\r\n\r\n",
           "GET /v1/devices HTTP/1.1\r\nHost: a\r\nHost: b\r\n\r\n",  // which one?
           "GET /v1/devices HTTP/1.1\r\nConnection: Close\r\n\r\n",   // httplib's rule is "close"
           "GET /v1/devices HTTP/1.1\r\nConnection: upgrade\r\n\r\n",
           "GET /v1/devices HTTP/1.1\r\nHost: a\r\n folded\r\n\r\n",
           "GET /v1/devices HTTP/1.1\r\nHost : a\r\n\r\n",
           "GET /v1/devices HTTP/1.1\r\nHost: caf\xc3\xa9\r\n\r\n",
           "GET /v1/devices HTTP/1.1\r\nHost: a\x01\r\n\r\n",
           "GET /v1/devices HTTP/1.1\r\nHost: a\r\n",            // not all there
           "GET /v1/devices HTTP/1.1\r\n\r\nGET /v1/devices HTTP/1.1\r\n\r\n",  // one at a time
       })
    EXPECT_FALSE(read_plain_list(request)) << request;
}

}  // namespace
