// The driver table: the four instrument drivers are built in, and a driver that is not (a third party's)
// still comes from a plugin in plugin_dir; a file there that is not a plugin is named, not fatal.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "core/toml_access.hpp"
#include "drivers/builtin.hpp"
#include "test_support.hpp"

using namespace guideway;
using namespace std::chrono_literals;

TEST(DriverTable, TheFourInstrumentDriversAreBuiltIn) {
  drivers::DriverRegistry registry;
  drivers::register_builtin_drivers(registry);
  std::vector<std::string> names;
  for (const auto& [name, description] : registry.list()) {
    names.push_back(name);
    EXPECT_FALSE(description.empty()) << name;
  }
  EXPECT_EQ(names, (std::vector<std::string>{"dbb-can", "autocollimator-serial", "micrometer-modbus", "profilometer-tcp"}));
}

TEST(DriverTable, ADriverNotBuiltInComesFromAPlugin) {
  drivers::DriverRegistry registry;
  drivers::register_builtin_drivers(registry);
  EXPECT_FALSE(registry.contains("example-ramp"));
  const auto errors = registry.load_plugins(GUIDEWAY_TEST_PLUGIN_DIR);
  EXPECT_TRUE(errors.empty()) << errors.front();
  ASSERT_TRUE(registry.contains("example-ramp"));
  EXPECT_TRUE(registry.contains("dbb-can")) << "a plugin adds to the built-in drivers";
  const toml::table root = parse_toml("[[device]]\nname = \"r\"\ndriver = \"example-ramp\"\ncount = 5\n", "plugin.toml");
  const TableReader top(root, "plugin.toml", "");
  const auto devices = top.tables("device");
  auto driver = registry.create({"r", "example-ramp", 64, devices[0]});
  driver->start();
  ASSERT_TRUE(test::eventually([&] { return driver->ring().depth() == 5; }, 5s));
  driver->stop();
  Sample s;
  for (double want = 0; want < 5; ++want) {
    ASSERT_TRUE(driver->ring().try_pop(s));
    EXPECT_EQ(s.value[0], want);
  }
}

TEST(DriverTable, AFileInThePluginDirectoryThatIsNoPluginIsNamed) {
  test::TempDir dir;
  std::ofstream(dir.file("junk.so")) << "not an ELF file";
  drivers::DriverRegistry registry;
  const auto errors = registry.load_plugins(dir.path().string());
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_NE(errors[0].find("junk.so"), std::string::npos) << errors[0];
  EXPECT_TRUE(registry.load_plugins(dir.file("no-such-directory")).empty()) << "no directory: no plugins, no error";
}
