// The samples a device lost, from the sample indices of the samples kept, in the order they were
// written: the recorder counts them live, and a crashed recording's recovery counts them again
// from the raw messages, the same way.
//
// A step forward by more than one is a loss; an index that goes back is a restarted stream and
// adds nothing. One index out of line with its neighbours (the next sample continues the index
// before it, and this one lies beyond the next or behind the one before) is damaged: it passed
// the frame's check (an 8-bit sum, as Xsens frames carry, lets one in 256 multi-byte errors
// through). What its step added is taken back and it takes the place after the index before
// it, so 100, 1000101, 102 counts no loss where it counted a million, and 100, 5, 102 none
// where it counted 96. Not told apart: two indices swapped in transit (100, 102, 101, 103
// counts 1 lost, where nothing was; 2 before the repair), and a damaged first index.
#pragma once

#include <algorithm>
#include <cstdint>

namespace imukit::capture {

class SequenceGaps {
 public:
  struct Step {
    // The sample continues the index before it (as repaired): its step, a loss when above one.
    bool forward = false;
    uint64_t index_step = 0;
    // The index before it was found damaged: the step that index made as it arrived (0 unless
    // forward) and as repaired.
    bool repaired_previous = false;
    uint64_t previous_step = 0, previous_repaired_step = 0;
  };

  // The next sample's index; `refused`: samples the recorder's queue refused just before it
  // (its own loss, counted apart from the device's).
  Step add(uint64_t index, uint64_t refused = 0) {
    Step step;
    if (kept_++ == 0) {
      last_ = index;
      last_refused_ = refused;
      return step;
    }
    uint64_t from = last_;
    if (kept_ > 2 && before_ < index && (last_ > index || last_ < before_)) {
      missing_ -= last_missing_;
      step.repaired_previous = true;
      step.previous_step = last_step_;
      // After the index before it, plus what the queue refused there; at most this index
      // (index > before_, so nothing here wraps).
      from = before_ + 1 + std::min(last_refused_, index - before_ - 1);
      step.previous_repaired_step = from - before_;
    }
    last_step_ = last_missing_ = 0;
    if (index > from) {
      const uint64_t lost = index - from - 1;
      last_missing_ = lost - std::min(lost, refused);
      missing_ += last_missing_;
      last_step_ = index - from;
      step.forward = true;
      step.index_step = last_step_;
    }
    before_ = from;
    last_ = index;
    last_refused_ = refused;
    return step;
  }

  uint64_t kept() const { return kept_; }
  uint64_t missing() const { return missing_; }

 private:
  uint64_t kept_ = 0, missing_ = 0;
  uint64_t before_ = 0;  // the index before the last, as repaired
  uint64_t last_ = 0;    // the last index, as it arrived
  // What the last sample's step added: its index step (0 unless forward), its loss, and the
  // samples the queue refused before it.
  uint64_t last_step_ = 0, last_missing_ = 0, last_refused_ = 0;
};

}  // namespace imukit::capture
