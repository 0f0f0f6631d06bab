#include "imukit/capture/clock_map.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>
#include <utility>

namespace imukit::capture {
namespace {

// The slowest and (inverted) fastest host seconds per device second a fit may have.
constexpr double kMinRate = 0.5;

// t - t0 in seconds, or nothing when the difference does not fit in int64 ns (a corrupt file).
std::optional<double> seconds_since(TimeNs t, TimeNs t0) {
  TimeNs d = 0;
  if (__builtin_sub_overflow(t, t0, &d)) return std::nullopt;
  return to_seconds(d);
}

// t0 + seconds, saturated at the int64 range (a tick from a corrupt file cannot overflow it).
TimeNs offset_by(TimeNs t0, double seconds) {
  constexpr double kLimit = 9.2e18;
  const double ns = std::clamp(std::round(seconds * 1e9), -kLimit, kLimit);
  TimeNs t = 0;
  if (__builtin_add_overflow(t0, static_cast<TimeNs>(ns), &t))
    return ns > 0 ? std::numeric_limits<TimeNs>::max() : std::numeric_limits<TimeNs>::min();
  return t;
}

}  // namespace

ClockMapper::ClockMapper(double tick_hz) : tick_hz_(tick_hz) { assert(tick_hz > 0); }

double ClockMapper::device_seconds(uint64_t ticks) const {
  // Signed difference so ticks before the first packet (pings) map too.
  return static_cast<double>(static_cast<int64_t>(ticks - tick0_)) / tick_hz_;
}

void ClockMapper::add_packet(uint64_t device_ticks, TimeNs host_receive) {
  if (!started_) {
    started_ = true;
    tick0_ = device_ticks;
    host0_ = host_receive;
  }
  const std::optional<double> y = seconds_since(host_receive, host0_);
  const double x = device_seconds(device_ticks);
  // Andrew's monotone chain below needs x in order; a tick going back is not one clock.
  if (!y || (packets_ > 0 && x < last_packet_x_)) {
    ++rejected_;
    return;
  }
  const Point p{x, *y};
  last_packet_x_ = x;
  ++packets_;
  sum_x_ += p.x;
  if (recent_.size() < kJitterWindow) {
    recent_.push_back(p);
  } else {
    recent_[recent_next_] = p;
    recent_next_ = (recent_next_ + 1) % kJitterWindow;
  }
  // Andrew's monotone chain, lower hull: drop points that the new one makes non-convex. Equal x:
  // keep only the lowest y.
  if (!hull_.empty() && hull_.back().x == p.x) {
    if (hull_.back().y <= p.y) return;
    hull_.pop_back();
  }
  while (hull_.size() >= 2) {
    const Point& o = hull_[hull_.size() - 2];
    const Point& a = hull_.back();
    const double cross = (a.x - o.x) * (p.y - o.y) - (a.y - o.y) * (p.x - o.x);
    if (cross > 0) break;  // counter-clockwise turn: a stays on the lower hull
    hull_.pop_back();
  }
  hull_.push_back(p);
  dirty_ = true;
}

void ClockMapper::add_sample(uint64_t device_ticks, TimeNs host_receive) {
  if (pending_ && host_receive != pending_host_) flush();
  pending_ = true;
  pending_ticks_ = device_ticks;
  pending_host_ = host_receive;
  if (!started_) {
    // The first sample anchors map() until the first packet is complete; it does not enter the
    // fit itself (it may be the earliest sample of a buffered block).
    started_ = true;
    tick0_ = device_ticks;
    host0_ = host_receive;
  }
}

void ClockMapper::flush() {
  if (pending_) add_packet(pending_ticks_, pending_host_);
  pending_ = false;
}

void ClockMapper::add_ping(TimeNs host_send, uint64_t device_receive_ticks,
                           uint64_t device_transmit_ticks, TimeNs host_receive) {
  if (!started_) return;  // the mapping is anchored on the first packet
  const std::optional<double> sent = seconds_since(host_send, host0_);
  const std::optional<double> received = seconds_since(host_receive, host0_);
  if (!sent || !received) return;  // not a time of this recording
  const double x_mid =
      0.5 * (device_seconds(device_receive_ticks) + device_seconds(device_transmit_ticks));
  const double y_mid = 0.5 * (*sent + *received);
  const double round_trip = (*received - *sent) - (device_seconds(device_transmit_ticks) -
                                                   device_seconds(device_receive_ticks));
  if (!std::isfinite(round_trip)) return;
  if (pings_ == 0 || round_trip < best_round_trip_s_) {
    best_round_trip_s_ = round_trip;
    best_ping_x_ = x_mid;
    best_ping_y_ = y_mid;
    dirty_ = true;
  }
  ++pings_;
}

void ClockMapper::refit() const {
  if (!dirty_) return;
  dirty_ = false;
  if (hull_.size() < 2) {
    a_ = hull_.empty() ? 0.0 : hull_.front().y - hull_.front().x;
    b_ = 1.0;
  } else {
    // The LP optimum: the hull edge whose x-range contains the mean x of all packets.
    const double mean_x = sum_x_ / static_cast<double>(packets_);
    std::size_t k = 0;
    while (k + 2 < hull_.size() && hull_[k + 1].x < mean_x) ++k;
    const Point& p = hull_[k];
    const Point& q = hull_[k + 1];
    b_ = (q.y - p.y) / (q.x - p.x);
    a_ = p.y - b_ * p.x;
    // A host clock that stepped back can tilt the envelope down, and a file replayed faster than
    // it was recorded lays it almost flat; no device clock is off by half its rate, so such a
    // fit falls back to the nominal rate (a clock map must not run backwards, nor squeeze
    // seconds of samples into the milliseconds of a replay). The line of slope 1 must still lie
    // under every packet (no sample is made after it arrives, and receive jitter is never
    // negative), so it goes through the hull vertex with the smallest y - x: the minimum of a
    // linear function over the points is at a vertex of their lower hull. A replay thus maps
    // its samples to end at the last one's arrival, as if it had been recorded live just then.
    if (!(b_ > kMinRate && b_ < 1.0 / kMinRate && std::isfinite(a_))) {
      b_ = 1.0;
      a_ = std::numeric_limits<double>::infinity();
      for (const Point& h : hull_) a_ = std::min(a_, h.y - h.x);
    }
  }
  // Latency from the least disturbed ping: envelope minus the ping's mid-point estimate.
  if (pings_ > 0 && packets_ >= 2) {
    latency_s_ = (a_ + b_ * best_ping_x_) - best_ping_y_;
  } else {
    latency_s_.reset();
  }
}

double ClockMapper::estimate(double x) const {
  refit();
  return a_ + b_ * x - latency_s_.value_or(0.0);
}

TimeNs ClockMapper::to_host(double y) const { return offset_by(host0_, y); }

TimeNs ClockMapper::map(uint64_t device_ticks) const {
  return to_host(estimate(device_seconds(device_ticks)));
}

ClockFit ClockMapper::fit() const {
  refit();
  ClockFit f;
  f.packets = packets_;
  f.rejected = rejected_;
  f.skew_ppm = (1.0 / b_ - 1.0) * 1e6;  // device seconds per host second, minus 1
  f.ping_corrected = latency_s_.has_value();
  f.latency_correction_s = latency_s_.value_or(0.0);
  f.pings = pings_;
  f.best_round_trip_s = best_round_trip_s_;
  if (!recent_.empty()) {
    double sum = 0.0, sum_sq = 0.0, max = 0.0;
    for (const Point& p : recent_) {
      const double r = p.y - (a_ + b_ * p.x);
      sum += r;
      sum_sq += r * r;
      max = std::max(max, r);
    }
    const double n = static_cast<double>(recent_.size());
    f.jitter_mean_s = sum / n;
    f.jitter_std_s = std::sqrt(std::max(0.0, sum_sq / n - f.jitter_mean_s * f.jitter_mean_s));
    f.jitter_max_s = max;
  }
  return f;
}

DeviceClock::DeviceClock(double tick_hz) : tick_hz_(tick_hz) { assert(tick_hz > 0); }

bool DeviceClock::follows(const Stamp& a, const Stamp& b) const {
  if (b.ticks < a.ticks) return false;
  const std::optional<double> host_elapsed = seconds_since(b.host, a.host);
  if (!host_elapsed) return false;
  return static_cast<double>(b.ticks - a.ticks) / tick_hz_ <= *host_elapsed + kMaxLeadS;
}

std::optional<DeviceClock::IndexStep> DeviceClock::index_step(const Segment& seg,
                                                              const Stamp& b) const {
  const Stamp& a = seg.last;
  const Stamp& r = seg.run;
  if (!a.index || !b.index || !r.index) return std::nullopt;
  if (*b.index <= *a.index || *a.index <= *r.index || a.ticks <= r.ticks) return std::nullopt;
  const double per_index =
      static_cast<double>(a.ticks - r.ticks) / static_cast<double>(*a.index - *r.index);
  const double ticks = static_cast<double>(*b.index - *a.index) * per_index;
  return IndexStep{ticks, 0.5 * per_index + kGapTolerance * ticks};
}

bool DeviceClock::bridges_gap(const Segment& seg, const Stamp& b) const {
  // Both clocks of the device, its tick and its sample counter, say the same time elapsed.
  const std::optional<IndexStep> step = index_step(seg, b);
  return step && b.ticks >= seg.last.ticks &&
         std::abs(static_cast<double>(b.ticks - seg.last.ticks) - step->ticks) <= step->tolerance;
}

bool DeviceClock::runs_ahead_of_counter(const Segment& seg, const Stamp& b) const {
  if (!b.counter || b.ticks < seg.last.ticks) return false;
  const std::optional<IndexStep> step = index_step(seg, b);
  const double tick_step = static_cast<double>(b.ticks - seg.last.ticks);
  if (!step || tick_step <= step->ticks + step->tolerance) return false;
  // A sample counter has at least 16 bits (drivers::Sample::has_sample_counter): it undercounts a
  // loss by a multiple of 2^16 samples, so a tick fewer than 2^15 periods beyond a certain step is
  // damaged whatever the host time. Found in review (2026-11-26): blocks of 8 samples arrive one
  // block period apart, which covers half of a tick damaged 6-12 ms ahead at 1 kHz, and each such
  // tick began a segment (29 segments in 10 minutes).
  // The step is certain where the run holds kSettledRun indices (its first samples were
  // taken on the host-time rule and may be damaged), and the excess is beyond what the last
  // sample's tick and the run's ends, each off by up to half a period, make of the step (found in
  // review: an Xsens at 800 Hz on 10 kHz ticks, 12 or 13 a sample, lost 2,000 samples after
  // sample 1, and the step held to 12 ticks an index was 1,000 ticks short: a restart, and
  // `record --duration` overshot by the loss). Otherwise the host time decides.
  const double index_steps = static_cast<double>(*b.index - *seg.last.index);
  const double per_index = step->ticks / index_steps;
  const double run_indices = static_cast<double>(*seg.last.index - *seg.run.index);
  const double uncertain =
      step->tolerance + 0.5 * per_index + index_steps * per_index / run_indices;
  const double excess = tick_step - step->ticks;
  if (run_indices >= kSettledRun && excess > uncertain &&
      excess < kMinCounterUndercount * per_index)
    return true;
  // Beyond that, a loss longer than half the counter's range, which a live stream's
  // host time shows (the samples after it arrive when they are made); a damaged tick arrives
  // with its neighbours, and in a replay every sample does. (A counter short enough to wrap
  // within a live loss is no sample counter: drivers::Sample::has_sample_counter.)
  const std::optional<double> host_elapsed = seconds_since(b.host, seg.last.host);
  return !host_elapsed || *host_elapsed < 0.5 * tick_step / tick_hz_;
}

bool DeviceClock::run_continues_first(const Stamp& from, const Stamp& to) const {
  const Segment& seg = segments_.back();
  const Stamp& first = seg.first;
  if (seg.accepted > 2 || !first.index || !from.index || !to.index) return false;
  if (*to.index <= *from.index || to.ticks <= from.ticks || *from.index <= *first.index ||
      from.ticks < first.ticks)
    return false;
  const double per_index =
      static_cast<double>(to.ticks - from.ticks) / static_cast<double>(*to.index - *from.index);
  // s's tick step from the first sample is its index step's at the run's ticks per index.
  const auto on_line = [&](const Stamp& s) {
    const double ticks = static_cast<double>(*s.index - *first.index) * per_index;
    return std::abs(static_cast<double>(s.ticks - first.ticks) - ticks) <=
           0.5 * per_index + kGapTolerance * ticks;
  };
  if (!on_line(from)) return false;
  if (seg.accepted < 2) return true;  // a gap right after the first sample
  const Stamp& second = seg.last;
  return second.index && *second.index > *first.index && *second.index < *from.index &&
         second.ticks >= first.ticks && !on_line(second);
}

bool DeviceClock::doubts_second(const Segment& seg, const Stamp& b) const {
  const Stamp &first = seg.first, &second = seg.last;
  return seg.accepted == 2 && first.index && second.index && b.index &&
         *first.index < *second.index && *second.index < *b.index && b.ticks >= first.ticks &&
         b.ticks < second.ticks;
}

bool DeviceClock::overturns_second(const Stamp& b) const {
  // Only with a sample counter: where the index counts the lines that arrived, a loss right after
  // the first sample shifts it, and a genuine second sample with a damaged tick after it looks
  // the same (found in review: text, 11 lines lost after the first, line 2's tick 3.5 ms behind:
  // the genuine line 1 became the outlier, 11 ms early).
  const auto counted = [](const Stamp& s) { return s.counter; };
  return b.counter && std::all_of(candidates_.begin(), candidates_.end(), counted) &&
         !candidates_.empty() && doubts_second(segments_.back(), candidates_.front()) &&
         follows(candidates_.back(), b) && run_continues_first(candidates_.front(), b);
}

bool DeviceClock::continues_segment(const Stamp& b) const {
  const Segment& seg = segments_.back();
  return bridges_gap(seg, b) || (follows(seg.last, b) && !runs_ahead_of_counter(seg, b));
}

std::size_t DeviceClock::candidate_run(const Stamp& b) const {
  return !candidates_.empty() && follows(candidates_.back(), b) ? candidates_.size() + 1 : 1;
}

void DeviceClock::begin_segment(const Stamp& s) {
  if (!segments_.empty()) {
    Segment& last = segments_.back();
    last.mapper.flush();
    // Saturated: only a crafted stream spans 2^64 ticks.
    if (__builtin_add_overflow(earlier_spans_, last.last.ticks - last.first.ticks, &earlier_spans_))
      earlier_spans_ = std::numeric_limits<uint64_t>::max();
  }
  segments_.push_back(Segment{ClockMapper(tick_hz_), s, s, s, 0, {}});
  segment_starts_.push_back(s.k);
  awaiting_after_.clear();  // the outliers of the segment before keep no next sample
}

void DeviceClock::accept(const Stamp& s) {
  shifts_dirty_ = true;
  Segment& seg = segments_.back();
  seg.mapper.add_sample(s.ticks, s.host);
  if (seg.accepted == 0) seg.first = s;
  if (seg.accepted == 0 || !s.index || !seg.last.index || *s.index <= *seg.last.index) seg.run = s;
  seg.last = s;
  ++seg.accepted;
  // The outliers before it have it as their next sample (when the first segment is rebuilt its
  // first sample is accepted again, before the outliers that come after it).
  std::erase_if(awaiting_after_, [&](std::size_t k) {
    if (k > s.k) return false;
    const auto o = outliers_.find(k);
    if (o != outliers_.end() && o->second.segment == segments_.size() - 1) o->second.after = s;
    return true;
  });
}

double DeviceClock::elapsed_s(uint64_t device_ticks, TimeNs host_receive,
                              std::optional<uint64_t> sample_index, bool counter) const {
  if (segments_.empty()) return 0.0;
  const Stamp s{next_k_, device_ticks, host_receive, sample_index, counter};
  const Segment& seg = segments_.back();
  const auto since_first = [&](uint64_t ticks) {
    return static_cast<double>(ticks - seg.first.ticks);
  };
  // Summed in ticks and divided once, so that a duration of whole ticks is met exactly.
  const auto seconds = [&](double ticks_in_segment) {
    return (static_cast<double>(earlier_spans_) + ticks_in_segment) / tick_hz_;
  };
  if (continues_segment(s)) return seconds(since_first(s.ticks));
  // The outlier that completes a restart: its segment begins after this one, at the first of
  // the run.
  if (candidate_run(s) >= kRestartSamples) {
    if (run_continues_first(candidates_.front(), s)) return seconds(since_first(s.ticks));
    return seconds(since_first(seg.last.ticks) +
                   static_cast<double>(s.ticks - candidates_.front().ticks));
  }
  // The first segment's second sample or this one is damaged: until a run shows which, at its
  // own tick (the second's step is the segment's only period).
  if (doubts_second(seg, s)) return seconds(since_first(s.ticks));
  return seconds(since_first(seg.last.ticks) + step_ticks(seg, seg.last, s));
}

void DeviceClock::add_sample(uint64_t device_ticks, TimeNs host_receive,
                             std::optional<uint64_t> sample_index, bool counter) {
  const Stamp s{next_k_++, device_ticks, host_receive, sample_index, counter};
  const bool was_accepted = last_accepted_;
  last_added_ = s;
  withdrawn_.reset();
  if (segments_.empty()) {
    anchor_ = host_receive;
    begin_segment(s);
    accept(s);
    last_accepted_ = true;
    continues_ = false;
    // A reply to the ping sent at the start may come before the stream's first sample.
    for (const Ping& p : std::exchange(pings_before_first_, {}))
      add_ping(p.host_send, p.device_receive_ticks, p.device_transmit_ticks, p.host_receive);
    return;
  }
  if (continues_segment(s) && overturns_second(s)) {
    // The outliers before it doubted the first segment's second sample, and with it they
    // continue the first sample: the second was the damaged one.
    continues_ = false;
    candidates_.push_back(s);
    rebuild_first_segment();
    accept_candidates();
    return;
  }
  if (continues_segment(s)) {
    continues_ = was_accepted;
    candidates_.clear();  // they were outliers after all (recorded as such)
    const Stamp& last = segments_.back().last;
    if (continues_ && segments_.size() == 1 && segments_.back().accepted == 1 && s.index &&
        last.index && *s.index > *last.index)
      second_step_ = Step{s.ticks - last.ticks, *s.index - *last.index};
    accept(s);
    last_accepted_ = true;
    return;
  }
  continues_ = false;
  if (candidate_run(s) == 1) candidates_.clear();
  candidates_.push_back(s);
  if (candidates_.size() < kRestartSamples) {
    outliers_[s.k] = Outlier{segments_.size() - 1, segments_.back().last, s, std::nullopt};
    awaiting_after_.push_back(s.k);
    last_accepted_ = false;
    return;
  }
  if (run_continues_first(candidates_.front(), candidates_.back())) {
    rebuild_first_segment();
  } else {
    // A restart: the outliers in a row begin a segment of their own.
    begin_segment(candidates_.front());
  }
  accept_candidates();
}

void DeviceClock::rebuild_first_segment() {
  // On its first sample and the run that continues it, its second sample (if it has one) an
  // outlier.
  Segment& seg = segments_.back();
  const Stamp first = seg.first, second = seg.last;
  const bool had_second = seg.accepted == 2;
  const std::vector<Ping> pings = std::move(seg.early_pings);
  seg = Segment{ClockMapper(tick_hz_), first, first, first, 0, {}};
  accept(first);
  for (const Ping& p : pings)
    add_ping(p.host_send, p.device_receive_ticks, p.device_transmit_ticks, p.host_receive);
  if (had_second) {
    // Timed from the first sample, as the outliers that were timed from it are now.
    for (auto& [k, o] : outliers_) {
      if (o.segment != segments_.size() - 1) continue;
      if (o.before.k == second.k) o.before = first;
      // Those before it had it as their next sample: they wait for the next one again (found in
      // review: spread over the damaged second's tick they came 100 ms late and before it).
      if (o.after && o.after->k == second.k) {
        o.after.reset();
        awaiting_after_.push_back(k);
      }
    }
    outliers_[second.k] = Outlier{segments_.size() - 1, first, second, std::nullopt};
    awaiting_after_.push_back(second.k);
    withdrawn_ = second_step_;
  }
  second_step_.reset();
}

void DeviceClock::accept_candidates() {
  for (const Stamp& c : candidates_) {
    outliers_.erase(c.k);
    accept(c);
  }
  candidates_.clear();
  last_accepted_ = true;
}

double DeviceClock::seconds_since_anchor(TimeNs t) const {
  return seconds_since(t, anchor_).value_or(0.0);
}

TimeNs DeviceClock::online_time() {
  assert(!segments_.empty());
  const Stamp& s = last_added_;
  const bool same_clock = last_accepted_ && last_emitted_accepted_ &&
                          last_emitted_segment_ == segments_.size() - 1 &&
                          s.ticks >= last_emitted_.ticks;
  // The time elapsed since the last sample given out: on the device's clock where both are on
  // the same one, else on the host's.
  double elapsed = 0.0;
  if (emitted_) {
    elapsed = same_clock ? static_cast<double>(s.ticks - last_emitted_.ticks) / tick_hz_
                         : std::max(0.0, seconds_since(s.host, last_emitted_.host).value_or(0.0));
  }
  const double free_run = last_y_ + elapsed;
  double y = free_run;
  if (last_accepted_) {
    const double target = seconds_since_anchor(segments_.back().mapper.map(s.ticks));
    if (!emitted_) {
      y = target;
    } else {
      const double limit = kMaxSlew * elapsed;
      y = std::max(last_y_, free_run + std::clamp(target - free_run, -limit, limit));
    }
  }
  if (!std::isfinite(y)) y = last_y_;
  emitted_ = true;
  last_y_ = y;
  last_emitted_ = s;
  last_emitted_accepted_ = last_accepted_;
  last_emitted_segment_ = segments_.size() - 1;
  return offset_by(anchor_, y);
}

void DeviceClock::add_ping(TimeNs host_send, uint64_t device_receive_ticks,
                           uint64_t device_transmit_ticks, TimeNs host_receive) {
  if (segments_.empty()) {  // no clock to correct yet: kept for the first sample's
    if (pings_before_first_.size() < kEarlyPings)
      pings_before_first_.push_back(
          {host_send, device_receive_ticks, device_transmit_ticks, host_receive});
    return;
  }
  shifts_dirty_ = true;
  Segment& seg = segments_.back();
  seg.mapper.add_ping(host_send, device_receive_ticks, device_transmit_ticks, host_receive);
  if (seg.accepted <= 2 && seg.early_pings.size() < kEarlyPings)
    seg.early_pings.push_back(
        {host_send, device_receive_ticks, device_transmit_ticks, host_receive});
}

void DeviceClock::flush() {
  shifts_dirty_ = true;
  if (!segments_.empty()) segments_.back().mapper.flush();
}

double DeviceClock::period_ticks(const Segment& seg) const {
  if (seg.accepted < 2) return 0.0;
  return static_cast<double>(seg.last.ticks - seg.first.ticks) /
         static_cast<double>(seg.last.k - seg.first.k);
}

double DeviceClock::step_ticks(const Segment& seg, const Stamp& before, const Stamp& s) const {
  const double by_arrival = static_cast<double>(s.k - before.k) * period_ticks(seg);
  const Stamp &a = seg.last, &r = seg.run;
  if (!s.counter || !s.index || !before.index || *s.index <= *before.index || !a.index ||
      !r.index || *a.index - *r.index < static_cast<uint64_t>(kSettledRun) || a.ticks <= r.ticks)
    return by_arrival;
  const double by_index = static_cast<double>(*s.index - *before.index) *
                          static_cast<double>(a.ticks - r.ticks) /
                          static_cast<double>(*a.index - *r.index);
  // The loss its index shows, where the host time shows it too (a live stream; a replay's host
  // time shows none): a damaged index alone does not move it (found in review: trusted up to the
  // host time plus 1 s, a damaged index moved such a sample, and `elapsed_s`, by up to 1 s).
  const std::optional<double> host_elapsed = seconds_since(s.host, before.host);
  return host_elapsed && (by_index - by_arrival) / tick_hz_ <= *host_elapsed ? by_index
                                                                             : by_arrival;
}

double DeviceClock::place_ticks(const Outlier& o) const {
  const Stamp &before = o.before, &s = o.self;
  const double by_arrival =
      static_cast<double>(s.k - before.k) * period_ticks(segments_[o.segment]);
  if (!o.after) return step_ticks(segments_[o.segment], before, s);
  const Stamp& after = *o.after;
  const double span = static_cast<double>(after.ticks - before.ticks);
  if (s.counter && s.index && before.index && after.index && *before.index < *s.index &&
      *s.index < *after.index) {
    return span * static_cast<double>(*s.index - *before.index) /
           static_cast<double>(*after.index - *before.index);
  }
  // Without a counter, or with an index not between the neighbours' (damaged), a loss between
  // them cannot be placed; the outlier stays a mean period per sample after the one before (right
  // for a loss after it), never past the next.
  return std::min(by_arrival, span);
}

TimeNs DeviceClock::segment_time(std::size_t index, uint64_t device_ticks) const {
  if (shifts_dirty_) {
    shifts_.assign(segments_.size(), 0);
    for (std::size_t i = 1; i < segments_.size(); ++i) {
      const Segment& prev = segments_[i - 1];
      const TimeNs prev_end = offset_by(prev.mapper.map(prev.last.ticks),
                                        period_ticks(prev) / tick_hz_ + to_seconds(shifts_[i - 1]));
      const TimeNs start = segments_[i].mapper.map(segments_[i].first.ticks);
      TimeNs gap = 0;
      if (!__builtin_sub_overflow(prev_end, start, &gap) && gap > 0) shifts_[i] = gap;
    }
    shifts_dirty_ = false;
  }
  TimeNs t = 0;
  const TimeNs mapped = segments_[index].mapper.map(device_ticks);
  if (__builtin_add_overflow(mapped, shifts_[index], &t)) t = std::numeric_limits<TimeNs>::max();
  return t;
}

TimeNs DeviceClock::time_of(std::size_t k, uint64_t device_ticks) const {
  assert(!segments_.empty());
  if (const auto o = outliers_.find(k); o != outliers_.end()) {
    // Where its place in the sequence puts it, after the last sample accepted before it.
    const std::size_t index = o->second.segment;
    const Stamp& before = o->second.before;
    // Through the fit, so that it stays before the next sample whatever the fitted rate.
    const double place = std::round(place_ticks(o->second));
    const double room = static_cast<double>(std::numeric_limits<uint64_t>::max() - before.ticks);
    return segment_time(index, !(place < room) ? std::numeric_limits<uint64_t>::max()
                                               : before.ticks + static_cast<uint64_t>(place));
  }
  return map_near(k, device_ticks);
}

TimeNs DeviceClock::map_near(std::size_t k, uint64_t device_ticks) const {
  assert(!segments_.empty());
  const auto next = std::upper_bound(segment_starts_.begin(), segment_starts_.end(), k);
  return segment_time(static_cast<std::size_t>(next - segment_starts_.begin()) - 1, device_ticks);
}

ClockFit DeviceClock::fit() const {
  if (segments_.empty()) return {};
  const auto longest =
      std::max_element(segments_.begin(), segments_.end(),
                       [](const Segment& a, const Segment& b) { return a.accepted < b.accepted; });
  ClockFit f = longest->mapper.fit();
  f.packets = 0;
  f.rejected = 0;
  f.pings = 0;
  for (const Segment& seg : segments_) {
    const ClockFit s = seg.mapper.fit();
    f.packets += s.packets;
    f.rejected += s.rejected;
    f.pings += s.pings;
  }
  f.segments = segments_.size();
  f.outliers = outliers_.size();
  return f;
}

}  // namespace imukit::capture
