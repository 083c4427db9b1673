#include "device/device_protocol.h"

#include <cmath>
#include <cstring>

namespace ffd::device {

namespace {

// Explicit little-endian byte order, whatever the host's: the bytes on the wire are the
// protocol, not the struct layout.
void put_u16(std::uint8_t* p, std::uint16_t v) {
  p[0] = static_cast<std::uint8_t>(v);
  p[1] = static_cast<std::uint8_t>(v >> 8);
}
void put_u32(std::uint8_t* p, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) p[i] = static_cast<std::uint8_t>(v >> (8 * i));
}
void put_u64(std::uint8_t* p, std::uint64_t v) {
  for (int i = 0; i < 8; ++i) p[i] = static_cast<std::uint8_t>(v >> (8 * i));
}
void put_f64(std::uint8_t* p, double v) {
  std::uint64_t bits;
  std::memcpy(&bits, &v, sizeof bits);
  put_u64(p, bits);
}
std::uint16_t get_u16(const std::uint8_t* p) { return static_cast<std::uint16_t>(p[0] | (p[1] << 8)); }
std::uint32_t get_u32(const std::uint8_t* p) {
  std::uint32_t v = 0;
  for (int i = 0; i < 4; ++i) v |= static_cast<std::uint32_t>(p[i]) << (8 * i);
  return v;
}
std::uint64_t get_u64(const std::uint8_t* p) {
  std::uint64_t v = 0;
  for (int i = 0; i < 8; ++i) v |= static_cast<std::uint64_t>(p[i]) << (8 * i);
  return v;
}
double get_f64(const std::uint8_t* p) {
  const std::uint64_t bits = get_u64(p);
  double v;
  std::memcpy(&v, &bits, sizeof v);
  return v;
}

void put_header(std::uint8_t* p, std::uint32_t magic, std::uint16_t kind) {
  put_u32(p, magic);
  put_u16(p + 4, kProtocolVersion);
  put_u16(p + 6, kind);
}

DecodeError check_header(const std::uint8_t* data, std::size_t size, std::uint32_t magic, std::uint16_t kind) {
  if (size != kMessageSize) return DecodeError::WrongSize;
  if (get_u32(data) != magic) return DecodeError::WrongMagic;
  if (get_u16(data + 4) != kProtocolVersion) return DecodeError::WrongVersion;
  if (get_u16(data + 6) != kind) return DecodeError::WrongKind;
  return DecodeError::None;
}

}  // namespace

const char* decode_error_name(DecodeError e) {
  switch (e) {
    case DecodeError::None: return "none";
    case DecodeError::WrongSize: return "wrong_size";
    case DecodeError::WrongMagic: return "wrong_magic";
    case DecodeError::WrongVersion: return "wrong_version";
    case DecodeError::WrongKind: return "wrong_kind";
    case DecodeError::NotFinite: return "not_finite";
    case DecodeError::OutOfRange: return "out_of_range";
    case DecodeError::Count: break;
  }
  return "unknown";
}

Message encode_sample(const Sample& s) {
  Message m{};
  put_header(m.data(), kSampleMagic, kSampleKind);
  put_u32(m.data() + 8, s.sequence);
  put_u32(m.data() + 12, s.buttons);
  put_u64(m.data() + 16, s.device_time_us);
  for (int i = 0; i < 3; ++i) put_f64(m.data() + 24 + 8 * i, s.position[i]);
  for (int i = 0; i < 4; ++i) put_f64(m.data() + 48 + 8 * i, s.orientation[static_cast<std::size_t>(i)]);
  return m;
}

Message encode_force(const Force& f) {
  Message m{};
  put_header(m.data(), kForceMagic, kForceKind);
  put_u32(m.data() + 8, f.sample_sequence);
  put_u32(m.data() + 12, f.status);
  put_u64(m.data() + 16, f.sample_device_time_us);
  put_u64(m.data() + 24, f.step);
  for (int i = 0; i < 3; ++i) put_f64(m.data() + 32 + 8 * i, f.force[i]);
  for (int i = 0; i < 3; ++i) put_f64(m.data() + 56 + 8 * i, f.torque[i]);
  return m;
}

DecodeError decode_sample(const std::uint8_t* data, std::size_t size, Sample& out) {
  if (const DecodeError e = check_header(data, size, kSampleMagic, kSampleKind); e != DecodeError::None) return e;
  Sample s;
  s.sequence = get_u32(data + 8);
  s.buttons = get_u32(data + 12);
  s.device_time_us = get_u64(data + 16);
  for (int i = 0; i < 3; ++i) s.position[i] = get_f64(data + 24 + 8 * i);
  double norm_sq = 0.0;
  for (int i = 0; i < 4; ++i) {
    const double q = get_f64(data + 48 + 8 * i);
    if (!std::isfinite(q)) return DecodeError::NotFinite;
    s.orientation[static_cast<std::size_t>(i)] = q;
    norm_sq += q * q;
  }
  for (int i = 0; i < 3; ++i) {
    if (!std::isfinite(s.position[i])) return DecodeError::NotFinite;
    if (std::fabs(s.position[i]) > kMaxPositionM) return DecodeError::OutOfRange;
  }
  if (s.device_time_us > kMaxDeviceTimeUs) return DecodeError::OutOfRange;
  // A unit quaternion, within what single-precision device SDKs round to.
  if (!(std::fabs(norm_sq - 1.0) < 1e-3)) return DecodeError::OutOfRange;
  out = s;
  return DecodeError::None;
}

DecodeError decode_force(const std::uint8_t* data, std::size_t size, Force& out) {
  if (const DecodeError e = check_header(data, size, kForceMagic, kForceKind); e != DecodeError::None) return e;
  Force f;
  f.sample_sequence = get_u32(data + 8);
  f.status = get_u32(data + 12);
  f.sample_device_time_us = get_u64(data + 16);
  f.step = get_u64(data + 24);
  for (int i = 0; i < 3; ++i) f.force[i] = get_f64(data + 32 + 8 * i);
  for (int i = 0; i < 3; ++i) f.torque[i] = get_f64(data + 56 + 8 * i);
  for (int i = 0; i < 3; ++i)
    if (!std::isfinite(f.force[i]) || !std::isfinite(f.torque[i])) return DecodeError::NotFinite;
  out = f;
  return DecodeError::None;
}

}  // namespace ffd::device
