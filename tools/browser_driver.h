// What the tools that measure with a browser share: the source tree's tests/browser/ driver scripts, run by
// node (with puppeteer-core, from tests/browser/node_modules) against the system Chromium.
#pragma once

#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include <gio/gio.h>
#include <glib.h>

namespace vclassroom_tools {

// The source root (VCLASSROOM_SOURCE_DIR, else the current folder), absolute: node runs in tests/browser.
// Exits with a message when tests/browser/`script` or its node_modules are missing.
inline std::string browser_driver_root(const std::string& script) {
  const char* source_dir = g_getenv("VCLASSROOM_SOURCE_DIR");
  gchar* absolute = g_canonicalize_filename(source_dir ? source_dir : ".", nullptr);
  const std::string root = absolute;
  g_free(absolute);
  if (!g_file_test((root + "/tests/browser/" + script).c_str(), G_FILE_TEST_EXISTS) ||
      !g_file_test((root + "/tests/browser/node_modules/puppeteer-core").c_str(), G_FILE_TEST_IS_DIR)) {
    std::fprintf(stderr, "%s: needs tests/browser/%s and tests/browser/node_modules (scripts/setup.sh runs npm ci); "
                 "run from the source root or set VCLASSROOM_SOURCE_DIR\n", g_get_prgname(), script.c_str());
    std::exit(1);
  }
  return root;
}

// node tests/browser/`script` `args`... from that folder, its stdout piped, without this program's preload (a
// sanitizer's runtime is not for node and Chromium). Exits with a message when node cannot start.
inline GSubprocess* start_browser_driver(const std::string& root, const std::string& script,
                                         const std::vector<std::string>& args) {
  std::vector<const gchar*> argv = {"node", script.c_str()};
  for (const std::string& a : args) argv.push_back(a.c_str());
  argv.push_back(nullptr);
  GSubprocessLauncher* launcher = g_subprocess_launcher_new(G_SUBPROCESS_FLAGS_STDOUT_PIPE);
  g_subprocess_launcher_set_cwd(launcher, (root + "/tests/browser").c_str());
  g_subprocess_launcher_unsetenv(launcher, "LD_PRELOAD");
  GError* err = nullptr;
  GSubprocess* driver = g_subprocess_launcher_spawnv(launcher, argv.data(), &err);
  g_object_unref(launcher);
  if (!driver) {
    std::fprintf(stderr, "%s: cannot start node: %s\n", g_get_prgname(), err->message);
    std::exit(1);
  }
  return driver;
}

}  // namespace vclassroom_tools
