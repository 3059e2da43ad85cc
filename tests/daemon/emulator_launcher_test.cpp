// The daemon's emulator launcher with real child processes (small shell scripts standing in for
// guideway-emulate): endpoint hand-over into device tables, failures reported with the child's output,
// children terminated with the launcher.
#include "daemon/emulator_launcher.hpp"

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "daemon/config.hpp"
#include "test_support.hpp"

using namespace guideway;

namespace {

std::string write_script(const test::TempDir& dir, const std::string& name, const std::string& body) {
  const std::string path = dir.file(name);
  std::ofstream(path) << "#!/bin/sh\n" << body;
  chmod(path.c_str(), 0755);
  return path;
}

}  // namespace

TEST(EmulatorLauncher, PassesArgumentsAndHandsTheEndpointToDeviceTables) {
  test::TempDir dir;
  // Echoes its arguments into the endpoint so the test sees what it was given.
  const std::string exe = write_script(dir, "emu", "echo starting\necho \"endpoint: tcp:127.0.0.1:$2$3\"\nexec sleep 30\n");
  auto config = daemon::parse_config("[daemon]\nemulator_executable = \"" + exe +
                                         "\"\n[[emulator]]\nname = \"gauge\"\ninstrument = \"micrometer\"\nargs = "
                                         "[\"15\", \"02\"]\n[[device]]\nname = \"g\"\ndriver = \"x\"\naddress = "
                                         "\"emulator:gauge\"\nother = \"emulator-like but not\"\nhost = \"emulator:gauge:host\"\n"
                                         "port = \"emulator:gauge:port\"\n[device.sub]\nwhere = \"emulator:gauge\"\n",
                                     "t.toml");
  auto emulators = daemon::launch_emulators(config);
  ASSERT_EQ(emulators.size(), 1u);
  EXPECT_EQ(emulators[0]->endpoint(), "tcp:127.0.0.1:1502");
  EXPECT_TRUE(emulators[0]->alive());
  EXPECT_EQ(config.devices[0].table->get_string("address", ""), "tcp:127.0.0.1:1502");
  EXPECT_EQ(config.devices[0].table->get_string("other", ""), "emulator-like but not");
  EXPECT_EQ(config.devices[0].table->get_string("host", ""), "127.0.0.1");
  EXPECT_EQ(config.devices[0].table->get_int("port", 0), 1502);  // an integer, as the driver expects
  EXPECT_EQ(config.devices[0].table->table("sub")->get_string("where", ""), "tcp:127.0.0.1:1502");
  const pid_t pid = emulators[0]->pid();
  emulators.clear();
  EXPECT_NE(kill(pid, 0), 0);  // terminated and reaped
}

TEST(EmulatorLauncher, AnEmulatorThatDiesIsReportedWithItsOutput) {
  test::TempDir dir;
  const std::string exe = write_script(dir, "emu", "echo 'no such instrument: frobnicator' >&2\nexit 3\n");
  daemon::EmulatorSpec spec{"f", "frobnicator", {}};
  try {
    daemon::EmulatorProcess p(exe, spec);
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("exited"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("no such instrument: frobnicator"), std::string::npos) << e.what();
  }
}

TEST(EmulatorLauncher, ASilentEmulatorTimesOut) {
  test::TempDir dir;
  const std::string exe = write_script(dir, "emu", "exec sleep 30\n");
  daemon::EmulatorSpec spec{"s", "dbb", {}};
  EXPECT_THROW(daemon::EmulatorProcess(exe, spec, std::chrono::milliseconds(300)), std::runtime_error);
}

TEST(EmulatorLauncher, AnUnknownEmulatorNameIsAConfigError) {
  auto config = daemon::parse_config("[[device]]\nname = \"g\"\ndriver = \"x\"\naddress = \"emulator:nope\"\n", "t.toml");
  try {
    daemon::launch_emulators(config);
    FAIL() << "expected a ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("\"emulator:nope\" names no [[emulator]]"), std::string::npos) << e.what();
    EXPECT_EQ(e.line(), 4u) << "the reference's own line, not its table's";
    EXPECT_EQ(e.key(), "device[0].address");
  }
}

TEST(EmulatorLauncher, TheDaemonTellsAnEmulatorWhatASessionAsksOnItsStandardInput) {
  test::TempDir dir;
  const std::string heard = dir.file("heard");
  // Serves, then writes the first line it is told where the test can read it.
  const std::string exe = write_script(
      dir, "emu", "echo \"endpoint: unix:/nowhere\"\nread line\necho \"$line\" > " + heard + ".part\nmv " + heard +
                      ".part " + heard + "\nexec sleep 30\n");
  auto config = daemon::parse_config("[daemon]\nemulator_executable = \"" + exe +
                                         "\"\n[[emulator]]\nname = \"can\"\ninstrument = \"dbb\"\n[[emulator]]\nname = "
                                         "\"other\"\ninstrument = \"micrometer\"\n[[device]]\nname = \"bar\"\ndriver = "
                                         "\"x\"\nbus = \"emulator:can\"\nagain = \"emulator:can:path\"\n",
                                     "t.toml");
  auto emulators = daemon::launch_emulators(config);
  ASSERT_EQ(emulators.size(), 2u);
  // The device's table named one of the two: that one serves it.
  EXPECT_EQ(config.devices[0].emulators, std::vector<std::string>{"can"});
  ASSERT_TRUE(emulators[0]->command("circle 500"));
  std::string line;
  for (int i = 0; i < 500 && line.empty(); ++i) {
    std::ifstream(heard) >> line;
    if (line.empty()) usleep(10'000);
  }
  EXPECT_EQ(line, "circle");  // the first word of what it was told
  std::ifstream in(heard);
  std::string all((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(all, "circle 500\n");
  // One that is gone is told nothing, and whoever tells it is not killed by SIGPIPE.
  const pid_t pid = emulators[1]->pid();
  kill(pid, SIGKILL);
  std::string how;
  for (int i = 0; i < 500 && how.empty(); ++i) {
    how = emulators[1]->reap();
    if (how.empty()) usleep(10'000);
  }
  EXPECT_EQ(how, "killed by signal 9");
  EXPECT_FALSE(emulators[1]->command("circle 500"));
}

TEST(EmulatedMachineCommand, ADbbSessionsFeedAndGivenRadiusGoToTheDbbEmulator) {
  using daemon::emulated_machine_command;
  EXPECT_EQ(emulated_machine_command("dbb", "dbb", nlohmann::json::object()), "circle 1000");  // the default feed
  EXPECT_EQ(emulated_machine_command("dbb", "dbb", {{"feed_mm_per_min", 500}}), "circle 500");
  EXPECT_EQ(emulated_machine_command("dbb", "dbb", {{"feed_mm_per_min", 2500.5}, {"radius_mm", 150}}),
            "circle 2500.5 150");
  EXPECT_EQ(emulated_machine_command("dbb", "dbb", {{"feed_mm_per_min", 0}}), "");  // any feed: nothing to follow
  EXPECT_EQ(emulated_machine_command("micrometer", "dbb", {{"feed_mm_per_min", 500}}), "");
  EXPECT_EQ(emulated_machine_command("dbb", "runout", nlohmann::json::object()), "");
}
