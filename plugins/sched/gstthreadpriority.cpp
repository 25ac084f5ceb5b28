/**
 * SECTION:element-threadpriority
 * @title: threadpriority
 *
 * Passes everything through and lowers the scheduling priority of the thread that pushes it (Linux nice
 * value), so that work nobody waits for yields the CPU to work somebody does: on a server with more work
 * than cores, the work a pose waits for (warp, fuse, encode) should not share the CPU evenly with the work
 * it does not wait for (decoding and cleaning the next camera frame), so put a queue, then threadpriority,
 * in front of the latter (docs/network.md). Buffers, events and queries pass untouched.
 *
 * ## Properties
 *
 * nice: a thread already nicer is left as it is. Put the element after a queue so the value applies to
 * that queue's thread only. The thread keeps the value until it ends (raising a priority back needs
 * privileges), also when its pool gives it to another task after a stop.
 *
 * ## Example launch line
 * |[
 * gst-launch-1.0 rgbdtestsrc num-buffers=300 ! queue ! threadpriority nice=10 ! rgbddemux name=d d.color ! videoconvert ! fakesink
 * ]|
 */
// Why an element: gst-launch-1.0 descriptions cannot set thread priorities from the application's
// stream-status messages.
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "gstthreadpriority.h"

#include <cerrno>
#include <cstring>
#include <mutex>

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

struct PriorityState {
  std::mutex lock;
  int nice = kDefaultNice;
  // The thread last set, and the value asked for then: a queue's thread
  // lives as long as the stream, so the system call is made once, and again
  // only when the thread or the property changes.
  long applied_thread = -1;
  int applied_nice = -1;
  bool warned = false;
};
}  // namespace

struct _GstThreadPriority {
  GstBaseTransform parent;
  PriorityState* st;
};

G_DEFINE_TYPE(GstThreadPriority, gst_thread_priority, GST_TYPE_BASE_TRANSFORM)
GST_ELEMENT_REGISTER_DEFINE(threadpriority, "threadpriority", GST_RANK_NONE, GST_TYPE_THREAD_PRIORITY)

static GstStaticPadTemplate sink_template =
    GST_STATIC_PAD_TEMPLATE("sink", GST_PAD_SINK, GST_PAD_ALWAYS, GST_STATIC_CAPS_ANY);
static GstStaticPadTemplate src_template =
    GST_STATIC_PAD_TEMPLATE("src", GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS_ANY);

// True the first time only: one warning per element, not one per buffer.
static bool first_warning(PriorityState* st) {
  std::lock_guard<std::mutex> g(st->lock);
  const bool first = !st->warned;
  st->warned = true;
  return first;
}

static void apply_to_current_thread(GstThreadPriority* self) {
  PriorityState* st = self->st;
#ifdef __linux__
  const long thread = syscall(SYS_gettid);
  int nice;
  {
    std::lock_guard<std::mutex> g(st->lock);
    if (thread == st->applied_thread && st->nice == st->applied_nice) return;
    st->applied_thread = thread;
    st->applied_nice = nice = st->nice;
  }
  // On Linux, PRIO_PROCESS with a thread id is that one thread. Only ever
  // lowered: a thread already nicer (a server started with `nice`) stays so.
  errno = 0;
  const int current = getpriority(PRIO_PROCESS, static_cast<id_t>(thread));
  if (errno == 0 && current >= nice) return;
  if (setpriority(PRIO_PROCESS, static_cast<id_t>(thread), nice) != 0) {
    const int err = errno;
    if (first_warning(st))
      GST_ELEMENT_WARNING(self, RESOURCE, SETTINGS, ("Could not set the streaming thread's nice value to %d", nice),
                          ("setpriority: %s", std::strerror(err)));
    return;
  }
  GST_DEBUG_OBJECT(self, "thread %ld now runs at nice %d", thread, nice);
#else
  if (first_warning(st))
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
    case PROP_NICE: {
      std::lock_guard<std::mutex> g(self->st->lock);
      self->st->nice = g_value_get_int(value);
      break;
    }
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID(object, id, pspec);
  }
}

static void gst_thread_priority_get_property(GObject* object, guint id, GValue* value, GParamSpec* pspec) {
  GstThreadPriority* self = GST_THREAD_PRIORITY(object);
  switch (id) {
    case PROP_NICE: {
      std::lock_guard<std::mutex> g(self->st->lock);
      g_value_set_int(value, self->st->nice);
      break;
    }
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID(object, id, pspec);
  }
}

static void gst_thread_priority_finalize(GObject* object) {
  delete GST_THREAD_PRIORITY(object)->st;
  G_OBJECT_CLASS(gst_thread_priority_parent_class)->finalize(object);
}

static void gst_thread_priority_class_init(GstThreadPriorityClass* klass) {
  GObjectClass* gobject_class = G_OBJECT_CLASS(klass);
  GstElementClass* element_class = GST_ELEMENT_CLASS(klass);
  GstBaseTransformClass* trans_class = GST_BASE_TRANSFORM_CLASS(klass);
  gobject_class->set_property = gst_thread_priority_set_property;
  gobject_class->get_property = gst_thread_priority_get_property;
  gobject_class->finalize = gst_thread_priority_finalize;
  g_object_class_install_property(
      gobject_class, PROP_NICE,
      g_param_spec_int("nice", "Nice value",
                       "Nice value of the streaming thread pushing through it (0 = normal, 19 = lowest priority)",
                       0, 19, kDefaultNice,
                       GParamFlags(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_PLAYING)));
  gst_element_class_add_static_pad_template(element_class, &sink_template);
  gst_element_class_add_static_pad_template(element_class, &src_template);
  gst_element_class_set_static_metadata(element_class, "Streaming thread priority", "Generic",
      "Lowers the priority of the streaming thread that passes it", "gst-vclassroom developers");
  trans_class->transform_ip = GST_DEBUG_FUNCPTR(gst_thread_priority_transform_ip);
  trans_class->transform_ip_on_passthrough = TRUE;
  GST_DEBUG_CATEGORY_INIT(thread_priority_debug, "threadpriority", 0, "streaming thread priority");
}

static void gst_thread_priority_init(GstThreadPriority* self) {
  self->st = new PriorityState();
  gst_base_transform_set_passthrough(GST_BASE_TRANSFORM(self), TRUE);
}
