#!/usr/bin/env python3
"""Writes the depth link's seed frames (tests/fuzz/corpus/depth_link) from docs/network.md's description of
the depth frame ("VCDL", version 2) alone, so that DepthLink.FramesWrittenFromTheDocumentationDecode checks
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


class Encoder:
    def __init__(self):
        self.low, self.range, self.cache, self.pending, self.out = 0, 0xFFFFFFFF, 0, 1, bytearray()
        self.models = {}

    def bit(self, model, b):
        p = self.models.get(model, 2048)
        bnd = (self.range >> 12) * p
        if not b:
            self.range = bnd
            p += (4096 - p) >> 5
        else:
            self.low += bnd
            self.range -= bnd
            p -= p >> 5
        self.models[model] = p
        while self.range < 1 << 24:
            self.range = (self.range << 8) & 0xFFFFFFFF
            self.shift()

    def shift(self):
        if self.low % 2**32 < 0xFF000000 or self.low >= 2**32:
            carry = self.low >> 32
            self.out.append((self.cache + carry) % 256)
            for _ in range(self.pending - 1):
                self.out.append((0xFF + carry) % 256)
            self.pending = 0
            self.cache = (self.low >> 24) & 0xFF
        self.pending += 1
        self.low = (self.low % 2**24) << 8

    def magnitude(self, c, v):
        n = v.bit_length() - 1
        for i in range(n):
            self.bit(("length", c, i), 1)
        if n < 16:
            self.bit(("length", c, n), 0)
        for j in range(n - 1, -1, -1):
            self.bit(("mantissa", c, n, j), (v >> j) & 1)

    def finish(self):
        for _ in range(5):
            self.shift()
        return bytes(self.out)


def depth_section(rows, key, t, memory, history):
    """Codes one frame; `memory` (last decoded measurement) and `history` are updated as the decoder's."""
    bin_of, centre = bins(t)
    h, w = len(rows), len(rows[0])
    k = 1 if key else 0
    if key:
        for y in range(h):
            memory[y] = [0] * w
            history[y] = [0] * w
    enc = Encoder()
    state = [[0] * w for _ in range(h)]
    s = lambda y, x: state[y][x] if 0 <= y and 0 <= x < w else 0
    for y in range(h):
        run = 0
        for x in range(w):
            z = rows[y][x]
            n = (s(y, x - 1) != 0) + 2 * (s(y - 1, x) != 0) + 4 * (s(y - 1, x - 1) != 0) + 8 * (s(y - 1, x + 1) != 0)
            hist = history[y][x]
            enc.bit(("measured", k, 16 * hist + n), z != 0)
            history[y][x] = (2 * hist + (z != 0)) % 4
            if z == 0:
                continue
            p = run if key else memory[y][x]
            if p == 0:
                enc.magnitude(2, bin_of[z])
                v, st = centre[bin_of[z]], 2
            else:
                changed = abs(z - p) > bound(z, t)
                enc.bit(("changed", k, 9 * (hist & 1) + 3 * s(y, x - 1) + s(y - 1, x)), changed)
                v, st = p, 1
                if changed and key:
                    enc.bit(("sign", 1), bin_of[z] < bin_of[p])
                    enc.magnitude(1, abs(bin_of[z] - bin_of[p]))
                    v, st = centre[bin_of[z]], 2
                elif changed:
                    # t = 0 in these seeds: the step grid is 1 mm and z itself is on it (the encoder may
                    # always step; escaping to the row's bin is its choice where that is shorter).
                    assert t == 0
                    enc.bit("escape", 0)
                    enc.bit(("sign", 0), z < p)
                    enc.magnitude(0, abs(z - p))
                    v, st = z, 2
            state[y][x] = st
            memory[y][x] = run = v
    return enc.finish()


def frame(rows, labels, key, number, t, memory, history):
    depth = depth_section(rows, key, t, memory, history)
    label = zlib.compress(bytes(sum(labels, []))) if labels else b""
    flags = (1 if key else 0) | (2 if labels else 0)
    head = b"VCDL" + struct.pack("<BBHHHIIII", 2, flags, t, len(rows[0]), len(rows), number, len(CAPS), len(depth),
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
    memory, history = [None, None], [None, None]
    key = frame([[1000, 1000, 0, 1002], [0, 0, 1003, 1003]], [[0, 0, 1, 1], [0, 2, 2, 0]], True, 0, 0, memory, history)
    delta = frame([[1000, 1001, 1001, 1002], [0, 0, 1003, 0]], None, False, 1, 0, memory, history)
    files = {"key-4x2-lossless.vcdl": key, "delta-4x2-lossless.vcdl": delta, "truncated-key.vcdl": key[:40],
             "access-unit-with-depth-sei.h264": access_unit(key)}
    for name, data in files.items():
        with open(os.path.join(out, name), "wb") as f:
            f.write(data)


if __name__ == "__main__":
    main()
