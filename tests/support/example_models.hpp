// Example device descriptions shared by the tests and the benchmarks, so both exercise the same
// values: a hardware model with every error term on (consumer-grade MEMS magnitudes) and the
// DeviceInfo an imukit-protocol device with an accelerometer and a gyroscope announces.
// Header-only: the benchmarks use it without linking the test support library (GoogleTest).
#pragma once

#include <cstdint>
#include <numbers>

#include "imukit/core/hardware_model.hpp"
#include "imukit/firmware_proto/messages.hpp"

namespace imukit::testing {

// Every term of the accelerometer, gyroscope and magnetometer on, with values of a
// consumer-grade MEMS IMU (a +-16 g accelerometer, a +-2000 deg/s gyroscope, 16-bit).
inline HardwareModel consumer_mems_model() {
  HardwareModel m;
  auto& acc = m.accelerometer;
  acc.noise_density = {1.5e-3, 1.6e-3, 2.0e-3};
  acc.bias_instability = {4e-4, 5e-4, 6e-4};
  acc.random_walk = {3e-5, 3e-5, 4e-5};
  acc.turn_on_bias_mean = {0.02, -0.03, 0.05};
  acc.turn_on_bias_spread = {0.01, 0.01, 0.02};
  acc.scale = {1.01, 0.99, 1.002};
  acc.misalignment << 1.0, 0.002, -0.001, 0.003, 1.0, 0.004, -0.002, 0.001, 1.0;
  acc.range = 16 * 9.80665;
  acc.resolution = acc.range / 32768.0;
  acc.bandwidth_hz = 40.0;
  auto& gyro = m.gyroscope;
  gyro.noise_density = {1.2e-4, 1.3e-4, 1.1e-4};
  gyro.bias_instability = {2e-5, 3e-5, 2.5e-5};
  gyro.random_walk = {2e-6, 3e-6, 2e-6};
  gyro.turn_on_bias_mean = {0.001, -0.002, 0.0005};
  gyro.turn_on_bias_spread = {0.002, 0.002, 0.002};
  gyro.scale = {0.995, 1.004, 1.0};
  gyro.misalignment << 1.0, -0.003, 0.002, 0.001, 1.0, -0.002, 0.004, 0.001, 1.0;
  gyro.g_sensitivity << 1e-4, 2e-5, 0.0, -3e-5, 1e-4, 1e-5, 0.0, 2e-5, 8e-5;
  gyro.range = 2000.0 * std::numbers::pi / 180.0;
  gyro.resolution = gyro.range / 32768.0;
  gyro.bandwidth_hz = 30.0;
  auto& mag = m.magnetometer;
  mag.noise_density = {1e-8, 1e-8, 1.5e-8};
  mag.hard_iron = {2e-6, -1e-6, 5e-6};
  mag.soft_iron << 1.02, 0.01, 0.0, 0.01, 0.98, 0.0, 0.0, 0.0, 1.01;
  mag.resolution = 1.5e-7;
  return m;
}

// DeviceInfo of a device with a +-16 g accelerometer (scale 0.0047884 m/s^2 per count) and a
// +-2000 deg/s gyroscope (0.001065264 rad/s per count), one output rate. The defaults are a
// watch crystal (32768 Hz, so the sample period is not a whole number of ticks) at 100 Hz.
inline proto::DeviceInfo example_device_info(uint32_t tick_hz = 32768,
                                             uint32_t rate_mhz = 100'000) {
  proto::DeviceInfo info;
  info.vendor.set("acme");
  info.model.set("imu");
  info.serial.set("7");
  info.tick_hz = tick_hz;
  info.rate_count = 1;
  info.rates_mhz[0] = rate_mhz;
  info.sensor_count = 2;
  info.sensors[0].kind = proto::SensorKind::kAccelerometer;
  info.sensors[0].range_count = 1;
  info.sensors[0].ranges[0] = {156.9064f, 0.00478840f};
  info.sensors[1].kind = proto::SensorKind::kGyroscope;
  info.sensors[1].offset = 0.0f;
  info.sensors[1].range_count = 1;
  info.sensors[1].ranges[0] = {34.9f, 0.001065264f};
  return info;
}

}  // namespace imukit::testing
