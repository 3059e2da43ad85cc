// The driver table: the four instrument drivers are built in, and a driver that is not (a third party's)
// comes from a plugin in plugin_dir through the C boundary (drivers/plugin_abi.h). The plugin here is
// tests/drivers/example_driver_plugin.c, loaded with dlopen; broken builds of it are named, not fatal, and the
// host holds a plugin that misbehaves (tests/drivers/faulty_driver_plugin.c) to its device's state and counters.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <optional>

#include "core/toml_access.hpp"
#include "drivers/builtin.hpp"
#include "test_support.hpp"

using namespace guideway;
using namespace std::chrono_literals;

namespace {

drivers::DriverRegistry registry_with_plugins() {
  drivers::DriverRegistry registry;
  drivers::register_builtin_drivers(registry);
  const auto errors = registry.load_plugins(GUIDEWAY_TEST_PLUGIN_DIR);
  EXPECT_TRUE(errors.empty()) << errors.front();
  return registry;
}

// One example-ramp device from the keys of its [[device]] table; `keys` starts on line 3.
struct RampDevice {
  explicit RampDevice(const std::string& keys, std::optional<std::size_t> ring_capacity = 64)
      : root(parse_toml("[[device]]\nname = \"r\"\ndriver = \"example-ramp\"\n" + keys, "plugin.toml")),
        top(root, "plugin.toml", ""),
        table(top.tables("device").at(0)),
        driver(registry.create({"r", "example-ramp", ring_capacity, table})) {
    table.require_string("name");  // the daemon's keys, read as the daemon reads them
    table.require_string("driver");
  }
  drivers::DriverRegistry registry = registry_with_plugins();
  toml::table root;
  TableReader top;
  TableReader table;
  std::unique_ptr<drivers::Driver> driver;
};

std::uint64_t driver_counter(const drivers::DriverStatus& status, const std::string& name) {
  for (const auto& c : status.driver_counters) {
    if (c.name == name) return c.value;
  }
  ADD_FAILURE() << "no driver counter " << name;
  return 0;
}

std::string config_error_of(const std::string& keys) {
  try {
    RampDevice device(keys);
    device.table.reject_unknown_keys();  // as the daemon does after creating a device
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "no error";
}

}  // namespace

TEST(DriverTable, TheFourInstrumentDriversAndLinuxCncAreBuiltIn) {
  drivers::DriverRegistry registry;
  drivers::register_builtin_drivers(registry);
  std::vector<std::string> names;
  for (const auto& [name, description] : registry.list()) {
    names.push_back(name);
    EXPECT_FALSE(description.empty()) << name;
  }
  EXPECT_EQ(names,
            (std::vector<std::string>{"dbb-can", "autocollimator-serial", "micrometer-modbus", "profilometer-tcp",
                                      "linuxcnc-hal"}));
}

TEST(DriverPlugin, ADriverNotBuiltInComesFromACPlugin) {
  drivers::DriverRegistry registry;
  drivers::register_builtin_drivers(registry);
  EXPECT_FALSE(registry.contains("example-ramp"));
  EXPECT_TRUE(registry.load_plugins(GUIDEWAY_TEST_PLUGIN_DIR).empty());
  ASSERT_TRUE(registry.contains("example-ramp"));
  EXPECT_TRUE(registry.contains("dbb-can")) << "a plugin adds to the built-in drivers";
  const auto drivers = registry.list();
  ASSERT_EQ(drivers.size(), 7u);
  EXPECT_EQ(drivers[5],
            (std::pair<std::string, std::string>{"example-ramp", "example plugin (C): a ramp of `count` samples"}));
  EXPECT_EQ(drivers[6].first, "example-faulty") << "plugins in file name order, after the built-in drivers";
}

TEST(DriverPlugin, SamplesStateAndCountersCrossTheBoundary) {
  // Every kind of value the host passes as text: integer, float (a float must read back exactly), string.
  RampDevice device("count = 5\nstep_m = 1.234567890123e-5\ndirection = \"down\"\nperiod_s = 0.001\n");
  device.table.reject_unknown_keys();
  drivers::Driver& d = *device.driver;
  ASSERT_EQ(d.channels().size(), 2u);
  EXPECT_EQ(d.channels()[0].name, "ramp");
  EXPECT_EQ(d.channels()[0].unit, "m");
  EXPECT_EQ(d.channels()[1].name, "elapsed");
  EXPECT_EQ(d.channels()[1].unit, "s");
  EXPECT_EQ(d.driver(), "example-ramp");
  EXPECT_EQ(d.status().state, drivers::DeviceState::stopped);

  d.start();
  ASSERT_TRUE(test::eventually([&] { return d.status().reason == "ramp complete"; }, 5s)) << d.status().reason;
  const drivers::DriverStatus status = d.status();
  EXPECT_EQ(status.state, drivers::DeviceState::streaming);
  EXPECT_EQ(status.counters.samples, 5u);
  EXPECT_EQ(status.counters.frames, 5u);
  EXPECT_EQ(status.counters.overruns, 0u);
  EXPECT_EQ(driver_counter(status, "ramps_completed"), 1u);
  EXPECT_EQ(status.ring.depth, 5u);

  Sample s;
  std::int64_t last_t = 0;
  double last_elapsed = -1;
  for (int i = 0; i < 5; ++i) {
    ASSERT_TRUE(d.ring().try_pop(s));
    EXPECT_EQ(s.seq, static_cast<std::uint64_t>(i));
    EXPECT_EQ(s.value_count, 2u);
    EXPECT_EQ(s.flags, 0u);
    EXPECT_EQ(s.value[0], i * -1.234567890123e-5) << i;
    EXPECT_GT(s.value[1], last_elapsed);
    EXPECT_GT(s.t_mono_ns, last_t);
    last_elapsed = s.value[1];
    last_t = s.t_mono_ns;
  }
  EXPECT_GE(last_elapsed, 4 * 0.001) << "period_s paces the samples";
  d.stop();
  EXPECT_EQ(d.status().state, drivers::DeviceState::stopped);
}

TEST(DriverPlugin, AFullRingCountsOverrunsAndStopEndsAPluginThatNeverFinishes) {
  RampDevice device("count = 10\nrepeat = true\n", 4);
  drivers::Driver& d = *device.driver;
  d.start();
  ASSERT_TRUE(test::eventually([&] { return driver_counter(d.status(), "ramps_completed") >= 3; }, 5s));
  d.stop();
  const drivers::DriverStatus status = d.status();
  EXPECT_EQ(status.state, drivers::DeviceState::stopped);
  EXPECT_EQ(status.ring.depth, 4u);
  EXPECT_EQ(status.counters.overruns, status.counters.samples - 4);
  EXPECT_GE(status.counters.samples, 30u);
  EXPECT_EQ(status.counters.frames, status.counters.samples);
}

TEST(DriverPlugin, APluginsRingHolds65536SamplesUnlessItsTableGivesItsSize) {
  // The ABI does not say a plugin's rate, which sizes a built-in driver's ring (drivers/ring_capacity.hpp).
  EXPECT_EQ(RampDevice("count = 3\n", std::nullopt).driver->ring_capacity(), 65536u);
  EXPECT_EQ(RampDevice("count = 3\n", 256).driver->ring_capacity(), 256u);
}

TEST(DriverPlugin, ConfigurationErrorsNameFileLineAndKey) {
  EXPECT_EQ(config_error_of("count = 3\n"), "no error");
  // A nested table or an array has no text form: refused by the host before the plugin sees it.
  const std::string nested = config_error_of("count = { value = 5 }\n");
  EXPECT_NE(nested.find("plugin.toml:4: device[0].count:"), std::string::npos) << nested;
  EXPECT_NE(nested.find("not a table"), std::string::npos) << nested;
  const std::string array = config_error_of("step_m = [1, 2]\n");
  EXPECT_NE(array.find("plugin.toml:4: device[0].step_m:"), std::string::npos) << array;
  EXPECT_NE(array.find("not an array"), std::string::npos) << array;
  // A value the plugin refuses, through config_error.
  const std::string value = config_error_of("count = 3\ndirection = \"sideways\"\n");
  EXPECT_NE(value.find("plugin.toml:5: device[0].direction: expected \"up\" or \"down\""), std::string::npos) << value;
  const std::string range = config_error_of("count = -1\n");
  EXPECT_NE(range.find("plugin.toml:4: device[0].count: expected an integer"), std::string::npos) << range;
  // A key the plugin does not list in config_keys.
  const std::string unknown = config_error_of("cuont = 3\n");
  EXPECT_NE(unknown.find("plugin.toml:4: device[0].cuont"), std::string::npos) << unknown;
}

TEST(DriverPlugin, TheHostHoldsAPluginThatBreaksTheRulesToItsStateAndCounters) {
  // tests/drivers/faulty_driver_plugin.c: 3 samples into a ring of 2, one with more values than channels.
  const drivers::DriverRegistry registry = registry_with_plugins();
  const toml::table root = parse_toml(
      "[[device]]\nname = \"a\"\ndriver = \"example-faulty\"\nfault = \"early_return\"\n"
      "[[device]]\nname = \"b\"\ndriver = \"example-faulty\"\nfault = \"unknown_counter\"\n",
      "faulty.toml");
  const auto devices = TableReader(root, "faulty.toml", "").tables("device");
  const auto early = registry.create({"a", "example-faulty", 2, devices[0]});
  const auto unknown = registry.create({"b", "example-faulty", 2, devices[1]});
  early->start();
  unknown->start();
  ASSERT_TRUE(test::eventually([&] { return early->status().state == drivers::DeviceState::error; }, 5s));
  ASSERT_TRUE(test::eventually([&] { return unknown->status().state == drivers::DeviceState::error; }, 5s));
  EXPECT_EQ(early->status().reason, "the plugin's run() returned before it was stopped");
  EXPECT_EQ(unknown->status().reason, "the plugin counted an unknown counter 23");
  for (const auto* d : {early.get(), unknown.get()}) {
    const drivers::DriverStatus status = d->status();
    EXPECT_EQ(status.counters.samples, 3u) << "the refused sample is not one";
    EXPECT_EQ(status.counters.overruns, 1u);
    EXPECT_EQ(status.ring.depth, 2u);
    EXPECT_EQ(driver_counter(status, "dropped_pushes"), 1u) << "push_sample answered 1 for the dropped one";
    EXPECT_EQ(driver_counter(status, "refused_pushes"), 1u) << "push_sample answered -1 for the refused one";
  }
  early->stop();
  unknown->stop();
}

TEST(DriverPlugin, APluginOfAnotherAbiOrWithoutTheEntryPointIsNamedAndSkipped) {
  drivers::DriverRegistry registry;
  drivers::register_builtin_drivers(registry);
  const auto errors = registry.load_plugins(GUIDEWAY_BROKEN_PLUGIN_DIR);
  ASSERT_EQ(errors.size(), 2u);
  const std::string dir = GUIDEWAY_BROKEN_PLUGIN_DIR;
  EXPECT_EQ(errors[0],
            dir + "/example_driver_plugin_no_entry.so: not a guideway driver plugin (no guideway_driver_plugin())");
  EXPECT_EQ(errors[1], dir + "/example_driver_plugin_other_abi.so: plugin ABI 99, guidewayd expects 1 "
                             "(rebuild it against this drivers/plugin_abi.h)");
  EXPECT_FALSE(registry.contains("example-ramp"));
  EXPECT_EQ(registry.list().size(), 5u) << "the built-in drivers stay";
}

TEST(DriverPlugin, AFileInThePluginDirectoryThatIsNoPluginIsNamed) {
  test::TempDir dir;
  std::ofstream(dir.file("junk.so")) << "not an ELF file";
  drivers::DriverRegistry registry;
  const auto errors = registry.load_plugins(dir.path().string());
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_NE(errors[0].find("junk.so"), std::string::npos) << errors[0];
  EXPECT_TRUE(registry.load_plugins(dir.file("no-such-directory")).empty()) << "no directory: no plugins, no error";
}
