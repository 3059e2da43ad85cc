/* A plugin that breaks the rules the host guards against (tests/drivers/driver_plugin_test.cpp): "example-faulty"
 * pushes three samples into what should be a ring of two (one is dropped), one sample with more values
 * than it has channels (refused), counts what push_sample answered, then does what `fault` says:
 * "unknown_counter" counts a counter it never named; "early_return" returns from run before it is
 * stopped. */
#include <string.h>

#include "drivers/plugin_abi.h"

enum { counter_dropped, counter_refused };

static char fault_early_return; /* the handle says which fault: the address of one of these */
static char fault_unknown_counter;

static void* faulty_open(const guideway_config_entry* entries, uint32_t entry_count, const guideway_host* host) {
  if (entry_count == 1 && strcmp(entries[0].value, "early_return") == 0) return &fault_early_return;
  if (entry_count == 1 && strcmp(entries[0].value, "unknown_counter") == 0) return &fault_unknown_counter;
  host->config_error(host->ctx, "fault", "expected \"early_return\" or \"unknown_counter\"");
  return NULL;
}

static void tally(const guideway_host* host, int pushed) {
  if (pushed == 1) host->count(host->ctx, GUIDEWAY_COUNTER_OWN + counter_dropped, 1);
  if (pushed == -1) host->count(host->ctx, GUIDEWAY_COUNTER_OWN + counter_refused, 1);
}

static void faulty_run(void* handle, const guideway_host* host) {
  const double values[2] = {1.0, 2.0};
  host->set_state(host->ctx, GUIDEWAY_STATE_STREAMING, "");
  for (int i = 0; i < 3; ++i) tally(host, host->push_sample(host->ctx, i + 1, 0, values, 1));
  tally(host, host->push_sample(host->ctx, 4, 0, values, 2));
  if (handle == &fault_unknown_counter) {
    host->count(host->ctx, GUIDEWAY_COUNTER_OWN + 7, 1);
    while (host->sleep_ns(host->ctx, 50000000)) {
    }
  }
}

static void faulty_close(void* handle) { (void)handle; }

static const guideway_channel faulty_channels[] = {{"x", "m"}};
static const char* const faulty_keys[] = {"fault"};
static const char* const faulty_counters[] = {"dropped_pushes", "refused_pushes"};

static const guideway_driver faulty_driver = {
    .abi_version = GUIDEWAY_DRIVER_ABI_VERSION,
    .name = "example-faulty",
    .description = "test plugin (C): breaks the rules the host guards against",
    .channels = faulty_channels,
    .channel_count = 1,
    .config_keys = faulty_keys,
    .config_key_count = 1,
    .counter_names = faulty_counters,
    .counter_count = 2,
    .open = faulty_open,
    .run = faulty_run,
    .interrupt = NULL,
    .close = faulty_close,
};

GUIDEWAY_PLUGIN_EXPORT const guideway_driver* guideway_driver_plugin(void) { return &faulty_driver; }
