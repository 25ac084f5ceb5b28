#!/usr/bin/env bash
# Server: N RTP camera inputs -> decode -> V-DA -> V-VA -> JPEG -> RTP -> UDP to the lecturer;
# pose packets from the lecturer come back on POSE_PORT and steer the view.
# Variables: CAMERAS (ids, default "0 1 2"), BASE_PORT (camera k on BASE_PORT + k, default 5000),
#   CAMERA_PORTS (one port per camera in CAMERAS order, instead of BASE_PORT + k),
#   LECTURER (host, default 127.0.0.1), VIDEO_PORT (default 5010), POSE_PORT (default 5011),
#   AUDIO_PORT (the classroom's sound to the lecturer, with CLASSROOM_SOUND below; default 5012),
#   MODEL (folder from vclassroom-build-model; empty: no V-DA), RIG (rig file; empty: the default classroom rig),
#   each camera's stream must have its size in RIG, or without RIG in MODEL's rig: another size is refused
#   (frames dropped, a rate-limited warning) and the other cameras go on,
#   WIDTH/HEIGHT (virtual view, default 960x540), QUALITY (JPEG quality of the lecturer's video, default 90).
#   STATS (0: quiet; N: every N frames each camera's decoder posts vclassroom-codec-stats, printed by -m),
#   MTU (largest RTP packet received from the cameras and sent to the lecturer, default 1400; as classroom.sh),
#   PREP_NICE (nice value of the threads that decode, complete and segment camera frames, default 19: when
#   the CPU is short, warping, fusing and sending the lecturers' views go first; 0 shares it evenly),
#   FUSE_LATENCY (ns the fuse waits for a late camera's frame before rendering without it, default 100000000).
#   WARP_SYNC (longest wait, ns, of each camera's warp for the others' next frames before it reads the
#   lecturer's pose, so a pose shows after one camera frame, not the last of several; it waits two thirds of
#   the frame interval within it; default 100000000; 0: no wait; docs/vva.md).
#   LONGEST_TURN (whep-views only: the lecturers' views take turns to warp, so a frame's pose is as old as one
#   view's warps, not every view's; a view holding the turn longer than this, ns, loses it to the next,
#   default 100000000; 0: every view warps at once; docs/lecturer.md).
#   POSE_KEY (file holding the pose key shared with lecturer.sh, e.g. `head -c 32 /dev/urandom > pose.key`:
#   only poses tagged with it steer the view; empty: anyone who can reach POSE_PORT can steer it).
#   CAMERA_HOSTS (one address per camera in CAMERAS order, default 127.0.0.1 each; a missing entry repeats the
#   last): only packets from camera k's host are taken on its ports, and its retransmission requests go there.
#   CAMERA_NACK_PORTS (each camera's port for our RTCP, i.e. retransmission requests, default camera port + 100).
#   RTX (1, the default: request lost camera packets again; 0: plain RTP (docs/network.md); the cameras'
#   RTX must match),
#   CAMERA_SSRCS (each camera's SSRC in CAMERAS order, default classroom.sh's 0x56430000 + camera id; its
#   retransmissions' SSRC is that + 0x8000): only these streams are taken on a camera's port.
#   RTX_LATENCY (ms a camera packet may wait for its retransmission, default 300).
#   Packets from other addresses, or a second RTP stream on a camera port, are dropped and counted
#   (senderfilter, docs/network.md); the pose port takes packets only from LECTURER.
#   SRTP_KEY (a 30-byte key file: every RTP link in and out is SRTP, with the cameras' and the lecturer's
#   same file; docs/network.md).
#   STOP_GRACE (seconds the pipeline gets to end after Ctrl-C before it is killed, default 5).
#   NAV_RIG (rig file with navigation bounds: every pose is moved into them, docs/navigation.md; default
#   $MODEL/rig.yaml when MODEL is set, which vclassroom-build-model gives bounds; set it empty for none).
#   MEMORY (frames of viewwarp's background memory, default 8; 0: off; with MODEL it starts from the model's
#   empty-room colour and draws the room behind the learners, docs/vva.md; with whep-views every lecturer's
#   view keeps its own).
#   CAMERA_GROUPS (one IPv4 multicast group per camera in CAMERAS order, as its classroom.sh SERVER: this
#   server joins the group on the camera's port, so several servers take the same cameras; empty: unicast),
#   MULTICAST_IFACE (the interface to join on, e.g. lo for cameras on this machine; default the system's).
#   LINK (h264, the default: the cameras send H.264 colour with the depth in each access unit, rgbdlinkdemux
#   and rgbdlinkjoin pair them again; vcrd1: rgbdenc frames through rtpgstpay; as the cameras' classroom.sh;
#   docs/network.md, "The H.264 camera link").
set -euo pipefail
. "$(dirname "$0")/trees.sh"
# shellcheck source=pipelines/srtp.sh
. "$(dirname "$0")/srtp.sh"
# shellcheck source=pipelines/launch.sh
. "$(dirname "$0")/launch.sh"
CAMERAS=${CAMERAS:-"0 1 2"}
BASE_PORT=${BASE_PORT:-5000}
LECTURER=${LECTURER:-127.0.0.1}
VIDEO_PORT=${VIDEO_PORT:-5010}
POSE_PORT=${POSE_PORT:-5011}
MODEL=${MODEL:-}
RIG=${RIG:-}
WIDTH=${WIDTH:-960}
HEIGHT=${HEIGHT:-540}
QUALITY=${QUALITY:-90}
# A 960x540 RGB-D frame is ~400 packets sent at once: the socket must hold a few frames.
UDP_BUFFER=${UDP_BUFFER:-33554432}
STATS=${STATS:-0}
MTU=${MTU:-1400}
if ! [[ $MTU =~ ^[0-9]+$ ]] || [ "$MTU" -lt 200 ] || [ "$MTU" -gt 65000 ]; then
  echo "server.sh: MTU must be a packet size in bytes, 200 to 65000 (got '$MTU')" >&2
  exit 2
fi
RTX=${RTX:-1}
LINK=${LINK:-h264}
if [ "$LINK" != h264 ] && [ "$LINK" != vcrd1 ]; then
  echo "server.sh: LINK must be h264 or vcrd1 (got '$LINK')" >&2
  exit 2
fi
RTX_LATENCY=${RTX_LATENCY:-300}
PREP_NICE=${PREP_NICE:-19}
MEMORY=${MEMORY:-8}
if ! [[ $PREP_NICE =~ ^[0-9]+$ ]] || [ "$PREP_NICE" -gt 19 ]; then
  echo "server.sh: PREP_NICE must be a nice value, 0 to 19 (got '$PREP_NICE')" >&2
  exit 2
fi
if ! [[ $MEMORY =~ ^[0-9]+$ ]] || [ "$MEMORY" -gt 64 ]; then
  echo "server.sh: MEMORY must be a number of frames, 0 (off) to 64 (got '$MEMORY')" >&2
  exit 2
fi
pose_key=""
[ -n "${POSE_KEY:-}" ] && pose_key="key-file=$POSE_KEY"
POSE_EXT="extmap-3=(string)urn:gst-vclassroom:rtp-hdrext:pose"

check_port() {
  if ! [[ $1 =~ ^[0-9]+$ ]] || [ "$1" -lt 1 ] || [ "$1" -gt 65535 ]; then
    echo "server.sh: ports must be 1 to 65535 (got '$1')" >&2
    exit 2
  fi
}
read -r -a camera_ports <<< "${CAMERA_PORTS:-}"
read -r -a camera_hosts <<< "${CAMERA_HOSTS:-127.0.0.1}"
read -r -a nack_ports <<< "${CAMERA_NACK_PORTS:-}"
read -r -a camera_ssrcs <<< "${CAMERA_SSRCS:-}"
read -r -a camera_groups <<< "${CAMERA_GROUPS:-}"
if ! [[ ${MULTICAST_IFACE:-lo} =~ ^[A-Za-z0-9._-]+$ ]]; then
  echo "server.sh: MULTICAST_IFACE is an interface name (got '$MULTICAST_IFACE')" >&2
  exit 2
fi
AUDIO_PORT=${AUDIO_PORT:-5012}
for p in "$VIDEO_PORT" "$POSE_PORT" "$AUDIO_PORT"; do check_port "$p"; done
RTP_CAPS="$RTP_MEDIA,media=application,clock-rate=90000,encoding-name=X-GST,payload=96"
[ "$LINK" = h264 ] && RTP_CAPS="$RTP_MEDIA,media=video,clock-rate=90000,encoding-name=H264,payload=96"
branches=""
i=0
host=${camera_hosts[0]}
for k in $CAMERAS; do
  port=${camera_ports[$i]:-$((BASE_PORT + k))}
  nack_port=${nack_ports[$i]:-$((port + 100))}
  host=${camera_hosts[$i]:-$host}
  ssrc=${camera_ssrcs[$i]:-$((0x56430000 + k))}
  if ! [[ $ssrc =~ ^[0-9]+$ ]] || [ "$ssrc" -gt 4294967294 ]; then
    echo "server.sh: CAMERA_SSRCS must be numbers, 0 to 4294967294 (got '$ssrc')" >&2
    exit 2
  fi
  for p in "$port" "$nack_port"; do check_port "$p"; done
  i=$((i + 1))
  vda=""
  [ -n "$MODEL" ] && vda="depthcomplete model=$MODEL ! planerefine model=$MODEL !"
  prior=""
  [ -n "$MODEL" ] && prior="prior-depth=$MODEL/prior-depth/cam$k.png"
  rig=""
  [ -n "$RIG" ] && rig="rig=$RIG"
  # The decoder refuses a stream of another size than its rig camera's before it allocates anything; without
  # RIG the model's rig is the one the stream must fit (depthcomplete would refuse it later, after decoding).
  dec_rig=$rig
  [ -z "$RIG" ] && [ -n "$MODEL" ] && dec_rig="rig=$MODEL/rig.yaml"
  # Camera k's link: only its host, one stream (senderfilter); with RTX an RTCP session (AVPF: a NACK goes
  # out at once; rtcp-min-interval and bandwidth let it send one every few ms, as a LAN's RTT is tiny) whose
  # requests rtprtxreceive matches with the resent packets before the jitter buffer. probation=0: the first
  # packet carries the stream's caps and must not be dropped while the session validates the sender.
  # Only the camera's own streams pass: its video (96) and, with RTX, its retransmissions (97), each with its
  # fixed SSRC, so no stray packet can open a stream that nothing downstream takes.
  streams="payload-types=96 ssrcs=96=$ssrc"
  [ "$RTX" = 1 ] && streams="payload-types=96,97 ssrcs=96=$ssrc,97=$(( (ssrc + 0x8000) % 4294967296 ))"
  group=${camera_groups[$i - 1]:-}
  join=""
  if [ -n "$group" ]; then
    if ! [[ $group =~ ^(22[4-9]|23[0-9])\.[0-9]{1,3}\.[0-9]{1,3}\.[0-9]{1,3}$ ]]; then
      echo "server.sh: CAMERA_GROUPS are IPv4 multicast groups, 224.0.0.0 to 239.255.255.255 (got '$group')" >&2
      exit 2
    fi
    join="address=$group auto-multicast=true ${MULTICAST_IFACE:+multicast-iface=$MULTICAST_IFACE}"
  fi
  receive="udpsrc port=$port $join buffer-size=$UDP_BUFFER mtu=$((MTU + 100)) caps=\"$RTP_CAPS\" ! senderfilter name=from$k allow=$host $streams ! $(srtp_dec)"
  if [ "$RTX" = 1 ]; then
    branches="$branches rtpsession name=link$k probation=0 rtp-profile=avpf rtcp-min-interval=10000000 bandwidth=20000000 \
      link$k.send_rtcp_src ! udpsink host=$host port=$nack_port sync=false async=false"
    receive="$receive link$k.recv_rtp_sink link$k.recv_rtp_src ! \
      rtprtxreceive payload-type-map=application/x-rtp-pt-map,96=(uint)97 ! rtpssrcdemux ! \
      rtpjitterbuffer latency=$RTX_LATENCY do-retransmission=true rtx-min-retry-timeout=40 drop-on-latency=true !"
  else
    receive="$receive rtpjitterbuffer latency=50 drop-on-latency=true !"
  fi
  # One view (the default): the camera's viewwarp feeds the fuse. LECTURER_OUT=whep-views: whepviewsink
  # makes the viewwarps, one per lecturer.
  memory=""
  [ "$MEMORY" != 0 ] && memory="background-memory=$MEMORY${MODEL:+ empty-room=$MODEL/prior-color/cam$k.png}"
  to_view="queue max-size-buffers=1 leaky=downstream ! viewwarp $rig width=$WIDTH height=$HEIGHT $prior $memory ! fuse.cam_$k"
  # whepviewsink's viewprep (the memory, the warp's first half) runs in this queue's thread, at PREP_NICE too.
  [ "${LECTURER_OUT:-rtp}" = whep-views ] &&
    to_view="queue max-size-buffers=1 leaky=downstream ! threadpriority nice=$PREP_NICE ! views.cam_$k"
  # The old link: the newest coded frame only is decoded, in the low-priority thread. The H.264 link: every
  # picture must be decoded (each builds on the one before), so a queue of up to half a second of packets
  # feeds the H.264 decoder in a low-priority thread of its own, which catches up while the views wait (at
  # normal priority it delays them); a decoder that falls further behind loses the oldest packets, asks the
  # camera for a key frame and starts again from it. The newest picture goes on to the low-priority
  # preparation thread, where rgbdlinkjoin converts it and decodes its depth (with the depth frames of the
  # pictures dropped before it, which the depth builds on; docs/network.md, "Decoding the depth where the
  # picture is used"). A lost packet asks the camera for a key frame
  # (rtph264depay request-keyframe: a PLI through the RTCP session, RFC 4585), and pictures wait for it.
  # FFmpeg's decoder on one thread: a little cheaper per picture than openh264dec, and the pose-to-photon
  # latency 10-15 ms lower with it (docs/network.md, "The whole flow, measured").
  if [ "$LINK" = h264 ]; then
    decode="queue max-size-buffers=0 max-size-bytes=0 max-size-time=500000000 leaky=downstream ! \
      threadpriority nice=$PREP_NICE ! rtph264depay request-keyframe=true wait-for-keyframe=true ! rgbdlinkdemux name=dec$k $dec_rig stats-interval=$STATS ! \
      avdec_h264 max-threads=1 ! queue max-size-buffers=1 leaky=downstream ! threadpriority nice=$PREP_NICE ! \
      videoconvert ! rgbdlinkjoin name=join$k stats-interval=$STATS !"
  else
    decode="rtpgstdepay ! queue max-size-buffers=1 leaky=downstream ! threadpriority nice=$PREP_NICE ! \
      rgbddec name=dec$k $dec_rig stats-interval=$STATS !"
  fi
  branches="$branches $receive $decode $vda learnerseg $prior ! $to_view"
done
# Word-split the description (no globbing): gst-launch-1.0 takes one word per
# argument and handles the quotes inside them itself.
set -f
FUSE_LATENCY=${FUSE_LATENCY:-100000000}
WARP_SYNC=${WARP_SYNC:-100000000}
LONGEST_TURN=${LONGEST_TURN:-100000000}
if ! [[ $FUSE_LATENCY =~ ^[0-9]{1,18}$ ]] || ! [[ $WARP_SYNC =~ ^[0-9]{1,18}$ ]] || ! [[ $LONGEST_TURN =~ ^[0-9]{1,10}$ ]]; then
  echo "server.sh: FUSE_LATENCY, WARP_SYNC and LONGEST_TURN are nanoseconds (got '$FUSE_LATENCY', '$WARP_SYNC', '$LONGEST_TURN')" >&2
  exit 2
fi
NAV_RIG=${NAV_RIG-${MODEL:+$MODEL/rig.yaml}}
desc="viewfuse name=fuse latency=$FUSE_LATENCY warp-sync=$WARP_SYNC ${NAV_RIG:+rig=$NAV_RIG} ! poserecv name=poses $pose_key ! \
  jpegenc quality=$QUALITY ! rtpgstpay config-interval=1 mtu=$MTU ! application/x-rtp,$POSE_EXT ! \
  $SRTP_ENC udpsink host=$LECTURER port=$VIDEO_PORT sync=false \
  udpsrc port=$POSE_PORT caps=\"$RTP_MEDIA,media=application,clock-rate=90000,encoding-name=X-VCLASSROOM-POSE,payload=96\" ! \
    senderfilter name=from_lecturer lock-ssrc=false allow=$LECTURER ! $(srtp_dec) poses.rtp \
  $branches"
# The classroom's sound to lecturer.sh (CLASSROOM_SOUND, as below for the browsers): Opus over RTP to
# AUDIO_PORT, beside the view.
[ -n "${CLASSROOM_SOUND:-}" ] &&
  desc="$desc $CLASSROOM_SOUND ! audioconvert ! audioresample ! opusenc inband-fec=true packet-loss-percentage=5 ! \
    rtpopuspay pt=97 mtu=$MTU ! $SRTP_ENC udpsink host=$LECTURER port=$AUDIO_PORT sync=false async=false"
# --- WebRTC lecturer output (issue 13, docs/lecturer.md) ---------------------------------------------
# LECTURER_OUT=whep: the view goes to browsers over WebRTC (whepserversink) instead of RTP/JPEG to
# LECTURER, and the pose comes back over the page's data channel; every lecturer sees the one view.
# LECTURER_OUT=whep-views: each lecturer gets a view of their own (whepviewsink), up to WHEP_SESSIONS
# (default 4). TOKEN (the join secret, required; letters, digits, . _ ~ -), WHEP_PORT (default 8080),
# WHEP_TLS_CERT and WHEP_TLS_KEY (PEM files: HTTPS, which browsers need for WebXR off localhost),
# WHEP_BITRATE (kbit/s, default 4000), WHEP_STUN (stun://host:port) and WHEP_TURN (turn://user:password@host:port
# or turns://...) for lecturers behind NAT, WHEP_LECTURER_TIMEOUT (seconds without a receiver report after which
# a lecturer is gone and their session ended, default 15, 0: never), WHEP_LISTEN (comma-separated IP addresses
# the HTTP(S) server listens on, default 0.0.0.0,:: = every interface, IPv4 and IPv6), WHEP_ALLOW_ORIGIN
# (comma-separated origins, https://host[:port], whose pages may call the endpoint: another WHEP player;
# * = any; default none), CLASSROOM_SOUND (a GStreamer audio source, e.g. autoaudiosrc, pulsesrc, alsasrc
# device=hw:1 or "audiotestsrc is-live=true wave=ticks": coded as Opus and sent to every lecturer's browser;
# default none), CLASSROOM_SPEAKER (a GStreamer audio sink, e.g. autoaudiosink or "alsasink device=hw:1": the
# lecturers' voices, mixed, played in the classroom; default none), ECHO_CANCEL (with both: 1, the default,
# cancels what the microphone hears of the loudspeaker, webrtcdsp with webrtcechoprobe; 0: off)
# (docs/lecturer.md).
if [ "${LECTURER_OUT:-rtp}" = whep ] || [ "${LECTURER_OUT:-rtp}" = whep-views ]; then
  WHEP_PORT=${WHEP_PORT:-8080}
  if ! [[ ${TOKEN:-} =~ ^[A-Za-z0-9._~-]{8,}$ ]] || ! [[ $WHEP_PORT =~ ^[0-9]+$ ]]; then
    echo "server.sh: LECTURER_OUT=whep needs TOKEN (8 or more of A-Z a-z 0-9 . _ ~ -) and a numeric WHEP_PORT" >&2
    exit 2
  fi
  # Addresses only (hex digits, dots, colons, commas): the element checks each is an IP address.
  if [ -n "${WHEP_LISTEN:-}" ] && ! [[ $WHEP_LISTEN =~ ^[0-9A-Fa-f.:,]+$ ]]; then
    echo "server.sh: WHEP_LISTEN is a comma-separated list of IP addresses, e.g. 192.168.1.10 or 0.0.0.0,::" >&2
    exit 2
  fi
  if [ -n "${WHEP_ALLOW_ORIGIN:-}" ] && ! [[ $WHEP_ALLOW_ORIGIN =~ ^[][A-Za-z0-9.:/,*-]+$ ]]; then
    echo "server.sh: WHEP_ALLOW_ORIGIN is a comma-separated list of origins, e.g. https://player.example:8443 or *" >&2
    exit 2
  fi
  whep_tls=""
  # The page lies beside the pipelines: ../web/lecturer both in a checkout and installed (datadir).
  [ -n "${WHEP_TLS_CERT:-}" ] && whep_tls="tls-certificate=$WHEP_TLS_CERT tls-key=${WHEP_TLS_KEY:?WHEP_TLS_KEY}"
  whep="port=$WHEP_PORT token=$TOKEN bitrate=${WHEP_BITRATE:-4000} max-sessions=${WHEP_SESSIONS:-4} $whep_tls \
    ${WHEP_STUN:+stun-server=$WHEP_STUN} ${WHEP_TURN:+turn-server=$WHEP_TURN} \
    ${WHEP_LECTURER_TIMEOUT:+lecturer-timeout=$WHEP_LECTURER_TIMEOUT} ${WHEP_LISTEN:+listen-addresses=$WHEP_LISTEN} \
    ${WHEP_ALLOW_ORIGIN:+allow-origin=$WHEP_ALLOW_ORIGIN} \
    web-root=\"$(cd "$(dirname "$0")/../web/lecturer" && pwd)\""
  # The classroom's sound to the lecturers and their voices back, through the echo canceller when both are
  # on (the probe hears what the loudspeaker plays; webrtcdsp removes it from the microphone's signal).
  sound=""
  dsp=""
  if [ -n "${CLASSROOM_SOUND:-}" ] && [ -n "${CLASSROOM_SPEAKER:-}" ] && [ "${ECHO_CANCEL:-1}" != 0 ]; then
    # (delay-agnostic, extended-filter: a room's loudspeaker-to-microphone delay is not known beforehand;
    # vclassroom-measure-echo: 6.4 dB less echo with them, 2.6 dB without, docs/lecturer.md.)
    dsp="audio/x-raw,format=S16LE,rate=48000,channels=1 ! webrtcdsp probe=classroom_echo delay-agnostic=true \
      extended-filter=true ! audioconvert !"
  fi
  [ -n "${CLASSROOM_SOUND:-}" ] &&
    sound="$CLASSROOM_SOUND ! audioconvert ! audioresample ! $dsp opusenc inband-fec=true packet-loss-percentage=5 ! queue ! views.audio"
  if [ -n "${CLASSROOM_SPEAKER:-}" ]; then
    sound="$sound views.voice ! queue ! ${dsp:+webrtcechoprobe name=classroom_echo !} audioconvert ! audioresample ! $CLASSROOM_SPEAKER"
  fi
  if [ "$LECTURER_OUT" = whep ]; then
    desc="viewfuse name=fuse latency=$FUSE_LATENCY warp-sync=$WARP_SYNC ${NAV_RIG:+rig=$NAV_RIG} ! whepserversink name=views $whep $branches $sound"
  else
    desc="whepviewsink name=views $whep ${RIG:+rig=$RIG} ${NAV_RIG:+navigation-rig=$NAV_RIG} ${MODEL:+model=$MODEL} \
      width=$WIDTH height=$HEIGHT fuse-latency=$FUSE_LATENCY warp-sync=$WARP_SYNC longest-turn=$LONGEST_TURN background-memory=$MEMORY \
      $branches $sound"
  fi
  echo "server.sh: lecturer joins at http${whep_tls:+s}://$(hostname -f 2>/dev/null || hostname):$WHEP_PORT/?token=$TOKEN"
fi
# --- end of the WebRTC lecturer output ---------------------------------------------------------------
# shellcheck disable=SC2086
# STATS > 0: every STATS frames each decoder posts what it got (printed by -m).
verbose=""
[ "$STATS" -gt 0 ] && verbose="-m"
run_launch -e $verbose $desc
