/* ffdsim device link, reference bridge for C and C++ (docs/realtime.md, "Haptic devices").
 *
 * One header, no dependencies beyond POSIX sockets. Copy it into your device's program and,
 * in the device SDK's servo callback (1 kHz), send the device's pose and apply the newest
 * force ffdsim sent back:
 *
 *   ffdsim_link link;
 *   ffdsim_link_open(&link, "127.0.0.1", 47000);          // where `ffdsim run --device` listens
 *   ...
 *   ffdsim_sample s = ffdsim_sample_at(sequence++, time_us, x, y, z);   // metres, scene frame
 *   ffdsim_link_send(&link, &s);
 *   ffdsim_force f;
 *   if (ffdsim_link_newest_force(&link, &f) > 0) set_device_force(f.force);  // newtons
 *
 * Wire format: version 1, 80-byte messages, little-endian (see ui/device/device_protocol.h).
 */
#ifndef FFDSIM_DEVICE_H
#define FFDSIM_DEVICE_H

#include <arpa/inet.h>
#include <netinet/in.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

#define FFDSIM_DEVICE_VERSION 1
#define FFDSIM_DEVICE_MESSAGE_SIZE 80
/* Force status bits. */
#define FFDSIM_FORCE_LIVE 1u            /* samples arrive: the force is rendered */
#define FFDSIM_FORCE_WATCHDOG 2u        /* ffdsim heard nothing for its watchdog time: force zero */
#define FFDSIM_FORCE_LIMITED 4u         /* cut to the force limit */
#define FFDSIM_FORCE_RATE_LIMITED 8u    /* its change cut to the rate limit */
#define FFDSIM_FORCE_REENGAGING 16u     /* after a silence: the probe eases back to the device */

typedef struct {
  uint32_t sequence;        /* +1 per sample */
  uint32_t buttons;         /* bit i: button i down */
  uint64_t device_time_us;  /* the device's own clock */
  double position[3];       /* m, in the scene's frame */
  double orientation[4];    /* unit quaternion w, x, y, z; 1, 0, 0, 0 without one */
} ffdsim_sample;

typedef struct {
  uint32_t sample_sequence;        /* the newest sample the step used */
  uint32_t status;                 /* FFDSIM_FORCE_* bits */
  uint64_t sample_device_time_us;  /* that sample's device time: now minus it is the round trip */
  uint64_t step;                   /* the physics step the force is from */
  double force[3];                 /* N */
  double torque[3];                /* N m (0 for ffdsim's sphere probe) */
} ffdsim_force;

static inline ffdsim_sample ffdsim_sample_at(uint32_t sequence, uint64_t device_time_us, double x, double y, double z) {
  ffdsim_sample s;
  memset(&s, 0, sizeof s);
  s.sequence = sequence;
  s.device_time_us = device_time_us;
  s.position[0] = x;
  s.position[1] = y;
  s.position[2] = z;
  s.orientation[0] = 1.0;
  return s;
}

static inline void ffdsim_put_u64_(uint8_t* p, uint64_t v) {
  int i;
  for (i = 0; i < 8; ++i) p[i] = (uint8_t)(v >> (8 * i));
}
static inline uint64_t ffdsim_get_u64_(const uint8_t* p) {
  uint64_t v = 0;
  int i;
  for (i = 0; i < 8; ++i) v |= (uint64_t)p[i] << (8 * i);
  return v;
}
static inline void ffdsim_put_u32_(uint8_t* p, uint32_t v) {
  int i;
  for (i = 0; i < 4; ++i) p[i] = (uint8_t)(v >> (8 * i));
}
static inline uint32_t ffdsim_get_u32_(const uint8_t* p) {
  return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) | ((uint32_t)p[3] << 24);
}
static inline void ffdsim_put_f64_(uint8_t* p, double v) {
  uint64_t bits;
  memcpy(&bits, &v, sizeof bits);
  ffdsim_put_u64_(p, bits);
}
static inline double ffdsim_get_f64_(const uint8_t* p) {
  const uint64_t bits = ffdsim_get_u64_(p);
  double v;
  memcpy(&v, &bits, sizeof v);
  return v;
}

static inline void ffdsim_encode_sample(const ffdsim_sample* s, uint8_t out[FFDSIM_DEVICE_MESSAGE_SIZE]) {
  int i;
  memcpy(out, "FFDS", 4);
  out[4] = FFDSIM_DEVICE_VERSION;
  out[5] = 0;
  out[6] = 1; /* kind: sample */
  out[7] = 0;
  ffdsim_put_u32_(out + 8, s->sequence);
  ffdsim_put_u32_(out + 12, s->buttons);
  ffdsim_put_u64_(out + 16, s->device_time_us);
  for (i = 0; i < 3; ++i) ffdsim_put_f64_(out + 24 + 8 * i, s->position[i]);
  for (i = 0; i < 4; ++i) ffdsim_put_f64_(out + 48 + 8 * i, s->orientation[i]);
}

/* 0 and `out` filled for a force message of this version; -1 for anything else. */
static inline int ffdsim_decode_force(const uint8_t* data, size_t size, ffdsim_force* out) {
  int i;
  if (size != FFDSIM_DEVICE_MESSAGE_SIZE || memcmp(data, "FFDF", 4) != 0) return -1;
  if (data[4] != FFDSIM_DEVICE_VERSION || data[5] != 0 || data[6] != 2 || data[7] != 0) return -1;
  out->sample_sequence = ffdsim_get_u32_(data + 8);
  out->status = ffdsim_get_u32_(data + 12);
  out->sample_device_time_us = ffdsim_get_u64_(data + 16);
  out->step = ffdsim_get_u64_(data + 24);
  for (i = 0; i < 3; ++i) out->force[i] = ffdsim_get_f64_(data + 32 + 8 * i);
  for (i = 0; i < 3; ++i) out->torque[i] = ffdsim_get_f64_(data + 56 + 8 * i);
  return 0;
}

typedef struct {
  int fd;
} ffdsim_link;

/* A UDP socket connected to ffdsim; 0 on success, -1 on failure (errno says why). */
static inline int ffdsim_link_open(ffdsim_link* link, const char* host, uint16_t port) {
  struct sockaddr_in to;
  memset(&to, 0, sizeof to);
  to.sin_family = AF_INET;
  to.sin_port = htons(port);
  link->fd = -1;
  if (inet_pton(AF_INET, host, &to.sin_addr) != 1) return -1;
  link->fd = socket(AF_INET, SOCK_DGRAM, 0);
  if (link->fd < 0) return -1;
  if (connect(link->fd, (const struct sockaddr*)&to, sizeof to) != 0) {
    close(link->fd);
    link->fd = -1;
    return -1;
  }
  return 0;
}

/* Sends one sample; never blocks the servo loop. 0 on success. */
static inline int ffdsim_link_send(ffdsim_link* link, const ffdsim_sample* s) {
  uint8_t message[FFDSIM_DEVICE_MESSAGE_SIZE];
  ffdsim_encode_sample(s, message);
  return send(link->fd, message, sizeof message, MSG_DONTWAIT) == (ssize_t)sizeof message ? 0 : -1;
}

/* Reads every force waiting, without blocking, and keeps the newest (by step) in `newest`.
 * Returns how many valid forces were read (0: none since the last call; keep the last one
 * only as long as your device's own safety allows). */
static inline int ffdsim_link_newest_force(ffdsim_link* link, ffdsim_force* newest) {
  uint8_t buffer[2 * FFDSIM_DEVICE_MESSAGE_SIZE];
  int count = 0;
  for (;;) {
    ffdsim_force f;
    const ssize_t n = recv(link->fd, buffer, sizeof buffer, MSG_DONTWAIT);
    if (n < 0) break;
    if (ffdsim_decode_force(buffer, (size_t)n, &f) != 0) continue;
    if (count == 0 || f.step > newest->step) *newest = f;
    ++count;
  }
  return count;
}

static inline void ffdsim_link_close(ffdsim_link* link) {
  if (link->fd >= 0) close(link->fd);
  link->fd = -1;
}

#endif /* FFDSIM_DEVICE_H */
