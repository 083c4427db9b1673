#include "device/device_link.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <pthread.h>
#include <sched.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <stdexcept>

namespace ffd::device {

namespace {

std::int64_t now_ns() {
  timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

bool is_loopback(const in_addr& a) { return (ntohl(a.s_addr) >> 24) == 127; }

// The I/O thread's longest sleep between looks at the force queue: a force waits at most this
// long before it is sent (the physics thread never makes a system call to wake the thread).
constexpr int kPollMicroseconds = 100;

}  // namespace

void parse_device_url(const std::string& url, LinkSettings& settings) {
  const std::string scheme = "udp://";
  if (url.rfind(scheme, 0) != 0)
    throw std::invalid_argument(url + ": expected udp://HOST:PORT (for example udp://127.0.0.1:47000)");
  const std::string rest = url.substr(scheme.size());
  const std::size_t colon = rest.rfind(':');
  if (colon == std::string::npos || colon == 0 || colon + 1 == rest.size())
    throw std::invalid_argument(url + ": expected udp://HOST:PORT with both a host and a port");
  std::string host = rest.substr(0, colon);
  const std::string port = rest.substr(colon + 1);
  if (host == "localhost") host = "127.0.0.1";
  in_addr address{};
  if (inet_pton(AF_INET, host.c_str(), &address) != 1)
    throw std::invalid_argument(url + ": host '" + host + "' is not an IPv4 address");
  if (port.find_first_not_of("0123456789") != std::string::npos || port.size() > 5 || std::stoul(port) > 65535)
    throw std::invalid_argument(url + ": port '" + port + "' is not a number from 0 to 65535");
  settings.address = host;
  settings.port = static_cast<std::uint16_t>(std::stoul(port));
}

const char* link_state_name(LinkState s) {
  switch (s) {
    case LinkState::Waiting: return "waiting";
    case LinkState::Live: return "live";
    case LinkState::Silent: return "silent";
  }
  return "unknown";
}

std::uint64_t LinkCounters::malformed_total() const {
  std::uint64_t n = 0;
  for (std::uint64_t m : malformed) n += m;
  return n;
}

SequenceOrder::Verdict SequenceOrder::take(std::uint32_t sequence, std::int64_t arrival_ns, std::uint32_t& skipped) {
  skipped = 0;
  const std::int32_t ahead = static_cast<std::int32_t>(sequence - last_);
  if (started_ && arrival_ns - last_arrival_ns_ <= restart_after_ns_) {
    if (ahead == 0) return Verdict::Duplicate;
    if (ahead < 0) return Verdict::OutOfOrder;
    skipped = static_cast<std::uint32_t>(ahead - 1);
  } else if (started_ && ahead > 0 && ahead <= kCountedAfterSilence) {
    // The same bridge went on counting through the silence (or this thread was not scheduled
    // for a while): the numbers passed over were lost all the same.
    skipped = static_cast<std::uint32_t>(ahead - 1);
  }
  started_ = true;
  last_ = sequence;
  last_arrival_ns_ = arrival_ns;
  return Verdict::Taken;
}

DeviceLink::DeviceLink(const LinkSettings& settings)
    : settings_(settings), order_(static_cast<std::int64_t>(settings.watchdog_ms * 1e6)) {
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(settings.port);
  if (inet_pton(AF_INET, settings.address.c_str(), &address.sin_addr) != 1)
    throw std::runtime_error("device link: '" + settings.address + "' is not an IPv4 address");
  if (!is_loopback(address.sin_addr) && !settings.allow_remote)
    throw std::runtime_error("device link: " + settings.address +
                             " is not a loopback address; binding it exposes the probe to the network: add "
                             "--device-allow-remote to do so");
  socket_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (socket_ < 0) throw std::runtime_error(std::string("device link: cannot open a UDP socket: ") + std::strerror(errno));
  if (::bind(socket_, reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0) {
    const std::string why = std::strerror(errno);
    ::close(socket_);
    throw std::runtime_error("device link: cannot bind udp://" + settings.address + ":" +
                             std::to_string(settings.port) + ": " + why);
  }
  socklen_t length = sizeof address;
  getsockname(socket_, reinterpret_cast<sockaddr*>(&address), &length);
  port_ = ntohs(address.sin_port);
  for (auto& m : malformed_) m.store(0);
  io_thread_ = std::thread([this] { io_loop(); });
}

DeviceLink::~DeviceLink() {
  stop_.store(true);
  if (io_thread_.joinable()) io_thread_.join();
  if (socket_ >= 0) ::close(socket_);
}

LinkCounters DeviceLink::counters() const {
  LinkCounters c;
  c.state = shared_state_.load(std::memory_order_relaxed);
  c.datagrams = datagrams_.load(std::memory_order_relaxed);
  c.samples = samples_.load(std::memory_order_relaxed);
  for (std::size_t i = 0; i < c.malformed.size(); ++i) c.malformed[i] = malformed_[i].load(std::memory_order_relaxed);
  c.duplicates = duplicates_.load(std::memory_order_relaxed);
  c.out_of_order = out_of_order_.load(std::memory_order_relaxed);
  c.sequence_gaps = sequence_gaps_.load(std::memory_order_relaxed);
  c.queue_full = queue_full_.load(std::memory_order_relaxed);
  c.forces_sent = forces_sent_.load(std::memory_order_relaxed);
  c.forces_unsent = forces_unsent_.load(std::memory_order_relaxed);
  c.watchdog_trips = watchdog_trips_.load(std::memory_order_relaxed);
  c.reengagements = reengagements_.load(std::memory_order_relaxed);
  c.force_limited = force_limited_.load(std::memory_order_relaxed);
  c.rate_limited = rate_limited_.load(std::memory_order_relaxed);
  c.sample_rate_hz = sample_rate_hz_.load(std::memory_order_relaxed);
  c.force = Vec3(force_x_.load(std::memory_order_relaxed), force_y_.load(std::memory_order_relaxed),
                 force_z_.load(std::memory_order_relaxed));
  return c;
}

// ---- I/O thread ----------------------------------------------------------------------------

void DeviceLink::io_loop() {
  // Below the physics threads' priority (physics_loop.cpp: max - 9), above the UI's, so that a
  // force waits for a core no longer than a step; quietly left as it is when not permitted.
  sched_param param{};
  param.sched_priority = sched_get_priority_max(SCHED_FIFO) - 19;
  pthread_setschedparam(pthread_self(), SCHED_FIFO, &param);
  pollfd fd{socket_, POLLIN, 0};
  const timespec wait{0, kPollMicroseconds * 1000L};
  while (!stop_.load(std::memory_order_relaxed)) {
    ppoll(&fd, 1, &wait, nullptr);
    receive_all();
    send_forces();
  }
}

void DeviceLink::receive_all() {
  std::uint8_t buffer[2048];
  for (;;) {
    sockaddr_in from{};
    socklen_t from_length = sizeof from;
    // MSG_TRUNC: the datagram's real length, so that an oversized one is refused, not cut.
    const ssize_t n = recvfrom(socket_, buffer, sizeof buffer, MSG_DONTWAIT | MSG_TRUNC,
                               reinterpret_cast<sockaddr*>(&from), &from_length);
    if (n < 0) return;  // EAGAIN: nothing more now
    datagrams_.fetch_add(1, std::memory_order_relaxed);
    Arrival a;
    const DecodeError error = decode_sample(buffer, static_cast<std::size_t>(n), a.sample);
    if (error != DecodeError::None) {
      malformed_[static_cast<std::size_t>(error)].fetch_add(1, std::memory_order_relaxed);
      continue;
    }
    a.arrival_ns = now_ns();
    const bool restarted = a.arrival_ns - last_accepted_ns_ > settings_.watchdog_ms * 1e6;
    std::uint32_t skipped = 0;
    switch (order_.take(a.sample.sequence, a.arrival_ns, skipped)) {
      case SequenceOrder::Verdict::Duplicate: duplicates_.fetch_add(1, std::memory_order_relaxed); continue;
      case SequenceOrder::Verdict::OutOfOrder: out_of_order_.fetch_add(1, std::memory_order_relaxed); continue;
      case SequenceOrder::Verdict::Taken: break;
    }
    sequence_gaps_.fetch_add(skipped, std::memory_order_relaxed);
    if (!restarted && last_accepted_ns_ > 0) {  // the sample rate, over about 100 samples
      const double interval = static_cast<double>(a.arrival_ns - last_accepted_ns_) / (1.0 + skipped);
      interval_average_ns_ = interval_average_ns_ > 0.0 ? 0.99 * interval_average_ns_ + 0.01 * interval : interval;
      sample_rate_hz_.store(1e9 / interval_average_ns_, std::memory_order_relaxed);
    }
    last_accepted_ns_ = a.arrival_ns;
    std::memcpy(peer_, &from, sizeof from);
    have_peer_ = true;
    if (arrivals_.try_enqueue(a)) samples_.fetch_add(1, std::memory_order_relaxed);
    else queue_full_.fetch_add(1, std::memory_order_relaxed);
  }
}

void DeviceLink::send_forces() {
  Force f;
  while (forces_.try_dequeue(f)) {
    if (!have_peer_) {
      forces_unsent_.fetch_add(1, std::memory_order_relaxed);
      continue;
    }
    const Message m = encode_force(f);
    if (sendto(socket_, m.data(), m.size(), MSG_DONTWAIT, reinterpret_cast<const sockaddr*>(peer_), sizeof(sockaddr_in)) ==
        static_cast<ssize_t>(m.size()))
      forces_sent_.fetch_add(1, std::memory_order_relaxed);
    else
      forces_unsent_.fetch_add(1, std::memory_order_relaxed);
  }
}

// ---- physics thread ------------------------------------------------------------------------

bool DeviceLink::device_position(std::uint64_t step, std::int64_t release_ns, const Vec3& current, Vec3& position) {
  Arrival a;
  while (arrivals_.try_dequeue(a)) {
    history_.add({static_cast<std::int64_t>(a.sample.device_time_us * 1000), a.arrival_ns, a.sample.position});
    newest_ = a.sample;
  }
  if (history_.empty()) return false;  // waiting for the first sample
  if (static_cast<double>(release_ns - history_.newest().received_ns) > settings_.watchdog_ms * 1e6) {
    if (state_ == LinkState::Live) {
      state_ = LinkState::Silent;
      shared_state_.store(state_, std::memory_order_relaxed);
      watchdog_trips_.fetch_add(1, std::memory_order_relaxed);
    }
    return false;  // the probe's target stays where it is
  }
  // The position at the release time less the delay, on the device's clock: between the two
  // samples around it.
  const double t = static_cast<double>(release_ns - history_.clock_offset_ns()) - settings_.delay_ms * 1e6;
  const Vec3 device = history_.at(t);
  if (state_ != LinkState::Live) {
    // The first sample, or the first after a silence: ease from where the probe's target is.
    state_ = LinkState::Live;
    shared_state_.store(state_, std::memory_order_relaxed);
    ease_offset_ = current - device;
    ease_start_step_ = step;
    easing_ = true;
    reengagements_.fetch_add(1, std::memory_order_relaxed);
  }
  position = device;
  if (easing_) {
    const double s = static_cast<double>(step - ease_start_step_) * settings_.step_ms / settings_.reengage_ms;
    if (s >= 1.0) {
      easing_ = false;
    } else {
      const double w = s * s * (3.0 - 2.0 * s);  // smoothstep: no jump in the target's speed either
      position = device + (1.0 - w) * ease_offset_;
    }
  }
  return true;
}

void DeviceLink::rendered_force(std::uint64_t step, std::int64_t, const Vec3& force) {
  Force out;
  out.step = step;
  if (!history_.empty()) {
    out.sample_sequence = newest_.sequence;
    out.sample_device_time_us = newest_.device_time_us;
  }
  Vec3 f = Vec3::Zero();
  if (state_ == LinkState::Live) {
    out.status |= kForceLive;
    f = force.allFinite() ? force : Vec3::Zero();
    const double size = f.norm();
    if (size > settings_.force_limit_n) {
      f *= settings_.force_limit_n / size;
      out.status |= kForceLimited;
      force_limited_.fetch_add(1, std::memory_order_relaxed);
    }
    const Vec3 change = f - last_force_;
    const double most = settings_.force_rate_limit_n_per_ms * settings_.step_ms, changed = change.norm();
    if (changed > most) {
      f = last_force_ + change * (most / changed);
      out.status |= kForceRateLimited;
      rate_limited_.fetch_add(1, std::memory_order_relaxed);
    }
    if (easing_) out.status |= kForceReengaging;
  } else if (state_ == LinkState::Silent) {
    out.status |= kForceWatchdog;  // zero at once: the safe side of a lost device
  }
  last_force_ = f;
  out.force = f;
  force_x_.store(f.x(), std::memory_order_relaxed);
  force_y_.store(f.y(), std::memory_order_relaxed);
  force_z_.store(f.z(), std::memory_order_relaxed);
  if (!forces_.try_enqueue(out)) forces_unsent_.fetch_add(1, std::memory_order_relaxed);
}

}  // namespace ffd::device
