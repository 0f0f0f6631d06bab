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
// Online times (map_monotonic) never go backwards. The fit moves while a recording runs: the
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
#include <optional>
#include <vector>

#include "imukit/core/time.hpp"

namespace imukit::capture {

struct ClockFit {
  std::size_t packets = 0;
  std::size_t rejected = 0;           // packets left out: tick going back, absurd host time
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
  // packet's offset at the nominal rate. Non-decreasing in the tick (the fitted rate is kept
  // positive); saturates at the int64 range for ticks absurdly far from the first packet's.
  TimeNs map(uint64_t device_ticks) const;
  // The online time of the next sample, for a live recording: map() slewed so that it never goes
  // backwards (see the top of this file). Ticks of successive calls should not decrease; one that
  // does gets the previous time again.
  TimeNs map_monotonic(uint64_t device_ticks);
  static constexpr double kMaxSlew = 0.1;
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
  // map_monotonic's last output (device seconds, host seconds since host0_).
  bool emitted_ = false;
  double last_x_ = 0.0, last_y_ = 0.0;
};

}  // namespace imukit::capture
