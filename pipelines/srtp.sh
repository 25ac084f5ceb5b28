# Sourced by classroom.sh, server.sh and lecturer.sh: SRTP on their RTP links when SRTP_KEY names a key
# file (30 bytes: AES_CM_128_HMAC_SHA1_80's key and salt; make one with `head -c 30 /dev/urandom > srtp.key`
# and copy it to every machine of the flow). Sets RTP_MEDIA (the caps' media type the receivers' udpsrc
# declare), SRTP_ENC (an srtpenc step to put before a sender's udpsink) and srtp_dec (the step after a
# receiver's senderfilter). Empty SRTP_KEY: plain RTP (the default).
RTP_MEDIA=application/x-rtp
SRTP_ENC=""
srtp_dec() { :; }
if [ -n "${SRTP_KEY:-}" ]; then
  if [ ! -r "$SRTP_KEY" ] || [ "$(wc -c < "$SRTP_KEY")" -ne 30 ]; then
    echo "$(basename "$0"): SRTP_KEY '$SRTP_KEY' must be a readable file of exactly 30 bytes (head -c 30 /dev/urandom > srtp.key)" >&2
    exit 2
  fi
  RTP_MEDIA=application/x-srtp
  SRTP_ENC="srtpenc key=$(od -An -tx1 -v "$SRTP_KEY" | tr -d ' \n') !"
  srtp_dec() { echo "srtpfiledec key-file=$SRTP_KEY !"; }
fi
