/* The driver plugin boundary: a shared object that guidewayd loads from plugin_dir exports one C
 * function, guideway_driver_plugin(), returning the table (guideway_driver) that describes one
 * driver and its callbacks. Only C types cross it (fixed-width integers, double, const char*,
 * function pointers, opaque handles), so a plugin may be written in C or in any language with a C
 * ABI, and built with any compiler or standard library. docs/plugins.md: the rules (threads, memory,
 * what a callback may do). Valid C99 and C++. */
#ifndef GUIDEWAY_DRIVERS_PLUGIN_ABI_H
#define GUIDEWAY_DRIVERS_PLUGIN_ABI_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* The layout of the tables below. abi_version stays the first member of guideway_driver
 * forever, so the host can read it from a plugin of any version and refuse a mismatch by name. */
#define GUIDEWAY_DRIVER_ABI_VERSION 1u

/* The most channels (values per sample) a driver may have. */
#define GUIDEWAY_MAX_CHANNELS 5u

/* Device states a plugin reports with set_state (the host reports "stopped" itself). */
#define GUIDEWAY_STATE_CONNECTING 1
#define GUIDEWAY_STATE_STREAMING 2
#define GUIDEWAY_STATE_LOST 3  /* the device went away; the plugin backs off and reconnects */
#define GUIDEWAY_STATE_ERROR 4 /* needs a person (bad configuration, wrong device) */

/* Sample flag bits for push_sample: a flagged value is not a number to use. */
#define GUIDEWAY_SAMPLE_OUT_OF_RANGE (1u << 0) /* the instrument reports its range exceeded */
#define GUIDEWAY_SAMPLE_NO_SIGNAL (1u << 1)    /* e.g. no reflection */
#define GUIDEWAY_SAMPLE_PARTIAL (1u << 2)      /* some channels missing in this cycle */
#define GUIDEWAY_SAMPLE_AFTER_GAP (1u << 3)    /* first sample after a reconnect or a detected gap */

/* Counters for count(): the host's, then the plugin's own (counter_names[i] is GUIDEWAY_COUNTER_OWN + i). */
#define GUIDEWAY_COUNTER_FRAMES 0u     /* frames/lines/responses received and parsed */
#define GUIDEWAY_COUNTER_BAD_FRAMES 1u /* garbage, CRC errors, truncated or unparseable input */
#define GUIDEWAY_COUNTER_TIMEOUTS 2u   /* requests that got no answer in time */
#define GUIDEWAY_COUNTER_RECONNECTS 3u /* successful connections after the first */
#define GUIDEWAY_COUNTER_OWN 16u

/* One key of the device's [[device]] table, as text: a string as written, an integer in decimal, a
 * float in the shortest form that reads back exactly, a boolean as "true" or "false". */
typedef struct guideway_config_entry {
  const char* key;
  const char* value;
} guideway_config_entry;

/* What the host offers a plugin; every callback takes ctx first. */
typedef struct guideway_host {
  void* ctx;
  /* During open only: refuses the configuration; key names the offending key (or is NULL). The host
   * turns it into a configuration error with file, line and key once open returns NULL. */
  void (*config_error)(void* ctx, const char* key, const char* message);
  /* The rest during run only, from the thread that runs it. */
  /* One sample: t_mono_ns from CLOCK_MONOTONIC, values in SI units in the order of the channels,
   * 1 <= count <= channel_count. Returns 0 when queued, 1 when dropped because the ring is full
   * (counted as an overrun), -1 when refused (count out of range). */
  int (*push_sample)(void* ctx, int64_t t_mono_ns, uint32_t flags, const double* values, uint32_t count);
  /* state is a GUIDEWAY_STATE_*; reason says why in a few words ("" or NULL: none). */
  void (*set_state)(void* ctx, int32_t state, const char* reason);
  /* Adds n to a counter (GUIDEWAY_COUNTER_*). */
  void (*count)(void* ctx, uint32_t counter, uint64_t n);
  /* Nonzero once the host asks run to return. */
  int (*stop_requested)(void* ctx);
  /* Sleeps up to ns nanoseconds; returns 0 at once when stop is requested, else 1. */
  int (*sleep_ns)(void* ctx, int64_t ns);
} guideway_host;

typedef struct guideway_channel {
  const char* name; /* e.g. "x", "pitch" */
  const char* unit; /* SI unit of the values: "m", "rad", "s" */
} guideway_channel;

typedef struct guideway_driver {
  uint32_t abi_version;    /* GUIDEWAY_DRIVER_ABI_VERSION */
  const char* name;        /* the [[device]] table's driver = "..." */
  const char* description; /* one line for guidewayd --list-drivers */
  const guideway_channel* channels;
  uint32_t channel_count; /* 1 to GUIDEWAY_MAX_CHANNELS */
  /* The keys a [[device]] table may hold for this driver besides name, driver, ring_capacity and
   * enabled; the host rejects any other key with file and line. */
  const char* const* config_keys;
  uint32_t config_key_count;
  /* Names of the plugin's own counters (snake_case, never changing): STATUS driver_counters. */
  const char* const* counter_names;
  uint32_t counter_count;

  /* Reads the configuration (entries: the present config_keys, valid during the call only) and
   * returns the device's handle, or NULL after host->config_error. No I/O and no threads: it runs
   * while the configuration is checked. host stays valid until close returns. */
  void* (*open)(const guideway_config_entry* entries, uint32_t entry_count, const guideway_host* host);
  /* The driver thread: connect, read, push samples, report states; on a fault back off (sleep_ns)
   * and reconnect. Returns promptly once stop_requested (or sleep_ns returns 0). */
  void (*run)(void* handle, const guideway_host* host);
  /* May be NULL. Called from another thread while run goes on, to unblock a read (e.g. write an
   * eventfd run polls); it must not call the host. */
  void (*interrupt)(void* handle);
  /* Frees the handle; run has returned (or never started). */
  void (*close)(void* handle);
} guideway_driver;

/* The one symbol a plugin exports (the returned table and everything it points to stay valid while
 * the plugin is loaded). */
typedef const guideway_driver* (*guideway_driver_plugin_fn)(void);
#define GUIDEWAY_DRIVER_PLUGIN_SYMBOL "guideway_driver_plugin"
#if defined(__GNUC__)
#define GUIDEWAY_PLUGIN_EXPORT __attribute__((visibility("default")))
#else
#define GUIDEWAY_PLUGIN_EXPORT
#endif
GUIDEWAY_PLUGIN_EXPORT const guideway_driver* guideway_driver_plugin(void);

#ifdef __cplusplus
}
#endif

#endif /* GUIDEWAY_DRIVERS_PLUGIN_ABI_H */
