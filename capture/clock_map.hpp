// ClockMapper: maps a device's clock (ticks) to host time from the times at which its packets
// arrived, robust to receive jitter, and, where the device answers time-sync pings, corrects
// for the link latency as well.
//
// Model: host_receive = offset + (1 + skew) * device_time + latency + jitter, with jitter >= 0
// (a packet can be late, never early). The best line under every point is the lower envelope:
// the line that touches the lower convex hull of the (device_time, receive_time) points and
// minimises the total distance to them (Moon, Skelly & Towsley, "Estimation and removal of clock
// skew from network delay measurements", INFOCOM 1999). The hull is kept incrementally as points
// arrive in device-time order (amortised O(1) per packet), so the same code gives the online
// estimate during a recording and the offline fit over the whole file.
//
// The envelope maps a sample to "when it would have arrived with the smallest latency seen";
// the constant latency itself is invisible in receive times. A time-sync ping (host send time
// t1, device receive tick r, device transmit tick s, host receive time t2) measures it: with
// symmetric paths the device instant (r + s)/2 happened at host time (t1 + t2)/2. The ping with
// the shortest round trip is the least disturbed one and gives the latency correction.
//
// DeviceClock (below) runs one ClockMapper per stretch of unbroken device clock and gives the
// online times. Online times never go backwards. The fit moves while a recording runs: the
// first packets arrive late by the device's buffering and by jitter, and every packet that arrives
// with less delay than any before lowers the envelope (a ping lowers it by the latency). Stepping
// the time stamps with the fit would step them back, so the online map slews instead, as NTP
// slews a clock (RFC 5905, section 11.3): the next time is the previous one plus the device time
// elapsed (at the nominal tick rate), corrected toward the fit by at most kMaxSlew of that
// interval. Each interval between time stamps thus stays within +-kMaxSlew of the device's own,
// and the times meet the fit after (distance / kMaxSlew) of device time, then follow it exactly
// (the fitted skew, parts per million, is far inside the slew).
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <vector>

#include "imukit/core/time.hpp"

namespace imukit::capture {

struct ClockFit {
  std::size_t packets = 0;
  std::size_t rejected = 0;  // packets left out: tick going back, absurd host time
  // DeviceClock: stretches of unbroken device clock (a restart begins a new one; the figures
  // below are the longest's) and samples whose tick fitted neither (timed from their neighbours).
  std::size_t segments = 1;
  std::size_t outliers = 0;
  double skew_ppm = 0.0;              // device clock fast (> 0) or slow relative to the host
  double latency_correction_s = 0.0;  // subtracted from the envelope (0 without pings)
  bool ping_corrected = false;
  std::size_t pings = 0;
  double best_round_trip_s = 0.0;
  // Receive time minus the envelope over the most recent kJitterWindow packets: the receive
  // jitter above the fastest delivery (mean, standard deviation, maximum).
  double jitter_mean_s = 0.0;
  double jitter_std_s = 0.0;
  double jitter_max_s = 0.0;
};

class ClockMapper {
 public:
  static constexpr std::size_t kJitterWindow = 100'000;

  explicit ClockMapper(double tick_hz);

  // One packet: the (unwrapped) device tick of a sample it carried and when it reached the host.
  // Ticks should not decrease: a packet whose tick is before the last one's (a device that reset
  // its clock, a corrupt file) is left out of the fit and counted in ClockFit::rejected, as is
  // one whose host time is more than 2^63 ns from the first packet's.
  void add_packet(uint64_t device_ticks, TimeNs host_receive);
  // One sample of a packet: samples that arrived together (the same host time) form one packet,
  // and only its last sample, the one least delayed by the device's own buffering, enters the
  // fit (when the next packet begins, or at flush()).
  void add_sample(uint64_t device_ticks, TimeNs host_receive);
  void flush();
  // One time-sync exchange (ticks unwrapped on the same scale as the packets).
  void add_ping(TimeNs host_send, uint64_t device_receive_ticks, uint64_t device_transmit_ticks,
                TimeNs host_receive);

  // Host time of a device tick under the current fit; before two packets arrived, the first
  // packet's offset at the nominal rate. Non-decreasing in the tick: a fitted rate that is not
  // within a factor 2 of the nominal one (a host clock that stepped, a file replayed at once) is
  // replaced by the nominal rate, on the line of that slope under every packet (receive jitter
  // stays >= 0; a replay's samples end at the last one's arrival). Saturates at the int64 range for
  // ticks absurdly far from the first packet's.
  TimeNs map(uint64_t device_ticks) const;
  bool ready() const { return packets_ >= 2; }
  // Statistics of the fit (a pass over the kept residual samples: call at the end, or rarely).
  ClockFit fit() const;

 private:
  struct Point {
    double x;  // device seconds since the first packet
    double y;  // host seconds since the first packet
  };
  double device_seconds(uint64_t ticks) const;
  void refit() const;
  double estimate(double x) const;  // the fit at device seconds x, in host seconds since host0_
  TimeNs to_host(double y) const;   // host0_ + y seconds, saturated

  double tick_hz_;
  bool started_ = false;
  uint64_t tick0_ = 0;
  TimeNs host0_ = 0;
  std::size_t packets_ = 0;
  std::size_t rejected_ = 0;
  double last_packet_x_ = 0.0;
  double sum_x_ = 0.0;
  std::vector<Point> hull_;    // lower convex hull, x increasing
  std::vector<Point> recent_;  // ring of the last kJitterWindow packets, for the statistics
  std::size_t recent_next_ = 0;
  bool pending_ = false;  // add_sample's last sample, not yet in the fit
  uint64_t pending_ticks_ = 0;
  TimeNs pending_host_ = 0;
  // The ping with the shortest round trip so far (device mid-time, host mid-time).
  std::size_t pings_ = 0;
  double best_round_trip_s_ = 0.0;
  double best_ping_x_ = 0.0, best_ping_y_ = 0.0;
  // Lazily refreshed line y = a + b x and latency correction.
  mutable bool dirty_ = true;
  mutable double a_ = 0.0, b_ = 1.0;
  mutable std::optional<double> latency_s_;
};

// DeviceClock: one device's clock over a whole recording, through restarts and corrupt ticks.
//
// A device that restarts begins its tick counter again, and a tick damaged on the link (a text
// line's time stamp with a flipped digit) lands anywhere: fed to one ClockMapper, either stops the
// fit (every later packet "goes back") and freezes the online times. So every sample is first
// checked against the last one accepted: its tick must not go back, nor run ahead of the host
// time elapsed by more than kMaxLeadS (no packet arrives that much earlier than the one before
// it), unless its sample index says the same: a tick step that is the index step at the
// segment's own ticks per index (within half a period and kGapTolerance) is a gap, samples lost
// while the clock ran on, not a restart (a replay reads a gap of seconds in microseconds of host
// time; found in review: a replay's gaps of 1 s and more vanished from its time axis). Where the
// index counts every sample made (a device's counter: a loss is a jump in it), a tick step
// beyond the index step's is damaged whatever the host time allows, unless the host time since
// the last sample covers half of it and it runs ahead by at least half a 16-bit counter's range
// (a live loss longer than the counter's range, which it undercounts by a multiple of its range;
// a replay's host time never covers it). Found in review (2026-11-26, fourth
// round): a tick 0.8 s ahead in a 1 kHz replay passed as samples lost, the samples after it went
// back and began a new segment, and `record --duration 2` kept 1,201 samples. A counter that
// wraps within a plausible live loss (the Sony pads' 6 or 8 bits: 64 reports at 250 Hz) is no
// sample counter here: a stall delivers its buffered reports late, and the host time since the
// last of them does not cover the loss after it (the same review's second pass: a pad began a
// second segment and lost 0.284 s of 5.996; a bound from when the last sample was made instead,
// tried next, let damaged ticks through on a clock 100 ppm slow and after a host-time step).
// A count of the samples that arrived (a text
// stream's) cannot tell such a tick from samples lost and keeps the host-time rule alone. A sample
// that fails is an outlier: left out of the fit, and timed from the last accepted sample plus its
// place in the sequence (place_ticks: between the accepted samples on either side of it by its
// counter where it has one, else at the segment's mean sample period per sample that arrived).
// kRestartSamples outliers in a row that agree with each other are a restart: they begin a new
// segment, a new ClockMapper on their own clock. A segment's times begin no earlier than one sample
// period after the previous segment's last (where the host times cannot place it: a file replayed
// faster than it was recorded), so a recording's times run forward through restarts.
//
// The first sample of a recording has no rate to hold the next to: its second sample is taken
// on the host-time rule alone. So the outliers in a row that would be a restart continue the
// first segment instead where it holds at most two samples and they continue its first sample:
// their indices increase, and the first one's tick step from it is its index step at the run's
// own ticks per index (within half a period and kGapTolerance), which the second sample's is not.
// The second is then the outlier (a damaged tick), or the run bridges a gap right after the first
// sample. While that is open (a sample after the second by its index whose tick lies between the
// first's and the second's: one of the two is damaged), elapsed_s puts such a sample at its own
// tick. Found in review (same round): an Xsens replay with a tick 0.8 s ahead at sample 1 kept 3
// samples for `record --duration 2` (its samples after it were outliers at 0.801 s a sample).
// A second sample only a few periods ahead leaves fewer outliers than a restart before a sample
// follows it again; where those doubt the second and continue the first with that sample, they
// decide the same way (overturns_second). Found in review (2026-11-26): a second tick 1.5 periods
// ahead made sample 2 the outlier, and 2.5 periods samples 2 and 3, each timed 1.5-2.5 ms late.
//
// Samples are numbered in the order they are added (k = 0, 1, ...); the offline re-timing of a
// recording adds them all in a first pass and asks for their times by number in a second.
class DeviceClock {
 public:
  static constexpr double kMaxLeadS = 1.0;
  static constexpr double kGapTolerance = 1e-3;
  static constexpr std::size_t kRestartSamples = 3;
  static constexpr std::size_t kEarlyPings = 16;
  // The fewest samples a sample counter undercounts a loss by: half the range of 16 bits.
  static constexpr double kMinCounterUndercount = 32768.0;
  // Indices a run spans before its ticks per index hold a tick to its counter whatever the host
  // time (runs_ahead_of_counter).
  static constexpr double kSettledRun = 64.0;
  // Online times: each interval within +-kMaxSlew of the device's own (see the top of the file).
  static constexpr double kMaxSlew = 0.1;

  explicit DeviceClock(double tick_hz);

  // The next sample: its (unwrapped) device tick and when it reached the host; samples that
  // arrived together (the same host time) are one packet (ClockMapper::add_sample). The sample's
  // index (drivers::Sample::sequence), where it has one, lets a gap be told from a restart;
  // `counter`: the index counts every sample made, lost ones included
  // (drivers::Sample::has_sample_counter), and holds the tick step to its own.
  void add_sample(uint64_t device_ticks, TimeNs host_receive,
                  std::optional<uint64_t> sample_index = std::nullopt, bool counter = false);
  // True when the sample just added continues the one before it on the same clock (neither is
  // an outlier, no restart between): its tick step is elapsed device time.
  bool continues() const { return continues_; }
  // When the sample just added made the first segment's second sample an outlier
  // (run_continues_first), the tick and index steps continues() reported for that sample, which
  // a caller that summed them takes back; nothing otherwise.
  struct Step {
    uint64_t ticks = 0, index = 0;
  };
  std::optional<Step> withdrawn() const { return withdrawn_; }
  // The device time from the first sample to one with this tick and receive time if it were
  // added next, in seconds, on a clock that runs on through damaged ticks and restarts: within a
  // segment its tick minus the segment's first, after the spans (first to last accepted sample)
  // of the segments before it, so a restart adds nothing; a sample that would be an outlier sits
  // at its place in the sequence, as time_of puts it (one that puts the first segment's second
  // sample in doubt at its own tick, see above). Lets a caller decide on a sample (whether it is
  // inside a recording's duration) before it enters the fit.
  double elapsed_s(uint64_t device_ticks, TimeNs host_receive,
                   std::optional<uint64_t> sample_index = std::nullopt, bool counter = false) const;
  // The online time of the sample just added: the fit of its segment, slewed so that it never
  // goes before the previous sample's; outliers advance by the host time elapsed.
  TimeNs online_time();
  // One time-sync exchange, on the clock of the current segment (before the first sample: the
  // first kEarlyPings are held for the first segment).
  void add_ping(TimeNs host_send, uint64_t device_receive_ticks, uint64_t device_transmit_ticks,
                TimeNs host_receive);
  // Enters the last packet into the fit (at the end of a recording or of a pass).
  void flush();

  // The time of sample k (added with device_ticks) under the fit of its segment.
  TimeNs time_of(std::size_t k, uint64_t device_ticks) const;
  // Any device tick under the fit of the segment sample k belongs to (an event found near it).
  TimeNs map_near(std::size_t k, uint64_t device_ticks) const;
  // The longest segment's fit, with the packets, segments and outliers of all.
  ClockFit fit() const;

 private:
  struct Stamp {
    std::size_t k = 0;
    uint64_t ticks = 0;
    TimeNs host = 0;
    std::optional<uint64_t> index;  // drivers::Sample::sequence
    bool counter = false;           // index counts every sample made (add_sample)
  };
  struct Ping {
    TimeNs host_send;
    uint64_t device_receive_ticks, device_transmit_ticks;
    TimeNs host_receive;
  };
  struct Segment {
    ClockMapper mapper;
    Stamp first, last;  // its first and last accepted sample
    Stamp run;          // the first accepted sample of the latest run of increasing indices
    std::size_t accepted = 0;
    // The first kEarlyPings pings while it holds at most two samples (it may be rebuilt on its
    // first: run_continues_first).
    std::vector<Ping> early_pings;
  };
  std::vector<Ping> pings_before_first_;  // add_ping before any sample
  struct Outlier {
    std::size_t segment;
    Stamp before;  // the last sample its segment had accepted
    Stamp self;
    std::optional<Stamp> after;  // the next sample its segment accepted
  };
  // b can follow a on one clock: its tick not before a's, nor ahead by more than the host time
  // elapsed plus kMaxLeadS.
  bool follows(const Stamp& a, const Stamp& b) const;
  // The tick step from seg's last sample to b that b's index step gives at the ticks per index
  // seg's latest run of indices shows, and how far off the tick step may be (half a period and
  // kGapTolerance): where b's index is ahead of the last one's and the run has a rate.
  struct IndexStep {
    double ticks;
    double tolerance;
  };
  std::optional<IndexStep> index_step(const Segment& seg, const Stamp& b) const;
  // b continues seg across a gap: its tick step from seg's last sample is its index step's.
  bool bridges_gap(const Segment& seg, const Stamp& b) const;
  // b's tick runs ahead of its sample counter (b.counter) by more than the index step allows,
  // and the host time since seg's last sample does not cover half its tick step.
  bool runs_ahead_of_counter(const Segment& seg, const Stamp& b) const;
  // The outliers in a row from `from` to `to` continue the last segment's first sample (see the
  // class comment): the segment holds at most two samples, and the run's first tick step from
  // its first sample is the index step at the run's ticks per index, its second's is not.
  bool run_continues_first(const Stamp& from, const Stamp& to) const;
  // b puts seg's second sample in doubt: seg holds two, b is after the second by its index and
  // its tick lies between the first's (included) and the second's.
  bool doubts_second(const Segment& seg, const Stamp& b) const;
  // The outliers in a row before b (fewer than a restart's) put the first segment's second
  // sample in doubt, and with b they continue its first sample (run_continues_first).
  bool overturns_second(const Stamp& b) const;
  // bridges_gap, or follows and does not run ahead of its counter, from the last segment.
  bool continues_segment(const Stamp& b) const;
  // How many outliers in a row that agree with each other b would make (kRestartSamples: a
  // restart), were it an outlier.
  std::size_t candidate_run(const Stamp& b) const;
  void begin_segment(const Stamp& s);
  void accept(const Stamp& s);
  // The first segment begun again on its first sample (run_continues_first).
  void rebuild_first_segment();
  // The outliers in a row (candidates_) accepted into the last segment.
  void accept_candidates();
  double seconds_since_anchor(TimeNs t) const;
  double period_ticks(const Segment& seg) const;  // its mean ticks per accepted sample
  // The ticks from an outlier's `before` to its place in the sequence: between its neighbours
  // (before and after) by its index where the index counts every sample made and lies between
  // theirs (a loss before it stays before it); else its arrival number's step at the segment's
  // mean period, never past `after`; step_ticks without an `after` (found in review, 2026-11-26
  // fifth round: the first sample after 10 lost, its tick damaged, was timed 10 periods early;
  // placed by its index at a run's ticks per index instead, a damaged index moved it 41 s).
  double place_ticks(const Outlier& o) const;
  // Without the next sample (online, or none accepted after it): s's step from `before`, by its
  // index at the ticks per index of seg's settled run where it has a counter and the host time
  // elapsed covers the loss the index shows, else by its arrival number at seg's mean period.
  double step_ticks(const Segment& seg, const Stamp& before, const Stamp& s) const;
  TimeNs segment_time(std::size_t index, uint64_t device_ticks) const;  // its fit, shifted

  double tick_hz_;
  std::vector<Segment> segments_;
  std::vector<std::size_t> segment_starts_;  // k of each segment's first sample
  uint64_t earlier_spans_ = 0;               // ticks spanned by the segments before the last
  mutable std::vector<TimeNs> shifts_;       // per segment: how far its fit is moved later
  mutable bool shifts_dirty_ = true;
  std::map<std::size_t, Outlier> outliers_;
  std::vector<Stamp> candidates_;            // outliers in a row that agree with each other
  std::vector<std::size_t> awaiting_after_;  // k of the outliers since the last accepted sample
  Stamp last_added_;
  bool last_accepted_ = false, continues_ = false;
  std::optional<Step> second_step_;  // continues()'s step at the first segment's second sample
  std::optional<Step> withdrawn_;
  std::size_t next_k_ = 0;
  // Online state: the last time given out, in seconds since the first sample's arrival (anchor_).
  TimeNs anchor_ = 0;
  bool emitted_ = false;
  double last_y_ = 0.0;
  Stamp last_emitted_;
  bool last_emitted_accepted_ = false;
  std::size_t last_emitted_segment_ = 0;
};

}  // namespace imukit::capture
