/* A device bridge in C, with a pretend device: the probe circles 2 cm above the point given,
 * at 1 kHz, for the seconds given, and the forces ffdsim sends back are read every
 * millisecond. Put your device SDK's calls where the comments say.
 *
 *   cc -O2 -I ui/device/bridges ui/device/bridges/example_bridge.c -o example_bridge
 *   ./example_bridge 127.0.0.1 47000 2 0 0.12 0      # host port seconds x y z
 */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "ffdsim_device.h"

static uint64_t now_us(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (uint64_t)ts.tv_sec * 1000000u + (uint64_t)ts.tv_nsec / 1000u;
}

int main(int argc, char** argv) {
  if (argc != 7) {
    fprintf(stderr, "usage: %s HOST PORT SECONDS X Y Z\n", argv[0]);
    return 1;
  }
  ffdsim_link link;
  if (ffdsim_link_open(&link, argv[1], (uint16_t)atoi(argv[2])) != 0) {
    fprintf(stderr, "example_bridge: cannot reach %s:%s\n", argv[1], argv[2]);
    return 2;
  }
  const double seconds = atof(argv[3]), cx = atof(argv[4]), cy = atof(argv[5]), cz = atof(argv[6]);
  const uint64_t start = now_us();
  struct timespec next;
  clock_gettime(CLOCK_MONOTONIC, &next);
  ffdsim_force newest;
  memset(&newest, 0, sizeof newest);
  long forces = 0;
  double largest = 0.0;
  uint32_t sequence = 0;
  for (long ms = 0; ms < (long)(seconds * 1000.0); ++ms) {
    /* The servo tick: in a device SDK, its callback. Read the device's position here. */
    const double t = (double)ms * 1e-3;
    const ffdsim_sample s = ffdsim_sample_at(sequence++, now_us() - start, cx + 0.02 * cos(6.0 * t), cy + 0.02,
                                             cz + 0.02 * sin(6.0 * t));
    ffdsim_link_send(&link, &s);
    const int got = ffdsim_link_newest_force(&link, &newest);
    if (got > 0) {
      forces += got;
      /* Apply newest.force (N) to the device here, after your SDK's own limits. */
      const double size = sqrt(newest.force[0] * newest.force[0] + newest.force[1] * newest.force[1] +
                               newest.force[2] * newest.force[2]);
      if (size > largest) largest = size;
    }
    next.tv_nsec += 1000000;
    if (next.tv_nsec >= 1000000000) {
      next.tv_nsec -= 1000000000;
      ++next.tv_sec;
    }
    clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &next, NULL);
  }
  ffdsim_link_close(&link);
  printf("example_bridge: %u samples sent, %ld forces received, largest %.3f N, last from step %llu\n", sequence, forces,
         largest, (unsigned long long)newest.step);
  return forces > 0 ? 0 : 3;
}
