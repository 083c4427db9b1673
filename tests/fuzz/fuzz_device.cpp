// Datagrams from a device bridge through the link's decoder and sequence order, as its I/O
// thread takes them: the input is cut into datagrams (each a length byte, then that many
// bytes; the seeds hold whole 80-byte samples, NaNs, huge values, other versions and sizes).
// Every datagram must end in exactly one counter, and a sample taken must be finite and in range.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>

#include "device/device_link.h"
#include "device/device_protocol.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace ffd::device;
  SequenceOrder order(20'000'000);
  std::size_t datagrams = 0, malformed = 0, taken = 0, duplicates = 0, late = 0;
  std::int64_t arrival_ns = 0;
  for (std::size_t at = 0; at < size;) {
    // A length byte of 0 stands for a whole message (80 bytes), the usual case.
    const std::size_t length = data[at] == 0 ? kMessageSize : data[at];
    ++at;
    const std::size_t n = std::min(length, size - at);
    ++datagrams;
    arrival_ns += 1'000'000;
    Sample s;
    const DecodeError e = decode_sample(data + at, n, s);
    at += n;
    if (e != DecodeError::None) {
      if (e >= DecodeError::Count) std::abort();
      ++malformed;
      continue;
    }
    for (int i = 0; i < 3; ++i)
      if (!std::isfinite(s.position[i]) || std::fabs(s.position[i]) > kMaxPositionM) std::abort();
    std::uint32_t skipped = 0;
    switch (order.take(s.sequence, arrival_ns, skipped)) {
      case SequenceOrder::Verdict::Taken: ++taken; break;
      case SequenceOrder::Verdict::Duplicate: ++duplicates; break;
      case SequenceOrder::Verdict::OutOfOrder: ++late; break;
    }
    // A taken sample re-encodes to the bytes it came from.
    const Message again = encode_sample(s);
    for (std::size_t i = 0; i < kMessageSize; ++i)
      if (again[i] != data[at - n + i]) std::abort();
  }
  if (malformed + taken + duplicates + late != datagrams) std::abort();
  return 0;
}
