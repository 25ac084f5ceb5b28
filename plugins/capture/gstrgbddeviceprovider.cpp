// The RGB-D cameras plugged into this machine, for gst-device-monitor-1.0 and
// any application's GstDeviceMonitor: each V4L2 node that offers depth, with
// the colour node on the same bus, becomes one device whose element is an
// rgbdsrc for both nodes. Probing is find_rgbd_cameras()'s (the library).
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstrgbddeviceprovider.h"

#include <string>
#include <vector>

#include <gst/vclassroom/capture/v4l2_device.h>
#include <gst/vclassroom/core/rgbd.h>

using namespace vclassroom;

struct _GstRgbdDevice {
  GstDevice parent;
  gchar* color_path;
  gchar* depth_path;
};

G_DEFINE_TYPE(GstRgbdDevice, gst_rgbd_device, GST_TYPE_DEVICE)

static GstElement* gst_rgbd_device_create_element(GstDevice* device, const gchar* name) {
  GstRgbdDevice* self = GST_RGBD_DEVICE(device);
  GstElement* src = gst_element_factory_make("rgbdsrc", name);
  if (src) g_object_set(src, "color-device", self->color_path, "depth-device", self->depth_path, nullptr);
  return src;
}

static void gst_rgbd_device_finalize(GObject* object) {
  GstRgbdDevice* self = GST_RGBD_DEVICE(object);
  g_free(self->color_path);
  g_free(self->depth_path);
  G_OBJECT_CLASS(gst_rgbd_device_parent_class)->finalize(object);
}

static void gst_rgbd_device_class_init(GstRgbdDeviceClass* klass) {
  GST_DEVICE_CLASS(klass)->create_element = gst_rgbd_device_create_element;
  G_OBJECT_CLASS(klass)->finalize = gst_rgbd_device_finalize;
}

static void gst_rgbd_device_init(GstRgbdDevice*) {}

struct _GstRgbdDeviceProvider {
  GstDeviceProvider parent;
};

G_DEFINE_TYPE(GstRgbdDeviceProvider, gst_rgbd_device_provider, GST_TYPE_DEVICE_PROVIDER)
GST_DEVICE_PROVIDER_REGISTER_DEFINE(rgbddeviceprovider, "rgbddeviceprovider", GST_RANK_PRIMARY,
                                    GST_TYPE_RGBD_DEVICE_PROVIDER)

// The V4L2 nodes looked at: /dev/video0 to /dev/video63 (a node that does not
// exist is skipped at once).
static std::vector<std::string> candidate_nodes() {
  std::vector<std::string> paths;
  for (int i = 0; i < 64; ++i) paths.push_back("/dev/video" + std::to_string(i));
  return paths;
}

static GList* gst_rgbd_device_provider_probe(GstDeviceProvider*) {
  GList* devices = nullptr;
  for (const RgbdCameraNodes& cam : find_rgbd_cameras(candidate_nodes())) {
    GstCaps* caps = gst_caps_new_empty();
    for (const auto& [w, h] : cam.sizes)
      gst_caps_append_structure(caps, gst_structure_new(kRgbdMediaType, "width", G_TYPE_INT, w, "height", G_TYPE_INT,
                                                        h, nullptr));
    GstStructure* props = gst_structure_new("rgbd-device-properties", "device.bus", G_TYPE_STRING, cam.bus.c_str(),
                                            "device.color-path", G_TYPE_STRING, cam.color_path.c_str(),
                                            "device.depth-path", G_TYPE_STRING, cam.depth_path.c_str(), nullptr);
    GstRgbdDevice* dev = GST_RGBD_DEVICE(g_object_new(GST_TYPE_RGBD_DEVICE, "display-name",
                                                      (cam.name + " (RGB-D)").c_str(), "device-class",
                                                      "Video/Source/RGBD", "caps", caps, "properties", props, nullptr));
    dev->color_path = g_strdup(cam.color_path.c_str());
    dev->depth_path = g_strdup(cam.depth_path.c_str());
    gst_caps_unref(caps);
    gst_structure_free(props);
    devices = g_list_append(devices, gst_object_ref_sink(dev));
  }
  return devices;
}

static void gst_rgbd_device_provider_class_init(GstRgbdDeviceProviderClass* klass) {
  GstDeviceProviderClass* dp_class = GST_DEVICE_PROVIDER_CLASS(klass);
  dp_class->probe = gst_rgbd_device_provider_probe;
  gst_device_provider_class_set_static_metadata(
      dp_class, "RGB-D camera provider", "Video/Source/RGBD",
      "Lists consumer RGB-D cameras (a V4L2 node offering Z16/Y16 depth with a colour node on the same bus) as "
      "rgbdsrc devices",
      "gst-vclassroom developers");
}

static void gst_rgbd_device_provider_init(GstRgbdDeviceProvider*) {}
