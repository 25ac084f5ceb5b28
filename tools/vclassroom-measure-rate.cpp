// The lecturer's rate control behind a slow link: for each link rate, starts a
// whepviewsink (one live synthetic camera) and a headless Chromium lecturer in
// a network namespace whose loopback carries only that many kbit/s
// (tests/browser/slow-link.sh: unshare -rn, tc tbf; tests/browser/
// measure-rate.mjs samples the page's inbound statistics every second), and
// reports how long the picture takes to settle (the first five seconds with
// under 10 % of the packets lost and at least 15 frames shown: the criterion
// of the slow-link test), what the lecturer receives afterwards, and the rates
// the server chose (its vclassroom-lecturer-bitrate messages). Needs user
// namespaces, iproute2 with tc tbf, node, chromium and tests/browser/
// node_modules; exits 77, saying why, where the namespace cannot be made.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <glib.h>
#include <sys/wait.h>

#include "browser_driver.h"
#include "tool_options.h"

using namespace vclassroom_tools;

namespace {

struct Sample {
  double t_ms = 0, lost = 0, got = 0, shown = 0, kbps = 0;
};

double json_number(const std::string& json, const std::string& key) {
  const size_t at = json.find("\"" + key + "\":");
  return at == std::string::npos ? std::nan("") : std::atof(json.c_str() + at + key.size() + 3);
}

// The first sample ending five seconds with under 10 % lost, >= 50 packets and >= 15 frames shown, or -1.
int settled_at(const std::vector<Sample>& s) {
  for (size_t i = 5; i < s.size(); ++i) {
    const Sample &a = s[i - 5], &b = s[i];
    const double lost = b.lost - a.lost, got = b.got - a.got;
    if (got >= 50 && lost / (lost + got) < 0.10 && b.shown - a.shown >= 15) return int(i);
  }
  return -1;
}

}  // namespace

int main(int argc, char** argv) {
  g_autofree gchar* links_text = nullptr;
  g_autofree gchar* size_text = nullptr;
  gint seconds = 60, bitrate = 4000;
  const GOptionEntry entries[] = {
      {"links", 0, 0, G_OPTION_ARG_STRING, &links_text, "Link rates to measure behind, kbit/s (default 500,1000,2000)",
       "K,K"},
      {"seconds", 0, 0, G_OPTION_ARG_INT, &seconds, "How long the lecturer watches behind each link (default 60)", "S"},
      {"size", 0, 0, G_OPTION_ARG_STRING, &size_text, "The lecturer's view (default 960x540)", "WxH"},
      {"bitrate", 0, 0, G_OPTION_ARG_INT, &bitrate, "whepviewsink's bitrate, the rate it starts at (default 4000)",
       "KBIT"},
      {nullptr, 0, 0, G_OPTION_ARG_NONE, nullptr, nullptr, nullptr}};
  parse_command_line(&argc, &argv, "",
                     "How fast a lecturer's bitrate comes down to a slow link, and what the lecturer receives then "
                     "(whepviewsink behind a token bucket in a network namespace; needs unshare -rn, tc, node, "
                     "chromium and tests/browser/node_modules).",
                     entries, nullptr);
  int width = 960, height = 540;
  if (size_text) parse_size_or_exit("--size", size_text, &width, &height);
  if (seconds < 20 || seconds > 150) usage_error("--seconds must be 20 to 150");
  if (bitrate < 250 || bitrate > 100000) usage_error("--bitrate must be 250 to 100000 kbit/s");
  std::vector<int> links;
  gchar** parts = g_strsplit(links_text ? links_text : "500,1000,2000", ",", -1);
  for (gchar** it = parts; *it; ++it) links.push_back(std::atoi(*it));
  g_strfreev(parts);
  for (int k : links)
    if (k < 100 || k > 100000) usage_error("--links: each rate 100 to 100000 kbit/s");
  const std::string root = browser_driver_root("measure-rate.mjs");
  const std::string browser_dir = root + "/tests/browser";
  std::printf("| link kbit/s | settled after s | then received kbit/s | then lost %% | then frames/s | lost %% in the "
              "first 5 s | server's rate after its first change, lowest, last kbit/s (changes) |\n|---|---|---|---|---|---|---|\n");
  for (int link : links) {
    // The namespace has its own ports: any will do.
    const std::string server =
        "whepviewsink name=w port=8080 token=measure-token bitrate=" + std::to_string(bitrate) + " width=" +
        std::to_string(width) + " height=" + std::to_string(height) + " web-root=" + root +
        "/web/lecturer rgbdtestsrc camera-id=0 is-live=true ! learnerseg ! queue max-size-buffers=1 "
        "leaky=downstream ! w.cam_0";
    const std::string script = browser_dir + "/slow-link.sh", kbit = std::to_string(link),
                      window = std::to_string(seconds);
    const gchar* child_argv[] = {"unshare", "-rn", "sh", script.c_str(), kbit.c_str(), "8080", server.c_str(),
                                 "measure-rate.mjs", "measure-token", window.c_str(), nullptr};
    gchar** env = g_environ_unsetenv(g_get_environ(), "LD_PRELOAD");  // node and Chromium are not ours
    gchar *output = nullptr, *errors = nullptr;
    gint status = 0;
    GError* err = nullptr;
    std::fprintf(stderr, "behind %d kbit/s: %d s\n", link, seconds);
    const bool ran = g_spawn_sync(browser_dir.c_str(), const_cast<gchar**>(child_argv), env, G_SPAWN_SEARCH_PATH,
                                  nullptr, nullptr, &output, &errors, &status, &err);
    g_strfreev(env);
    const std::string out = std::string(output ? output : "") + (errors ? errors : "");
    g_free(output);
    g_free(errors);
    if (!ran) {
      std::fprintf(stderr, "%s: cannot start unshare: %s\n", g_get_prgname(), err ? err->message : "");
      return 77;
    }
    if (WIFEXITED(status) && WEXITSTATUS(status) == 77) {
      std::fprintf(stderr, "%s: %s", g_get_prgname(), out.c_str());
      return 77;
    }
    std::vector<Sample> samples;
    std::vector<int> rates;
    bool done = false;
    gchar** lines = g_strsplit(out.c_str(), "\n", -1);
    for (gchar** it = lines; *it; ++it) {
      const std::string l = *it;
      if (l.rfind("sample {", 0) == 0) {
        samples.push_back(Sample{json_number(l, "t"), json_number(l, "lost"), json_number(l, "got"),
                                 json_number(l, "shown"), json_number(l, "kbps")});
      } else if (l == "done") {
        done = true;
      } else if (l.find("vclassroom-lecturer-bitrate") != std::string::npos) {
        const size_t k = l.find("kbit=(int)");
        if (k != std::string::npos) rates.push_back(std::atoi(l.c_str() + k + 10));
      }
    }
    g_strfreev(lines);
    if (!done || samples.size() < 10) {
      std::fprintf(stderr, "%s: behind %d kbit/s the lecturer did not finish:\n%s\n", g_get_prgname(), link,
                   out.c_str());
      return 1;
    }
    const int settled = settled_at(samples);
    const Sample& first = samples.front();
    const Sample& early = samples[std::min<size_t>(5, samples.size() - 1)];
    const double early_lost = early.lost - first.lost, early_got = early.got - first.got;
    char settle_text[32] = "never", kbps_text[32] = "-", lost_text[32] = "-", fps_text[32] = "-";
    if (settled >= 0) {
      const Sample& from = samples[size_t(settled)];
      const Sample& last = samples.back();
      const double span = (last.t_ms - from.t_ms) / 1000, lost = last.lost - from.lost, got = last.got - from.got;
      double kbps = 0;
      for (size_t i = size_t(settled); i < samples.size(); ++i) kbps += samples[i].kbps;
      std::snprintf(settle_text, sizeof settle_text, "%.0f", (from.t_ms - first.t_ms) / 1000);
      std::snprintf(kbps_text, sizeof kbps_text, "%.0f", kbps / double(samples.size() - size_t(settled)));
      if (lost + got > 0) std::snprintf(lost_text, sizeof lost_text, "%.1f", 100 * lost / (lost + got));
      if (span > 0) std::snprintf(fps_text, sizeof fps_text, "%.1f", (last.shown - from.shown) / span);
    }
    std::string rate_text = "none";
    if (!rates.empty())
      rate_text = std::to_string(rates.front()) + ", " + std::to_string(*std::min_element(rates.begin(), rates.end())) +
                  ", " + std::to_string(rates.back()) + " (" + std::to_string(rates.size()) + ")";
    std::printf("| %d | %s | %s | %s | %s | %.1f | %s |\n", link, settle_text, kbps_text, lost_text, fps_text,
                early_lost + early_got > 0 ? 100 * early_lost / (early_lost + early_got) : 0.0, rate_text.c_str());
    std::fflush(stdout);
  }
  return 0;
}
