// What the benchmarks measure about this process and machine (lf-bench,
// lf-gst-bench): CPU time, the machine's stolen time, peak resident set
// size (Linux /proc), and order statistics.
#pragma once

#include <string>
#include <vector>

namespace measure {

// CPU time of this process and of the calling thread, seconds (user +
// system: time another guest takes from the machine is not counted).
double process_cpu_s();
double thread_cpu_s();

// The machine's CPU time split (/proc/stat, all cores): total and stolen
// (taken by the hypervisor for other guests), in clock ticks.
struct MachineTicks {
  unsigned long long total = 0, steal = 0;
};
MachineTicks machine_ticks();

// Peak resident set size of this process since the last reset (Linux
// VmHWM; writing 5 to clear_refs resets it, so each row gets its own
// peak), MiB.
void reset_peak_rss();
double peak_rss_mib();

// The CPU's model name (Linux /proc/cpuinfo; "unknown CPU" elsewhere).
std::string cpu_model();

// The q-quantile (nearest rank), the median and the mean; 0 when empty.
double percentile(std::vector<double> v, double q);
double median(std::vector<double> v);
double mean(const std::vector<double>& v);

}  // namespace measure
