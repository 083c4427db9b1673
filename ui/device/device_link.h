#pragma once
// A haptic device on the probe (docs/realtime.md, "Haptic devices"): a device bridge sends the device's
// pose every millisecond over UDP (device_protocol.h) and receives the probe's coupling force.
//
//   bridge --UDP--> I/O thread --decode, order--> [SPSC queue] --> physics thread
//   physics thread --force of each step--> [SPSC queue] --> I/O thread --UDP--> bridge
//
// The physics thread never waits on the link: each step it takes what has arrived, maps the
// samples' device clock onto its own, interpolates the position at the step's release time
// (less a small delay, so that it lies between two samples), and hands it to the loop as a
// ProbePose command for that step, which is applied and recorded like any other. After the
// step it limits the force (magnitude and rate) and queues it for the I/O thread.
//
// Safety: no sample for `watchdog_ms` and the force sent is zero at once and the probe's
// target stays where it was; when samples return (and when the first arrives) the target
// eases from where it is to the device over `reengage_ms`, and the force never changes by
// more than the rate limit a step, so nothing is yanked. Datagrams that are malformed, of
// another protocol or version, duplicated or out of order are dropped and counted.
#include <atomic>
#include <cstdint>
#include <string>
#include <thread>

#include <readerwriterqueue/readerwriterqueue.h>

#include "device/device_protocol.h"
#include "device/position_history.h"
#include "ffd/physics_loop.h"

namespace ffd::device {

struct LinkSettings {
  std::string address = "127.0.0.1";  // IPv4 address to bind
  std::uint16_t port = 0;              // 0: any free port (port() says which)
  bool allow_remote = false;           // an address other than loopback only with this
  double force_limit_n = 8.0;          // |F| sent never exceeds this
  double force_rate_limit_n_per_ms = 1.0;  // nor changes by more than this per millisecond
  double watchdog_ms = 20.0;           // no sample for this long: force zero, probe held
  double reengage_ms = 200.0;          // after a silence: the probe eases to the device over this
  double delay_ms = 1.0;               // samples are interpolated at release time minus this
  double step_ms = 1.0;                // the physics step (the scene's dt)
};

// "udp://HOST:PORT" (HOST an IPv4 address or "localhost") into `settings`; throws
// std::invalid_argument naming the URL and the problem (a command-line error).
void parse_device_url(const std::string& url, LinkSettings& settings);

// Which samples the link takes: each newer than the last taken (serial-number arithmetic, so
// the 32-bit sequence may wrap); after a silence longer than `restart_after_ns` any sequence
// starts anew (a bridge that restarted counts from 0), and one at most a minute of 1 kHz
// samples ahead counts the numbers it passed over as gaps. The I/O thread's rule, on its own so
// that the tests and the fuzzer drive it without a socket.
class SequenceOrder {
 public:
  enum class Verdict : std::uint8_t { Taken, Duplicate, OutOfOrder };
  explicit SequenceOrder(std::int64_t restart_after_ns) : restart_after_ns_(restart_after_ns) {}
  // `skipped`: sequence numbers passed over by a taken sample (lost, or coming later).
  Verdict take(std::uint32_t sequence, std::int64_t arrival_ns, std::uint32_t& skipped);
  static constexpr std::int32_t kCountedAfterSilence = 60'000;

 private:
  std::int64_t restart_after_ns_;
  bool started_ = false;
  std::uint32_t last_ = 0;
  std::int64_t last_arrival_ns_ = 0;
};

enum class LinkState : std::uint8_t { Waiting, Live, Silent };
const char* link_state_name(LinkState s);

// What the link has seen and done, readable from any thread at any time.
struct LinkCounters {
  LinkState state = LinkState::Waiting;
  std::uint64_t datagrams = 0;          // every datagram received
  std::uint64_t samples = 0;            // accepted and handed to the physics thread
  std::array<std::uint64_t, static_cast<std::size_t>(DecodeError::Count)> malformed{};  // by reason
  std::uint64_t duplicates = 0;         // a sequence number seen already
  std::uint64_t out_of_order = 0;       // older than one already taken
  std::uint64_t sequence_gaps = 0;      // sequence numbers skipped when a later one arrived (lost,
                                        // or arriving later out of order)
  std::uint64_t queue_full = 0;         // the physics thread fell behind (dropped)
  std::uint64_t forces_sent = 0;
  std::uint64_t forces_unsent = 0;      // no bridge known yet, the queue full, or a send error
  std::uint64_t watchdog_trips = 0;     // silences longer than the watchdog
  std::uint64_t reengagements = 0;      // eases back to the device (the first sample included)
  std::uint64_t force_limited = 0;      // steps whose force was cut to the limit
  std::uint64_t rate_limited = 0;       // steps whose force change was cut to the rate limit
  double sample_rate_hz = 0.0;          // over the last ~100 samples
  Vec3 force = Vec3::Zero();            // the newest force sent, N
  std::uint64_t malformed_total() const;
};

class DeviceLink final : public ProbeSource {
 public:
  // Binds the socket and starts the I/O thread; throws std::runtime_error naming the address
  // when it cannot (in use, not local without allow_remote).
  explicit DeviceLink(const LinkSettings& settings);
  ~DeviceLink() override;
  DeviceLink(const DeviceLink&) = delete;
  DeviceLink& operator=(const DeviceLink&) = delete;

  std::uint16_t port() const { return port_; }
  const LinkSettings& settings() const { return settings_; }
  LinkCounters counters() const;

  // ProbeSource, on the physics thread.
  bool device_position(std::uint64_t step, std::int64_t release_ns, const Vec3& current, Vec3& position) override;
  void rendered_force(std::uint64_t step, std::int64_t release_ns, const Vec3& force) override;

 private:
  struct Arrival {
    Sample sample;
    std::int64_t arrival_ns = 0;  // CLOCK_MONOTONIC when the I/O thread took it
  };
  void io_loop();
  void receive_all();
  void send_forces();

  LinkSettings settings_;
  int socket_ = -1;
  std::uint16_t port_ = 0;
  moodycamel::ReaderWriterQueue<Arrival> arrivals_{1024};
  moodycamel::ReaderWriterQueue<Force> forces_{1024};
  std::atomic<bool> stop_{false};
  std::thread io_thread_;

  // I/O thread only.
  SequenceOrder order_;
  std::int64_t last_accepted_ns_ = 0;
  bool have_peer_ = false;
  std::uint8_t peer_[16]{};  // sockaddr_in
  double interval_average_ns_ = 0.0;

  // Physics thread only: the newest samples (device clock), and the newest one whole.
  PositionHistory history_;
  Sample newest_;
  LinkState state_ = LinkState::Waiting;
  Vec3 ease_offset_ = Vec3::Zero();  // target = device + offset * (1 - ease)
  std::uint64_t ease_start_step_ = 0;
  bool easing_ = false;
  Vec3 last_force_ = Vec3::Zero();

  // Shared counters (relaxed: figures, not synchronisation).
  std::atomic<std::uint64_t> datagrams_{0}, samples_{0}, duplicates_{0}, out_of_order_{0}, sequence_gaps_{0}, queue_full_{0},
      forces_sent_{0}, forces_unsent_{0}, watchdog_trips_{0}, reengagements_{0}, force_limited_{0},
      rate_limited_{0};
  std::array<std::atomic<std::uint64_t>, static_cast<std::size_t>(DecodeError::Count)> malformed_{};
  std::atomic<LinkState> shared_state_{LinkState::Waiting};
  std::atomic<double> sample_rate_hz_{0.0};
  std::atomic<double> force_x_{0.0}, force_y_{0.0}, force_z_{0.0};
};

}  // namespace ffd::device
