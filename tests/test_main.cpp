#include <gst/gst.h>
#include <gtest/gtest.h>

#include <cstdio>
#include <cstring>

namespace {

// GStreamer's leaks tracer (GST_TRACERS=leaks) lists the objects still alive
// when gst_deinit() runs and then only warns: remember that warning so the
// program fails on a leak (docs/development.md, "Sanitizers and leak checks").
bool leaks_reported = false;

void log_handler(const gchar* domain, GLogLevelFlags level, const gchar* message, gpointer) {
  if ((level & G_LOG_LEVEL_WARNING) && message && std::strstr(message, "Leaks detected")) leaks_reported = true;
  g_log_default_handler(domain, level, message, nullptr);
}

}  // namespace

int main(int argc, char** argv) {
  g_log_set_default_handler(log_handler, nullptr);
  gst_init(&argc, &argv);
  ::testing::InitGoogleTest(&argc, argv);
  const int rc = RUN_ALL_TESTS();
  gst_deinit();
  if (leaks_reported) {
    std::fprintf(stderr,
                 "FAILED: GStreamer's leaks tracer found objects still alive at exit "
                 "(rerun with GST_DEBUG=GST_TRACER:7 to list them)\n");
    return 1;
  }
  return rc;
}
