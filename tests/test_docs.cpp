// The documentation runs as written: every gst-launch-1.0 command in README.md
// and docs/*.md, and the example launch line in every element's documentation
// block (the gtk-doc comment at the top of its source, "SECTION:element-NAME"),
// is parsed as gst-launch-1.0 would parse it and run to the end, with
// display sinks replaced by fakesink and sources bounded to a few buffers.
// Any error (a missing element or property, not-negotiated, a missing file)
// fails the test naming the doc file and line, or the element.
//
// Commands run from a scratch folder standing for the project root: what a
// command needs under out/ (a model, an imported dataset) is made first by
// the documented tool command that writes it (build/tools/... mapped to the
// build's tools, ../shared/data to the shared data); where that tool needs
// the shared data and it is absent, the command is skipped, saying why.
#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <sys/wait.h>
#include <unistd.h>

#include <gst/base/gstbasesrc.h>
#include <gst/gst.h>
#include <gtest/gtest.h>

#include <gst/vclassroom/core/rig.h>

#include "test_util.h"

namespace fs = std::filesystem;

using vctest::Exit;
using vctest::run_tool;

namespace {

// Sources are bounded to this many buffers: enough to negotiate and to run
// every element on real frames, few enough for a quick test.
constexpr int kBuffersPerSource = 3;

// Sinks that open a window or a sound device; a test machine has neither.
const std::set<std::string> kDisplaySinks = {"autovideosink", "ximagesink", "xvimagesink", "glimagesink",
                                             "gtksink",       "waylandsink", "autoaudiosink"};

constexpr const char* kWindowCaps = "video/x-raw,format=BGRx";

// A command found in a document: where, and its text with continuation lines joined.
struct DocCommand {
  std::string where;  // "docs/vda.md:28" or "plugins/vda/gstdepthcomplete.cpp:16 (depthcomplete)"
  std::string text;
  std::string context = {};  // the text around it that may say how to make what it reads
};

std::string trim(const std::string& s) {
  const size_t a = s.find_first_not_of(" \t");
  if (a == std::string::npos) return "";
  const size_t b = s.find_last_not_of(" \t\r");
  return s.substr(a, b - a + 1);
}

bool starts_with(const std::string& s, const std::string& prefix) { return s.rfind(prefix, 0) == 0; }

// The command a code line starts, if any: after an optional "$ " prompt and
// VAR=value assignments, the first word is `program`.
bool starts_command(const std::string& line, const std::string& program) {
  std::string t = trim(line);
  if (starts_with(t, "$ ")) t = trim(t.substr(2));
  static const std::regex assignment(R"(^[A-Za-z_][A-Za-z0-9_]*=\S*\s+)");
  std::smatch m;
  while (std::regex_search(t, m, assignment)) t = t.substr(m.length());
  return starts_with(t, program + " ");
}

// Every command of `program` in a markdown text: lines inside ``` blocks
// (joined with the lines they continue with a trailing backslash) and inline
// code spans that hold a whole command.
std::vector<DocCommand> extract_commands(const std::string& name, const std::string& markdown,
                                         const std::string& program) {
  std::vector<DocCommand> out;
  std::vector<std::string> lines;
  std::istringstream in(markdown);
  for (std::string l; std::getline(in, l);) lines.push_back(l);
  bool in_fence = false;
  for (size_t i = 0; i < lines.size(); ++i) {
    const std::string t = trim(lines[i]);
    if (starts_with(t, "```")) {
      in_fence = !in_fence;
      continue;
    }
    if (in_fence) {
      if (!starts_command(t, program)) continue;
      const size_t first = i;
      std::string text = t;
      while (!text.empty() && text.back() == '\\' && i + 1 < lines.size()) {
        text.pop_back();
        text += " " + trim(lines[++i]);
      }
      if (starts_with(text, "$ ")) text = text.substr(2);
      out.push_back({name + ":" + std::to_string(first + 1), text});
      continue;
    }
    // Inline code: `...` spans on one line.
    for (size_t a = t.find('`'); a != std::string::npos;) {
      const size_t b = t.find('`', a + 1);
      if (b == std::string::npos) break;
      const std::string span = t.substr(a + 1, b - a - 1);
      if (starts_command(span, program)) out.push_back({name + ":" + std::to_string(i + 1), trim(span)});
      a = t.find('`', b + 1);
    }
  }
  return out;
}

std::string read_text(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::string env_or_empty(const char* name) {
  const char* v = std::getenv(name);
  return v ? v : "";
}

// README.md and docs/*.md, in a fixed order.
std::vector<std::pair<std::string, std::string>> project_documents() {
  const fs::path root = env_or_empty("VCLASSROOM_SOURCE_DIR");
  std::vector<std::pair<std::string, std::string>> docs;
  if (root.empty()) return docs;
  docs.emplace_back("README.md", read_text(root / "README.md"));
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(root / "docs"))
    if (e.path().extension() == ".md") names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  for (const std::string& n : names) docs.emplace_back("docs/" + n, read_text(root / "docs" / n));
  return docs;
}

std::vector<std::string> split_argv(const std::string& text, std::string* error) {
  gchar** argv = nullptr;
  GError* err = nullptr;
  std::vector<std::string> out;
  if (!g_shell_parse_argv(text.c_str(), nullptr, &argv, &err)) {
    *error = err ? err->message : "cannot split into words";
    g_clear_error(&err);
    return out;
  }
  for (gchar** a = argv; *a; ++a) out.emplace_back(*a);
  g_strfreev(argv);
  return out;
}

// The pipeline words of a gst-launch-1.0 command (what gst-launch-1.0 hands to
// gst_parse_launchv: after the environment assignments, the program and its
// options), display sinks replaced by fakesink without their properties.
std::vector<std::string> pipeline_words(const std::vector<std::string>& argv) {
  size_t i = 0;
  while (i < argv.size() && argv[i] != "gst-launch-1.0") ++i;
  ++i;
  while (i < argv.size() && starts_with(argv[i], "-")) ++i;
  std::vector<std::string> words;
  for (; i < argv.size(); ++i) {
    if (kDisplaySinks.count(argv[i])) {
      // A window takes only the formats the display does: what ximagesink (autovideosink's choice
      // without Xv or OpenGL) takes on a usual 24-bit X display. A sink that accepts anything would
      // hide a missing videoconvert.
      if (argv[i] != "autoaudiosink") words.insert(words.end(), {"capsfilter", "caps=" + std::string(kWindowCaps), "!"});
      words.push_back("fakesink");
      // The display sink's own properties (sync=false, force-aspect-ratio=...) go with it; its name stays.
      while (i + 1 < argv.size() && argv[i + 1].find('=') != std::string::npos &&
             argv[i + 1].find('!') == std::string::npos && argv[i + 1].find('/') == std::string::npos) {
        if (starts_with(argv[i + 1], "name=")) words.push_back(argv[i + 1]);
        ++i;
      }
      continue;
    }
    words.push_back(argv[i]);
  }
  return words;
}

// Bounds every source that counts buffers to kBuffersPerSource, and lets every element that listens
// (udpsrc, the WHEP sinks) bind a port of the system's choosing.
void bound_sources(GstElement* pipeline) {
  GstIterator* it = gst_bin_iterate_recurse(GST_BIN(pipeline));
  GValue v = G_VALUE_INIT;
  while (gst_iterator_next(it, &v) == GST_ITERATOR_OK) {
    GstElement* e = GST_ELEMENT(g_value_get_object(&v));
    if (GST_IS_BASE_SRC(e) && g_object_class_find_property(G_OBJECT_GET_CLASS(e), "num-buffers")) {
      gint n = -1;
      g_object_get(e, "num-buffers", &n, nullptr);
      if (n < 0 || n > kBuffersPerSource) g_object_set(e, "num-buffers", kBuffersPerSource, nullptr);
    }
    // What listens binds a port of the system's choosing: the port a documented pipeline names may be taken
    // on the machine running the tests.
    GstElementFactory* f = gst_element_get_factory(e);
    const std::string kind = f ? GST_OBJECT_NAME(f) : "";
    if ((kind == "udpsrc" || kind == "whepviewsink" || kind == "whepserversink") &&
        g_object_class_find_property(G_OBJECT_GET_CLASS(e), "port"))
      g_object_set(e, "port", 0, nullptr);
    g_value_reset(&v);
  }
  g_value_unset(&v);
  gst_iterator_free(it);
}

// Whether a source of the pipeline is live (udpsrc, a camera): it may wait for ever for data.
bool has_live_source(GstElement* pipeline) {
  bool live = false;
  GstIterator* it = gst_bin_iterate_sources(GST_BIN(pipeline));
  GValue v = G_VALUE_INIT;
  while (gst_iterator_next(it, &v) == GST_ITERATOR_OK) {
    GstElement* e = GST_ELEMENT(g_value_get_object(&v));
    if (GST_IS_BASE_SRC(e) && gst_base_src_is_live(GST_BASE_SRC(e))) live = true;
    g_value_reset(&v);
  }
  g_value_unset(&v);
  gst_iterator_free(it);
  return live;
}

// Runs the pipeline to its end. "" on EOS, else what went wrong (the error,
// its source and GStreamer's debug text, which says e.g. not-negotiated).
std::string run_to_end(GstElement* pipeline) {
  GstBus* bus = gst_element_get_bus(pipeline);
  std::string problem;
  const GstStateChangeReturn started = gst_element_set_state(pipeline, GST_STATE_PLAYING);
  if (started == GST_STATE_CHANGE_FAILURE) problem = "cannot start: ";
  const auto types = GstMessageType(GST_MESSAGE_EOS | GST_MESSAGE_ERROR);
  // A guard against a pipeline that never ends, not a measurement: a few buffers take well under it.
  GstMessage* m = nullptr;
  if (has_live_source(pipeline)) {
    // Live (e.g. udpsrc waiting for a sender that is not there): what it gets in a while is checked, then
    // it is stopped as gst-launch-1.0 -e stops it on Ctrl-C, and must end cleanly.
    m = gst_bus_timed_pop_filtered(bus, 10 * GST_SECOND, types);
    if (!m) {
      gst_element_send_event(pipeline, gst_event_new_eos());
      m = gst_bus_timed_pop_filtered(bus, 300 * GST_SECOND, types);
    }
  } else {
    m = gst_bus_timed_pop_filtered(bus, 300 * GST_SECOND, types);
  }
  if (!m) {
    problem += "did not end within 300 s with its sources bounded to a few buffers";
  } else if (GST_MESSAGE_TYPE(m) == GST_MESSAGE_ERROR) {
    GError* err = nullptr;
    gchar* debug = nullptr;
    gst_message_parse_error(m, &err, &debug);
    problem += std::string(GST_OBJECT_NAME(GST_MESSAGE_SRC(m))) + ": " + (err ? err->message : "error") + " (" +
               (debug ? debug : "") + ")";
    g_clear_error(&err);
    g_free(debug);
  }
  if (m) gst_message_unref(m);
  gst_element_set_state(pipeline, GST_STATE_NULL);
  gst_object_unref(bus);
  return problem;
}

// Runs documented commands in one scratch folder standing for the project root.
class DocRunner {
 public:
  DocRunner() {
    old_cwd_ = fs::current_path();
    fs::current_path(scratch_.path());
  }
  ~DocRunner() { fs::current_path(old_cwd_); }

  // The documented tool commands (build/tools/vclassroom-...) that may make what launch lines need.
  void add_tools(const std::vector<DocCommand>& tools) { tools_ = tools; }

  // Runs one command. Returns "" when it ran to the end, else the failure; a
  // skip (with its reason in *skip) returns "".
  std::string run(const DocCommand& c, std::string* skip) {
    std::string error;
    const std::vector<std::string> argv = split_argv(c.text, &error);
    if (!error.empty()) return "cannot split into words as a shell would: " + error;
    if (c.text.find('$') != std::string::npos) {
      *skip = "uses shell variables";
      return "";
    }
    // A line for a real camera runs where one is plugged in.
    static const std::regex device(R"(/dev/video[0-9]+)");
    for (std::sregex_iterator it(c.text.begin(), c.text.end(), device), end; it != end; ++it)
      if (!fs::exists(it->str())) {
        *skip = "needs a camera at " + it->str();
        return "";
      }
    const std::vector<std::string> words = pipeline_words(argv);
    if (words.empty()) return "no pipeline description after gst-launch-1.0";
    if (std::string why = make_prerequisites(c.text, c.context, skip); !why.empty() || !skip->empty()) return why;

    std::vector<const gchar*> cwords;
    for (const std::string& w : words) cwords.push_back(w.c_str());
    cwords.push_back(nullptr);
    GError* err = nullptr;
    GstElement* p = gst_parse_launchv_full(cwords.data(), nullptr, GST_PARSE_FLAG_FATAL_ERRORS, &err);
    if (!p || err) {
      std::string msg = std::string("does not parse: ") + (err ? err->message : "?");
      g_clear_error(&err);
      if (p) gst_object_unref(p);
      return msg;
    }
    if (!GST_IS_PIPELINE(p)) {  // gst-launch-1.0 puts a lone element into a pipeline too
      GstElement* pipe = gst_pipeline_new(nullptr);
      gst_bin_add(GST_BIN(pipe), p);
      p = pipe;
    }
    bound_sources(p);
    const std::string problem = run_to_end(p);
    gst_object_unref(p);
    return problem;
  }

 private:
  // Makes each out/... path the command names and the folder lacks, with the
  // first documented tool command that writes it and succeeds. Returns the
  // failure, or sets *skip; each path is tried once, its outcome kept.
  std::string make_prerequisites(const std::string& text, const std::string& context, std::string* skip) {
    // A key file the command reads (key-file=F) is made as the text around
    // it says: "head -c N /dev/urandom > F".
    static const std::regex key_file(R"(key-file=([A-Za-z0-9_./-]+))");
    for (std::sregex_iterator it(text.begin(), text.end(), key_file), end; it != end; ++it) {
      const std::string file = (*it)[1].str();
      if (fs::exists(file)) continue;
      std::smatch made;
      const std::regex making("head -c ([0-9]+) /dev/urandom > " + std::regex_replace(file, std::regex(R"([.])"), R"(\.)"));
      if (!std::regex_search(context, made, making)) return "needs the key file " + file + ", and the text does not say how to make it";
      std::ofstream(file, std::ios::binary) << std::string(std::stoul(made[1].str()), '\x5a');
    }
    static const std::regex out_path(R"(\bout/[A-Za-z0-9_.-]+)");
    for (std::sregex_iterator it(text.begin(), text.end(), out_path), end; it != end; ++it) {
      const std::string need = it->str();
      if (!outcomes_.count(need) && fs::exists(need)) continue;
      if (writes(text, need)) continue;  // the command makes it (a recording)
      if (!outcomes_.count(need)) outcomes_[need] = make(need);
      const Outcome& o = outcomes_[need];
      if (!o.skip.empty()) *skip = o.skip;
      if (!o.failure.empty() || !o.skip.empty()) return o.failure;
    }
    return "";
  }

  // Whether the launch line itself writes `path`: a sink's location, or posesend's trace.
  static bool writes(const std::string& text, const std::string& path) {
    const std::regex writer(R"((sink[^!]*\blocation=|trace-location=))" + std::regex_replace(path, std::regex(R"([.])"), R"(\.)") +
                            R"((\s|$))");
    return std::regex_search(text, writer);
  }

  struct Outcome {
    std::string failure, skip;
  };

  Outcome make(const std::string& need) {
    std::string failures;
    for (const DocCommand& t : tools_) {
      if (t.text.find('[') != std::string::npos) continue;  // a synopsis with optional parts, not a command
      std::string error;
      std::vector<std::string> argv = split_argv(t.text, &error);
      if (!error.empty() || std::find(argv.begin(), argv.end(), need) == argv.end()) continue;
      const std::string shared_prefix = "../shared/data/";
      bool needs_absent_data = false;
      for (std::string& a : argv) {
        if (starts_with(a, "build/tools/")) a = env_or_empty("VCLASSROOM_TOOLS_DIR") + "/" + a.substr(12);
        if (starts_with(a, shared_prefix)) {
          if (vctest::shared_data().empty()) needs_absent_data = true;
          a = vctest::shared_data() + "/" + a.substr(shared_prefix.size());
        }
      }
      if (needs_absent_data) return {"", "needs " + need + ", which " + t.where + " makes from ../shared/data, absent here"};
      const std::string result = run_program(argv);
      if (result.empty()) {
        std::printf("[ docs     ] made %s with %s\n", need.c_str(), t.where.c_str());
        return {};
      }
      failures += "\n  " + t.where + ": " + result;
    }
    return {"needs " + need + ", and no documented command made it" +
                (failures.empty() ? std::string(" (none writes it)") : failures),
            ""};
  }

  static std::string run_program(const std::vector<std::string>& argv) {
    std::vector<gchar*> cargv;
    for (const std::string& a : argv) cargv.push_back(const_cast<gchar*>(a.c_str()));
    cargv.push_back(nullptr);
    gchar *out = nullptr, *err_text = nullptr;
    gint status = 0;
    GError* err = nullptr;
    std::string result;
    if (!g_spawn_sync(nullptr, cargv.data(), nullptr, G_SPAWN_DEFAULT, nullptr, nullptr, &out, &err_text, &status,
                      &err) ||
        !g_spawn_check_wait_status(status, &err))
      result = std::string(err ? err->message : "failed") + ": " + (err_text ? err_text : "");
    g_clear_error(&err);
    g_free(out);
    g_free(err_text);
    return result;
  }

  vctest::TempDir scratch_;
  fs::path old_cwd_;
  std::vector<DocCommand> tools_;
  std::map<std::string, Outcome> outcomes_;
};

// Runs every command, failing the test for each that fails; returns how many
// ran, and counts in *skipped those skipped (each printed with its reason).
int run_all(DocRunner& runner, const std::vector<DocCommand>& commands, int* skipped) {
  int ran = 0;
  *skipped = 0;
  for (const DocCommand& c : commands) {
    // Said before it runs, so that a command that hangs is named in the log the test's timeout leaves (once in
    // eight runs of the whole suite, whepserversink's example hung in its stop: the lost quit that
    // WhepEndpoint.AServerStoppedRightAfterItStartedStops now holds).
    std::printf("[ docs     ] running %s\n", c.where.c_str());
    std::fflush(stdout);
    std::string skip;
    const std::string failure = runner.run(c, &skip);
    if (!skip.empty()) {
      std::printf("[ docs     ] skipped %s: %s\n", c.where.c_str(), skip.c_str());
      ++*skipped;
      continue;
    }
    ++ran;
    if (failure.empty())
      std::printf("[ docs     ] ran %s\n", c.where.c_str());
    else
      ADD_FAILURE() << c.where << ": " << failure << "\n  the command: " << c.text;
  }
  return ran;
}

std::vector<DocCommand> documented(const std::string& program) {
  std::vector<DocCommand> all;
  for (const auto& [name, text] : project_documents()) {
    const std::vector<DocCommand> found = extract_commands(name, text, program);
    all.insert(all.end(), found.begin(), found.end());
  }
  return all;
}

// The project's element factories (from its plugins, named vclassroom*), by name.
std::map<std::string, GstElementFactory*> project_elements() {
  std::map<std::string, GstElementFactory*> out;
  GList* plugins = gst_registry_get_plugin_list(gst_registry_get());
  for (GList* p = plugins; p; p = p->next) {
    const gchar* plugin = gst_plugin_get_name(GST_PLUGIN(p->data));
    if (!g_str_has_prefix(plugin, "vclassroom")) continue;
    GList* features = gst_registry_get_feature_list_by_plugin(gst_registry_get(), plugin);
    for (GList* f = features; f; f = f->next)
      if (GST_IS_ELEMENT_FACTORY(f->data))
        out[GST_OBJECT_NAME(f->data)] = GST_ELEMENT_FACTORY(f->data);
    gst_plugin_feature_list_free(features);
  }
  gst_plugin_list_free(plugins);
  return out;
}

// The example launch line of each element's documentation block, by element: in a source file under
// plugins/, the gtk-doc comment "SECTION:element-NAME" with its "## Example launch line" and the command
// between "|[" and "]|" (its lines joined, a trailing backslash dropped). The block's text is the context
// that says how to make what the command reads. An element whose block has no example gets an empty text.
std::map<std::string, DocCommand> element_doc_examples(const fs::path& plugins) {
  std::map<std::string, DocCommand> out;
  for (const auto& e : fs::recursive_directory_iterator(plugins)) {
    if (!e.is_regular_file() || e.path().extension() != ".cpp") continue;
    std::vector<std::string> lines;
    std::istringstream in(read_text(e.path()));
    for (std::string l; std::getline(in, l);) lines.push_back(l);
    // A doc comment line without its " * " lead.
    const auto body = [](const std::string& l) {
      std::string t = trim(l);
      if (starts_with(t, "*") && !starts_with(t, "*/")) t = trim(t.substr(1));
      return t;
    };
    for (size_t i = 0; i < lines.size(); ++i) {
      const std::string t = body(lines[i]);
      if (!starts_with(t, "SECTION:element-")) continue;
      const std::string name = trim(t.substr(16));
      const std::string file = fs::relative(e.path(), plugins.parent_path()).string();
      DocCommand c{file + ":" + std::to_string(i + 1) + " (" + name + ")", ""};
      bool in_example = false, in_code = false;
      for (size_t j = i + 1; j < lines.size() && trim(lines[j]).find("*/") == std::string::npos; ++j) {
        const std::string b = body(lines[j]);
        c.context += b + "\n";
        if (starts_with(b, "## Example launch line")) in_example = true;
        if (in_example && b == "|[") {
          in_code = true;
          c.where = file + ":" + std::to_string(j + 2) + " (" + name + ")";
        } else if (in_code && b == "]|") {
          in_code = in_example = false;
        } else if (in_code) {
          std::string part = b;
          if (!part.empty() && part.back() == '\\') part.pop_back();
          c.text += (c.text.empty() ? "" : " ") + trim(part);
        }
      }
      out[name] = c;
    }
  }
  return out;
}

}  // namespace

TEST(DocsExtraction, FindsFencedContinuedAndInlineCommandsOnly) {
  const std::string md =
      "Intro with `gst-launch-1.0` alone and `gst-launch-1.0 -m`.\n"
      "Inline: `gst-launch-1.0 videotestsrc ! fakesink` works.\n"
      "```sh\n"
      "# a comment\n"
      "gst-launch-1.0 videotestsrc ! videoconvert \\\n"
      "    ! autovideosink\n"
      "$ GST_DEBUG=3 gst-launch-1.0 -v audiotestsrc ! fakesink\n"
      "build/tools/vclassroom-build-model --out out/m\n"
      "```\n"
      "gst-launch-1.0 outside a block is prose\n";
  const std::vector<DocCommand> c = extract_commands("x.md", md, "gst-launch-1.0");
  ASSERT_EQ(c.size(), 4u);
  EXPECT_EQ(c[0].where, "x.md:1");
  EXPECT_EQ(c[0].text, "gst-launch-1.0 -m");  // found, then refused: no pipeline (tested below)
  EXPECT_EQ(c[1].where, "x.md:2");
  EXPECT_EQ(c[2].where, "x.md:5");
  EXPECT_EQ(c[2].text, "gst-launch-1.0 videotestsrc ! videoconvert  ! autovideosink");
  EXPECT_EQ(c[3].where, "x.md:7");
  EXPECT_EQ(c[3].text, "GST_DEBUG=3 gst-launch-1.0 -v audiotestsrc ! fakesink");
  const std::vector<DocCommand> tools = extract_commands("x.md", md, "build/tools/vclassroom-build-model");
  ASSERT_EQ(tools.size(), 1u);
  EXPECT_EQ(tools[0].where, "x.md:8");
}

TEST(DocsExtraction, DisplaySinksBecomeAFakesinkTakingAWindowsFormats) {
  std::string error;
  const std::vector<std::string> w = pipeline_words(split_argv(
      "GST_DEBUG=2 gst-launch-1.0 -e -v videotestsrc ! d.sink ximagesink sync=false name=win d.src ! "
      "\"video/x-raw,width=4\" ! autovideosink",
      &error));
  ASSERT_TRUE(error.empty()) << error;
  const std::vector<std::string> expected = {
      "videotestsrc", "!", "d.sink",         "capsfilter", "caps=video/x-raw,format=BGRx", "!",
      "fakesink",     "name=win", "d.src", "!",          "video/x-raw,width=4",         "!",
      "capsfilter",   "caps=video/x-raw,format=BGRx", "!", "fakesink"};
  EXPECT_EQ(w, expected);
  EXPECT_TRUE(pipeline_words(split_argv("gst-launch-1.0 -m", &error)).empty());
}

TEST(DocsExtraction, ALineThatCannotRunIsReportedWithItsError) {
  // The test below must be able to fail: a launch line that cannot negotiate is caught as such.
  DocRunner runner;
  std::string skip;
  EXPECT_NE(runner.run({"x.md:2", "gst-launch-1.0 videotestsrc ! nosuchelement ! fakesink"}, &skip), "");
  // A live line that receives nothing is stopped as Ctrl-C would, and passes when it ends cleanly.
  EXPECT_EQ(runner.run({"x.md:5", "gst-launch-1.0 -e udpsrc port=0 ! fakesink"}, &skip), "");
  // docs/vda.md's line before its fix: depthcolorize's RGB straight into a window.
  const std::string no_convert =
      runner.run({"x.md:3", "gst-launch-1.0 rgbdtestsrc ! rgbddemux name=d d.depth ! depthcolorize ! autovideosink"},
                 &skip);
  // gst-launch-1.0 reports not-negotiated when the window opens; the stand-in's caps refuse the link at once.
  EXPECT_TRUE(no_convert.find("not-negotiated") != std::string::npos ||
              no_convert.find("could not link depthcolorize") != std::string::npos)
      << no_convert;
  EXPECT_EQ(runner.run({"x.md:4", "gst-launch-1.0 rgbdtestsrc ! rgbddemux name=d d.depth ! depthcolorize ! "
                                  "videoconvert ! autovideosink"},
                       &skip),
            "");
}

// The documented commands that make what launch lines read under out/ (a
// model, an imported dataset).
std::vector<DocCommand> documented_tool_commands() {
  std::vector<DocCommand> tools = documented("build/tools/vclassroom-build-model");
  const std::vector<DocCommand> imports = documented("build/tools/vclassroom-import");
  tools.insert(tools.end(), imports.begin(), imports.end());
  return tools;
}

TEST(Docs, EveryLaunchLineOfReadmeAndDocsRuns) {
  ASSERT_FALSE(env_or_empty("VCLASSROOM_SOURCE_DIR").empty()) << "VCLASSROOM_SOURCE_DIR is not set";
  const std::vector<DocCommand> lines = documented("gst-launch-1.0");
  std::vector<DocCommand> commands;
  for (const DocCommand& c : lines) {
    std::string error;
    if (pipeline_words(split_argv(c.text, &error)).empty() && error.empty())
      std::printf("[ docs     ] %s mentions gst-launch-1.0 without a pipeline (not a command)\n", c.where.c_str());
    else
      commands.push_back(c);
  }
  DocRunner runner;
  runner.add_tools(documented_tool_commands());
  int skipped = 0;
  const int ran = run_all(runner, commands, &skipped);
  std::printf("[ docs     ] ran %d of %zu gst-launch-1.0 commands in README.md and docs/*.md (%d skipped)\n", ran,
              commands.size(), skipped);
  RecordProperty("doc_launch_lines_run", ran);
  RecordProperty("doc_launch_lines_found", static_cast<int>(commands.size()));
  EXPECT_GT(ran, 0) << "no gst-launch-1.0 command found in README.md and docs/*.md";
}

// Every element is documented the GStreamer way: a gtk-doc block at the top of its source whose example
// launch line uses it and runs. (The examples used to sit in the gst-inspect-1.0 description, which is now
// one sentence.)
TEST(Docs, EveryElementsDocBlockCarriesAnExampleThatRuns) {
  const std::map<std::string, GstElementFactory*> elements = project_elements();
  ASSERT_FALSE(elements.empty()) << "no vclassroom plugin on GST_PLUGIN_PATH";
  ASSERT_FALSE(env_or_empty("VCLASSROOM_SOURCE_DIR").empty()) << "VCLASSROOM_SOURCE_DIR is not set";
  const std::map<std::string, DocCommand> blocks =
      element_doc_examples(fs::path(env_or_empty("VCLASSROOM_SOURCE_DIR")) / "plugins");
  std::vector<DocCommand> examples;
  for (const auto& [name, factory] : elements) {
    const std::string description =
        gst_element_factory_get_metadata(factory, GST_ELEMENT_METADATA_DESCRIPTION);
    const auto b = blocks.find(name);
    if (b == blocks.end()) {
      ADD_FAILURE() << name << ": no documentation block (SECTION:element-" << name << ") in plugins/";
      continue;
    }
    const DocCommand& c = b->second;
    if (!starts_with(c.text, "gst-launch-1.0 ")) {
      ADD_FAILURE() << c.where << ": the documentation block has no example launch line";
      continue;
    }
    EXPECT_EQ(description.find("gst-launch-1.0"), std::string::npos)
        << name << ": the gst-inspect-1.0 description still holds an example (it belongs in the block)";
    std::string error;
    const std::vector<std::string> words = pipeline_words(split_argv(c.text, &error));
    // A header extension is used through a payloader's extmap caps field, not by name.
    const bool header_extension =
        g_str_has_prefix(gst_element_factory_get_metadata(factory, GST_ELEMENT_METADATA_KLASS), "Network/Extension");
    if (header_extension ? c.text.find("extmap-") == std::string::npos
                         : std::find(words.begin(), words.end(), name) == words.end())
      ADD_FAILURE() << c.where << ": the example does not use " << name << ": " << c.text;
    examples.push_back(c);
  }
  DocRunner runner;
  runner.add_tools(documented_tool_commands());
  int skipped = 0;
  const int ran = run_all(runner, examples, &skipped);
  std::printf("[ docs     ] ran %d example launch lines of %zu elements (%d skipped)\n", ran, elements.size(),
              skipped);
  RecordProperty("element_examples_run", ran);
  EXPECT_EQ(ran + skipped, static_cast<int>(elements.size()));
  EXPECT_GT(ran, 0);
}

namespace {

// Every program the build made in tools/ (vclassroom-*).
std::vector<std::string> built_tools() {
  std::vector<std::string> tools;
  const std::string dir = env_or_empty("VCLASSROOM_TOOLS_DIR");
  if (dir.empty()) return tools;
  for (const auto& e : fs::directory_iterator(dir)) {
    const std::string name = e.path().filename().string();
    if (e.is_regular_file() && starts_with(name, "vclassroom-") && access(e.path().c_str(), X_OK) == 0)
      tools.push_back(e.path().string());
  }
  std::sort(tools.begin(), tools.end());
  return tools;
}

}  // namespace

TEST(Tools, HelpGoesToStdoutWithStatus0AndABadOptionToStderrWithStatus2) {
  const std::vector<std::string> tools = built_tools();
  ASSERT_GE(tools.size(), 9u) << "the tools are missing from VCLASSROOM_TOOLS_DIR";
  for (const std::string& t : tools) {
    const Exit help = run_tool({t, "--help"});
    EXPECT_EQ(help.status, 0) << t << " --help";
    EXPECT_NE(help.out.find("Usage:"), std::string::npos) << t << " --help printed: " << help.out;
    EXPECT_EQ(help.err, "") << t << " --help";
    const Exit bad = run_tool({t, "--no-such-option"});
    EXPECT_EQ(bad.status, 2) << t << " --no-such-option";
    EXPECT_EQ(bad.out, "") << t;
    EXPECT_NE(bad.err.find("--no-such-option"), std::string::npos) << t << " said: " << bad.err;
  }
}

TEST(Tools, BuildModelMakesItsOutputFolderWithTheParents) {
  vctest::TempDir dir;
  const std::string out = dir / "not/there/yet/model";
  const Exit e = run_tool({env_or_empty("VCLASSROOM_TOOLS_DIR") + "/vclassroom-build-model", "--synthetic",
                           "--frames", "1", "--size", "160x90", "--out", out});
  ASSERT_EQ(e.status, 0) << e.err;
  EXPECT_TRUE(fs::exists(out + "/rig.yaml"));
  EXPECT_TRUE(fs::exists(out + "/planes.csv"));
}

TEST(Tools, CalibrateFindsTheSyntheticRigAndEndsWithItsError) {
  vctest::TempDir dir;
  const std::string tool = env_or_empty("VCLASSROOM_TOOLS_DIR") + "/vclassroom-calibrate";
  const Exit e = run_tool({tool, "--synthetic", "--views", "8", "--out", dir / "cal"});
  ASSERT_EQ(e.status, 0) << e.err;
  // Progress per view, per camera and per pair, then the rig against the true one.
  EXPECT_NE(e.out.find("view 8: per camera"), std::string::npos) << e.out;
  EXPECT_NE(e.out.find("pairs 0-1: "), std::string::npos) << e.out;
  vctest::expect_rig_error_within_targets(e.out);
  EXPECT_EQ(vclassroom::load_rig(dir / "cal/rig.yaml").cameras.size(), 3u);
  // Too few views: refused, saying what to do, and no rig written.
  const Exit few = run_tool({tool, "--synthetic", "--views", "3", "--out", dir / "few"});
  EXPECT_EQ(few.status, 1);
  EXPECT_NE(few.err.find("more places"), std::string::npos) << few.err;
  EXPECT_FALSE(fs::exists(dir / "few/rig.yaml"));
  EXPECT_EQ(run_tool({tool, "--synthetic", "--source", "rgbdtestsrc", "--out", dir / "x"}).status, 2);
  EXPECT_EQ(run_tool({tool, "--synthetic", "--board", "8x6", "--out", dir / "x"}).status, 2);
}

TEST(Tools, EvalViewsTakesAnyDatasetAndEndsWithThePsnrLine) {
  vctest::TempDir dir;
  const std::string rig = dir / "rig.yaml";
  vclassroom::save_rig(vctest::make_rig(3, 64, 48), rig);
  const std::string data = dir / "data";
  std::string record;
  for (int cam = 0; cam < 3; ++cam)
    record += "rgbdtestsrc rig=" + rig + " camera-id=" + std::to_string(cam) + " num-buffers=3 ! rgbdfilesink location=" +
              data + "  ";
  ASSERT_EQ(vctest::run_launch(record).error, "");
  const std::string tool = env_or_empty("VCLASSROOM_TOOLS_DIR") + "/vclassroom-eval-views";
  const std::string out = dir / "eval/images";
  const Exit e = run_tool({tool, "--dataset", data, "--target", "0", "--sources", "1,2", "--crop-right", "8", "--out", out});
  ASSERT_EQ(e.status, 0) << e.err;
  static const std::regex last_line(R"(PSNR [0-9]+\.[0-9]{2} dB SSIM [0-9]+\.[0-9]{2}\n$)");
  EXPECT_TRUE(std::regex_search(e.out, last_line)) << e.out;
  for (const char* f : {"cam0-from-1,2-frame0.png", "cam0-from-1,2-frame2.png", "cam0-from-1,2-psnr.png"})
    EXPECT_TRUE(fs::exists(out + "/" + f)) << f;
  // With the dataset's own rig given as --rig, the same figure.
  const Exit same = run_tool({tool, "--dataset", data, "--target", "0", "--sources", "1,2", "--crop-right", "8", "--rig",
                              data + "/rig.yaml"});
  ASSERT_EQ(same.status, 0) << same.err;
  EXPECT_EQ(e.out.substr(e.out.rfind("PSNR")), same.out.substr(same.out.rfind("PSNR")));
  // What makes no sense is refused with status 2, what is not there with status 1 naming it.
  EXPECT_EQ(run_tool({tool, "--dataset", data, "--target", "0", "--sources", "0,1"}).status, 2);
  EXPECT_EQ(run_tool({tool, "--dataset", data, "--target", "0"}).status, 2);
  const Exit missing = run_tool({tool, "--dataset", data, "--target", "0", "--sources", "7"});
  EXPECT_EQ(missing.status, 1);
  EXPECT_NE(missing.err.find("7"), std::string::npos) << missing.err;
}

TEST(Tools, EvalDepthTakesAnyDatasetWithGroundTruthDepth) {
  vctest::TempDir dir;
  const std::string rig = dir / "rig.yaml";
  vclassroom::save_rig(vctest::make_rig(2, 64, 48), rig);
  const std::string with_truth = dir / "truth", without = dir / "plain";
  ASSERT_EQ(vctest::run_launch("rgbdtestsrc rig=" + rig + " ground-truth=true num-buffers=2 ! rgbdfilesink location=" +
                               with_truth + "  rgbdtestsrc rig=" + rig + " ground-truth=false num-buffers=2 ! rgbdfilesink location=" +
                               without)
                .error,
            "");
  const std::string tool = env_or_empty("VCLASSROOM_TOOLS_DIR") + "/vclassroom-eval-depth";
  const Exit e = run_tool({tool, "--dataset", with_truth});
  ASSERT_EQ(e.status, 0) << e.err;
  static const std::regex last_line(R"(RMSE [0-9]+\.[0-9] mm \(edge band [0-9]+\.[0-9] mm\)\n$)");
  EXPECT_TRUE(std::regex_search(e.out, last_line)) << e.out;
  EXPECT_NE(e.out.find("2 frames of camera(s) 0"), std::string::npos) << e.out;
  const Exit plain = run_tool({tool, "--dataset", without});
  EXPECT_EQ(plain.status, 1);
  EXPECT_NE(plain.err.find("has no ground-truth depth"), std::string::npos) << plain.err;
  EXPECT_EQ(run_tool({tool, "--camera", "0"}).status, 2);  // --camera without --dataset
}

namespace {

// `meson introspect <build> <what>`'s output ("" when meson is not on PATH).
std::string introspect(const std::string& build, const std::string& what) {
  gchar* meson = g_find_program_in_path("meson");
  if (!meson) return "";
  const std::string out = run_tool({meson, "introspect", build, what}).out;
  g_free(meson);
  return out;
}

// The build folder the tests run from (the tools' folder's parent).
std::string build_dir() {
  const std::string tools = env_or_empty("VCLASSROOM_TOOLS_DIR");
  return tools.empty() ? "" : fs::path(tools).parent_path().string();
}

// The value of `key=` on a line of a unit or configuration file ("" when absent).
std::string setting(const std::string& text, const std::string& key) {
  std::istringstream lines(text);
  for (std::string line; std::getline(lines, line);)
    if (starts_with(line, key + "=")) return line.substr(key.size() + 1);
  return "";
}

}  // namespace

// The service runs the installed server.sh with the installed configuration file, and systemd finds
// nothing wrong with the unit but that server.sh is not installed yet.
TEST(Deploy, TheServiceUnitRunsTheInstalledServerWithTheConfigurationFile) {
  const std::string build = build_dir();
  if (build.empty()) GTEST_SKIP() << "VCLASSROOM_TOOLS_DIR not set (run through meson test)";
  const std::string unit = read_text(fs::path(build) / "vclassroom-server.service");
  ASSERT_FALSE(unit.empty());
  const std::string exec = setting(unit, "ExecStart"), config = setting(unit, "EnvironmentFile");
  EXPECT_TRUE(exec.size() > 10 && exec.substr(exec.size() - 10) == "/server.sh") << exec;
  EXPECT_TRUE(config.size() > 12 && config.substr(config.size() - 12) == "/server.conf") << config;
  const std::string installed = introspect(build, "--installed");
  EXPECT_NE(installed.find("\"" + exec + "\""), std::string::npos) << "ExecStart is not what meson installs";
  EXPECT_NE(installed.find("\"" + config + "\""), std::string::npos) << "EnvironmentFile is not what meson installs";
  if (access("/usr/bin/systemd-analyze", X_OK) != 0) GTEST_SKIP() << "no systemd-analyze to check the unit";
  const Exit verify = run_tool({"systemd-analyze", "verify", fs::path(build) / "vclassroom-server.service"});
  std::istringstream complaints(verify.out + verify.err);
  for (std::string line; std::getline(complaints, line);)
    if (!line.empty() && line.find(exec + " is not executable") == std::string::npos)
      ADD_FAILURE() << "systemd-analyze verify: " << line;
}

// Every setting of the configuration file is one server.sh (or a part it sources) reads.
TEST(Deploy, TheConfigurationFileSetsWhatServerShReads) {
  const std::string source = env_or_empty("VCLASSROOM_SOURCE_DIR");
  if (source.empty()) GTEST_SKIP() << "VCLASSROOM_SOURCE_DIR not set (run through meson test)";
  const std::string conf = read_text(fs::path(source) / "deploy/server.conf");
  const std::string server = read_text(fs::path(source) / "pipelines/server.sh") +
                             read_text(fs::path(source) / "pipelines/srtp.sh");
  ASSERT_FALSE(conf.empty());
  std::istringstream lines(conf);
  int settings = 0;
  static const std::regex assignment(R"(^#?([A-Z_]+)=(.*)$)");
  for (std::string line; std::getline(lines, line);) {
    std::smatch m;
    if (!std::regex_match(line, m, assignment)) continue;
    ++settings;
    const std::regex read_there("\\$\\{" + m[1].str() + "[:}-]");
    EXPECT_TRUE(std::regex_search(server, read_there)) << m[1] << " is not a setting of server.sh";
    EXPECT_EQ(m[2].str().find('"'), std::string::npos) << line << ": systemd keeps quotes as part of the value";
  }
  EXPECT_GE(settings, 8);
}

// `meson install` puts the user tools, the service and its configuration in place, and the bench, measure
// and fault-injection tools only when asked (-Dinstall_dev_tools=true).
TEST(Deploy, OnlyTheUserToolsAreInstalledByDefault) {
  const std::string build = build_dir();
  if (build.empty()) GTEST_SKIP() << "VCLASSROOM_TOOLS_DIR not set (run through meson test)";
  const std::string installed = introspect(build, "--installed");
  const std::string options = introspect(build, "--buildoptions");
  ASSERT_FALSE(installed.empty());
  for (const char* tool : {"vclassroom-import", "vclassroom-build-model", "vclassroom-calibrate", "vclassroom-eval-views"})
    EXPECT_NE(installed.find(std::string("/bin/") + tool + "\""), std::string::npos) << tool;
  EXPECT_NE(installed.find("/systemd/system/vclassroom-server.service\""), std::string::npos);
  EXPECT_NE(installed.find("/gst-vclassroom/server.conf\""), std::string::npos);
  if (options.find("\"name\": \"install_dev_tools\", \"value\": true") != std::string::npos)
    GTEST_SKIP() << "this build installs the developer tools (-Dinstall_dev_tools=true)";
  for (const char* tool : {"vclassroom-bench-server", "vclassroom-measure-flow", "vclassroom-fault-inject"})
    EXPECT_EQ(installed.find(std::string("/bin/") + tool + "\""), std::string::npos) << tool << " is installed";
}
