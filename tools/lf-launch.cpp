// lf-launch: runs a gst-launch-style pipeline description on a clock shared
// across machines (gst-launch-1.0 cannot select a network clock).
//  * --clock-server PORT: the pipeline runs on this machine's system clock,
//    which is published with GstNetTimeProvider on PORT (UDP).
//  * --clock-client HOST:PORT: the pipeline runs on a GstNetClientClock
//    slaved to that provider, after it has synchronised.
// All hosts must use the same --base-time (ns on the shared clock): then
// running time k * period is the same instant everywhere and the capture
// schedules of lfcamsrc align within the clock error (paper 4.4.4). With
// --base-time now+MS the server picks "now + MS ms" and prints it
// (`base-time NS`) for the clients.
// --rtp-clock-rate PT=HZ answers every rtpjitterbuffer's request-pt-map for
// payload type PT with that clock rate: the forward error correction packets
// (rtpulpfecenc) that share a stream's SSRC and sequence numbers under a
// payload type of their own. Without it the jitter buffer drops each parity
// packet ("No clock-rate in caps!"), waits its whole latency for the gap,
// and the decoder never sees the packet in order. Any other payload type
// stays unanswered, so the jitter buffer drops it: a forged packet of a
// third type never reaches an rtpptdemux, which would make a pad for it
// that nothing is linked to and stop the stream.
#include <gst/gst.h>
#include <gst/net/gstnet.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

namespace {

const char* kSummary =
    "Runs a gst-launch-style pipeline description on a clock shared across machines.\n"
    "Give exactly one of --clock-server and --clock-client; every host uses the same\n"
    "--base-time.";

GstClockTime parse_base(const std::string& s, GstClock* clock) {
  if (s.rfind("now+", 0) == 0)
    return gst_clock_get_time(clock) + std::stoull(s.substr(4)) * GST_MSECOND;
  return std::stoull(s);
}

// The payload type and clock rate of --rtp-clock-rate.
struct PtClock {
  guint pt = 0;
  gint rate = 0;
};

// request-pt-map of an rtpjitterbuffer: RTP caps at the clock rate given,
// for its payload type only (nullptr: the jitter buffer drops the packet).
GstCaps* pt_map(GstElement*, guint pt, gpointer data) {
  const auto* c = static_cast<const PtClock*>(data);
  if (pt != c->pt) return nullptr;
  return gst_caps_new_simple("application/x-rtp", "clock-rate", G_TYPE_INT, c->rate, "payload",
                             G_TYPE_INT, static_cast<gint>(pt), nullptr);
}

// Connects pt_map to every rtpjitterbuffer in the pipeline.
void answer_pt_maps(GstElement* pipeline, const PtClock* c) {
  GstIterator* it = gst_bin_iterate_recurse(GST_BIN(pipeline));
  GValue v = G_VALUE_INIT;
  while (gst_iterator_next(it, &v) == GST_ITERATOR_OK) {
    GstElement* e = GST_ELEMENT(g_value_get_object(&v));
    GstElementFactory* f = gst_element_get_factory(e);
    if (f && g_str_equal(GST_OBJECT_NAME(f), "rtpjitterbuffer"))
      g_signal_connect(e, "request-pt-map", G_CALLBACK(pt_map), const_cast<PtClock*>(c));
    g_value_reset(&v);
  }
  g_value_unset(&v);
  gst_iterator_free(it);
}

}  // namespace

int main(int argc, char** argv) {
  gint port = 0;
  gchar* client_opt = nullptr;
  gchar* base_opt = nullptr;
  gdouble sync_timeout = 10, duration = -1, max_round_trip_ms = 0, settle = 0;
  gboolean check = FALSE;
  gchar* pt_clock_opt = nullptr;
  gchar** rest = nullptr;
  const GOptionEntry entries[] = {
      {"clock-server", 0, 0, G_OPTION_ARG_INT, &port,
       "Publish this machine's clock (GstNetTimeProvider) on UDP PORT", "PORT"},
      {"clock-client", 0, 0, G_OPTION_ARG_STRING, &client_opt,
       "Slave to a provider (GstNetClientClock); waits until synchronised", "HOST:PORT"},
      {"base-time", 0, 0, G_OPTION_ARG_STRING, &base_opt,
       "Base time shared by every host, ns on the shared clock; now+MS (server): now + MS "
       "milliseconds, printed as \"base-time NS\" (default now+500)",
       "NS|now+MS"},
      {"sync-timeout", 0, 0, G_OPTION_ARG_DOUBLE, &sync_timeout,
       "Client: give up if not synchronised after S seconds (default 10)", "S"},
      {"clock-settle", 0, 0, G_OPTION_ARG_DOUBLE, &settle,
       "With --check-clock: let the clock run S seconds after sync before reading it (default 0)",
       "S"},
      {"max-round-trip", 0, 0, G_OPTION_ARG_DOUBLE, &max_round_trip_ms,
       "Client: clock observations with a longer round trip are dropped (default 0: none, "
       "GstNetClientClock's own filtering only). An observation can be off by half its round "
       "trip, and a clock synchronised on a delayed one corrects itself only slowly "
       "(GstNetClientClock clamps each step to a quarter of the average round trip); too small "
       "a limit on a busy host delays synchronisation",
       "MS"},
      {"duration", 0, 0, G_OPTION_ARG_DOUBLE, &duration,
       "Stop after S seconds (default: run to end of stream)", "S"},
      {"check-clock", 0, 0, G_OPTION_ARG_NONE, &check,
       "Client: print \"clock-offset-ms X\" (client clock - local system clock, read between two "
       "readings of the system clock, right after sync; with --clock-settle, the median of 10 "
       "readings 100 ms apart after it) and exit without running a pipeline",
       nullptr},
      {"rtp-clock-rate", 0, 0, G_OPTION_ARG_STRING, &pt_clock_opt,
       "Answer every rtpjitterbuffer's request-pt-map for payload type PT (e.g. forward error "
       "correction packets sharing the stream) with clock rate HZ; other payload types stay "
       "unanswered and dropped (default: none answered)",
       "PT=HZ"},
      {G_OPTION_REMAINING, 0, 0, G_OPTION_ARG_STRING_ARRAY, &rest, nullptr, nullptr},
      {nullptr, 0, 0, G_OPTION_ARG_NONE, nullptr, nullptr, nullptr}};
  GOptionContext* ctx = g_option_context_new("-- PIPELINE DESCRIPTION...");
  g_option_context_set_summary(ctx, kSummary);
  g_option_context_add_main_entries(ctx, entries, nullptr);
  g_option_context_add_group(ctx, gst_init_get_option_group());
  GError* opt_err = nullptr;
  if (!g_option_context_parse(ctx, &argc, &argv, &opt_err)) {
    std::fprintf(stderr, "lf-launch: error: %s (see --help)\n", opt_err->message);
    g_clear_error(&opt_err);
    g_option_context_free(ctx);
    return 2;
  }
  g_option_context_free(ctx);
  PtClock pt_clock;
  if (pt_clock_opt) {
    unsigned pt = 0;
    int rate = 0;
    char tail = 0;
    if (std::sscanf(pt_clock_opt, "%u=%d%c", &pt, &rate, &tail) != 2 || pt > 127 || rate <= 0) {
      std::fprintf(stderr, "lf-launch: error: --rtp-clock-rate '%s': give PT=HZ (PT 0..127)\n",
                   pt_clock_opt);
      g_free(pt_clock_opt);
      return 2;
    }
    pt_clock = {pt, rate};
    g_free(pt_clock_opt);
  }
  const std::string server_port = port > 0 ? std::to_string(port) : "";
  const std::string client = client_opt ? client_opt : "";
  const std::string base = base_opt ? base_opt : "now+500";
  std::string description;
  for (gchar** r = rest; r && *r; ++r) description += std::string(*r) + " ";
  g_free(client_opt);
  g_free(base_opt);
  g_strfreev(rest);
  if (server_port.empty() == client.empty()) {
    std::fprintf(stderr, "lf-launch: error: give exactly one of --clock-server, --clock-client\n");
    return 2;
  }
  GstClock* clock = nullptr;
  GstNetTimeProvider* provider = nullptr;
  // The pipeline, parsed and set to PAUSED (nullptr: an error, printed).
  GstElement* pipeline = nullptr;
  auto build = [&]() -> GstElement* {
    if (description.empty()) return nullptr;
    GError* err = nullptr;
    GstElement* p = gst_parse_launch(description.c_str(), &err);
    if (!p || err) {  // a missing element too: never run half a pipeline
      std::fprintf(stderr, "lf-launch: error: %s\n", err ? err->message : "bad description");
      g_clear_error(&err);
      if (p) gst_object_unref(p);
      return nullptr;
    }
    if (pt_clock.rate > 0) answer_pt_maps(p, &pt_clock);
    // A failure here is posted on the bus and reported below.
    gst_element_set_state(p, GST_STATE_PAUSED);
    return p;
  };
  if (!server_port.empty()) {
    clock = gst_system_clock_obtain();
    provider = gst_net_time_provider_new(clock, nullptr, std::stoi(server_port));
    if (!provider) {
      std::fprintf(stderr, "lf-launch: error: cannot publish the clock on UDP port %s\n",
                   server_port.c_str());
      return 1;
    }
  } else {
    const auto colon = client.rfind(':');
    if (colon == std::string::npos) {
      std::fprintf(stderr, "lf-launch: error: --clock-client needs HOST:PORT\n");
      return 2;
    }
    clock = gst_net_client_clock_new("lf-net-clock", client.substr(0, colon).c_str(),
                                     std::stoi(client.substr(colon + 1)), 0);
    if (max_round_trip_ms > 0)
      g_object_set(clock, "round-trip-limit", static_cast<guint64>(max_round_trip_ms * GST_MSECOND),
                   nullptr);
    // While the clock synchronises, the pipeline starts up to PAUSED (a live
    // pipeline's sources open their inputs there, e.g. lfcamsrc decodes its
    // stills): a restarted camera host is back sooner.
    if (!check && !(pipeline = build()) && !description.empty()) return 1;
    if (!gst_clock_wait_for_sync(clock, static_cast<GstClockTime>(sync_timeout * GST_SECOND))) {
      std::fprintf(stderr, "lf-launch: error: clock %s not synchronised after %.0f s\n",
                   client.c_str(), sync_timeout);
      if (pipeline) gst_element_set_state(pipeline, GST_STATE_NULL), gst_object_unref(pipeline);
      return 1;
    }
    if (check) {
      // Right at sync the clock has a rate fitted to a few observations;
      // on a busy machine it drifts by several ms over the next second
      // until more observations come. With --clock-settle S the clock runs
      // S seconds first (as a camera host does before its first capture
      // instant), then the median of 10 readings 100 ms apart says how far
      // it agrees; without, one reading right at sync. A reading preempted
      // between the system clock's two readings (> 1 ms apart) is taken
      // again.
      const size_t readings = settle > 0 ? 10 : 1;
      g_usleep(static_cast<gulong>(settle * G_USEC_PER_SEC));
      GstClock* sys = gst_system_clock_obtain();
      std::vector<double> offs;
      for (int tries = 0; offs.size() < readings && tries < 100; ++tries) {
        const GstClockTime a = gst_clock_get_time(sys);
        const GstClockTime c = gst_clock_get_time(clock);
        const GstClockTime b = gst_clock_get_time(sys);
        if (b - a <= GST_MSECOND) {
          offs.push_back((static_cast<double>(c) - (static_cast<double>(a) + b) / 2) / 1e6);
          if (offs.size() < readings) g_usleep(100000);
        }
      }
      if (offs.empty()) {
        std::fprintf(stderr, "lf-launch: error: no clock reading without preemption\n");
        return 1;
      }
      std::sort(offs.begin(), offs.end());
      std::printf("clock-offset-ms %.3f\n", offs[offs.size() / 2]);
      gst_object_unref(sys);
      gst_object_unref(clock);
      return 0;
    }
  }
  GstClockTime base_time;
  try {
    base_time = parse_base(base, clock);
  } catch (const std::exception&) {
    std::fprintf(stderr, "lf-launch: error: --base-time '%s' is not NS or now+MS\n", base.c_str());
    return 2;
  }
  std::printf("base-time %" G_GUINT64_FORMAT "\n", base_time);
  std::fflush(stdout);
  if (description.empty()) {
    std::fprintf(stderr, "lf-launch: error: no pipeline description after --\n");
    return 2;
  }
  if (!pipeline && !(pipeline = build())) return 1;
  // Same clock and base time everywhere; never redistribute the base time.
  gst_pipeline_use_clock(GST_PIPELINE(pipeline), clock);
  gst_element_set_start_time(pipeline, GST_CLOCK_TIME_NONE);
  gst_element_set_base_time(pipeline, base_time);
  gst_element_set_state(pipeline, GST_STATE_PLAYING);
  GstBus* bus = gst_element_get_bus(pipeline);
  int rc = 0;
  const GstClockTime timeout =
      duration >= 0 ? static_cast<GstClockTime>(duration * GST_SECOND) : GST_CLOCK_TIME_NONE;
  GstMessage* msg = gst_bus_timed_pop_filtered(
      bus, timeout, static_cast<GstMessageType>(GST_MESSAGE_EOS | GST_MESSAGE_ERROR));
  if (msg && GST_MESSAGE_TYPE(msg) == GST_MESSAGE_ERROR) {
    GError* e = nullptr;
    gchar* dbg = nullptr;
    gst_message_parse_error(msg, &e, &dbg);
    std::fprintf(stderr, "lf-launch: error from %s: %s\n%s\n", GST_OBJECT_NAME(msg->src),
                 e->message, dbg ? dbg : "");
    g_clear_error(&e);
    g_free(dbg);
    rc = 1;
  }
  if (msg) gst_message_unref(msg);
  gst_element_set_state(pipeline, GST_STATE_NULL);
  gst_object_unref(bus);
  gst_object_unref(pipeline);
  if (provider) gst_object_unref(provider);
  gst_object_unref(clock);
  return rc;
}
