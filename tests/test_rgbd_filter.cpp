// GstRgbdFilter, the base of the RGB-D filters, through GstHarness with subclasses made here: caps refused at
// negotiation with a clear message, unusable frames dropped with a rate-limited warning, the library's errors
// turned into bus errors naming the element, the new plane written while the others pass, a refused stream.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include <gst/check/gstharness.h>
#include <opencv2/core.hpp>

#include <gst/vclassroom/core/error.h>
#include <gst/vclassroom/core/rgbd.h>
#include <gst/vclassroom/core/rgbd_filter.h>

using namespace vclassroom;

namespace {

// What the test filters do with a frame, set per test (the harness runs one element at a time).
enum class Behaviour { Write, ThrowError, ThrowOpenCv };
Behaviour g_behaviour = Behaviour::Write;
int g_refused_camera = -1;  // a camera whose stream the filters refuse

struct TestFilterSettings {
  guint value = 7;
};

// "rgbdtestdepth": needs colour and depth, writes the depth plane as the colour's red + `value`.
struct GstTestDepth {
  GstRgbdFilter parent;
  TestFilterSettings* settings;
};
struct GstTestDepthClass {
  GstRgbdFilterClass parent_class;
};
G_DEFINE_TYPE(GstTestDepth, gst_test_depth, GST_TYPE_RGBD_FILTER)

GstStaticPadTemplate sink_template =
    GST_STATIC_PAD_TEMPLATE("sink", GST_PAD_SINK, GST_PAD_ALWAYS, GST_STATIC_CAPS(kRgbdTemplateCaps));
GstStaticPadTemplate src_template =
    GST_STATIC_PAD_TEMPLATE("src", GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS(kRgbdTemplateCaps));

gboolean test_set_info(GstRgbdFilter* self, const RgbdInfo& in, const RgbdInfo&) {
  if (in.camera.id == g_refused_camera) rgbd_filter_refuse_stream(self, "the settings have no such camera");
  return TRUE;
}

void act(guint value, const cv::Mat& color, cv::Mat& plane) {
  if (g_behaviour == Behaviour::ThrowError) throw Error("the frame says no");
  if (g_behaviour == Behaviour::ThrowOpenCv) cv::Mat(2, 2, CV_8UC1).copyTo(plane(cv::Rect(0, 0, 100, 100)));
  for (int y = 0; y < plane.rows; ++y)
    for (int x = 0; x < plane.cols; ++x) {
      const int red = color.at<cv::Vec3b>(y, x)[0];
      if (plane.type() == CV_16UC1)
        plane.at<uint16_t>(y, x) = static_cast<uint16_t>(red + value);
      else
        plane.at<uint8_t>(y, x) = static_cast<uint8_t>(value);
    }
}

void test_depth_transform_plane(GstRgbdFilter* self, const RgbdFrame& in, cv::Mat& plane) {
  const TestFilterSettings s = rgbd_filter_settings(self, *reinterpret_cast<GstTestDepth*>(self)->settings);
  act(s.value, in.color(), plane);
}

void test_depth_set_property(GObject* object, guint, const GValue* value, GParamSpec*) {
  const auto lock = rgbd_filter_lock(GST_RGBD_FILTER(object));
  reinterpret_cast<GstTestDepth*>(object)->settings->value = g_value_get_uint(value);
}
void test_depth_get_property(GObject* object, guint, GValue* value, GParamSpec*) {
  const auto lock = rgbd_filter_lock(GST_RGBD_FILTER(object));
  g_value_set_uint(value, reinterpret_cast<GstTestDepth*>(object)->settings->value);
}
void test_depth_finalize(GObject* object) {
  delete reinterpret_cast<GstTestDepth*>(object)->settings;
  G_OBJECT_CLASS(gst_test_depth_parent_class)->finalize(object);
}

void gst_test_depth_class_init(GstTestDepthClass* klass) {
  GObjectClass* gobject_class = G_OBJECT_CLASS(klass);
  gobject_class->set_property = test_depth_set_property;
  gobject_class->get_property = test_depth_get_property;
  gobject_class->finalize = test_depth_finalize;
  g_object_class_install_property(gobject_class, 1,
                                  g_param_spec_uint("value", "Value", "Added to the red channel", 0, 1000, 7,
                                                    GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS)));
  GstElementClass* element_class = GST_ELEMENT_CLASS(klass);
  gst_element_class_add_static_pad_template(element_class, &sink_template);
  gst_element_class_add_static_pad_template(element_class, &src_template);
  gst_element_class_set_static_metadata(element_class, "Test depth", "Filter/Video", "A test of GstRgbdFilter.",
                                        "tests");
  GstRgbdFilterClass* filter_class = GST_RGBD_FILTER_CLASS(klass);
  filter_class->required_planes = rgbd_plane_bit(Plane::Color) | rgbd_plane_bit(Plane::Depth);
  filter_class->new_plane = Plane::Depth;
  filter_class->set_info = test_set_info;
  filter_class->transform_plane = test_depth_transform_plane;
}
void gst_test_depth_init(GstTestDepth* self) { self->settings = new TestFilterSettings(); }

// "rgbdtestlabel": adds a label plane of 5s to any stream.
struct GstTestLabel {
  GstRgbdFilter parent;
};
struct GstTestLabelClass {
  GstRgbdFilterClass parent_class;
};
G_DEFINE_TYPE(GstTestLabel, gst_test_label, GST_TYPE_RGBD_FILTER)
void test_label_transform_plane(GstRgbdFilter*, const RgbdFrame& in, cv::Mat& plane) { act(5, in.color(), plane); }
void gst_test_label_class_init(GstTestLabelClass* klass) {
  GstElementClass* element_class = GST_ELEMENT_CLASS(klass);
  gst_element_class_add_static_pad_template(element_class, &sink_template);
  gst_element_class_add_static_pad_template(element_class, &src_template);
  gst_element_class_set_static_metadata(element_class, "Test label", "Filter/Video", "A test of GstRgbdFilter.",
                                        "tests");
  GST_RGBD_FILTER_CLASS(klass)->new_plane = Plane::Label;
  GST_RGBD_FILTER_CLASS(klass)->transform_plane = test_label_transform_plane;
}
void gst_test_label_init(GstTestLabel*) {}

// "rgbdtestip": in place, needs the label plane, counts the frames it reads.
int g_ip_frames = 0;
struct GstTestIp {
  GstRgbdFilter parent;
};
struct GstTestIpClass {
  GstRgbdFilterClass parent_class;
};
G_DEFINE_TYPE(GstTestIp, gst_test_ip, GST_TYPE_RGBD_FILTER)
void test_ip_transform(GstRgbdFilter*, GstBuffer*, const RgbdFrame& frame) {
  if (g_behaviour == Behaviour::ThrowError) throw Error("the frame says no");
  if (!frame.depth().empty()) ++g_ip_frames;
}
void gst_test_ip_class_init(GstTestIpClass* klass) {
  GstElementClass* element_class = GST_ELEMENT_CLASS(klass);
  gst_element_class_add_static_pad_template(element_class, &sink_template);
  gst_element_class_add_static_pad_template(element_class, &src_template);
  gst_element_class_set_static_metadata(element_class, "Test in place", "Filter/Video", "A test of GstRgbdFilter.",
                                        "tests");
  GST_RGBD_FILTER_CLASS(klass)->required_planes = rgbd_plane_bit(Plane::Label);
  GST_RGBD_FILTER_CLASS(klass)->set_info = test_set_info;
  GST_RGBD_FILTER_CLASS(klass)->transform_frame_ip = test_ip_transform;
}
void gst_test_ip_init(GstTestIp*) {}

RgbdInfo small_info(std::vector<Plane> planes = {Plane::Color, Plane::Depth}, int camera = 3) {
  RgbdInfo info;
  info.camera.id = camera;
  info.camera.width = 8;
  info.camera.height = 6;
  info.camera.fx = info.camera.fy = 8;
  info.camera.cx = 4;
  info.camera.cy = 3;
  info.planes = std::move(planes);
  return info;
}

// The stream each test filter takes.
RgbdInfo info_for(const std::string& name, int camera = 3) {
  return small_info(name == "rgbdtestip" ? std::vector<Plane>{Plane::Color, Plane::Depth, Plane::Label}
                                         : std::vector<Plane>{Plane::Color, Plane::Depth},
                    camera);
}

GstBuffer* frame(const RgbdInfo& info) {
  std::string err;
  cv::Mat color(info.height(), info.width(), CV_8UC3, cv::Scalar(40, 50, 60));
  cv::Mat depth(info.height(), info.width(), CV_16UC1, cv::Scalar(1000));
  GstBuffer* buf = rgbd_buffer_with_planes(info, {{Plane::Color, color}, {Plane::Depth, depth}}, &err);
  EXPECT_NE(buf, nullptr) << err;
  GST_BUFFER_PTS(buf) = 0;
  return buf;
}

// A harness around one test filter, with a bus to read what it posts.
class Filter {
 public:
  Filter(const char* name, const RgbdInfo& info) : Filter(name) { gst_harness_set_src_caps(h_, rgbd_caps_new(info)); }
  explicit Filter(const char* name) : h_(gst_harness_new(name)), bus_(gst_bus_new()) {
    gst_element_set_bus(h_->element, bus_);
    g_behaviour = Behaviour::Write;
    g_refused_camera = -1;
  }
  ~Filter() {
    gst_harness_teardown(h_);
    gst_bus_set_flushing(bus_, TRUE);
    gst_object_unref(bus_);
  }
  GstHarness* h() { return h_; }
  GstElement* element() { return h_->element; }
  // The texts of the messages of `type` posted so far.
  std::vector<std::string> messages(GstMessageType type) {
    std::vector<std::string> out;
    while (GstMessage* m = gst_bus_pop_filtered(bus_, type)) {
      GError* e = nullptr;
      gchar* debug = nullptr;
      if (type == GST_MESSAGE_ERROR)
        gst_message_parse_error(m, &e, &debug);
      else
        gst_message_parse_warning(m, &e, &debug);
      out.push_back(e->message);
      g_error_free(e);
      g_free(debug);
      gst_message_unref(m);
    }
    return out;
  }

 private:
  GstHarness* h_;
  GstBus* bus_;
};

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

class RgbdFilterBase : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    gst_element_register(nullptr, "rgbdtestdepth", GST_RANK_NONE, gst_test_depth_get_type());
    gst_element_register(nullptr, "rgbdtestlabel", GST_RANK_NONE, gst_test_label_get_type());
    gst_element_register(nullptr, "rgbdtestip", GST_RANK_NONE, gst_test_ip_get_type());
  }
};

}  // namespace

TEST_F(RgbdFilterBase, WritesTheNewPlaneAndPassesTheOthers) {
  Filter f("rgbdtestdepth", small_info({Plane::Color, Plane::Depth, Plane::Label}));
  g_object_set(f.element(), "value", 100u, nullptr);
  GstBuffer* in = frame(small_info({Plane::Color, Plane::Depth, Plane::Label}));
  GST_BUFFER_PTS(in) = 5 * GST_SECOND;
  GstBuffer* out = gst_harness_push_and_pull(f.h(), in);
  ASSERT_NE(out, nullptr);
  EXPECT_EQ(GST_BUFFER_PTS(out), 5 * GST_SECOND);
  RgbdFrame mapped;
  std::string err;
  ASSERT_TRUE(mapped.map(out, small_info({Plane::Color, Plane::Depth, Plane::Label}), GST_MAP_READ, &err)) << err;
  EXPECT_EQ(mapped.depth().at<uint16_t>(2, 3), 140);  // the red channel + value, read under the lock per frame
  EXPECT_EQ(mapped.color().at<cv::Vec3b>(2, 3), cv::Vec3b(40, 50, 60));
  mapped.unmap();
  gst_buffer_unref(out);
  EXPECT_TRUE(f.messages(GST_MESSAGE_ERROR).empty());
}

TEST_F(RgbdFilterBase, AddsItsPlaneToTheCapsWhenTheStreamLacksIt) {
  Filter f("rgbdtestlabel", small_info());
  GstBuffer* out = gst_harness_push_and_pull(f.h(), frame(small_info()));
  ASSERT_NE(out, nullptr);
  GstCaps* caps = gst_pad_get_current_caps(f.h()->sinkpad);
  RgbdInfo got;
  std::string err;
  ASSERT_TRUE(rgbd_info_from_caps(caps, &got, &err)) << err;
  gst_caps_unref(caps);
  EXPECT_EQ(got.planes_string(), "color,depth,label");
  RgbdFrame mapped;
  ASSERT_TRUE(mapped.map(out, got, GST_MAP_READ, &err)) << err;
  EXPECT_EQ(mapped.label().at<uint8_t>(5, 7), 5);
  EXPECT_EQ(mapped.depth().at<uint16_t>(5, 7), 1000);
  mapped.unmap();
  gst_buffer_unref(out);
}

TEST_F(RgbdFilterBase, CapsThatAreNotRgbdAreRefusedAtNegotiation) {
  Filter f("rgbdtestdepth");
  gst_harness_set_src_caps_str(f.h(), "video/x-raw, format=RGB, width=8, height=6, framerate=30/1");
  EXPECT_EQ(gst_harness_push(f.h(), gst_harness_create_buffer(f.h(), 8 * 6 * 3)), GST_FLOW_NOT_NEGOTIATED);
  EXPECT_EQ(gst_harness_buffers_received(f.h()), 0u);
}

TEST_F(RgbdFilterBase, CapsWithoutANeededPlaneAreRefusedNamingIt) {
  Filter f("rgbdtestip", small_info());
  EXPECT_EQ(gst_harness_push(f.h(), frame(small_info())), GST_FLOW_NOT_NEGOTIATED);
  // Each try to configure the caps says it (the caps event, then the buffer's); a pipeline stops at the first.
  const std::vector<std::string> errors = f.messages(GST_MESSAGE_ERROR);
  ASSERT_FALSE(errors.empty());
  EXPECT_TRUE(contains(errors[0], GST_OBJECT_NAME(f.element()))) << errors[0];
  EXPECT_TRUE(contains(errors[0], "needs the label plane; the stream has 'color,depth'")) << errors[0];
}

TEST_F(RgbdFilterBase, AFrameTooSmallForItsCapsIsDroppedWithOneWarning) {
  for (const char* name : {"rgbdtestdepth", "rgbdtestip"}) {
    Filter f(name, info_for(name));
    for (int i = 0; i < 3; ++i) {
      GstBuffer* small = gst_buffer_new_allocate(nullptr, 10, nullptr);
      gst_buffer_memset(small, 0, 0, 10);
      EXPECT_EQ(gst_harness_push(f.h(), small), GST_FLOW_OK) << name;
    }
    EXPECT_EQ(gst_harness_buffers_received(f.h()), 0u) << name;
    const std::vector<std::string> warnings = f.messages(GST_MESSAGE_WARNING);
    ASSERT_EQ(warnings.size(), 1u) << name << ": the next drops are within the rate limit";
    EXPECT_TRUE(contains(warnings[0], std::string(GST_OBJECT_NAME(f.element())) + ": dropped a frame from camera 3"))
        << warnings[0];
    EXPECT_TRUE(f.messages(GST_MESSAGE_ERROR).empty()) << name;
    // The stream goes on with the next good frame.
    EXPECT_EQ(gst_harness_push(f.h(), frame(info_for(name))), GST_FLOW_OK) << name;
    EXPECT_EQ(gst_harness_buffers_received(f.h()), 1u) << name;
  }
}

TEST_F(RgbdFilterBase, ALibraryErrorBecomesABusErrorNamingTheElement) {
  for (const char* name : {"rgbdtestdepth", "rgbdtestip"}) {
    Filter f(name, info_for(name));
    g_behaviour = Behaviour::ThrowError;
    EXPECT_EQ(gst_harness_push(f.h(), frame(info_for(name))), GST_FLOW_ERROR) << name;
    const std::vector<std::string> errors = f.messages(GST_MESSAGE_ERROR);
    ASSERT_EQ(errors.size(), 1u) << name;
    EXPECT_EQ(errors[0], std::string(GST_OBJECT_NAME(f.element())) + ": the frame says no");
  }
}

TEST_F(RgbdFilterBase, AnOpenCvExceptionBecomesABusErrorNamingTheCamera) {
  Filter f("rgbdtestdepth", small_info());
  g_behaviour = Behaviour::ThrowOpenCv;
  EXPECT_EQ(gst_harness_push(f.h(), frame(small_info())), GST_FLOW_ERROR);
  const std::vector<std::string> errors = f.messages(GST_MESSAGE_ERROR);
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_TRUE(contains(errors[0], std::string(GST_OBJECT_NAME(f.element())) + ": camera 3's frame failed"))
      << errors[0];
}

TEST_F(RgbdFilterBase, ARefusedStreamHasItsFramesDroppedWithOneWarningWhileOthersGoOn) {
  for (const char* name : {"rgbdtestdepth", "rgbdtestip"}) {
    Filter f(name);
    g_refused_camera = 4;
    gst_harness_set_src_caps(f.h(), rgbd_caps_new(info_for(name, 4)));
    for (int i = 0; i < 3; ++i) EXPECT_EQ(gst_harness_push(f.h(), frame(info_for(name))), GST_FLOW_OK) << name;
    EXPECT_EQ(gst_harness_buffers_received(f.h()), 0u) << name;
    const std::vector<std::string> warnings = f.messages(GST_MESSAGE_WARNING);
    ASSERT_EQ(warnings.size(), 1u) << name;
    EXPECT_TRUE(contains(warnings[0], "dropped a frame from camera 4; the settings have no such camera")) << warnings[0];
    // Caps of a camera it serves: frames pass again.
    gst_harness_set_src_caps(f.h(), rgbd_caps_new(info_for(name)));
    EXPECT_EQ(gst_harness_push(f.h(), frame(info_for(name))), GST_FLOW_OK) << name;
    EXPECT_EQ(gst_harness_buffers_received(f.h()), 1u) << name;
  }
}

// Caps that do not describe a stream are refused at negotiation, saying which field is wrong.
TEST_F(RgbdFilterBase, CapsThatDoNotParseAreRefusedSayingWhy) {
  Filter f("depthcomplete", small_info({Plane::Color}));
  EXPECT_EQ(gst_harness_push(f.h(), frame(small_info({Plane::Color}))), GST_FLOW_NOT_NEGOTIATED);
  const std::vector<std::string> errors = f.messages(GST_MESSAGE_ERROR);
  ASSERT_FALSE(errors.empty());
  EXPECT_TRUE(contains(errors[0], "depthcomplete0: video/x-rgbd caps: field 'planes'")) << errors[0];
}
