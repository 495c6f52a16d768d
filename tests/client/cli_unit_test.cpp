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

}  // namespace
