// The pure guards in front of the API: where a request ends (and when it is too
// big), which Host headers HTTP answers, and If-None-Match against an ETag.
#include "api/format.hpp"
#include "api/host_check.hpp"
#include "api/request_head.hpp"

#include <gtest/gtest.h>

#include <string>

using rsd::api::HeadLimits;
using rsd::api::HeadVerdict;
using rsd::api::HostCheck;
using rsd::api::scan_request_head;

TEST(RequestHead, CompleteWhenTheBlankLineArrives) {
  const std::string req = "GET /v1/devices?domain=0 HTTP/1.1\r\nHost: localhost\r\n\r\nGET /next";
  const auto scan = scan_request_head(req, {});
  EXPECT_EQ(scan.verdict, HeadVerdict::complete);
  EXPECT_EQ(scan.head_length, req.find("GET /next"));
  EXPECT_EQ(scan.body_length, 0u);
  EXPECT_EQ(scan.target, "/v1/devices?domain=0");
  // Bare LF line ends, as httplib accepts them.
  EXPECT_EQ(scan_request_head("GET / HTTP/1.1\nHost: x\n\n", {}).verdict, HeadVerdict::complete);
}

TEST(RequestHead, EveryPrefixIsIncompleteAndResumingGivesTheSameAnswer) {
  const std::string req = "GET /healthz HTTP/1.1\r\nHost: localhost\r\nAccept: */*\r\n\r\n";
  std::size_t resume = 0;
  for (std::size_t n = 0; n < req.size(); ++n) {
    const auto scan = scan_request_head(std::string_view(req).substr(0, n), {}, resume);
    ASSERT_EQ(scan.verdict, HeadVerdict::incomplete) << n;
    resume = scan.scanned;
  }
  const auto done = scan_request_head(req, {}, resume);
  EXPECT_EQ(done.verdict, HeadVerdict::complete);
  EXPECT_EQ(done.head_length, req.size());
}

TEST(RequestHead, ABodyBelongsToItsRequest) {
  const std::string req = "POST /v1/devices HTTP/1.1\r\ncontent-LENGTH: 3\r\n\r\nabc";
  const auto scan = scan_request_head(req, {});
  EXPECT_EQ(scan.verdict, HeadVerdict::complete);
  EXPECT_EQ(scan.head_length + scan.body_length, req.size());
  EXPECT_EQ(scan_request_head("POST / HTTP/1.1\r\nContent-Length: -5\r\n\r\n", {}).verdict, HeadVerdict::bad_request);
  EXPECT_EQ(scan_request_head("POST / HTTP/1.1\r\nContent-Length: 99999999999999999999\r\n\r\n", {}).verdict,
            HeadVerdict::bad_request);
  EXPECT_EQ(scan_request_head("POST / HTTP/1.1\r\nContent-Length: 70000\r\n\r\n", {}).verdict,
            HeadVerdict::body_too_large);
}

TEST(RequestHead, TooLongLinesAndHeadsAreRefusedWithoutWaitingForTheEnd) {
  HeadLimits limits;
  limits.max_request_line = 100;
  limits.max_head = 400;
  EXPECT_EQ(scan_request_head("GET /" + std::string(200, 'a'), limits).verdict, HeadVerdict::uri_too_long);
  EXPECT_EQ(scan_request_head("GET /" + std::string(200, 'a') + " HTTP/1.1\r\n\r\n", limits).verdict,
            HeadVerdict::uri_too_long);
  std::string big = "GET / HTTP/1.1\r\n";
  while (big.size() < 500) big += "X-Filler: bbbbbbbbbbbbbbbbbbbb\r\n";
  EXPECT_EQ(scan_request_head(big, limits).verdict, HeadVerdict::head_too_large);
  EXPECT_EQ(scan_request_head(big + "\r\n", limits).verdict, HeadVerdict::head_too_large);
  // Right at the limits: still a request.
  EXPECT_EQ(scan_request_head("GET /" + std::string(80, 'a') + " HTTP/1.1\r\n\r\n", limits).verdict,
            HeadVerdict::complete);
}

TEST(HostCheck, LoopbackListenerAnswersItsAddressAndLocalhostOnly) {
  const HostCheck check({"127.0.0.1"}, false, {});
  for (const char* ok : {"localhost", "localhost:8035", "LocalHost", "localhost.", "127.0.0.1", "127.0.0.1:8035", ""})
    EXPECT_TRUE(check.allows(ok)) << ok;
  for (const char* bad : {"evil.example", "evil.example:8035", "127.0.0.1.evil.example", "127.0.0.2", "[::1]",
                          "localhost.evil.example", "[broken"})
    EXPECT_FALSE(check.allows(bad)) << bad;
}

TEST(HostCheck, WildcardListenerAnswersAnyAddressButNoForeignName) {
  const HostCheck check({"0.0.0.0"}, true, {"cams.lab.example"});
  for (const char* ok : {"192.0.2.7", "192.0.2.7:8035", "[fe80::1]:8035", "cams.lab.example", "CAMS.lab.example:1"})
    EXPECT_TRUE(check.allows(ok)) << ok;
  EXPECT_FALSE(check.allows("evil.example"));
}

TEST(HostCheck, StarTurnsItOffAndTheDefaultIsOff) {
  EXPECT_TRUE(HostCheck({"127.0.0.1"}, false, {"*"}).allows("evil.example"));
  EXPECT_FALSE(HostCheck({"127.0.0.1"}, false, {"*"}).enabled());
  EXPECT_TRUE(HostCheck().allows("evil.example"));  // the Unix socket's
  EXPECT_TRUE(HostCheck({"::1"}, false, {}).allows("[::1]:8035"));
  // A socket systemd passed: configured for one address, bound to another.
  const HostCheck passed({"127.0.0.1", "127.0.0.2"}, false, {});
  EXPECT_TRUE(passed.allows("127.0.0.2:8035"));
}

TEST(ETag, IfNoneMatchListsAndWeakTags) {
  using rsd::api::etag_matches;
  EXPECT_TRUE(etag_matches("\"42\"", "\"42\""));
  EXPECT_TRUE(etag_matches("\"1\", W/\"42\"", "\"42\""));
  EXPECT_TRUE(etag_matches("*", "\"42\""));
  EXPECT_FALSE(etag_matches("\"42-partial\"", "\"42\""));
  EXPECT_FALSE(etag_matches("", "\"42\""));
  EXPECT_FALSE(etag_matches("42", "\"42\""));
}
