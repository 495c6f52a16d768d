// The log's lazy forms build a message only when its level is on, and the domain
// prefix is the one every "domain N:" line starts with.
#include "log/log.hpp"

#include <gtest/gtest.h>

namespace {

struct LevelGuard {
  ~LevelGuard() { rsd::log::set_level(rsd::log::Level::info); }
};

TEST(Log, LazyMessageIsBuiltOnlyWhenItsLevelIsOn) {
  LevelGuard restore;
  int built = 0;
  auto message = [&] {
    ++built;
    return std::string("built");
  };
  rsd::log::set_level(rsd::log::Level::info);
  rsd::log::debug(message);
  EXPECT_EQ(built, 0);
  rsd::log::info(message);
  EXPECT_EQ(built, 1);
  rsd::log::set_level(rsd::log::Level::debug);
  rsd::log::debug(message);
  EXPECT_EQ(built, 2);
  rsd::log::set_level(rsd::log::Level::error);
  rsd::log::write(rsd::log::Level::warning, message);
  EXPECT_EQ(built, 2);
}

TEST(Log, DomainPrefix) {
  EXPECT_EQ(rsd::log::domain_prefix(0), "domain 0: ");
  EXPECT_EQ(rsd::log::domain_prefix(232), "domain 232: ");
}

}  // namespace
