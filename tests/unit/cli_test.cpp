// Unit tests of rs-discover's pure helpers: what the AGE column and `doctor` read
// from the daemon's timestamps, checked against the C library's own calendar.
#include "common.hpp"

#include <gtest/gtest.h>

#include <ctime>

namespace {

double by_libc(int y, int mo, int d, int h, int mi, int s) {
  std::tm tm{};
  tm.tm_year = y - 1900;
  tm.tm_mon = mo - 1;
  tm.tm_mday = d;
  tm.tm_hour = h;
  tm.tm_min = mi;
  tm.tm_sec = s;
  return static_cast<double>(timegm(&tm));
}

TEST(ParseIso8601, AgreesWithTimegmOverTheCalendar) {
  for (int y : {1970, 1999, 2000, 2024, 2026, 2100})
    for (int mo : {1, 2, 3, 12})
      for (int d : {1, 28, 29})
        for (int h : {0, 13, 23}) {
          if (mo == 2 && d == 29 && !((y % 4 == 0 && y % 100 != 0) || y % 400 == 0)) continue;
          char text[40];
          std::snprintf(text, sizeof text, "%04d-%02d-%02dT%02d:%02d:%02d.250Z", y, mo, d, h, 7, 59);
          const auto got = rsdiscover::parse_iso8601(text);
          ASSERT_TRUE(got) << text;
          EXPECT_DOUBLE_EQ(*got, by_libc(y, mo, d, h, 7, 59) + 0.25) << text;
        }
}

TEST(ParseIso8601, OffsetsFractionsAndNoZone) {
  const double utc = by_libc(2026, 11, 24, 10, 9, 54);
  EXPECT_DOUBLE_EQ(*rsdiscover::parse_iso8601("2026-11-24T10:09:54Z"), utc);
  EXPECT_DOUBLE_EQ(*rsdiscover::parse_iso8601("2026-11-24T10:09:54"), utc);
  EXPECT_DOUBLE_EQ(*rsdiscover::parse_iso8601("2026-11-24T10:09:54.065Z"), utc + 0.065);
  EXPECT_DOUBLE_EQ(*rsdiscover::parse_iso8601("2026-11-24T12:09:54+02:00"), utc);
  EXPECT_DOUBLE_EQ(*rsdiscover::parse_iso8601("2026-11-24T04:39:54-05:30"), utc);
}

TEST(ParseIso8601, RefusesWhatIsNotADate) {
  for (const char* bad : {"", "-", "yesterday", "2026-11-24", "2026-11-24T10:09", "2026-13-01T00:00:00Z",
                          "2026-02-30T00:00:00Z", "2026-11-24T24:00:00Z", "2026-11-24 10:09:54Z",
                          "20x6-11-24T10:09:54Z", "2026-11-24T10:09:54+"})
    EXPECT_FALSE(rsdiscover::parse_iso8601(bad)) << bad;
}

TEST(Template, NestedFieldsListsAndBraces) {
  const auto doc = rsdiscovery::json::parse_or_null(R"({"serial": "123", "domain": 5, "recovery": false,
      "server": {"addresses": ["10.0.0.1", "10.0.0.2"], "participant-name": "srv"}, "warnings": []})");
  ASSERT_TRUE(doc.IsObject());
  const rsdiscover::Template t("{serial}\\t{server.addresses} {domain} {recovery} {server.participant-name} "
                               "[{warnings}] [{usb.port-path}] {{x}}",
                               rsdiscover::device_fields());
  t.check({&doc});
  EXPECT_EQ(t.render(doc), "123\t10.0.0.1,10.0.0.2 5 false srv [] [] {x}");
  EXPECT_EQ(rsdiscover::Template("{state}", {"state"}).render(doc, [](const std::string& f) {
    return f == "state" ? std::optional<std::string>("ok") : std::nullopt;
  }), "ok");
}

// Numbers and control characters laid out as the daemon writes them: RapidJSON's own
// writer gives 0.000001, 10000000000000000.0 and \u001F. The digits are the shortest
// that read back: 7.87e+21 where nlohmann's Grisu2 wrote 7.870000000000001e+21, the
// same double.
TEST(Template, NumbersAndEscapesAreWrittenAsTheDaemonWritesThem) {
  const auto doc = rsdiscovery::json::parse_or_null(R"({"step": 1e-06, "big": 1e+16, "near": 7.870000000000001e+21,
      "mid": 0.001, "whole": 1500.0, "range": [9.999999974752427e-07, 0.01], "o": {"k": "a\u001fb\n"},
      "small": -0.0001, "neg": -2.5e-300, "zero": -0.0})");
  ASSERT_TRUE(doc.IsObject());
  const rsdiscover::Template t("{step} {big} {near} {mid} {whole} {range} {o} {small} {neg} {zero}",
                              rsdiscover::device_fields());
  t.check({&doc});
  EXPECT_EQ(t.render(doc), "1e-06 1e+16 7.87e+21 0.001 1500.0 9.999999974752427e-07,0.01 "
                           "{\"k\":\"a\\u001fb\\n\"} -0.0001 -2.5e-300 -0.0");
  EXPECT_EQ(std::stod("7.87e+21"), 7.870000000000001e+21);
}

// A GUID or a name may hold what reads as a long exponent ("e2345"): only numbers are
// refused for one.
TEST(Template, AnExponentInAStringIsNoNumber) {
  const auto doc = rsdiscovery::json::parse_or_null(R"({"guid": "010f78fd.1e2345ab", "name": "cube1234"})");
  ASSERT_TRUE(doc.IsObject());
  EXPECT_EQ(rsdiscover::Template("{guid} {name}", {}).render(doc), "010f78fd.1e2345ab cube1234");
  EXPECT_TRUE(rsdiscovery::json::parse_or_null(R"({"guid": "x", "n": 1e12345})").IsNull());
}

TEST(Template, AnUnknownFieldNamesTheKnownOnes) {
  const auto doc = rsdiscovery::json::parse_or_null(R"({"serial": "123", "custom": {"deep": 1}})");
  ASSERT_TRUE(doc.IsObject());
  const rsdiscover::Template unknown("{seria}", rsdiscover::device_fields());
  try {
    unknown.check({&doc});
    FAIL() << "no error";
  } catch (const rsdiscover::UsageError& e) {
    EXPECT_NE(std::string(e.what()).find("unknown field '{seria}'"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("{serial}, "), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("{server.addresses}"), std::string::npos) << e.what();
  }
  // A key a document has, though undocumented, is a field.
  const rsdiscover::Template custom("{custom.deep}", rsdiscover::device_fields());
  EXPECT_NO_THROW(custom.check({&doc}));
  EXPECT_EQ(custom.render(doc), "1");
  EXPECT_THROW(rsdiscover::Template("{serial", {}), rsdiscover::UsageError);
  EXPECT_THROW(rsdiscover::Template("serial}", {}), rsdiscover::UsageError);
}

}  // namespace
