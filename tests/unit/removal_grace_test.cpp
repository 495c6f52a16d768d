// DomainBook's removal grace and its lease losses, driven with made-up writers and
// times: a device whose server's lease ran out stays listed, unresponsive, until the
// grace ends; announced again by then it is kept; every lease-expired removal is
// handed on for its host to be probed.
#include "dds/domain_book.hpp"

#include "book_sightings.hpp"

#include <gtest/gtest.h>

using namespace std::chrono_literals;
using book_test::id;
using book_test::info;
using book_test::writer;
using rsd::dds::BookOptions;
using rsd::dds::DomainBook;

namespace {
const DomainBook::Clock::time_point t0{};

BookOptions with_grace(std::chrono::milliseconds grace) {
  BookOptions o;
  o.domain = 7;
  o.removal_grace = grace;
  return o;
}

// Camera 100 announced by writer 1 at t0, its participant's lease lost at t0 + 1 s.
void announce_then_lose_by_lease(DomainBook& book) {
  book.writer_matched(1, writer(1, 1), t0);
  book.sample(1, info("100"));
  book.participant_gone(writer(1, 1).participant_guid, t0 + 1s);
}
}  // namespace

TEST(RemovalGrace, HeardAgainWithinTheGraceIsKeptAndUnmarked) {
  rsd::SharedTable table;
  DomainBook book(table, with_grace(5s));
  announce_then_lose_by_lease(book);
  book.writer_left(1, {}, t0 + 1s);  // its writer goes with it: the grace still decides
  auto dev = table.find(id("100"));
  ASSERT_TRUE(dev);
  EXPECT_EQ((*dev)["unresponsive"], true);
  book.tick(t0 + 5900ms, {});
  EXPECT_TRUE(table.find(id("100")));
  book.writer_matched(1, writer(1, 1), t0 + 5s);
  book.sample(1, info("100"));
  dev = table.find(id("100"));
  ASSERT_TRUE(dev);
  EXPECT_FALSE(dev->contains("unresponsive"));
  book.tick(t0 + 20s, {1});
  EXPECT_TRUE(table.find(id("100")));
  EXPECT_EQ(table.counts().removals[static_cast<std::size_t>(rsd::model::RemovalReason::lease_expired)], 0u);
  EXPECT_TRUE(book.take_lease_losses().empty());
}

TEST(RemovalGrace, NotHeardAgainIsRemovedByLeaseWhenTheGraceEnds) {
  rsd::SharedTable table;
  DomainBook book(table, with_grace(5s));
  announce_then_lose_by_lease(book);
  book.tick(t0 + 5900ms, {});
  EXPECT_TRUE(table.find(id("100")));
  book.tick(t0 + 6s, {});
  EXPECT_FALSE(table.find(id("100")));
  const auto gone = table.find_gone(id("100"));
  ASSERT_TRUE(gone);
  EXPECT_EQ(gone->reason, rsd::model::RemovalReason::lease_expired);
  const auto losses = book.take_lease_losses();
  ASSERT_EQ(losses.size(), 1u);
  EXPECT_EQ(losses[0].entry_id, id("100"));
  EXPECT_EQ(losses[0].generation, gone->generation);
  EXPECT_EQ(losses[0].addresses, writer(1, 1).addresses);
}

TEST(RemovalGrace, WithoutItTheLeaseRemovesAtOnceAndTheLossIsHandedOn) {
  rsd::SharedTable table;
  DomainBook book(table, with_grace(0ms));
  announce_then_lose_by_lease(book);
  EXPECT_FALSE(table.find(id("100")));
  EXPECT_EQ(book.take_lease_losses().size(), 1u);
  EXPECT_TRUE(book.take_lease_losses().empty());  // taken once
}

TEST(RemovalGrace, HeardAgainButNotItsDeviceYetIsKeptOnceMore) {
  // A lossy link: the server's participant is heard again within the grace, but the
  // refresh and the new reader that bring its device-info back take longer.
  rsd::SharedTable table;
  DomainBook book(table, with_grace(5s));
  announce_then_lose_by_lease(book);
  book.participant_alive(writer(1, 1).participant_guid, t0 + 3s);
  book.participant_made();  // the refresh that follows: the new participant has not heard it yet
  book.tick(t0 + 6s, {});
  auto dev = table.find(id("100"));
  ASSERT_TRUE(dev);
  EXPECT_EQ((*dev)["unresponsive"], true);
  EXPECT_EQ(book.next_deadline(t0 + 6s).value_or(t0), t0 + 6s + with_grace(5s).heard_again_grace);
  book.writer_matched(1, writer(1, 1), t0 + 8s);
  book.sample(1, info("100"));
  book.tick(t0 + 20s, {1});
  dev = table.find(id("100"));
  ASSERT_TRUE(dev);
  EXPECT_FALSE(dev->contains("unresponsive"));
  EXPECT_EQ(table.counts().removals[static_cast<std::size_t>(rsd::model::RemovalReason::lease_expired)], 0u);
}

TEST(RemovalGrace, HeardAgainButNeverItsDeviceIsRemovedAfterTheSecondGrace) {
  rsd::SharedTable table;
  DomainBook book(table, with_grace(5s));
  announce_then_lose_by_lease(book);
  book.participant_alive(writer(1, 1).participant_guid, t0 + 3s);
  book.tick(t0 + 6s, {});
  const auto second_end = t0 + 6s + with_grace(5s).heard_again_grace;
  book.tick(second_end - 1ms, {});
  EXPECT_TRUE(table.find(id("100")));
  book.tick(second_end, {});  // extended once only
  EXPECT_FALSE(table.find(id("100")));
  EXPECT_EQ(table.find_gone(id("100"))->reason, rsd::model::RemovalReason::lease_expired);
}

TEST(RemovalGrace, HeardAgainInEachExtensionIsKeptAFewTimesAtMost) {
  // A link that keeps losing the server: each time it is heard again the grace goes
  // on, a few times; a server heard for ever without its device cannot keep it.
  rsd::SharedTable table;
  const auto options = with_grace(5s);
  DomainBook book(table, options);
  announce_then_lose_by_lease(book);
  auto end = t0 + 6s;
  for (int i = 0; i < DomainBook::kMaxGraceExtensions; ++i) {
    book.participant_alive(writer(1, 1).participant_guid, end - 1s);
    book.participant_gone(writer(1, 1).participant_guid, end - 500ms);  // lost again
    book.tick(end, {});
    ASSERT_TRUE(table.find(id("100"))) << i;
    end += options.heard_again_grace;
  }
  book.participant_alive(writer(1, 1).participant_guid, end - 1s);
  book.tick(end, {});
  EXPECT_FALSE(table.find(id("100")));
  EXPECT_EQ(table.find_gone(id("100"))->reason, rsd::model::RemovalReason::lease_expired);
}
