// Driver plugins: loading a plugin's C table (drivers/plugin_abi.h) and the Driver that runs one.
#include <dlfcn.h>

#include <algorithm>
#include <charconv>
#include <filesystem>
#include <optional>

#include "drivers/driver.hpp"
#include "drivers/plugin_abi.h"
#include "drivers/ring_capacity.hpp"

namespace guideway::drivers {

namespace {

static_assert(GUIDEWAY_MAX_CHANNELS == max_sample_values);
static_assert(GUIDEWAY_SAMPLE_OUT_OF_RANGE == sample_out_of_range && GUIDEWAY_SAMPLE_NO_SIGNAL == sample_no_signal &&
              GUIDEWAY_SAMPLE_PARTIAL == sample_partial && GUIDEWAY_SAMPLE_AFTER_GAP == sample_after_gap);

// A [[device]] key as the text the plugin reads (plugin_abi.h, guideway_config_entry); reading it
// through the TableReader marks it read, so the keys the plugin does not take are rejected later.
std::string config_text(const TableReader& table, std::string_view key) {
  const toml::node& node = *table.raw().get(key);
  if (node.is_string()) return table.get_string(key, {});
  if (node.is_integer()) return std::to_string(table.get_int(key, 0));
  if (node.is_boolean()) return table.get_bool(key, false) ? "true" : "false";
  if (node.is_floating_point()) {
    char text[32];
    const auto end = std::to_chars(text, text + sizeof text, table.get_double(key, 0)).ptr;
    return std::string(text, end);
  }
  const char* what = node.is_table() ? "a table" : node.is_array() ? "an array" : "a date or time";
  table.fail(key, std::string("a plugin driver's setting is a string, a number or a boolean, not ") + what);
}

std::vector<ChannelInfo> channels_of(const guideway_driver& table) {
  std::vector<ChannelInfo> channels;
  for (std::uint32_t i = 0; i < table.channel_count; ++i)
    channels.push_back({table.channels[i].name, table.channels[i].unit});
  return channels;
}

// Runs one device of a plugin driver: the host callbacks land here, on the driver's thread.
class PluginDriver final : public Driver {
 public:
  PluginDriver(const guideway_driver& table, const DeviceConfig& config)
      : Driver(config.name, table.name, channels_of(table), config.ring_capacity.value_or(unknown_rate_ring_capacity)),
        table_(table),
        own_counters_(std::make_unique<std::atomic<std::uint64_t>[]>(table.counter_count)) {
    host_ = {this, &on_config_error, &on_push_sample, &on_set_state, &on_count, &on_stop_requested, &on_sleep_ns};
    std::vector<std::string> values;
    std::vector<guideway_config_entry> entries;
    values.reserve(table.config_key_count);  // entries point into values: no reallocation
    for (std::uint32_t i = 0; i < table.config_key_count; ++i) {
      const char* key = table.config_keys[i];
      if (!config.table.has(key)) continue;
      values.push_back(config_text(config.table, key));
      entries.push_back({key, values.back().c_str()});
    }
    handle_ = table_.open(entries.data(), static_cast<std::uint32_t>(entries.size()), &host_);
    if (handle_ != nullptr) return;
    const std::string message = config_error_ ? config_error_->second : "the plugin refused the configuration";
    const bool keyed = config_error_ && !config_error_->first.empty() && config.table.has(config_error_->first);
    config.table.fail(keyed ? config_error_->first : "driver", message);
  }
  ~PluginDriver() override {
    stop();
    table_.close(handle_);
  }

  [[nodiscard]] std::vector<NamedCounter> driver_counters() const override {
    std::vector<NamedCounter> out;
    for (std::uint32_t i = 0; i < table_.counter_count; ++i)
      out.push_back({table_.counter_names[i], own_counters_[i].load(std::memory_order_relaxed)});
    return out;
  }

 protected:
  void run(std::stop_token stop) override {
    stop_ = stop;
    table_.run(handle_, &host_);
    if (!stop.stop_requested() && status().state != DeviceState::error)
      set_state(DeviceState::error, "the plugin's run() returned before it was stopped");
  }
  void interrupt() override {
    if (table_.interrupt != nullptr) table_.interrupt(handle_);
  }

 private:
  static PluginDriver& self(void* ctx) { return *static_cast<PluginDriver*>(ctx); }

  static void on_config_error(void* ctx, const char* key, const char* message) noexcept {
    try {
      self(ctx).config_error_.emplace(key ? key : "", message ? message : "");
    } catch (...) {  // no exception crosses the C boundary; open's NULL still refuses
    }
  }

  static int on_push_sample(void* ctx, std::int64_t t_mono_ns, std::uint32_t flags, const double* values,
                            std::uint32_t count) noexcept {
    PluginDriver& d = self(ctx);
    if (count == 0 || count > d.table_.channel_count || values == nullptr) return -1;
    Sample s;
    s.t_mono_ns = t_mono_ns;
    s.flags = flags;
    s.value_count = count;
    std::copy(values, values + count, s.value.begin());
    const std::uint64_t drops = d.ring().drops();  // only this thread adds drops
    d.publish(s);
    return d.ring().drops() == drops ? 0 : 1;
  }

  static void on_set_state(void* ctx, std::int32_t state, const char* reason) noexcept {
    try {
      PluginDriver& d = self(ctx);
      std::string why = reason ? reason : "";
      switch (state) {
        case GUIDEWAY_STATE_CONNECTING: d.set_state(DeviceState::connecting, std::move(why)); return;
        case GUIDEWAY_STATE_STREAMING: d.set_state(DeviceState::streaming, std::move(why)); return;
        case GUIDEWAY_STATE_LOST: d.set_state(DeviceState::lost, std::move(why)); return;
        case GUIDEWAY_STATE_ERROR: d.set_state(DeviceState::error, std::move(why)); return;
        default: d.set_state(DeviceState::error, "the plugin reported an unknown state " + std::to_string(state));
      }
    } catch (...) {  // out of memory for the reason text: the state stays as it was
    }
  }

  static void on_count(void* ctx, std::uint32_t counter, std::uint64_t n) noexcept {
    PluginDriver& d = self(ctx);
    std::atomic<std::uint64_t>* target = nullptr;
    switch (counter) {
      case GUIDEWAY_COUNTER_FRAMES: target = &d.frames_; break;
      case GUIDEWAY_COUNTER_BAD_FRAMES: target = &d.bad_frames_; break;
      case GUIDEWAY_COUNTER_TIMEOUTS: target = &d.timeouts_; break;
      case GUIDEWAY_COUNTER_RECONNECTS: target = &d.reconnects_; break;
      default:
        if (counter >= GUIDEWAY_COUNTER_OWN && counter - GUIDEWAY_COUNTER_OWN < d.table_.counter_count)
          target = &d.own_counters_[counter - GUIDEWAY_COUNTER_OWN];
    }
    if (target != nullptr) {
      target->fetch_add(n, std::memory_order_relaxed);
      return;
    }
    const std::string why = "the plugin counted an unknown counter " + std::to_string(counter);
    on_set_state(ctx, GUIDEWAY_STATE_ERROR, why.c_str());
  }

  static int on_stop_requested(void* ctx) noexcept { return self(ctx).stop_.stop_requested() ? 1 : 0; }

  static int on_sleep_ns(void* ctx, std::int64_t ns) noexcept {
    return sleep_for(self(ctx).stop_, std::chrono::nanoseconds(std::max<std::int64_t>(ns, 0))) ? 1 : 0;
  }

  const guideway_driver& table_;
  guideway_host host_{};
  void* handle_ = nullptr;
  std::unique_ptr<std::atomic<std::uint64_t>[]> own_counters_;
  std::optional<std::pair<std::string, std::string>> config_error_;  // (key, message) from open
  std::stop_token stop_;                                              // the driver thread's, while run() goes on
};

// Why a plugin's table cannot be used ("" when it can): checked once at load, so a device never
// meets a NULL callback or a channel count its samples do not fit.
std::string table_problem(const guideway_driver* t) {
  if (t == nullptr) return "guideway_driver_plugin() returned NULL";
  if (t->abi_version != GUIDEWAY_DRIVER_ABI_VERSION)
    return "plugin ABI " + std::to_string(t->abi_version) + ", guidewayd expects " +
           std::to_string(GUIDEWAY_DRIVER_ABI_VERSION) + " (rebuild it against this drivers/plugin_abi.h)";
  if (t->name == nullptr || *t->name == '\0') return "the driver has no name";
  const std::string driver = std::string("driver \"") + t->name + "\": ";
  if (t->channel_count == 0 || t->channel_count > GUIDEWAY_MAX_CHANNELS || t->channels == nullptr)
    return driver + std::to_string(t->channel_count) + " channels (1 to " + std::to_string(GUIDEWAY_MAX_CHANNELS) + ")";
  for (std::uint32_t i = 0; i < t->channel_count; ++i) {
    if (t->channels[i].name == nullptr || t->channels[i].unit == nullptr)
      return driver + "channel " + std::to_string(i) + " has no name or unit";
  }
  const auto names_missing = [](const char* const* names, std::uint32_t n) {
    return n > 0 && (names == nullptr || std::any_of(names, names + n, [](const char* s) { return s == nullptr; }));
  };
  if (names_missing(t->config_keys, t->config_key_count)) return driver + "a NULL in config_keys";
  if (names_missing(t->counter_names, t->counter_count)) return driver + "a NULL in counter_names";
  if (t->open == nullptr || t->run == nullptr || t->close == nullptr) return driver + "open, run or close is NULL";
  return {};
}

}  // namespace

std::string default_plugin_dir() {
  std::error_code ec;
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const auto beside = exe.parent_path().parent_path() / "lib" / "guideway" / "plugins";
    if (std::filesystem::is_directory(beside, ec)) return beside.string();
  }
  return GUIDEWAY_PLUGIN_DIR;
}

std::vector<std::string> DriverRegistry::load_plugins(const std::string& dir) {
  std::vector<std::string> errors;
  std::error_code ec;
  if (!std::filesystem::is_directory(dir, ec)) return errors;
  std::vector<std::filesystem::path> files;
  for (const auto& entry : std::filesystem::directory_iterator(dir, ec)) {
    if (entry.path().extension() == ".so") files.push_back(entry.path());
  }
  std::sort(files.begin(), files.end());
  for (const auto& file : files) {
    void* handle = dlopen(file.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (!handle) {
      errors.push_back(file.string() + ": " + dlerror());
      continue;
    }
    const auto entry = reinterpret_cast<guideway_driver_plugin_fn>(dlsym(handle, GUIDEWAY_DRIVER_PLUGIN_SYMBOL));
    const guideway_driver* table = entry ? entry() : nullptr;
    const std::string problem =
        entry ? table_problem(table) : "not a guideway driver plugin (no " GUIDEWAY_DRIVER_PLUGIN_SYMBOL "())";
    if (!problem.empty()) {
      errors.push_back(file.string() + ": " + problem);
      dlclose(handle);
      continue;
    }
    add(table->name, table->description ? table->description : "",
        [table](const DeviceConfig& config) -> std::unique_ptr<Driver> {
          return std::make_unique<PluginDriver>(*table, config);
        });
    plugin_handles_.push_back(handle);  // never closed: the factory and its drivers point into it
  }
  return errors;
}

}  // namespace guideway::drivers
