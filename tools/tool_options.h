// What every tool's command line shares: options through GLib's GOption
// (--help on stdout, exit 0; a bad option or value: the message on stderr,
// exit 2), output folders made with their parents, and progress lines for
// work that takes more than a few seconds.
#pragma once

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>

#include <glib.h>
#include <glib/gstdio.h>

#include <gst/vclassroom/core/limits.h>

namespace vclassroom_tools {

[[noreturn]] inline void usage_error(const std::string& message);

// Parses argv with `entries` (NULL-terminated) and, when given, another
// option group (e.g. gst_init_get_option_group(), which also initialises
// GStreamer). What is left in argv are the `positional` arguments named in
// `parameters`; another count is a usage error. Exits 0 after --help, 2
// after a bad option.
inline void parse_command_line(int* argc, char*** argv, const char* parameters, const char* summary,
                               const GOptionEntry* entries, GOptionGroup* extra_group = nullptr,
                               int positional = 0) {
  // Result lines are progress too: shown as they come, also through a pipe (| tee).
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  GOptionContext* ctx = g_option_context_new(parameters);
  g_option_context_set_summary(ctx, summary);
  g_option_context_add_main_entries(ctx, entries, nullptr);
  if (extra_group) g_option_context_add_group(ctx, extra_group);
  GError* err = nullptr;
  if (!g_option_context_parse(ctx, argc, argv, &err)) {
    std::fprintf(stderr, "%s: %s\nRun '%s --help' to see the options.\n", g_get_prgname(), err->message,
                 g_get_prgname());
    g_error_free(err);
    g_option_context_free(ctx);
    std::exit(2);
  }
  g_option_context_free(ctx);
  if (*argc - 1 != positional)
    usage_error(positional == 0 ? std::string("unexpected argument ") + (*argv)[1]
                                : std::string("expected ") + parameters);
}

// A command line that parsed but makes no sense (a missing or out-of-range
// value): the reason on stderr, exit 2.
[[noreturn]] inline void usage_error(const std::string& message) {
  std::fprintf(stderr, "%s: %s\nRun '%s --help' to see the options.\n", g_get_prgname(), message.c_str(),
               g_get_prgname());
  std::exit(2);
}

// A --size WxH value: each side 16 to kMaxImageSide (the project's image limit).
inline void parse_size_or_exit(const char* option, const char* text, int* width, int* height) {
  int w = 0, h = 0;
  char end = 0;
  const int most = vclassroom::kMaxImageSide;
  if (std::sscanf(text, "%dx%d%c", &w, &h, &end) != 2 || w < 16 || h < 16 || w > most || h > most)
    usage_error(std::string(option) + " must be WxH, 16 to " + std::to_string(most) + " each (got '" + text + "')");
  *width = w;
  *height = h;
}

// A string option's value, "" when not given.
inline std::string text_of(const gchar* value) { return value ? value : ""; }

// Makes `path` and its missing parents; false, with the reason on stderr, when it cannot.
inline bool make_folder(const std::string& path) {
  if (g_mkdir_with_parents(path.c_str(), 0755) == 0) return true;
  std::fprintf(stderr, "%s: cannot create folder %s: %s\n", g_get_prgname(), path.c_str(), g_strerror(errno));
  return false;
}

// Makes the folder that will hold the file `path`.
inline bool make_parent_folder(const std::string& path) {
  gchar* dir = g_path_get_dirname(path.c_str());
  const bool ok = make_folder(dir);
  g_free(dir);
  return ok;
}

// A progress line on stderr at most every few seconds ("what: 12/40, 6 s"),
// and always for the last step, so a long run shows it is going.
class Progress {
 public:
  Progress(std::string what, long total) : what_(std::move(what)), total_(total) {}
  void step(long done) {
    const auto now = Clock::now();
    if (done < total_ && now - last_ < std::chrono::seconds(kEverySeconds)) return;
    last_ = now;
    std::fprintf(stderr, "%s: %ld/%ld, %.0f s\n", what_.c_str(), done, total_,
                 std::chrono::duration<double>(now - start_).count());
  }

 private:
  using Clock = std::chrono::steady_clock;
  static constexpr int kEverySeconds = 3;
  std::string what_;
  long total_;
  Clock::time_point start_ = Clock::now();
  Clock::time_point last_ = Clock::now();
};

}  // namespace vclassroom_tools
