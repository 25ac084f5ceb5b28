#pragma once

#include <gst/gst.h>

G_BEGIN_DECLS

#define GST_TYPE_RGBD_DEVICE_PROVIDER (gst_rgbd_device_provider_get_type())
G_DECLARE_FINAL_TYPE(GstRgbdDeviceProvider, gst_rgbd_device_provider, GST, RGBD_DEVICE_PROVIDER, GstDeviceProvider)

#define GST_TYPE_RGBD_DEVICE (gst_rgbd_device_get_type())
G_DECLARE_FINAL_TYPE(GstRgbdDevice, gst_rgbd_device, GST, RGBD_DEVICE, GstDevice)

GST_DEVICE_PROVIDER_REGISTER_DECLARE(rgbddeviceprovider);

G_END_DECLS
