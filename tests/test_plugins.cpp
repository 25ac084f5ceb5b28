// What gst-inspect-1.0 shows a user: every element of every vclassroom plugin
// is registered, has metadata and pad templates, and documents each property.
#include <gtest/gtest.h>

#include <cstring>
#include <set>
#include <thread>

#ifdef __linux__
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>
#endif

#include <gst/check/gstharness.h>
#include <gst/video/video.h>
#include <gst/vclassroom/core/visualize.h>

#include "test_util.h"

namespace {

std::vector<GstElementFactory*> our_factories() {
  std::vector<GstElementFactory*> out;
  GList* plugins = gst_registry_get_plugin_list(gst_registry_get());
  for (GList* p = plugins; p; p = p->next) {
    GstPlugin* plugin = GST_PLUGIN(p->data);
    if (!g_str_has_prefix(gst_plugin_get_name(plugin), "vclassroom")) continue;
    GList* features = gst_registry_get_feature_list_by_plugin(gst_registry_get(), gst_plugin_get_name(plugin));
    for (GList* f = features; f; f = f->next)
      if (GST_IS_ELEMENT_FACTORY(f->data)) out.push_back(GST_ELEMENT_FACTORY(gst_object_ref(f->data)));
    gst_plugin_feature_list_free(features);
  }
  gst_plugin_list_free(plugins);
  return out;
}

}  // namespace

TEST(Plugins, EveryElementIsDocumented) {
  const auto factories = our_factories();
  std::set<std::string> names;
  for (GstElementFactory* f : factories) names.insert(GST_OBJECT_NAME(f));
  for (const char* expected : {"rgbdmux", "rgbddemux", "rgbdfilesrc", "rgbdfilesink", "rgbdtestsrc", "depthcolorize",
                               "rgbdenc", "rgbddec", "posesend", "poserecv", "rtphdrextvcpose", "posenav",
                               "threadpriority"})
    EXPECT_TRUE(names.count(expected)) << expected << " is not registered";

  for (GstElementFactory* f : factories) {
    const std::string name = GST_OBJECT_NAME(f);
    const char* desc = gst_element_factory_get_metadata(f, GST_ELEMENT_METADATA_DESCRIPTION);
    EXPECT_TRUE(desc && strlen(desc) > 30) << name << ": description too short";
    // RTP header extensions are helpers that payloaders load, not pipeline elements: no pads.
    const char* klass = gst_element_factory_get_metadata(f, GST_ELEMENT_METADATA_KLASS);
    if (!g_strrstr(klass, "Network/Extension/RTPHeader")) {
      EXPECT_GT(gst_element_factory_get_num_pad_templates(f), 0u) << name << ": no pad templates";
    }
    GstElement* e = gst_element_factory_create(f, nullptr);
    ASSERT_NE(e, nullptr) << name;
    guint n = 0;
    GParamSpec** props = g_object_class_list_properties(G_OBJECT_GET_CLASS(e), &n);
    for (guint i = 0; i < n; ++i) {
      // Only what this project adds; base classes document their own.
      if (props[i]->owner_type != G_OBJECT_TYPE(e)) continue;
      const char* blurb = g_param_spec_get_blurb(props[i]);
      EXPECT_TRUE(blurb && strlen(blurb) > 15) << name << "::" << props[i]->name << " has no real description";
    }
    g_free(props);
    gst_object_unref(e);
    gst_object_unref(f);
  }
}

// threadpriority through a harness, in a thread of its own (the harness
// pushes from the calling thread, whose nice value it changes): buffers pass
// untouched; the pushing thread, only that one, runs at the nice value; a new
// value applies from the next buffer, and a lower one never raises the thread.
TEST(ThreadPriority, LowersThePushingThreadOnly) {
#ifdef __linux__
  auto own_nice = [] { return getpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid))); };
  const int before = own_nice();
  if (before > 7) {
    GTEST_SKIP() << "the tests already run at nice " << before;
  }
  bool allowed = true, same_buffer = false;
  int seen_first = -100, seen_second = -100, seen_third = -100;
  std::thread pusher([&] {
    // Some sandboxes refuse priority changes altogether: nothing to test there.
    if (setpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid)), own_nice()) != 0) {
      allowed = false;
      return;
    }
    GstHarness* h = gst_harness_new("threadpriority");
    g_object_set(h->element, "nice", 7, nullptr);
    gst_harness_set_src_caps_str(h, "video/x-raw,format=GRAY8,width=2,height=2,framerate=30/1");
    GstBuffer* in = gst_harness_create_buffer(h, 4);
    GstBuffer* out = gst_harness_push_and_pull(h, gst_buffer_ref(in));
    same_buffer = out == in;
    seen_first = own_nice();
    if (out) gst_buffer_unref(out);
    gst_buffer_unref(in);
    g_object_set(h->element, "nice", 12, nullptr);
    out = gst_harness_push_and_pull(h, gst_harness_create_buffer(h, 4));
    seen_second = own_nice();
    if (out) gst_buffer_unref(out);
    g_object_set(h->element, "nice", 3, nullptr);
    out = gst_harness_push_and_pull(h, gst_harness_create_buffer(h, 4));
    seen_third = own_nice();
    if (out) gst_buffer_unref(out);
    gst_harness_teardown(h);
  });
  pusher.join();
  if (!allowed) {
    GTEST_SKIP() << "this system refuses thread priority changes";
  }
  EXPECT_TRUE(same_buffer) << "the buffer did not pass through untouched";
  EXPECT_EQ(seen_first, 7);
  EXPECT_EQ(seen_second, 12);
  EXPECT_EQ(seen_third, 12) << "a lower value must not raise the thread's priority";
  EXPECT_EQ(own_nice(), before) << "another thread changed";
#else
  GTEST_SKIP() << "thread priorities are set on Linux only";
#endif
}

// depthcolorize through a harness: GRAY16_LE in, RGB out, 0 stays black, near
// and far get different colours, timestamps pass through.
TEST(DepthColorize, DrawsDepthThroughAHarness) {
  GstHarness* h = gst_harness_new("depthcolorize");
  gst_harness_set_src_caps_str(h, "video/x-raw,format=GRAY16_LE,width=4,height=2,framerate=30/1");
  GstVideoInfo vi;
  gst_video_info_set_format(&vi, GST_VIDEO_FORMAT_GRAY16_LE, 4, 2);
  GstBuffer* in = gst_harness_create_buffer(h, GST_VIDEO_INFO_SIZE(&vi));
  const uint16_t values[8] = {0, 500, 3000, 6000, 0, 65535, 1, 6000};
  GstMapInfo map;
  gst_buffer_map(in, &map, GST_MAP_WRITE);
  for (int y = 0; y < 2; ++y) memcpy(map.data + y * GST_VIDEO_INFO_PLANE_STRIDE(&vi, 0), values + 4 * y, 8);
  gst_buffer_unmap(in, &map);
  GST_BUFFER_PTS(in) = 42 * GST_MSECOND;
  GstBuffer* out = gst_harness_push_and_pull(h, in);
  ASSERT_NE(out, nullptr);
  EXPECT_EQ(GST_BUFFER_PTS(out), 42 * GST_MSECOND);
  GstCaps* caps = gst_pad_get_current_caps(h->sinkpad);
  EXPECT_STREQ(gst_structure_get_string(gst_caps_get_structure(caps, 0), "format"), "RGB");
  gst_caps_unref(caps);
  GstVideoInfo vo;
  gst_video_info_set_format(&vo, GST_VIDEO_FORMAT_RGB, 4, 2);
  gst_buffer_map(out, &map, GST_MAP_READ);
  auto px = [&](int x, int y) {
    const uint8_t* p = map.data + y * GST_VIDEO_INFO_PLANE_STRIDE(&vo, 0) + 3 * x;
    return cv::Vec3b(p[0], p[1], p[2]);
  };
  EXPECT_EQ(px(0, 0), cv::Vec3b(0, 0, 0));  // no measurement
  EXPECT_EQ(px(0, 1), cv::Vec3b(0, 0, 0));
  EXPECT_NE(px(1, 0), px(3, 0));                // near (500 mm) vs far (6000 mm)
  EXPECT_GT(px(1, 0)[0], px(1, 0)[2]);          // near is warm (red over blue)
  EXPECT_GT(px(3, 0)[2], px(3, 0)[0]);          // far is cool
  EXPECT_EQ(px(1, 0), px(2, 1));                // 1 mm clamps to the near end
  EXPECT_EQ(px(3, 0), px(1, 1));                // 65535 mm clamps to the far end
  gst_buffer_unmap(out, &map);
  gst_buffer_unref(out);
  gst_harness_teardown(h);
}

TEST(DepthColorize, LibraryMatchesTheElementRange) {
  cv::Mat d(1, 3, CV_16UC1);
  d.at<uint16_t>(0) = 0;
  d.at<uint16_t>(1) = 1000;
  d.at<uint16_t>(2) = 2000;
  cv::Mat a, b;
  vclassroom::colorize_depth(d, a, 1000, 2000);
  vclassroom::colorize_depth(d, b, 0, 4000);  // another range must not reuse the first table
  EXPECT_NE(a.at<cv::Vec3b>(1), b.at<cv::Vec3b>(1));
  EXPECT_EQ(a.at<cv::Vec3b>(0), cv::Vec3b(0, 0, 0));
}
