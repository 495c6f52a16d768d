// The route table's matcher (daemon/api/routes.cpp): the same choice as httplib makes
// with the regexes it registers, the blocking pool's choice, and Allow.
#include "api/routes.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <regex>
#include <set>
#include <vector>

using namespace rsd::api;

namespace {

// What httplib does with the registered regexes: the first match, most literal first.
const Route* httplib_choice(const std::string& path) {
  std::vector<const Route*> order;
  for (const auto& r : routes()) order.push_back(&r);
  std::stable_sort(order.begin(), order.end(),
                   [](const Route* a, const Route* b) { return literal_length(*a) > literal_length(*b); });
  for (const Route* r : order)
    if (std::regex_match(path, std::regex(route_regex(*r)))) return r;
  return nullptr;
}

}  // namespace

TEST(ApiRoutes, ReadOnlyAndEachPatternOnce) {
  std::set<std::string_view> patterns;
  for (const auto& r : routes()) {
    EXPECT_EQ(r.method, "GET") << r.pattern;
    EXPECT_TRUE(patterns.insert(r.pattern).second) << r.pattern;
    EXPECT_NE(r.handler, nullptr) << r.pattern;
  }
}

TEST(ApiRoutes, MatcherChoosesAsTheRegistrationDoes) {
  for (const std::string path :
       {"/", "", "/v1/devices", "/v1/devices/", "/v1/devices/a", "/v1/devices/realsense/D455_1",
        "/v1/devices/a/description", "/v1/devices//description", "/v1/devices/description",
        "/v1/devices/a/description/x", "/v1/devices/a\nb", "/v1/devices/a\r", "/v1/devices/\n/description",
        "/metricsx", "/metrics", "/openapi.yaml", "/openapiXyaml", "/v1/events", "/v1/events/", "/healthz",
        "/v1/domains", "/v1/participants", "/v2/devices", "//v1/devices"})
    EXPECT_EQ(match_route(path), httplib_choice(path)) << path;
  ASSERT_NE(match_route("/v1/devices/a/description"), nullptr);
  EXPECT_EQ(match_route("/v1/devices/a/description")->pattern, "/v1/devices/{id}/description");
  EXPECT_EQ(match_route("/v1/devices/realsense/D455_1")->pattern, "/v1/devices/{id}");
  EXPECT_EQ(match_route("/v1/devices/"), nullptr);  // an id is never empty
}

TEST(ApiRoutes, OnlyCameraDiscoveryGoesToTheBlockingPool) {
  EXPECT_TRUE(blocking_target("/v1/devices/a/description"));
  EXPECT_TRUE(blocking_target("/v1/devices/realsense/D455_1/description?x=1"));
  // Decoded as httplib decodes it before routing: this is the description route too.
  EXPECT_TRUE(blocking_target("/v1/devices/a%2Fdescription"));
  EXPECT_TRUE(blocking_target("/v1/devices/a%2fb/description"));
  EXPECT_FALSE(blocking_target("/v1/devices/a"));
  EXPECT_FALSE(blocking_target("/v1/devices?name=description"));
  EXPECT_FALSE(blocking_target("/foo/description"));  // a 404, at once
  EXPECT_FALSE(blocking_target("/v1/devices/%"));
  EXPECT_FALSE(blocking_target(""));
}

TEST(ApiRoutes, AllowNamesTheRoutesMethods) {
  EXPECT_EQ(allowed_methods("/v1/devices"), "GET, HEAD");
  EXPECT_EQ(allowed_methods("/v1/devices/x/description"), "GET, HEAD");
  EXPECT_EQ(allowed_methods("/nowhere"), "GET, HEAD");  // every route's
}
