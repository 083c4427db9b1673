#pragma once
// The device link's wire protocol (docs/realtime.md, "Haptic devices"): what a device bridge and ffdsim
// exchange every millisecond over UDP. Two fixed-size messages, little-endian, version 1.
//
//   Sample, bridge -> ffdsim, 80 bytes          Force, ffdsim -> bridge, 80 bytes
//   off type  field                              off type  field
//    0  u32  magic "FFDS" (0x53444646)            0  u32  magic "FFDF" (0x46444646)
//    4  u16  version (1)                          4  u16  version (1)
//    6  u16  kind (1: sample)                     6  u16  kind (2: force)
//    8  u32  sequence (+1 per sample)             8  u32  sequence of the newest sample used
//   12  u32  buttons (bit i: button i down)      12  u32  status (kForce* bits)
//   16  u64  device time, us (its own clock)     16  u64  device time of that sample, us (echo)
//   24  f64  position x, y, z (m, scene frame)   24  u64  physics step the force is from
//   48  f64  orientation w, x, y, z (unit)       32  f64  force x, y, z (N)
//                                                56  f64  torque x, y, z (N m; 0: a sphere probe)
//
// The C header `bridges/ffdsim_device.h` and the Python module `bridges/ffdsim_device.py`
// write and read the same bytes; the tests hold all three to one another.
#include <array>
#include <cstddef>
#include <cstdint>

#include "ffd/types.h"

namespace ffd::device {

inline constexpr std::uint32_t kSampleMagic = 0x53444646u;  // bytes "FFDS"
inline constexpr std::uint32_t kForceMagic = 0x46444646u;   // bytes "FFDF"
inline constexpr std::uint16_t kProtocolVersion = 1;
inline constexpr std::uint16_t kSampleKind = 1, kForceKind = 2;
inline constexpr std::size_t kMessageSize = 80;
// Positions beyond this (m) from the origin are refused: no scene is that large, and a value
// this far is a unit mistake or a corrupted packet, never a hand's motion.
inline constexpr double kMaxPositionM = 1000.0;
// Device times beyond this (us, 31 years of uptime) are refused: the link does arithmetic in
// signed nanoseconds on them.
inline constexpr std::uint64_t kMaxDeviceTimeUs = 1'000'000'000'000'000ull;

// Force status bits.
inline constexpr std::uint32_t kForceLive = 1u << 0;        // samples arrive: the force is rendered
inline constexpr std::uint32_t kForceWatchdog = 1u << 1;    // no sample for the watchdog time: force zero
inline constexpr std::uint32_t kForceLimited = 1u << 2;     // |F| was cut to the force limit
inline constexpr std::uint32_t kForceRateLimited = 1u << 3; // the change was cut to the rate limit
inline constexpr std::uint32_t kForceReengaging = 1u << 4;  // after a silence: the probe eases back to the device

struct Sample {
  std::uint32_t sequence = 0;
  std::uint32_t buttons = 0;
  std::uint64_t device_time_us = 0;
  Vec3 position = Vec3::Zero();
  std::array<double, 4> orientation{1.0, 0.0, 0.0, 0.0};  // w, x, y, z
};

struct Force {
  std::uint32_t sample_sequence = 0;
  std::uint32_t status = 0;
  std::uint64_t sample_device_time_us = 0;
  std::uint64_t step = 0;
  Vec3 force = Vec3::Zero();
  Vec3 torque = Vec3::Zero();
};

// Why a datagram was refused. Each has its own counter in the link.
enum class DecodeError : std::uint8_t {
  None,
  WrongSize,      // not kMessageSize bytes
  WrongMagic,     // another protocol (or random bytes)
  WrongVersion,   // this protocol, another version
  WrongKind,      // a force message sent to ffdsim, or an unknown kind
  NotFinite,      // a NaN or an infinity in a position or orientation
  OutOfRange,     // a position beyond kMaxPositionM, an orientation far from unit length, a
                  // device time beyond kMaxDeviceTimeUs
  Count
};
const char* decode_error_name(DecodeError e);

using Message = std::array<std::uint8_t, kMessageSize>;

Message encode_sample(const Sample& s);
Message encode_force(const Force& f);
// Validates and decodes; `out` is written only when the result is DecodeError::None.
DecodeError decode_sample(const std::uint8_t* data, std::size_t size, Sample& out);
DecodeError decode_force(const std::uint8_t* data, std::size_t size, Force& out);

}  // namespace ffd::device
