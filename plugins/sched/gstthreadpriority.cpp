// threadpriority: lowers the scheduling priority (raises the nice value) of
// the streaming thread that pushes buffers through it. On a server with more
// work than cores, the work a pose waits for (warp, fuse, encode) should not
// share the CPU evenly with the work it does not wait for (decoding and
// cleaning the next camera frame): put a queue, then threadpriority, in front
// of the latter (docs/network.md). gst-launch-1.0 descriptions cannot set
// thread priorities from the application's stream-status messages, hence an
// element. Buffers, events and queries pass untouched.
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstthreadpriority.h"

#include <atomic>
#include <cerrno>
#include <cstring>

#ifdef __linux__
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>
#endif

GST_DEBUG_CATEGORY_STATIC(thread_priority_debug);
#define GST_CAT_DEFAULT thread_priority_debug

enum { PROP_0, PROP_NICE };

namespace {
constexpr int kDefaultNice = 10;
}

struct _GstThreadPriority {
  GstBaseTransform parent;
  std::atomic<int> nice;
  // The thread last set, and to which value: a queue's thread lives as long
  // as the stream, so the system call is made once, and again only when the
  // thread or the property changes.
  std::atomic<long> applied_thread;
  std::atomic<int> applied_nice;
  std::atomic<bool> warned;
};

G_DEFINE_TYPE(GstThreadPriority, gst_thread_priority, GST_TYPE_BASE_TRANSFORM)

static GstStaticPadTemplate sink_template =
    GST_STATIC_PAD_TEMPLATE("sink", GST_PAD_SINK, GST_PAD_ALWAYS, GST_STATIC_CAPS_ANY);
static GstStaticPadTemplate src_template =
    GST_STATIC_PAD_TEMPLATE("src", GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS_ANY);

static void apply_to_current_thread(GstThreadPriority* self) {
#ifdef __linux__
  const long thread = syscall(SYS_gettid);
  const int nice = self->nice.load();
  if (thread == self->applied_thread.load() && nice == self->applied_nice.load()) return;
  self->applied_thread = thread;
  self->applied_nice = nice;
  // On Linux, PRIO_PROCESS with a thread id sets that one thread's nice value.
  if (setpriority(PRIO_PROCESS, static_cast<id_t>(thread), nice) != 0) {
    const int err = errno;
    if (!self->warned.exchange(true))
      GST_ELEMENT_WARNING(self, RESOURCE, SETTINGS, ("Could not set the streaming thread's nice value to %d", nice),
                          ("setpriority: %s (lowering priority needs no privileges; raising it back does)",
                           std::strerror(err)));
    return;
  }
  GST_DEBUG_OBJECT(self, "thread %ld now runs at nice %d", thread, nice);
#else
  if (!self->warned.exchange(true))
    GST_ELEMENT_WARNING(self, RESOURCE, SETTINGS, ("Thread priorities are only set on Linux"), (nullptr));
#endif
}

static GstFlowReturn gst_thread_priority_transform_ip(GstBaseTransform* trans, GstBuffer*) {
  apply_to_current_thread(GST_THREAD_PRIORITY(trans));
  return GST_FLOW_OK;
}

static void gst_thread_priority_set_property(GObject* object, guint id, const GValue* value, GParamSpec* pspec) {
  GstThreadPriority* self = GST_THREAD_PRIORITY(object);
  switch (id) {
    case PROP_NICE:
      self->nice = g_value_get_int(value);
      break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID(object, id, pspec);
  }
}

static void gst_thread_priority_get_property(GObject* object, guint id, GValue* value, GParamSpec* pspec) {
  GstThreadPriority* self = GST_THREAD_PRIORITY(object);
  switch (id) {
    case PROP_NICE:
      g_value_set_int(value, self->nice.load());
      break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID(object, id, pspec);
  }
}

static void gst_thread_priority_class_init(GstThreadPriorityClass* klass) {
  GObjectClass* gobject_class = G_OBJECT_CLASS(klass);
  GstElementClass* element_class = GST_ELEMENT_CLASS(klass);
  GstBaseTransformClass* trans_class = GST_BASE_TRANSFORM_CLASS(klass);
  gobject_class->set_property = gst_thread_priority_set_property;
  gobject_class->get_property = gst_thread_priority_get_property;
  g_object_class_install_property(
      gobject_class, PROP_NICE,
      g_param_spec_int("nice", "Nice value",
                       "Nice value given to the streaming thread that pushes through this element (0 = normal, 19 = "
                       "lowest priority). Put it after a queue so it applies to that queue's thread only",
                       0, 19, kDefaultNice,
                       GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_PLAYING)));
  gst_element_class_add_static_pad_template(element_class, &sink_template);
  gst_element_class_add_static_pad_template(element_class, &src_template);
  gst_element_class_set_static_metadata(
      element_class, "Streaming thread priority", "Generic",
      "Passes everything through and lowers the scheduling priority of the thread that pushes it (Linux nice "
      "value), so that work nobody waits for yields the CPU to work somebody does",
      "gst-vclassroom developers");
  trans_class->transform_ip = GST_DEBUG_FUNCPTR(gst_thread_priority_transform_ip);
  trans_class->transform_ip_on_passthrough = TRUE;
  GST_DEBUG_CATEGORY_INIT(thread_priority_debug, "threadpriority", 0, "streaming thread priority");
}

static void gst_thread_priority_init(GstThreadPriority* self) {
  self->nice = kDefaultNice;
  self->applied_thread = -1;
  self->applied_nice = -1;
  self->warned = false;
  gst_base_transform_set_passthrough(GST_BASE_TRANSFORM(self), TRUE);
}
