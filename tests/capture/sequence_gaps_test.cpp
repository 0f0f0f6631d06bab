#include "imukit/capture/sequence_gaps.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

namespace imukit::capture {
namespace {

// The samples missing after feeding these indices (no refusals).
uint64_t missing_after(const std::vector<uint64_t>& indices) {
  SequenceGaps g;
  for (const uint64_t i : indices) g.add(i);
  EXPECT_EQ(g.kept(), indices.size());
  return g.missing();
}

TEST(SequenceGaps, CountsStepsOfMoreThanOneAndNothingForARestart) {
  EXPECT_EQ(missing_after({}), 0u);
  EXPECT_EQ(missing_after({7}), 0u);
  EXPECT_EQ(missing_after({0, 1, 2, 3}), 0u);
  EXPECT_EQ(missing_after({0, 1, 5, 6, 10}), 3u + 3u);
  // A restart (the counter begins again) adds nothing, and the counting goes on after it.
  EXPECT_EQ(missing_after({5000, 5001, 0, 1, 3}), 1u);
  // A repeated index is no loss, and the step after it counts from it.
  EXPECT_EQ(missing_after({100, 101, 101, 102, 104}), 1u);
}

// Found in review (2026-11-27): one damaged index that passed the frame's check counted up to
// its whole jump as lost (a million for 100, 1000101, 102) or, jumping back, the way back up.
TEST(SequenceGaps, ALoneDamagedIndexIsTakenBack) {
  EXPECT_EQ(missing_after({99, 100, 1'000'101, 102, 103}), 0u);
  EXPECT_EQ(missing_after({99, 100, 5, 102, 103}), 0u);
  // The damaged sample takes the place after the one before it: a loss after it still counts.
  EXPECT_EQ(missing_after({99, 100, 1'000'101, 150}), 48u);
  EXPECT_EQ(missing_after({99, 100, 5, 150}), 48u);
  // From the second sample on; the first has nothing before it to continue, so a damaged first
  // index cannot be told from a loss after it.
  EXPECT_EQ(missing_after({100, 1'000'101, 102}), 0u);
  EXPECT_EQ(missing_after({5, 101, 102}), 95u);
  // Two indices swapped in transit: one counted lost where none was (a known limit).
  EXPECT_EQ(missing_after({100, 102, 101, 103}), 1u);
  // Near the top of the range with refusals: nothing wraps.
  SequenceGaps top;
  top.add(~uint64_t{0} - 3);
  top.add(0, 5);
  top.add(~uint64_t{0});
  EXPECT_LE(top.missing(), 2u);

  SequenceGaps g;
  g.add(99);
  g.add(100);
  const SequenceGaps::Step jump = g.add(1'000'101);
  EXPECT_TRUE(jump.forward);
  EXPECT_EQ(jump.index_step, 1'000'001u);
  EXPECT_EQ(g.missing(), 1'000'000u);
  const SequenceGaps::Step next = g.add(102);
  EXPECT_TRUE(next.repaired_previous);
  EXPECT_EQ(next.previous_step, 1'000'001u);
  EXPECT_EQ(next.previous_repaired_step, 1u);
  EXPECT_TRUE(next.forward);
  EXPECT_EQ(next.index_step, 1u);
  EXPECT_EQ(g.missing(), 0u);
  // Behind the one before it: it had added no step.
  SequenceGaps low;
  low.add(99);
  low.add(100);
  EXPECT_FALSE(low.add(5).forward);
  const SequenceGaps::Step after = low.add(102);
  EXPECT_TRUE(after.repaired_previous);
  EXPECT_EQ(after.previous_step, 0u);
  EXPECT_EQ(after.previous_repaired_step, 1u);
  EXPECT_EQ(after.index_step, 1u);
}

TEST(SequenceGaps, TheRecordersRefusalsAreNotTheDevicesLoss) {
  SequenceGaps g;
  g.add(0);
  g.add(10, 4);  // 9 missing, 4 of them refused by the queue
  EXPECT_EQ(g.missing(), 5u);
  // A damaged index with 3 refused before it: it sits after them, and the 2 after it that the
  // next index skips are the device's.
  SequenceGaps d;
  d.add(0);
  d.add(1);
  d.add(70'000, 3);
  d.add(8);
  EXPECT_EQ(d.missing(), 8u - (1u + 1u + 3u) - 1u);
}

}  // namespace
}  // namespace imukit::capture
