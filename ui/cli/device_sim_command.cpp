// `ffdsim device-sim`: a haptic device bridge without a device. It plays a replay script's
// [[probe_path]] as a device would, one pose sample per millisecond over the device link's
// protocol (device/device_protocol.h), and writes the force it received each millisecond.
// Faults are injected on request (dropped, duplicated and reordered samples, a silence) with
// a seeded generator, and counted, so that a test can hold the link's counters to them.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <mutex>
#include <optional>
#include <random>
#include <thread>

#include <nlohmann/json.hpp>

#include "commands.h"
#include "device/device_link.h"
#include "device/device_protocol.h"
#include "ffd/replay_script.h"
#include "ffd/step_statistics.h"

namespace ffdsim {

namespace {

std::int64_t now_ns() {
  timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

void sleep_until(std::int64_t deadline_ns) {
  const timespec ts{static_cast<time_t>(deadline_ns / 1'000'000'000), static_cast<long>(deadline_ns % 1'000'000'000)};
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
  }
}

struct Received {
  std::int64_t at_ns = 0;
  ffd::device::Force force;
};

// The device's positions, one a millisecond, from the script's probe commands (held before the
// first and after the last).
std::vector<ffd::Vec3> trajectory(const ffd::ReplayScript& script, double step_ms) {
  std::vector<std::pair<std::uint64_t, ffd::Vec3>> keys;
  for (const ffd::Command& c : script.commands)
    if (c.kind == ffd::CommandKind::ProbePose) keys.emplace_back(c.step, c.vector);
  if (keys.empty()) throw ffd::InputError(script.path + ": has no [[probe_path]] for the device to play");
  const double last_ms = static_cast<double>(keys.back().first) * step_ms;
  std::vector<ffd::Vec3> positions(static_cast<std::size_t>(last_ms) + 1);
  std::size_t k = 0;
  for (std::size_t ms = 0; ms < positions.size(); ++ms) {
    const double step = static_cast<double>(ms) / step_ms;
    while (k + 1 < keys.size() && static_cast<double>(keys[k + 1].first) <= step) ++k;
    positions[ms] = keys[k].second;
  }
  return positions;
}

}  // namespace

void register_device_sim(CLI::App& app, DeviceSimOptions& o) {
  CLI::App* cmd = app.add_subcommand(
      "device-sim", "A haptic device without a device: plays a replay script's probe path over the device link at 1 kHz "
                    "and writes the force it receives (docs/realtime.md, \"Haptic devices\")");
  cmd->add_option("script", o.script, "Replay script whose [[probe_path]] the device plays")->required();
  cmd->add_option("--to", o.url, "Where ffdsim run --device listens: udp://HOST:PORT")->required();
  cmd->add_option("--out", o.out_path, "CSV: each millisecond's sample and the newest force received");
  cmd->add_option("--report", o.report_path, "JSON: what was sent, injected and received, and the round trip");
  cmd->add_option("--drop", o.drop, "Share of samples not sent")->check(CLI::Range(0.0, 1.0));
  cmd->add_option("--duplicate", o.duplicate, "Share of samples sent twice")->check(CLI::Range(0.0, 1.0));
  cmd->add_option("--reorder", o.reorder, "Share of samples sent after the next one")->check(CLI::Range(0.0, 1.0));
  cmd->add_option("--seed", o.seed, "Seed of the fault injection");
  cmd->add_option("--silence-at-ms", o.silence_at_ms, "Stop sending at this time ...")->check(CLI::Range(0.0, 1e9));
  cmd->add_option("--silence-ms", o.silence_ms, "... for this long (a device unplugged, a bridge stalled)")
      ->check(CLI::Range(0.0, 1e9));
  cmd->add_option("--linger-ms", o.linger_ms, "Keep receiving this long after the last sample")->check(CLI::Range(0.0, 1e6));
  cmd->add_option("--wait-ms", o.wait_ms, "Keep sending the first pose until a force answers, at most this long")
      ->check(CLI::Range(0.0, 1e6));
  cmd->add_flag("--quiet,-q", o.quiet, "Print only errors");
}

int run_device_sim(const DeviceSimOptions& o) {
  std::vector<ffd::Vec3> positions;
  ffd::device::LinkSettings target;
  try {
    ffd::device::parse_device_url(o.url, target);
  } catch (const std::invalid_argument& e) {
    std::fprintf(stderr, "ffdsim: error: --to %s\n", e.what());
    return kExitUsage;
  }
  try {
    const ffd::LoadedReplay loaded = ffd::load_replay_file(o.script);
    positions = trajectory(loaded.script, loaded.model.settings.dt * 1000.0);
    if (!o.out_path.empty()) ensure_parent_folder(o.out_path);
    if (!o.report_path.empty()) ensure_parent_folder(o.report_path);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ffdsim: error: %s\n", e.what());
    return kExitBadInput;
  }
  if (o.drop + o.duplicate + o.reorder > 1.0) {
    std::fprintf(stderr, "ffdsim: error: --drop, --duplicate and --reorder add up to more than 1\n");
    return kExitUsage;
  }
  const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(target.port);
  inet_pton(AF_INET, target.address.c_str(), &to.sin_addr);
  if (fd < 0 || ::connect(fd, reinterpret_cast<const sockaddr*>(&to), sizeof to) != 0) {
    std::fprintf(stderr, "ffdsim: error: %s: cannot open a UDP socket to it\n", o.url.c_str());
    return kExitBadInput;
  }
  timeval timeout{0, 20'000};
  setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);

  // The receiver: every force as it arrives, with its arrival time.
  std::mutex mutex;
  std::vector<Received> received;
  received.reserve(positions.size() * 2 + 1000);
  std::uint64_t malformed_forces = 0;
  std::atomic<bool> stop{false};
  std::thread receiver([&] {
    std::uint8_t buffer[2048];
    while (!stop.load()) {
      const ssize_t n = recv(fd, buffer, sizeof buffer, MSG_TRUNC);
      if (n < 0) continue;  // the timeout, or the link not up yet
      Received r;
      r.at_ns = now_ns();
      const bool ok = ffd::device::decode_force(buffer, static_cast<std::size_t>(n), r.force) == ffd::device::DecodeError::None;
      std::lock_guard<std::mutex> lock(mutex);
      if (ok) received.push_back(r);
      else ++malformed_forces;
    }
  });

  std::mt19937_64 random(o.seed);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::uint32_t sequence = 0;
  const std::int64_t device_epoch = now_ns();  // the device's own clock starts at 0
  auto send_sample = [&](const ffd::Vec3& position, std::uint32_t seq, std::int64_t at_ns) {
    ffd::device::Sample s;
    s.sequence = seq;
    s.device_time_us = static_cast<std::uint64_t>((at_ns - device_epoch) / 1000);
    s.position = position;
    const ffd::device::Message m = ffd::device::encode_sample(s);
    return ::send(fd, m.data(), m.size(), 0) == static_cast<ssize_t>(m.size());
  };
  struct Sent {
    std::uint64_t planned = 0, sent = 0, dropped = 0, duplicated = 0, reordered = 0, silent = 0, errors = 0;
  } counts;
  // Until a force answers (ffdsim may still be loading its scene), the first pose, unsequenced
  // in the figures: the path starts once the link is up.
  std::int64_t start = now_ns();
  if (o.wait_ms > 0.0) {
    const std::int64_t give_up = start + static_cast<std::int64_t>(o.wait_ms * 1e6);
    for (std::int64_t t = start; t < give_up; t += 1'000'000) {
      sleep_until(t);
      send_sample(positions.front(), sequence++, now_ns());
      std::lock_guard<std::mutex> lock(mutex);
      if (!received.empty()) break;
    }
    std::lock_guard<std::mutex> lock(mutex);
    if (received.empty()) {
      stop.store(true);
      receiver.join();
      ::close(fd);
      std::fprintf(stderr, "ffdsim: error: %s: no force came back within %.0f ms (is `ffdsim run --device %s` running?)\n",
                   o.url.c_str(), o.wait_ms, o.url.c_str());
      return kExitRuntime;
    }
    received.clear();
  }
  const std::uint32_t first_sequence = sequence;
  start = now_ns();
  std::vector<std::int64_t> sent_at(positions.size(), -1);
  std::optional<std::pair<std::uint32_t, ffd::Vec3>> held;  // a sample held back to be sent late
  for (std::size_t ms = 0; ms < positions.size(); ++ms) {
    const std::int64_t due = start + static_cast<std::int64_t>(ms) * 1'000'000;
    sleep_until(due);
    const std::uint32_t seq = sequence++;
    ++counts.planned;
    const double t_ms = static_cast<double>(ms);
    if (o.silence_ms > 0.0 && t_ms >= o.silence_at_ms && t_ms < o.silence_at_ms + o.silence_ms) {
      ++counts.silent;
      continue;
    }
    const double roll = uniform(random);
    const std::int64_t at = now_ns();
    if (roll < o.drop) {
      ++counts.dropped;
      continue;
    }
    if (roll < o.drop + o.reorder && !held) {
      held = std::make_pair(seq, positions[ms]);  // sent after the next sample
      ++counts.reordered;
      continue;
    }
    if (!send_sample(positions[ms], seq, at)) ++counts.errors;
    ++counts.sent;
    sent_at[ms] = at;
    if (roll >= o.drop + o.reorder && roll < o.drop + o.reorder + o.duplicate) {
      send_sample(positions[ms], seq, at);
      ++counts.duplicated;
    }
    if (held) {
      send_sample(held->second, held->first, at);
      ++counts.sent;
      held.reset();
    }
  }
  if (held) {  // nothing came after it: it was lost, not reordered
    --counts.reordered;
    ++counts.dropped;
  }
  sleep_until(now_ns() + static_cast<std::int64_t>(o.linger_ms * 1e6));
  stop.store(true);
  receiver.join();
  ::close(fd);

  // Round trip: from a sample's sending to the first force that answers it (device clock).
  std::vector<std::int64_t> round_trip_ns;
  std::uint32_t answered = 0;
  bool any_answered = false;
  double max_force = 0.0, max_change_per_step = 0.0, max_rise_per_step = 0.0;
  std::uint64_t watchdog_forces = 0;
  std::sort(received.begin(), received.end(), [](const Received& a, const Received& b) { return a.force.step < b.force.step; });
  for (std::size_t i = 0; i < received.size(); ++i) {
    const ffd::device::Force& f = received[i].force;
    max_force = std::max(max_force, f.force.norm());
    if (f.status & ffd::device::kForceWatchdog) ++watchdog_forces;
    if (i > 0 && f.step == received[i - 1].force.step + 1) {
      const double change = (f.force - received[i - 1].force.force).norm();
      max_change_per_step = std::max(max_change_per_step, change);
      // What the rate limit bounds: every change into a rendered force (the watchdog's cut to
      // zero is the one change allowed to be sudden).
      if (f.status & ffd::device::kForceLive) max_rise_per_step = std::max(max_rise_per_step, change);
    }
  }
  std::sort(received.begin(), received.end(), [](const Received& a, const Received& b) { return a.at_ns < b.at_ns; });
  for (const Received& r : received) {
    const std::uint32_t seq = r.force.sample_sequence;
    if (seq < first_sequence || (any_answered && static_cast<std::int32_t>(seq - answered) <= 0)) continue;
    any_answered = true;
    answered = seq;
    const std::int64_t sent = device_epoch + static_cast<std::int64_t>(r.force.sample_device_time_us) * 1000;
    round_trip_ns.push_back(r.at_ns - sent);
  }
  const ffd::TimeSummary rtt = ffd::summarize_times(round_trip_ns);

  if (!o.out_path.empty()) {
    std::ofstream csv(o.out_path);
    // sent_at_ms: when the sample left, ms after the start (-1: not sent); a sender held up by
    // its scheduler sends later than its t_ms.
    csv << "t_ms,sent,x,y,z,fx,fy,fz,status,step,sent_at_ms\n";
    std::size_t r = 0;
    ffd::device::Force newest;
    for (std::size_t ms = 0; ms < positions.size(); ++ms) {
      const std::int64_t end = start + static_cast<std::int64_t>(ms + 1) * 1'000'000;
      while (r < received.size() && received[r].at_ns < end) newest = received[r++].force;
      const double sent_at_ms = sent_at[ms] >= 0 ? static_cast<double>(sent_at[ms] - start) * 1e-6 : -1.0;
      char line[256];
      std::snprintf(line, sizeof line, "%zu,%d,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%u,%llu,%.3f\n", ms, sent_at[ms] >= 0 ? 1 : 0,
                    positions[ms].x(), positions[ms].y(), positions[ms].z(), newest.force.x(), newest.force.y(),
                    newest.force.z(), newest.status, static_cast<unsigned long long>(newest.step), sent_at_ms);
      csv << line;
    }
    if (!csv) {
      std::fprintf(stderr, "ffdsim: error: %s: cannot write\n", o.out_path.c_str());
      return kExitBadInput;
    }
  }
  const nlohmann::json report = {{"samples_planned", counts.planned},
                                 {"samples_sent", counts.sent},
                                 {"dropped", counts.dropped},
                                 {"duplicated", counts.duplicated},
                                 {"reordered", counts.reordered},
                                 {"silent", counts.silent},
                                 {"send_errors", counts.errors},
                                 {"forces_received", received.size()},
                                 {"forces_malformed", malformed_forces},
                                 {"forces_watchdog", watchdog_forces},
                                 {"force_max_n", max_force},
                                 {"force_change_max_n_per_step", max_change_per_step},
                                 {"force_rise_max_n_per_step", max_rise_per_step},
                                 {"round_trip_us", {{"samples", round_trip_ns.size()},
                                                    {"p50", rtt.p50_us},
                                                    {"p99", rtt.p99_us},
                                                    {"max", rtt.max_us}}}};
  if (!o.report_path.empty()) {
    std::ofstream out(o.report_path);
    out << report.dump(2) << '\n';
    if (!out) {
      std::fprintf(stderr, "ffdsim: error: %s: cannot write\n", o.report_path.c_str());
      return kExitBadInput;
    }
  }
  if (!o.quiet)
    std::printf("device-sim: %llu samples sent of %llu (dropped %llu, duplicated %llu, reordered %llu, silent %llu); "
                "%zu forces received, max %.3f N; round trip p50 %.0f us, p99 %.0f us, max %.0f us\n",
                static_cast<unsigned long long>(counts.sent), static_cast<unsigned long long>(counts.planned),
                static_cast<unsigned long long>(counts.dropped), static_cast<unsigned long long>(counts.duplicated),
                static_cast<unsigned long long>(counts.reordered), static_cast<unsigned long long>(counts.silent),
                received.size(), max_force, rtt.p50_us, rtt.p99_us, rtt.max_us);
  if (received.empty()) {
    std::fprintf(stderr, "ffdsim: error: %s: no force came back while the path played\n", o.url.c_str());
    return kExitRuntime;
  }
  return kExitOk;
}

}  // namespace ffdsim
