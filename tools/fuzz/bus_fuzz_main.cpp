// objscan_bus_fuzz: publishes hostile messages (tools/fuzz/bus_fuzz.h) on every input channel of a running session,
// for issue 28's fuzz test. Usage: objscan_bus_fuzz --lcm-url URL [--seconds S] [--rate HZ] [--seed N]
// Prints how many messages of each kind it sent. Exit 0, or 2 on bad options or a bus that cannot start.
#include <chrono>
#include <cstdio>
#include <map>
#include <thread>

#include "common/bus.h"
#include "common/options.h"
#include "tools/fuzz/bus_fuzz.h"

int main(int argc, char** argv) {
  std::string url = objscan::kDefaultLcmUrl;
  double seconds = 10, rate = 100;
  int seed = 1;
  objscan::OptionParser options("objscan_bus_fuzz", "publishes hostile messages on every input channel of a session");
  options.Add("lcm-url", &url, "bus to publish on");
  options.Add("seconds", &seconds, "s, how long to publish");
  options.Add("rate", &rate, "messages per second (all channels)");
  options.Add("seed", &seed, "random seed");
  int exit_code = 0;  // --help prints the usage (and sends nothing); a bad command line exits 2
  if (!objscan::ParseCommandLineOrExit(options, argc, argv, &exit_code)) return exit_code;
  if (!(seconds > 0) || !(rate > 0)) {
    std::fprintf(stderr, "objscan_bus_fuzz: --seconds and --rate must be > 0\n%s", options.Usage().c_str());
    return 2;
  }
  std::unique_ptr<objscan::Bus> bus;
  try {
    bus = objscan::MakeLcmBus(url);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "objscan_bus_fuzz: %s\n", e.what());
    return 2;
  }
  objscan::BusFuzzer fuzzer(static_cast<uint32_t>(seed));
  std::map<std::string, int> sent;
  const auto start = std::chrono::steady_clock::now();
  const auto period = std::chrono::duration<double>(1.0 / rate);
  auto next = start;
  int total = 0;
  while (std::chrono::steady_clock::now() - start < std::chrono::duration<double>(seconds)) {
    const objscan::FuzzMessage m = fuzzer.Next();
    if (bus->Publish(m.channel, m.bytes.data(), static_cast<int>(m.bytes.size()))) {
      ++sent[objscan::FuzzKindName(m.kind)];
      ++total;
    }
    next += std::chrono::duration_cast<std::chrono::steady_clock::duration>(period);
    std::this_thread::sleep_until(next);
  }
  std::printf("objscan_bus_fuzz: %d messages in %.0f s:", total, seconds);
  for (const auto& [kind, n] : sent) std::printf(" %s %d,", kind.c_str(), n);
  std::printf("\n");
  return 0;
}
