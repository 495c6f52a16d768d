// Files the daemon serves from inside its binary, so they always match it: the
// web page (daemon/api/web/index.html, GET /) and the API spec
// (proto/openapi.yaml, GET /openapi.yaml). Made at build time by cmake/embed.cmake.
#pragma once

#include <string_view>

namespace rsd::embedded {

extern const std::string_view web_page;
extern const std::string_view openapi_yaml;

}  // namespace rsd::embedded
