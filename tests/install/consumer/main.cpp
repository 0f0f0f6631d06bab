// Simulates a left-wrist watch on the installed demo walk with the installed imukit::sim and
// checks the result: a sample per frame (the fd method leaves out the last frame, whose central
// difference needs the next one), every value finite, and the magnitude of the specific force
// within 0.5 to 3 g on average (a wrist while walking); core's SO(3) log/exp round trip holds
// to 1e-12 rad. What this test proves is that the installed package configures, links and runs.
#include <cmath>
#include <cstdio>
#include <memory>

#include <imukit/core/error.hpp>
#include <imukit/core/so3.hpp>
#include <imukit/sim/bvh.hpp>
#include <imukit/sim/placement.hpp>
#include <imukit/sim/scene.hpp>

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: consumer WALK.bvh\n");
    return 2;
  }
  try {
    imukit::sim::BvhData d = imukit::sim::read_bvh(argv[1]);
    imukit::sim::Scene scene;
    scene.body = std::move(d.body);
    scene.motion = std::make_shared<imukit::sim::Motion>(std::move(d.motion));
    scene.frames = scene.motion->frame_count();
    scene.sensors.push_back(imukit::sim::preset_sensor("left_wrist_watch", scene.body, "watch"));
    long samples = 0;
    bool finite = true;
    double norm_sum = 0.0;
    imukit::sim::run_scene(scene, [&](std::size_t, const imukit::sim::SensorBlock& b,
                                      const imukit::sim::SensorBlock*) {
      samples += static_cast<long>(b.t.size());
      finite = finite && b.specific_force.allFinite() && b.angular_rate.allFinite();
      norm_sum += b.specific_force.colwise().norm().sum();
    });
    const double mean_norm = norm_sum / static_cast<double>(samples);
    const Eigen::Quaterniond q = Eigen::Quaterniond(0.3, -0.5, 0.6, 0.2).normalized();
    const double round_trip = imukit::angular_distance(imukit::so3_exp(imukit::so3_log(q)), q);
    std::printf(
        "consumer: %ld samples of %ld frames, mean |specific force| %.4f m/s^2, so3 round trip "
        "%.2g rad\n",
        samples, static_cast<long>(*scene.frames), mean_norm, round_trip);
    const bool ok = samples >= *scene.frames - 1 && samples <= *scene.frames && finite &&
                    mean_norm > 0.5 * 9.80665 && mean_norm < 3 * 9.80665 && round_trip < 1e-12;
    std::printf("%s\n", ok ? "consumer: ok" : "consumer: FAILED");
    return ok ? 0 : 1;
  } catch (const imukit::Error& e) {
    std::fprintf(stderr, "consumer: error: %s\n", e.what());
    return 1;
  }
}
