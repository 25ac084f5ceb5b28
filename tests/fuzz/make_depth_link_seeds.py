#!/usr/bin/env python3
"""Writes the depth link's seed frames (tests/fuzz/corpus/depth_link) from docs/network.md's description of
the depth frame ("VCDL", version 3) alone, so that DepthLink.FramesWrittenFromTheDocumentationDecode checks
that the description is enough to write a sender. Usage: make_depth_link_seeds.py [CORPUS_DIR]"""
import os
import struct
import sys
import zlib

CAPS = b"video/x-rgbd, width=(int)4, height=(int)2, framerate=(fraction)30/1"
UUID = bytes.fromhex("6b1f2d904e3a470c9d55a821c37e10d4")


def bound(z, t):
    return t * z * z // 10**8


def bins(t):
    """bin_of[z] and centre[bin] (bin 0: no measurement)."""
    bin_of, centre = [0] * 65536, [0]
    a = 1
    while a < 65536:
        e = bound(a, t)
        end = min(a + 2 * e + 1, 65536)
        centre.append(min(a + e, 65535))
        for z in range(a, end):
            bin_of[z] = len(centre) - 1
        a = end
    return bin_of, centre


class Bits:
    """The depth section's bit writer: most significant bit first, the last byte padded with zeros."""

    def __init__(self):
        self.bits = []

    def put(self, v, n):
        self.bits += [(v >> i) & 1 for i in range(n - 1, -1, -1)]

    def finish(self):
        b = self.bits + [0] * (-len(self.bits) % 8)
        return bytes(int("".join(map(str, b[i:i + 8])), 2) for i in range(0, len(b), 8))


class Contexts:
    """The adaptive Golomb-Rice contexts (A, N), all (4, 1) at the start of every frame."""

    def __init__(self):
        self.state = {}

    def code(self, out, ctx, v):
        a, n = self.state.get(ctx, (4, 1))
        k = 0
        while k < 17 and (n << k) < a:
            k += 1
        if v >> k < 6:
            out.put(1, (v >> k) + 1)
            out.put(v & ((1 << k) - 1), k)
        else:
            u = v - (6 << k) + 1
            out.put(0, 6 + u.bit_length() - 1)
            out.put(u, u.bit_length())
        a, n = a + v, n + 1
        if n == 4:
            a, n = a >> 1, 2
        self.state[ctx] = (a, n)


def zigzag(d):
    return 2 * d if d >= 0 else -2 * d - 1


def step_context(p, left, t, bin_of):
    e = bound(p, t)
    size = 0 if e <= 1 else 1 if e <= 5 else 2 if e <= 13 else 3 if e <= 29 else 4
    edge = 2 if left == 0 else 1 if abs(bin_of[p] - bin_of[left]) > 1 else 0
    return 3 * size + edge


def depth_section(rows, key, t, memory):
    """Codes one frame; `memory` (each pixel's last value since the key frame) is updated as the decoder's."""
    bin_of, centre = bins(t)
    h, w = len(rows), len(rows[0])
    if key:
        for y in range(h):
            memory[y] = [0] * w
    out, c = Bits(), Contexts()
    for y in range(h):
        z = rows[y]
        # The runs: measured from x = 0 (maybe empty), then holes, measured ..., each but the first at least 1.
        runs, x, measured = [], 0, True
        while x < w:
            start = x
            while x < w and (z[x] != 0) == measured:
                x += 1
            runs.append(x - start)
            measured = not measured
        x = 0
        for i, r in enumerate(runs):
            above = y == 0 or rows[y - 1][x] != 0
            c.code(out, ("run", 2 * (i % 2) + above), r - (1 if i > 0 else 0))
            x += r
        left, kept = 0, 0  # the row's last depth so far; measured pixels kept since the last one sent
        for x in range(w):
            if z[x] == 0:
                continue
            p = left if key else memory[y][x]
            if p != 0 and abs(z[x] - p) <= bound(z[x], t):
                kept += 1
                memory[y][x] = left = p
                continue
            c.code(out, "gap", kept)
            kept = 0
            if key and left != 0:
                c.code(out, ("row", 1), zigzag(bin_of[z[x]] - bin_of[left]) - 1)
            elif key or p == 0:
                c.code(out, "bin", bin_of[z[x]]) if left == 0 else c.code(out, ("row", 0), zigzag(bin_of[z[x]] - bin_of[left]))
            elif t == 0:  # a step of z - p (the grid is 1 mm at t = 0)
                k = z[x] - p
                c.code(out, ("step", step_context(p, left, t, bin_of)), 2 * k - 1 if k > 0 else -2 * k)
                memory[y][x] = left = z[x]
                continue
            else:  # escape: the bin, against the row's last depth
                c.code(out, ("step", step_context(p, left, t, bin_of)), 0)
                c.code(out, "bin", bin_of[z[x]]) if left == 0 else c.code(out, ("row", 0), zigzag(bin_of[z[x]] - bin_of[left]))
            memory[y][x] = left = centre[bin_of[z[x]]]
        c.code(out, "gap", kept)  # the row's end
    return out.finish()


def frame(rows, labels, key, number, t, memory):
    depth = depth_section(rows, key, t, memory)
    label = zlib.compress(bytes(sum(labels, []))) if labels else b""
    flags = (1 if key else 0) | (2 if labels else 0)
    head = b"VCDL" + struct.pack("<BBHHHIIII", 3, flags, t, len(rows[0]), len(rows), number, len(CAPS), len(depth),
                                 len(label))
    body = CAPS + depth + label
    crc = zlib.crc32(body, zlib.crc32(head))
    return head + struct.pack("<I", crc) + body


def escape_emulation(rbsp):
    out, zeros = bytearray(), 0
    for b in rbsp:
        if zeros >= 2 and b <= 3:
            out.append(3)
            zeros = 0
        out.append(b)
        zeros = zeros + 1 if b == 0 else 0
    return bytes(out)


def access_unit(vcdl):
    size = len(UUID) + len(vcdl)
    payload = bytes([5]) + b"\xff" * (size // 255) + bytes([size % 255]) + UUID + vcdl + b"\x80"
    sps, pps, slice_ = bytes.fromhex("6742c01e"), bytes.fromhex("68ce3c80"), bytes.fromhex("658884 21a0".replace(" ", ""))
    start = b"\x00\x00\x00\x01"
    return start + sps + start + pps + start + b"\x06" + escape_emulation(payload) + start + slice_


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "corpus", "depth_link")
    memory = [None, None]
    key = frame([[1000, 1000, 0, 1002], [0, 0, 1003, 1003]], [[0, 0, 1, 1], [0, 2, 2, 0]], True, 0, 0, memory)
    delta = frame([[1000, 1001, 1001, 1002], [0, 0, 1003, 0]], None, False, 1, 0, memory)
    # Within the default bound (t = 280: e = 2 mm at 1 m, 25 mm at 3 m): kept values, a step and a bin.
    memory = [None, None]
    near_key = frame([[1000, 1001, 3000, 0], [2990, 0, 3003, 3010]], None, True, 0, 280, memory)
    near_delta = frame([[1001, 1009, 3040, 3000], [2995, 2990, 0, 3012]], None, False, 1, 280, memory)
    files = {"key-4x2-lossless.vcdl": key, "delta-4x2-lossless.vcdl": delta, "truncated-key.vcdl": key[:40],
             "key-4x2-t280.vcdl": near_key, "delta-4x2-t280.vcdl": near_delta,
             "access-unit-with-depth-sei.h264": access_unit(key)}
    for name, data in files.items():
        with open(os.path.join(out, name), "wb") as f:
            f.write(data)


if __name__ == "__main__":
    main()
