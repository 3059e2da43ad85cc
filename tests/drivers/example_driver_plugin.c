/* A driver that is not built in, as a third party would ship one: a MODULE in plain C that sees only
 * drivers/plugin_abi.h. "example-ramp" pushes `count` samples (ramp = i * step_m, elapsed since the
 * first sample), one every `period_s`, then idles streaming; with `repeat` it starts over.
 * Configuration errors go back through config_error, naming the key. */
#define _POSIX_C_SOURCE 200809L /* clock_gettime */

#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "drivers/plugin_abi.h"

typedef struct ramp {
  long long count;
  double step_m;
  double period_s;
  int repeat;
} ramp;

static int64_t now_ns(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (int64_t)ts.tv_sec * 1000000000 + ts.tv_nsec;
}

/* Each reader returns 0 and reports the key when the text is not a value it accepts. */
static int read_count(const guideway_host* host, const char* key, const char* text, long long* out) {
  char* end = NULL;
  errno = 0;
  const long long v = strtoll(text, &end, 10);
  if (errno != 0 || end == text || *end != '\0' || v < 0 || v > 1000000) {
    host->config_error(host->ctx, key, "expected an integer from 0 to 1000000");
    return 0;
  }
  *out = v;
  return 1;
}

static int read_number(const guideway_host* host, const char* key, const char* text, int non_negative, double* out) {
  char* end = NULL;
  errno = 0;
  const double v = strtod(text, &end);
  if (errno != 0 || end == text || *end != '\0' || (non_negative && !(v >= 0))) {
    host->config_error(host->ctx, key, non_negative ? "expected a number >= 0" : "expected a number");
    return 0;
  }
  *out = v;
  return 1;
}

static int read_direction(const guideway_host* host, const char* key, const char* text, double* sign) {
  if (strcmp(text, "up") == 0 || strcmp(text, "down") == 0) {
    *sign = text[0] == 'u' ? 1.0 : -1.0;
    return 1;
  }
  host->config_error(host->ctx, key, "expected \"up\" or \"down\"");
  return 0;
}

static void* ramp_open(const guideway_config_entry* entries, uint32_t entry_count, const guideway_host* host) {
  ramp r = {10, 1e-3, 0.0, 0};
  double sign = 1.0;
  for (uint32_t i = 0; i < entry_count; ++i) {
    const char* key = entries[i].key;
    const char* value = entries[i].value;
    int ok = 1;
    if (strcmp(key, "count") == 0) ok = read_count(host, key, value, &r.count);
    else if (strcmp(key, "step_m") == 0) ok = read_number(host, key, value, 0, &r.step_m);
    else if (strcmp(key, "period_s") == 0) ok = read_number(host, key, value, 1, &r.period_s);
    else if (strcmp(key, "direction") == 0) ok = read_direction(host, key, value, &sign);
    else if (strcmp(key, "repeat") == 0) r.repeat = strcmp(value, "true") == 0;
    if (!ok) return NULL;
  }
  r.step_m *= sign;
  ramp* handle = malloc(sizeof *handle);
  if (handle == NULL) {
    host->config_error(host->ctx, NULL, "out of memory");
    return NULL;
  }
  *handle = r;
  return handle;
}

static void ramp_run(void* handle, const guideway_host* host) {
  const ramp* r = handle;
  const int64_t period_ns = (int64_t)(r->period_s * 1e9);
  host->set_state(host->ctx, GUIDEWAY_STATE_STREAMING, "");
  const int64_t t0 = now_ns();
  do {
    for (long long i = 0; i < r->count && !host->stop_requested(host->ctx); ++i) {
      const int64_t t = now_ns();
      const double values[2] = {(double)i * r->step_m, (double)(t - t0) * 1e-9};
      host->push_sample(host->ctx, t, 0, values, 2);
      host->count(host->ctx, GUIDEWAY_COUNTER_FRAMES, 1);
      if (period_ns > 0 && !host->sleep_ns(host->ctx, period_ns)) return;
    }
    if (host->stop_requested(host->ctx)) return;
    host->count(host->ctx, GUIDEWAY_COUNTER_OWN + 0, 1);
  } while (r->repeat);
  host->set_state(host->ctx, GUIDEWAY_STATE_STREAMING, "ramp complete");
  while (host->sleep_ns(host->ctx, 50000000)) {
  }
}

static void ramp_close(void* handle) { free(handle); }

static const guideway_channel ramp_channels[] = {{"ramp", "m"}, {"elapsed", "s"}};
static const char* const ramp_keys[] = {"count", "step_m", "period_s", "direction", "repeat"};
static const char* const ramp_counters[] = {"ramps_completed"};

/* The tests build this file twice more: once claiming another ABI version, once without the entry point. */
#ifndef EXAMPLE_PLUGIN_ABI_VERSION
#define EXAMPLE_PLUGIN_ABI_VERSION GUIDEWAY_DRIVER_ABI_VERSION
#endif
#ifndef EXAMPLE_PLUGIN_ENTRY
#define EXAMPLE_PLUGIN_ENTRY guideway_driver_plugin
#endif

static const guideway_driver ramp_driver = {
    .abi_version = EXAMPLE_PLUGIN_ABI_VERSION,
    .name = "example-ramp",
    .description = "example plugin (C): a ramp of `count` samples",
    .channels = ramp_channels,
    .channel_count = 2,
    .config_keys = ramp_keys,
    .config_key_count = sizeof ramp_keys / sizeof ramp_keys[0],
    .counter_names = ramp_counters,
    .counter_count = 1,
    .open = ramp_open,
    .run = ramp_run,
    .interrupt = NULL, /* run blocks only in sleep_ns, which the host wakes on stop */
    .close = ramp_close,
};

GUIDEWAY_PLUGIN_EXPORT const guideway_driver* EXAMPLE_PLUGIN_ENTRY(void) { return &ramp_driver; }
