// A driver that is not built in, as a third party would ship one: a MODULE exporting the plugin entry
// points. "example-ramp" publishes `count` samples 0, 1, 2, ... then streams nothing more.
#include "drivers/driver.hpp"

namespace {

class RampDriver final : public guideway::drivers::Driver {
 public:
  RampDriver(const std::string& name, std::size_t ring_capacity, std::int64_t count)
      : Driver(name, "example-ramp", {{"ramp", "m"}}, ring_capacity), count_(count) {}
  ~RampDriver() override { stop(); }

 protected:
  void run(std::stop_token stop) override {
    set_state(guideway::drivers::DeviceState::streaming);
    for (std::int64_t i = 0; i < count_ && !stop.stop_requested(); ++i) {
      guideway::Sample s{};
      s.value_count = 1;
      s.value[0] = static_cast<double>(i);
      publish(s);
    }
    while (sleep_for(stop, std::chrono::milliseconds(50))) {
    }
  }

 private:
  std::int64_t count_;
};

}  // namespace

GUIDEWAY_DRIVER_PLUGIN(registry) {
  registry.add("example-ramp", "example plugin: a ramp of `count` samples",
               [](const guideway::drivers::DeviceConfig& c) -> std::unique_ptr<guideway::drivers::Driver> {
                 return std::make_unique<RampDriver>(c.name, c.ring_capacity, c.table.get_int("count", 10, 0, 1000));
               });
}
