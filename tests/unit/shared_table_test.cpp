// SharedTable's change hooks: every frontend that waits on the table (the API's
// loops, the service's STATUS=) is woken by each change, and a removed hook never
// runs again, so the object it points to may go.
#include "table/shared_table.hpp"

#include <gtest/gtest.h>

namespace {

nlohmann::json camera(const std::string& name) {
  return {{"name", name}, {"serial", "123"}, {"source", "dds"}, {"topic-root", "realsense/" + name}};
}

TEST(SharedTableHooks, EveryHookRunsOnEachChangeUntilRemoved) {
  rsd::SharedTable table;
  int api = 0, service = 0;
  const auto first = table.add_change_hook([&] { ++api; });
  table.add_change_hook([&] { ++service; });
  ASSERT_TRUE(table.upsert("a", camera("a")));
  EXPECT_EQ(api, 1);
  EXPECT_EQ(service, 1);

  table.remove_change_hook(first);
  ASSERT_TRUE(table.upsert("a", camera("renamed")));
  EXPECT_EQ(api, 1) << "a removed hook ran";
  EXPECT_EQ(service, 2);
}

TEST(SharedTableHooks, NoChangeRunsNoHook) {
  rsd::SharedTable table;
  int runs = 0;
  table.add_change_hook([&] { ++runs; });
  ASSERT_TRUE(table.upsert("a", camera("a")));
  EXPECT_FALSE(table.remove("never-listed", rsd::model::RemovalReason::stopping));
  EXPECT_EQ(runs, 1);
}

}  // namespace
