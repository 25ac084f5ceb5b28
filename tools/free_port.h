// A port on 127.0.0.1 that is free now (bound, read back and released): for the
// tools and the tests that start servers and links on loopback. Needs gio-2.0.
#pragma once

#include <gio/gio.h>

namespace vclassroom_tools {

inline int free_loopback_port(bool tcp) {
  GSocket* s = tcp ? g_socket_new(G_SOCKET_FAMILY_IPV4, G_SOCKET_TYPE_STREAM, G_SOCKET_PROTOCOL_TCP, nullptr)
                   : g_socket_new(G_SOCKET_FAMILY_IPV4, G_SOCKET_TYPE_DATAGRAM, G_SOCKET_PROTOCOL_UDP, nullptr);
  if (!s) return 0;
  GInetAddress* lo = g_inet_address_new_loopback(G_SOCKET_FAMILY_IPV4);
  GSocketAddress* any = g_inet_socket_address_new(lo, 0);
  int port = 0;
  if (g_socket_bind(s, any, TRUE, nullptr))
    if (GSocketAddress* bound = g_socket_get_local_address(s, nullptr)) {
      port = g_inet_socket_address_get_port(G_INET_SOCKET_ADDRESS(bound));
      g_object_unref(bound);
    }
  g_socket_close(s, nullptr);
  for (GObject* o : {G_OBJECT(any), G_OBJECT(lo), G_OBJECT(s)}) g_object_unref(o);
  return port;
}

}  // namespace vclassroom_tools
