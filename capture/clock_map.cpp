#include "imukit/capture/clock_map.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>

namespace imukit::capture {
namespace {

// t - t0 in seconds, or nothing when the difference does not fit in int64 ns (a corrupt file).
std::optional<double> seconds_since(TimeNs t, TimeNs t0) {
  TimeNs d = 0;
  if (__builtin_sub_overflow(t, t0, &d)) return std::nullopt;
  return to_seconds(d);
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
    // A host clock that stepped back can tilt the envelope down; a clock map must not run
    // backwards, so such a fit falls back to the nominal rate through the edge's first point.
    if (!(b_ > 0.0 && std::isfinite(b_) && std::isfinite(a_))) {
      b_ = 1.0;
      a_ = p.y - p.x;
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

TimeNs ClockMapper::to_host(double y) const {
  // Saturated so that a tick from a corrupt file cannot overflow int64 (9.2e18 ns).
  constexpr double kLimit = 9.2e18;
  const double ns = std::clamp(std::round(y * 1e9), -kLimit, kLimit);
  TimeNs t = 0;
  if (__builtin_add_overflow(host0_, static_cast<TimeNs>(ns), &t))
    return ns > 0 ? std::numeric_limits<TimeNs>::max() : std::numeric_limits<TimeNs>::min();
  return t;
}

TimeNs ClockMapper::map(uint64_t device_ticks) const {
  return to_host(estimate(device_seconds(device_ticks)));
}

TimeNs ClockMapper::map_monotonic(uint64_t device_ticks) {
  const double x = device_seconds(device_ticks);
  const double target = estimate(x);
  double y = target;
  if (emitted_) {
    // Free running from the last output at the device's nominal rate (the fitted one can be off
    // by percent over the first few packets), pulled toward the fit by at most kMaxSlew of the
    // elapsed device time: never before last_y_.
    const double dx = std::max(0.0, x - last_x_);
    const double free_run = last_y_ + dx;
    const double limit = kMaxSlew * dx;
    y = std::max(last_y_, free_run + std::clamp(target - free_run, -limit, limit));
  }
  if (!std::isfinite(y)) y = emitted_ ? last_y_ : 0.0;
  last_x_ = emitted_ ? std::max(last_x_, x) : x;
  last_y_ = y;
  emitted_ = true;
  return to_host(y);
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

}  // namespace imukit::capture
