// The ring-size rule (drivers/ring_capacity.hpp): 8 s of a device's full rate, a power of two, at least 1,024;
// a configured ring no smaller keeps working, a smaller one is a configuration error; and each built-in driver's
// ring follows the rate its table gives (the expected sizes written out, not computed by the rule under test).
#include "drivers/ring_capacity.hpp"

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <limits>
#include <optional>

#include "core/toml_access.hpp"
#include "drivers/builtin.hpp"

using namespace guideway;

namespace {

// The first [[device]] of `text` made by the built-in driver table, with the daemon's ring_capacity for it.
struct Device {
  Device(const std::string& text, std::optional<std::size_t> ring_capacity = std::nullopt)
      : root(parse_toml(text, "rings.toml")), top(root, "rings.toml", ""), table(top.tables("device").at(0)) {
    drivers::register_builtin_drivers(registry);
    driver = registry.create({table.require_string("name"), table.require_string("driver"), ring_capacity, table});
  }
  drivers::DriverRegistry registry;
  toml::table root;
  TableReader top;
  TableReader table;
  std::unique_ptr<drivers::Driver> driver;
};

std::string error_of(const std::string& text, std::optional<std::size_t> ring_capacity) {
  try {
    Device d(text, ring_capacity);
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "no error";
}

// A dbb-can device at 250 Hz, with `keys` in its own table.
std::string dbb_table(const std::string& keys = "") {
  return "[[device]]\nname = \"dbb\"\ndriver = \"dbb-can\"\nbus = \"unix:/nonexistent/can.sock\"\n"
         "sync_rate_hz = 250.0\n" + keys +
         "[[device.encoder]]\nchannel = \"bar_length\"\nnode_id = 1\nresolution_nm = 100\noffset_mm = 100\n"
         "[[device.encoder]]\nchannel = \"x\"\nnode_id = 2\nresolution_nm = 100\n"
         "[[device.encoder]]\nchannel = \"y\"\nnode_id = 3\nresolution_nm = 100\n";
}

}  // namespace

TEST(RingCapacity, EightSecondsOfTheFullRateInAPowerOfTwoOfAtLeast1024) {
  EXPECT_EQ(drivers::ring_capacity_for(0.01), 1024u);
  EXPECT_EQ(drivers::ring_capacity_for(20.0), 1024u);     // the autocollimator polled every 50 ms: 160 samples
  EXPECT_EQ(drivers::ring_capacity_for(128.0), 1024u);    // 8 s exactly
  EXPECT_EQ(drivers::ring_capacity_for(128.01), 2048u);
  EXPECT_EQ(drivers::ring_capacity_for(250.0), 2048u);    // the default DBB: 2,000
  EXPECT_EQ(drivers::ring_capacity_for(1000.0), 8192u);   // 8,000
  EXPECT_EQ(drivers::ring_capacity_for(5000.0), 65536u);  // the profilometer: 40,000
  EXPECT_EQ(drivers::ring_capacity_for(8192.0), 65536u);
  EXPECT_EQ(drivers::ring_capacity_for(10000.0), 131072u);  // the micrometer's amplifier: 80,000
  EXPECT_EQ(drivers::ring_capacity_for(1e9), drivers::max_ring_capacity);  // capped where a configuration is
}

TEST(RingCapacity, TheLeastPowerOfTwoThatHoldsEightSecondsOverEveryRate) {
  for (double rate = 0.1; rate < 1e6; rate *= 1.07) {
    const std::size_t c = drivers::ring_capacity_for(rate);
    EXPECT_TRUE(std::has_single_bit(c)) << rate;
    EXPECT_GE(c, 1024u) << rate;
    EXPECT_GE(static_cast<double>(c), 8.0 * rate) << rate;
    if (c > 1024) {
      EXPECT_LT(static_cast<double>(c / 2), 8.0 * rate) << rate;  // no larger than it must be
    }
  }
}

TEST(RingCapacity, ARateThatIsNoPositiveNumberIsRefused) {
  constexpr double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  for (const double rate : {0.0, -5.0, nan, inf})
    EXPECT_THROW((void)drivers::ring_capacity_for(rate), std::invalid_argument) << rate;
}

TEST(RingCapacity, EachBuiltInDriversRingFollowsTheRateItsTableGives) {
  EXPECT_EQ(Device(dbb_table()).driver->ring_capacity(), 2048u);
  const std::string ac = "[[device]]\nname = \"ac\"\ndriver = \"autocollimator-serial\"\nport = \"/nonexistent\"\n";
  EXPECT_EQ(Device(ac + "poll_period_ms = 50\n").driver->ring_capacity(), 1024u);
  EXPECT_EQ(Device(ac + "poll_period_ms = 2\n").driver->ring_capacity(), 4096u);  // 500 Hz
  EXPECT_EQ(Device(ac + "mode = \"stream\"\nstream_period_ms = 1\n").driver->ring_capacity(), 8192u);
  const std::string mic = "[[device]]\nname = \"mic\"\ndriver = \"micrometer-modbus\"\ntransport = \"tcp\"\n"
                          "host = \"127.0.0.1\"\nport = 1502\n";
  EXPECT_EQ(Device(mic).driver->ring_capacity(), 1024u);  // polled at 50 Hz
  EXPECT_EQ(Device(mic + "poll_hz = 1000.0\n").driver->ring_capacity(), 8192u);
  const std::string buffer =
      "[device.buffer]\ncounter_address = 100\nring_address = 200\nring_samples = 4096\nsample_rate_hz = 10000.0\n";
  EXPECT_EQ(Device(mic + buffer).driver->ring_capacity(), 131072u);  // buffered: the amplifier's own rate
  const std::string prof = "[[device]]\nname = \"prof\"\ndriver = \"profilometer-tcp\"\nport = 4001\n";
  EXPECT_EQ(Device(prof).driver->ring_capacity(), 65536u);  // 5,000 points/s
  EXPECT_EQ(Device(prof + "points_per_s = 500.0\n").driver->ring_capacity(), 4096u);
  EXPECT_EQ(Device("[[device]]\nname = \"cnc\"\ndriver = \"linuxcnc-hal\"\n").driver->ring_capacity(), 8192u);
}

TEST(RingCapacity, AConfiguredRingNoSmallerThanTheRulesIsKept) {
  EXPECT_EQ(Device(dbb_table(), 2048).driver->ring_capacity(), 2048u);
  EXPECT_EQ(Device(dbb_table(), 65536).driver->ring_capacity(), 65536u);
}

TEST(RingCapacity, ASmallerConfiguredRingIsAnErrorNamingTheRateAndTheLeast) {
  // Given by the device's table (its line 6) or by [daemon] for it: the same key, said which.
  const std::string own = error_of(dbb_table("ring_capacity = 1024\n"), 1024);
  EXPECT_NE(own.find("rings.toml:6: device[0].ring_capacity: ring_capacity = 1024 holds 4.1 s of device dbb's full "
                     "rate (250 Hz); a ring holds at least 8 s of it"),
            std::string::npos)
      << own;
  EXPECT_NE(own.find("give at least 2048, or leave ring_capacity out"), std::string::npos) << own;
  const std::string daemons = error_of(dbb_table(), 512);
  EXPECT_NE(daemons.find("ring_capacity = 512 ([daemon]'s, which this device takes) holds 2 s"), std::string::npos)
      << daemons;
}
