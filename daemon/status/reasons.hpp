// Why the DDS source drops a device-info message or refuses a writer: the keys of
// a domain's `rejected` and `writers-refused` (/v1/domains) and the `reason` labels
// of /metrics, which shows every one at 0 from the start (a counter that appears
// only at its first increment is invisible to rate() and increase()). The DDS
// source gives these and no others; the API reads them here, so neither includes
// the other's headers.
#pragma once

namespace rsd {

// parse_device_info()'s (dds/device_info.hpp); parse_flexible() gives the first ones.
inline constexpr const char* kParseRejectReasons[] = {
    "unknown-format", "custom-format", "too-large", "empty",        "invalid-utf8",
    "not-json",       "bad-cbor",      "too-deep",  "not-object",   "missing-name",
    "missing-topic-root"};

// The domain's bookkeeping (dds/domain_book.cpp): beyond a device cap, or sent by a
// writer a writer cap refused.
inline constexpr const char* kParticipantDeviceLimit = "participant-device-limit";
inline constexpr const char* kDomainDeviceLimit = "domain-device-limit";
inline constexpr const char* kRefusedWriter = "refused-writer";
inline constexpr const char* kBookRejectReasons[] = {kParticipantDeviceLimit, kDomainDeviceLimit, kRefusedWriter};

// Writers refused by a writer cap (dds/domain_book.cpp).
inline constexpr const char* kParticipantWriterLimit = "participant-writer-limit";
inline constexpr const char* kDomainWriterLimit = "domain-writer-limit";
inline constexpr const char* kWriterRefusedReasons[] = {kParticipantWriterLimit, kDomainWriterLimit};

// Endpoints (readers and writers of any topic) refused by an endpoint cap, or kept
// without their topic (dds/endpoint_book.cpp).
inline constexpr const char* kParticipantEndpointLimit = "participant-endpoint-limit";
inline constexpr const char* kDomainEndpointLimit = "domain-endpoint-limit";
inline constexpr const char* kTopicNameTooLong = "topic-name-too-long";
inline constexpr const char* kDomainTopicLimit = "domain-topic-limit";
inline constexpr const char* kEndpointRefusedReasons[] = {kParticipantEndpointLimit, kDomainEndpointLimit,
                                                           kTopicNameTooLong, kDomainTopicLimit};

}  // namespace rsd
