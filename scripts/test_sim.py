#!/usr/bin/env python3
"""Tests of the C++ Verilator harness (src/test/cpp/ielas_sim.cpp) and scripts/sim.sh on the stand-in top
src/test/cpp/stub/IElas.sv, built once for the `small` configuration (128x64).

The stub outputs left*16 for each pixel. Input row y is released to the output once row y+L has arrived (or the
frame is complete), seen C cycles late (+stub_lat_rows=L, +stub_extra=C). Without gaps and stalls, F frames of
WxH therefore take exactly F*W*H + (L+1)*W + C cycles, and every row's last output follows its last input by
(L+1)*W + C cycles, i.e. ceil(((L+1)*W + C) / W) latency rows. These tests compare the harness's numbers with
those hand-computed values, its disparity.npy with left*16, and check that every fault the stub can inject
(+stub_fault=N) and every bad input ends with the documented exit code and message. The soak mode (ielas_sim
soak-plan / soak, scripts/soak.sh) is tested the same way: good frames against left*16, and the malformed frames
the stub neither flags nor pads must make the run fail with the documented exit code.

Run: python3 scripts/test_sim.py   (no numpy needed; images are PGM files written here)
"""
import csv
import os
import random
import re
import struct
import subprocess
import tempfile
import time
import unittest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SIM = os.path.join(ROOT, "scripts", "sim.sh")
CONFIG = "small"  # maxWidth 128, maxHeight 64


def write_pgm(path, w, h, pixels, maxval=255):
    with open(path, "wb") as f:
        f.write(b"P5\n%d %d\n%d\n" % (w, h, maxval))
        if maxval > 255:
            f.write(b"".join(struct.pack(">H", p) for p in pixels))
        else:
            f.write(bytes(pixels))


def read_npy_i2(path):
    """A minimal .npy v1.0 reader for '<i2' 2-D arrays: (shape, values)."""
    with open(path, "rb") as f:
        data = f.read()
    assert data[:6] == b"\x93NUMPY", "not an .npy file"
    assert data[6:8] == b"\x01\x00", "not .npy version 1.0"
    hlen = struct.unpack("<H", data[8:10])[0]
    header = data[10:10 + hlen].decode("latin1")
    assert (10 + hlen) % 64 == 0, "header not padded to 64 bytes"
    assert "'descr': '<i2'" in header and "'fortran_order': False" in header, header
    shape = tuple(int(s) for s in re.search(r"'shape': \((\d+), (\d+)\)", header).groups())
    body = data[10 + hlen:]
    assert len(body) == 2 * shape[0] * shape[1], "body size does not match the shape"
    return shape, list(struct.unpack("<%dh" % (shape[0] * shape[1]), body))


def write_npy_i2(path, h, w, values):
    header = "{'descr': '<i2', 'fortran_order': False, 'shape': (%d, %d), }" % (h, w)
    header += " " * ((64 - (10 + len(header) + 1) % 64) % 64) + "\n"
    with open(path, "wb") as f:
        f.write(b"\x93NUMPY\x01\x00" + struct.pack("<H", len(header)) + header.encode("latin1"))
        f.write(struct.pack("<%dh" % len(values), *values))


def read_pgm(path):
    """(w, h, pixels) of a binary 8-bit PGM with a plain header (as soak-plan writes them)."""
    with open(path, "rb") as f:
        data = f.read()
    m = re.match(rb"P5\s+(\d+)\s+(\d+)\s+255\s", data)
    assert m, "not an 8-bit binary PGM: " + path
    w, h = int(m.group(1)), int(m.group(2))
    return w, h, list(data[m.end():m.end() + w * h])


def report_value(stdout, key):
    m = re.search(r"^%s: (\S+)" % re.escape(key), stdout, re.M)
    if not m:
        raise AssertionError("no '%s:' line in:\n%s" % (key, stdout))
    return m.group(1)


class HarnessTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        build = subprocess.run([SIM, "build", CONFIG, "--stub"], capture_output=True, text=True)
        if build.returncode != 0:
            raise RuntimeError("stub build failed:\n" + build.stdout + build.stderr)
        print(build.stdout.strip())
        cls.bin = subprocess.run([SIM, "path", CONFIG, "--stub"], capture_output=True, text=True,
                                 check=True).stdout.strip()
        cls.tmp = tempfile.TemporaryDirectory(prefix="ielas-sim-test-")
        cls.dir = cls.tmp.name
        rng = random.Random(20261123)
        cls.images = {}
        for name, (w, h) in {"a": (100, 40), "b": (128, 64), "c": (32, 16)}.items():
            left = [rng.randrange(256) for _ in range(w * h)]
            right = [rng.randrange(256) for _ in range(w * h)]
            write_pgm(cls.path(name + "_L.pgm"), w, h, left)
            write_pgm(cls.path(name + "_R.pgm"), w, h, right)
            cls.images[name] = (w, h, left)

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    @classmethod
    def path(cls, name):
        return os.path.join(cls.dir, name)

    def run_sim(self, image="a", args=(), out="out", left=None, right=None, config=CONFIG):
        cmd = [self.bin, "--left", left or self.path(image + "_L.pgm"), "--right", right or self.path(image + "_R.pgm"),
               "--out", self.path(out)]
        if config is not None:
            cmd += ["--config", config]
        return subprocess.run(cmd + list(args), capture_output=True, text=True, timeout=120)

    def check_ok(self, image, args, lat_rows, extra, frames=1, out="out"):
        w, h, left = self.images[image]
        r = self.run_sim(image, ["+stub_lat_rows=%d" % lat_rows, "+stub_extra=%d" % extra, "--frames", str(frames)]
                         + list(args), out=out)
        self.assertEqual(r.returncode, 0, r.stdout + r.stderr)
        self.assertEqual(report_value(r.stdout, "framing errors"), "0")
        self.assertEqual(report_value(r.stdout, "error"), "0")
        shape, values = read_npy_i2(self.path(out + "/disparity.npy"))
        self.assertEqual(shape, (h, w))
        mismatches = [(i % w, i // w, v, 16 * left[i]) for i, v in enumerate(values) if v != 16 * left[i]]
        self.assertEqual(mismatches[:5], [], "%d values differ from left*16 (x, y, got, want)" % len(mismatches))
        cycles = int(report_value(r.stdout, "cycles"))
        with open(self.path(out + "/cycles.txt")) as f:
            self.assertEqual(int(f.read().strip()), cycles)
        return r, cycles, int(report_value(r.stdout, "latency rows"))

    # ---- cycle counts and latency against hand-computed values (no gaps, no stalls) ----

    def test_one_frame_exact_cycles_and_latency(self):
        for image, lat, extra in [("a", 2, 3), ("a", 0, 0), ("b", 3, 0), ("c", 1, 64), ("a", 8, 1)]:
            w, h, _ = self.images[image]
            with self.subTest(image=image, lat_rows=lat, extra=extra):
                r, cycles, latency = self.check_ok(image, [], lat, extra)
                self.assertEqual(cycles, w * h + (lat + 1) * w + extra)
                self.assertEqual(latency, lat + 1 + -(-extra // w))  # ceil(((L+1)W + C) / W)
                cpp = cycles / (w * h)
                self.assertEqual(report_value(r.stdout, "cycles/pixel"), "%.3f" % cpp)
                self.assertEqual(report_value(r.stdout, "fps@200MHz"), "%.1f" % (200e6 / (cpp * w * h)))

    def test_frames_back_to_back(self):
        w, h, _ = self.images["a"]
        for frames in (2, 5):
            with self.subTest(frames=frames):
                _, cycles, latency = self.check_ok("a", [], 1, 0, frames=frames)
                self.assertEqual(cycles, frames * w * h + 2 * w)
                self.assertEqual(latency, 2)

    def test_input_back_pressure(self):
        # The stub's in_ready is low on cycles K-1, 2K-1, ...: pixel k enters at cycle k + k // (K-1); after the
        # last pixel, the last L+1 rows leave at one pixel per cycle, C cycles after the frame end is seen.
        w, h, _ = self.images["a"]
        n, lat, extra, k = w * h, 2, 5, 4
        _, cycles, _ = self.check_ok("a", ["+stub_bp=%d" % k], lat, extra)
        last_in = (n - 1) + (n - 1) // (k - 1)
        self.assertEqual(cycles, last_in + 1 + extra + (lat + 1) * w)

    # ---- random gaps and back-pressure: every value and the framing still hold ----

    def test_random_gaps_and_stalls(self):
        w, h, _ = self.images["b"]
        for gaps, stalls, seed in [(0.3, 0.0, 1), (0.0, 0.5, 2), (0.5, 0.5, 3), (0.9, 0.2, 4)]:
            with self.subTest(gaps=gaps, stalls=stalls, seed=seed):
                args = ["--gaps", str(gaps), "--stalls", str(stalls), "--seed", str(seed), "+stub_bp=7"]
                r, cycles, _ = self.check_ok("b", args, 2, 3, frames=2)
                self.assertIn("seed %d" % seed, r.stdout)
                self.assertGreater(cycles, 2 * w * h)
                again = self.run_sim("b", ["+stub_lat_rows=2", "+stub_extra=3", "--frames", "2", "+stub_bp=7"] + args,
                                     out="again")
                self.assertEqual(int(report_value(again.stdout, "cycles")), cycles, "same seed, different cycles")

    # ---- faults of the model: framing (exit 2), timeout (exit 3), error bit (exit 4) ----

    def check_fault(self, fault, code, stderr_pattern, extra_args=(), stdout_pattern=None):
        r = self.run_sim("a", ["+stub_fault=%d" % fault, "--frames", "2"] + list(extra_args))
        self.assertEqual(r.returncode, code, r.stdout + r.stderr)
        self.assertRegex(r.stderr, stderr_pattern)
        self.assertEqual(len(r.stderr.strip().splitlines()), 1, r.stderr)
        if stdout_pattern:
            self.assertRegex(r.stdout, stdout_pattern)
        return r

    def test_row_cycles(self):
        # --row-cycles: each row's last input cycle under the stub's back-pressure (pixel k enters k + k // (K-1)
        # cycles after the first), and the last row's last output is the end of the measured cycles
        w, h, _ = self.images["a"]
        k = 4
        _, cycles, _ = self.check_ok("a", ["+stub_bp=%d" % k, "--row-cycles"], 2, 5, out="rows")
        with open(self.path("rows/row_cycles.csv")) as f:
            rows = list(csv.DictReader(f))
        self.assertEqual([(int(x["frame"]), int(x["row"])) for x in rows], [(0, y) for y in range(h)])
        enters = lambda i: i + i // (k - 1)
        first = int(rows[0]["last_input_cycle"]) - enters(w - 1)
        self.assertEqual([int(x["last_input_cycle"]) - first for x in rows], [enters((y + 1) * w - 1) for y in range(h)])
        self.assertEqual(int(rows[-1]["last_output_cycle"]) - first + 1, cycles)

    def test_fault_missing_eol(self):
        self.check_fault(1, 2, r"^ielas_sim: 1 framing error\(s\)",
                         stdout_pattern=r"framing error: frame 0 output pixel \(x=99, y=1\): sof/eol/eof 000, expected 010")

    def test_fault_missing_eof(self):
        self.check_fault(2, 2, r"framing error",
                         stdout_pattern=r"frame 0 output pixel \(x=99, y=39\): sof/eol/eof 010, expected 011")

    def test_fault_sof_mid_frame(self):
        self.check_fault(5, 2, r"framing error",
                         stdout_pattern=r"frame 0 output pixel \(x=0, y=1\): sof/eol/eof 100, expected 000")

    def test_fault_early_eol(self):
        r = self.check_fault(6, 2, r"^ielas_sim: 2 framing error\(s\)")
        self.assertIn("(x=98, y=0): sof/eol/eof 010, expected 000", r.stdout)
        self.assertIn("(x=99, y=0): sof/eol/eof 000, expected 010", r.stdout)

    def test_fault_output_stops(self):
        self.check_fault(3, 3, r"timeout: no output progress for 5000 cycles \(100 of 8000 output pixels\)",
                         extra_args=["--timeout", "5000"])

    def test_fault_error_bit(self):
        r = self.check_fault(4, 4, r"error bit")
        self.assertEqual(report_value(r.stdout, "error"), "1")

    # ---- bad inputs: one line on stderr, exit 1 ----

    def check_bad(self, args_or_kw, pattern):
        r = self.run_sim(**args_or_kw)
        self.assertEqual(r.returncode, 1, r.stdout + r.stderr)
        self.assertEqual(len(r.stderr.strip().splitlines()), 1, r.stderr)
        self.assertRegex(r.stderr, pattern)

    def test_bad_inputs(self):
        rng = random.Random(5)
        write_pgm(self.path("big.pgm"), 129, 40, [rng.randrange(256) for _ in range(129 * 40)])
        write_pgm(self.path("tall.pgm"), 100, 65, [rng.randrange(256) for _ in range(100 * 65)])
        write_pgm(self.path("tiny.pgm"), 31, 16, [0] * (31 * 16))
        write_pgm(self.path("deep.pgm"), 100, 40, [1000] * (100 * 40), maxval=65535)
        with open(self.path("junk.png"), "wb") as f:
            f.write(b"not an image")
        with open(self.path("broken.json"), "w") as f:
            f.write("{ \"maxWidth\": 128, ")
        cases = [
            ({"left": self.path("missing.pgm")}, r"cannot read image .*missing\.pgm"),
            ({"left": self.path("junk.png")}, r"junk\.png: not a PNG or PGM image"),
            ({"left": self.path("deep.pgm"), "right": self.path("deep.pgm")},
             r"deep\.pgm: 16-bit PGM \(maxval 65535; 8-bit expected\)"),
            ({"right": self.path("b_R.pgm")}, r"left/right size mismatch: 100x40 vs 128x64"),
            ({"left": self.path("big.pgm"), "right": self.path("big.pgm")}, r"129x40 is outside 32x16\.\.128x64"),
            ({"left": self.path("tall.pgm"), "right": self.path("tall.pgm")}, r"100x65 is outside"),
            ({"left": self.path("tiny.pgm"), "right": self.path("tiny.pgm")}, r"31x16 is outside"),
            ({"config": "no-such-config"}, r"unknown configuration 'no-such-config'"),
            ({"config": self.path("broken.json")}, r"broken\.json"),
            ({"args": ["--gaps", "1.5"]}, r"--gaps wants a probability in \[0, 1\)"),
            ({"args": ["--frames", "0"]}, r"--frames wants an integer in 1\.\."),
            ({"args": ["--seed", "x"]}, r"--seed wants an integer"),
            ({"args": ["--bogus", "1"]}, r"unknown option --bogus"),
            ({"args": ["--frames"]}, r"option --frames needs a value"),
            ({"args": ["--max-width", "200"]}, r"give both --max-width and --max-height"),
        ]
        for kw, pattern in cases:
            with self.subTest(kw=kw):
                self.check_bad(kw, pattern)

    def test_max_size_from_command_line(self):
        # --max-width/--max-height override the configuration's size: a 100x40 pair fails a 64x64 maximum
        r = self.run_sim("a", ["--max-width", "64", "--max-height", "64"])
        self.assertEqual(r.returncode, 1, r.stdout + r.stderr)
        self.assertIn("100x40 is outside 32x16..64x64", r.stderr)
        # and the built-in default configuration (small) is used without --config
        r = self.run_sim("c", ["+stub_lat_rows=0", "+stub_extra=0"], config=None)
        self.assertEqual(r.returncode, 0, r.stdout + r.stderr)
        self.assertIn("(max 128x64)", r.stdout)

    # ---- --expect: the last frame against a reference .npy ----

    def test_expect(self):
        w, h, left = self.images["a"]
        good = [16 * v for v in left]
        write_npy_i2(self.path("expect_good.npy"), h, w, good)
        r = self.run_sim("a", ["--frames", "2", "--expect", self.path("expect_good.npy")])
        self.assertEqual(r.returncode, 0, r.stdout + r.stderr)
        self.assertEqual(report_value(r.stdout, "mismatches"), "0")
        bad = list(good)
        bad[3 * w + 7] = -1
        bad[5 * w + 9] += 16
        write_npy_i2(self.path("expect_bad.npy"), h, w, bad)
        r = self.run_sim("a", ["--expect", self.path("expect_bad.npy")])
        self.assertEqual(r.returncode, 5, r.stdout + r.stderr)
        self.assertEqual(report_value(r.stdout, "mismatches"), "2")
        self.assertIn("first mismatch: disparity.npy (x=7, y=3) hardware %d, expected -1" % good[3 * w + 7], r.stdout)
        self.assertRegex(r.stderr, r"^ielas_sim: 2 of 4000 values differ from ")
        write_npy_i2(self.path("expect_shape.npy"), w, h, good)
        r = self.run_sim("a", ["--expect", self.path("expect_shape.npy")])
        self.assertEqual(r.returncode, 1, r.stdout + r.stderr)
        self.assertIn("is not <i2 of shape (40, 100)", r.stderr)
        r = self.run_sim("a", ["--expect", self.path("missing.npy")])
        self.assertEqual(r.returncode, 1, r.stdout + r.stderr)

    def test_images(self):
        # --images: PFM (float32 little-endian, bottom row first) and KITTI PNG beside disparity.npy
        w, h, left = self.images["a"]
        r = self.run_sim("a", ["--images"], out="images")
        self.assertEqual(r.returncode, 0, r.stdout + r.stderr)
        with open(self.path("images/disparity.pfm"), "rb") as f:
            pfm = f.read()
        head = b"Pf\n%d %d\n-1.0\n" % (w, h)
        self.assertEqual(pfm[:len(head)], head)
        floats = struct.unpack("<%df" % (w * h), pfm[len(head):])
        self.assertEqual([floats[(h - 1 - y) * w + x] for y in (0, 17) for x in (0, 55)],
                         [float(left[y * w + x]) for y in (0, 17) for x in (0, 55)])
        with open(self.path("images/disparity_kitti.png"), "rb") as f:
            self.assertEqual(f.read(8), b"\x89PNG\r\n\x1a\n")

    # ---- demo (the `make run` job) ----

    def test_demo(self):
        golden = os.environ.get("IELAS_GOLDEN", os.path.join(ROOT, "golden", "build", "ielas-golden"))
        evaluate = os.environ.get("IELAS_EVAL", os.path.join(os.path.dirname(golden), "ielas-eval"))
        if not (os.access(golden, os.X_OK) and os.access(evaluate, os.X_OK)):
            self.skipTest("no golden model binaries (make golden, or set IELAS_GOLDEN)")
        env = dict(os.environ, IELAS_GOLDEN=golden, IELAS_EVAL=evaluate)
        w, h, left = self.images["a"]
        # ground truth = the stub's own output (disparity = left), so bad-3 must be exactly 0
        r = self.run_sim("a", ["--images"], out="gt")
        self.assertEqual(r.returncode, 0, r.stdout + r.stderr)
        demo = self.path("demo")
        r = subprocess.run([SIM, "demo", CONFIG, "--stub", "--left", self.path("a_L.pgm"), "--right",
                            self.path("a_R.pgm"), "--gt", self.path("gt/disparity.pfm"), "--out", demo],
                           capture_output=True, text=True, env=env)
        # the stub is not the accelerator: it differs from the golden model wherever disparity != left*16
        _, golden_values = read_npy_i2(os.path.join(demo, "golden", "disparity.npy"))
        want = sum(1 for g, l in zip(golden_values, left) if g != 16 * l)
        self.assertGreater(want, 0)
        self.assertEqual(r.returncode, 5, r.stdout + r.stderr)
        self.assertEqual(report_value(r.stdout, "mismatches"), str(want))
        self.assertEqual(report_value(r.stdout, "bad-3"), "0.00")
        self.assertEqual(report_value(r.stdout, "latency rows"), "4")
        self.assertEqual(report_value(r.stdout, "cycles/pixel"), "%.3f" % ((w * h + 3 * w + 3) / (w * h)))
        for f in ("disparity.png", "hardware/disparity.npy", "hardware/disparity.pfm", "hardware/disparity_kitti.png",
                  "hardware/cycles.txt"):
            self.assertTrue(os.path.isfile(os.path.join(demo, f)), f)
        # without ../shared/data: the synthetic scene (ielas-synth), cut to the configuration's 128x64, with its GT
        r = subprocess.run([SIM, "demo", CONFIG, "--stub", "--out", self.path("demo-synth")], capture_output=True,
                           text=True, env=dict(env, IELAS_DATA=self.path("no-data")))
        self.assertEqual(r.returncode, 5, r.stdout + r.stderr)
        self.assertRegex(r.stdout, r"run: small, pair \S*/build/run/synth-small/left\.pgm")
        self.assertIn("ielas_sim: 128x64 (max 128x64)", r.stdout)
        self.assertRegex(r.stdout, r"(?m)^bad-3: \d+\.\d\d$")

    # ---- soak mode (ielas_sim soak-plan / soak, scripts/soak.sh): the stub computes left*16 and checks only the
    # frame size, so good frames are compared with left*16 and malformed frames must be reported as not flagged ----

    def soak_frames(self, name, specs):
        """Writes a manifest of frames [(kind, w, h, gap, stall, a, b)] with seeded random images; a good frame's
        expected output is left*16. Returns (manifest path, [left pixels per frame])."""
        d = self.path(name)
        os.makedirs(d, exist_ok=True)
        rng = random.Random(name)
        lines, lefts = ["# test manifest"], []
        for i, (kind, w, h, gap, stall, a, b) in enumerate(specs):
            left = [rng.randrange(256) for _ in range(w * h)]
            write_pgm(os.path.join(d, "%d_L.pgm" % i), w, h, left)
            write_pgm(os.path.join(d, "%d_R.pgm" % i), w, h, [rng.randrange(256) for _ in range(w * h)])
            expect = "-"
            if kind == "good":
                expect = "%d.npy" % i
                write_npy_i2(os.path.join(d, expect), h, w, [16 * v for v in left])
            lines.append("%d %s %d %d %s %s %d %d test %d_L.pgm %d_R.pgm %s" % (i, kind, w, h, gap, stall, a, b, i, i,
                                                                              expect))
            lefts.append(left)
        with open(os.path.join(d, "manifest.txt"), "w") as f:
            f.write("\n".join(lines) + "\n")
        return os.path.join(d, "manifest.txt"), lefts

    def run_soak(self, manifest, args=()):
        return subprocess.run([self.bin, "soak", "--manifest", manifest, "--config", CONFIG] + list(args),
                              capture_output=True, text=True, timeout=120)

    GOOD = [("good", 100, 40, 0, 0, 0, 0), ("good", 32, 16, 0.3, 0.2, 0, 0), ("good", 128, 64, 0.1, 0.5, 0, 0),
            ("good", 57, 23, 0, 0.3, 0, 0), ("good", 100, 40, 0.5, 0, 0, 0)]

    def test_soak_good_frames(self):
        manifest, _ = self.soak_frames("soak-good", self.GOOD)
        r = self.run_soak(manifest, ["--seed", "3", "--progress", "2"])
        self.assertEqual(r.returncode, 0, r.stdout + r.stderr)
        self.assertEqual(report_value(r.stdout, "values compared"), str(sum(w * h for _, w, h, *_ in self.GOOD)))
        self.assertEqual(report_value(r.stdout, "mismatches"), "0")
        self.assertIn("frames streamed: 5 (5 good, 0 malformed", r.stdout)
        self.assertIn("soak: 4 of 5 frames out", r.stdout)
        self.assertEqual(report_value(r.stdout, "framing errors"), "0")
        self.assertEqual(report_value(r.stdout, "lost or shifted frames"), "0")
        self.assertTrue(r.stdout.rstrip().endswith("soak: passed"), r.stdout)
        # the seed drives the gaps and stalls: the same seed gives the same cycles, another seed other cycles
        again = self.run_soak(manifest, ["--seed", "3"])
        other = self.run_soak(manifest, ["--seed", "4"])
        self.assertEqual(report_value(again.stdout, "cycles"), report_value(r.stdout, "cycles"))
        self.assertNotEqual(report_value(other.stdout, "cycles"), report_value(r.stdout, "cycles"))
        # a manifest named without a directory: its paths are relative to the current directory
        here = subprocess.run([self.bin, "soak", "--manifest", "manifest.txt", "--config", CONFIG],
                              cwd=os.path.dirname(manifest), capture_output=True, text=True, timeout=120)
        self.assertEqual(here.returncode, 0, here.stdout + here.stderr)

    def test_soak_mismatch(self):
        manifest, lefts = self.soak_frames("soak-mismatch", self.GOOD)
        w, h = 57, 23
        values = [16 * v for v in lefts[3]]
        values[5 * w + 7] = -1
        write_npy_i2(os.path.join(os.path.dirname(manifest), "3.npy"), h, w, values)
        r = self.run_soak(manifest)
        self.assertEqual(r.returncode, 5, r.stdout + r.stderr)
        self.assertEqual(report_value(r.stdout, "mismatches"), "1")
        self.assertIn("mismatch: frame 3 (good 57x23 test) first at (x=7, y=5): hardware %d, expected -1"
                      % (16 * lefts[3][5 * w + 7]), r.stdout)
        self.assertEqual(r.stderr.strip(), "ielas_sim: soak: 1 of %d values differ from the golden model"
                         % sum(w * h for _, w, h, *_ in self.GOOD))

    def test_soak_truncated_frame_not_flagged(self):
        # the stub passes the 10 lines of the truncated frame 1 out with sof and eol but no eof (its eof comes from
        # the height): cut output as a malformed frame's, but no errorCauses and no frameAborted pulse
        manifest, _ = self.soak_frames("soak-trunc", [self.GOOD[0], ("trunc", 100, 40, 0.1, 0.1, 10, 0)] + self.GOOD[1:])
        r = self.run_soak(manifest)
        self.assertEqual(r.returncode, 4, r.stdout + r.stderr)
        self.assertIn("malformed frames flagged: 0 of 1", r.stdout)
        self.assertIn("not flagged: frame 1 (trunc 100x40 test) (truncated frame): errorCauses pulse no, "
                      "frameAborted pulse no", r.stdout)
        self.assertIn("malformed frames cut: 1 of 1 (whole lines, no eof; lines put out 10..10)", r.stdout)
        self.assertIn("errorCauses 0x00 at cycle", r.stdout)  # the next frame's sof should have pulsed bit 3
        self.assertEqual(report_value(r.stdout, "mismatches"), "0")  # every good frame still exact
        self.assertRegex(r.stderr, r"^ielas_sim: soak: 1 malformed frame\(s\) not flagged, \d+ flag error\(s\)\n$")

    def test_soak_short_line_shifts(self):
        # the stub does not pad a short line: its frame ends with eof 90 pixels early, which the harness must
        # report as a lost or shifted frame
        manifest, _ = self.soak_frames("soak-short", [self.GOOD[0], ("short", 100, 40, 0, 0, 3, 9)] + self.GOOD[1:])
        r = self.run_soak(manifest)
        self.assertEqual(r.returncode, 2, r.stdout + r.stderr)
        self.assertIn("framing error: frame 2 (good 32x16 test): 3910 output pixels up to eof, expected 512 "
                      "(frame lost or shifted)", r.stdout)
        self.assertNotEqual(report_value(r.stdout, "lost or shifted frames"), "0")

    def test_soak_faults(self):
        same = [("good", 100, 40, 0, 0, 0, 0)] * 3
        manifest, _ = self.soak_frames("soak-faults", same)
        for fault, code, pattern in [
                (2, 2, r"framing error: frame 0 \(good 100x40 test\): output cut after 4000 pixels without eof "
                       r"\(frame lost or shifted\)"),
                (3, 3, r"timeout: no output transfer for 5000 cycles"),
                (4, 4, r"flag error: error bit 1 at cycle \d+, expected 0"),
                (5, 2, r"framing error: frame 0 \(good 100x40 test\): output cut after 100 pixels without eof")]:
            with self.subTest(fault=fault):
                r = self.run_soak(manifest, ["+stub_fault=%d" % fault, "--timeout", "5000"])
                self.assertEqual(r.returncode, code, r.stdout + r.stderr)
                self.assertRegex(r.stdout, pattern)
                self.assertEqual(len(r.stderr.strip().splitlines()), 1, r.stderr)

    def test_soak_bad_manifest(self):
        d = self.path("soak-bad")
        manifest, _ = self.soak_frames("soak-bad", self.GOOD[:2])
        with open(manifest) as f:
            good = f.read()
        cases = [
            ("0 good 100 40 0 0 0 0 test 0_L.pgm\n", r"line 1: expected 12 fields"),
            (good + "2 short 100 40 0 0 3 9 test 0_L.pgm 0_R.pgm -\n", r"the last frame must be good"),
            ("0 good 129 40 0 0 0 0 test 0_L.pgm 0_R.pgm 0.npy\n", r"129x40 is outside 32x16\.\.128x64"),
            ("0 bent 100 40 0 0 0 0 test 0_L.pgm 0_R.pgm 0.npy\n", r"unknown frame kind 'bent'"),
            ("0 short 100 40 0 0 3 99 test 0_L.pgm 0_R.pgm -\n" + good, r"parameters a, b out of range"),
            ("0 good 100 40 0 0 0 0 test 0_L.pgm 0_R.pgm missing.npy\n", r"no expected output .*missing\.npy"),
            ("0 good 32 16 0 0 0 0 test 0_L.pgm 0_R.pgm 0.npy\n", r"0_L\.pgm is not 32x16"),
        ]
        for text, pattern in cases:
            with self.subTest(text=text.splitlines()[0]):
                with open(os.path.join(d, "bad.txt"), "w") as f:
                    f.write(text)
                r = self.run_soak(os.path.join(d, "bad.txt"))
                self.assertEqual(r.returncode, 1, r.stdout + r.stderr)
                self.assertEqual(len(r.stderr.strip().splitlines()), 1, r.stderr)
                self.assertRegex(r.stderr, pattern)

    def test_soak_plan(self):
        # without a dataset every frame is synthetic; frame 5, 15, ... is malformed (never the last), kinds cycling
        out = self.path("plan")
        args = [self.bin, "soak-plan", "--config", CONFIG, "--frames", "26", "--data", self.path("no-data")]
        r = subprocess.run(args + ["--seed", "9", "--out", out], capture_output=True, text=True)
        self.assertEqual(r.returncode, 0, r.stdout + r.stderr)
        self.assertIn("26 frames (24 good, 2 malformed; 0 dataset crops from 0 pairs, 26 synthetic)", r.stdout)
        with open(os.path.join(out, "manifest.txt")) as f:
            text = f.read()
        rows = [line.split() for line in text.splitlines() if not line.startswith("#")]
        self.assertEqual([row[0] for row in rows], [str(i) for i in range(26)])
        self.assertEqual([(row[0], row[1]) for row in rows if row[1] != "good"], [("5", "short"), ("15", "long")])
        self.assertEqual(rows[-1][1], "good")
        for row in rows:
            w, h = int(row[2]), int(row[3])
            self.assertTrue(32 <= w <= 128 and 16 <= h <= 64, row)
            self.assertEqual(read_pgm(os.path.join(out, row[9]))[:2], (w, h))
            self.assertEqual(read_pgm(os.path.join(out, row[10]))[:2], (w, h))
            self.assertEqual(row[11] == "-", row[1] != "good")
        # the same seed gives the same plan; another seed another one
        r = subprocess.run(args + ["--seed", "9", "--out", self.path("plan-again")], capture_output=True, text=True)
        with open(os.path.join(self.path("plan-again"), "manifest.txt")) as f:
            self.assertEqual(f.read(), text)
        r = subprocess.run(args + ["--seed", "10", "--out", self.path("plan-other")], capture_output=True, text=True)
        with open(os.path.join(self.path("plan-other"), "manifest.txt")) as f:
            self.assertNotEqual(f.read().splitlines()[2:], text.splitlines()[2:])
        # four malformed frames cycle through the four kinds
        r = subprocess.run(args[:4] + ["--frames", "40", "--malformed-every", "4", "--data", self.path("no-data"),
                                       "--out", self.path("plan-kinds")], capture_output=True, text=True)
        self.assertEqual(r.returncode, 0, r.stdout + r.stderr)
        with open(os.path.join(self.path("plan-kinds"), "manifest.txt")) as f:
            kinds = [line.split()[1] for line in f if not line.startswith("#")]
        self.assertEqual([k for k in kinds if k != "good"], ["short", "long", "sof", "trunc"] * 2 + ["short", "long"])
        self.assertEqual([i for i, k in enumerate(kinds) if k != "good"], list(range(2, 40, 4)))

    def test_soak_script(self):
        # scripts/soak.sh end to end on the stub: plan, golden model per good frame, run. Without malformed frames
        # the only failures are the stub's values, so the mismatch count must equal golden != left*16 over the frames.
        golden = os.environ.get("IELAS_GOLDEN", os.path.join(ROOT, "golden", "build", "ielas-golden"))
        if not os.access(golden, os.X_OK):
            self.skipTest("no golden model binary (make golden, or set IELAS_GOLDEN)")
        out = self.path("soak-script")
        r = subprocess.run([os.path.join(ROOT, "scripts", "soak.sh"), CONFIG, "--stub", "--frames", "8",
                            "--malformed-every", "0", "--seed", "2", "--out", out],
                           capture_output=True, text=True, env=dict(os.environ, IELAS_GOLDEN=golden), timeout=600)
        self.assertEqual(r.returncode, 5, r.stdout + r.stderr)
        want = total = 0
        with open(os.path.join(out, "manifest.txt")) as f:
            for line in f:
                if line.startswith("#"):
                    continue
                row = line.split()
                _, _, left = read_pgm(os.path.join(out, row[9]))
                _, values = read_npy_i2(os.path.join(out, row[11]))
                want += sum(1 for v, l in zip(values, left) if v != 16 * l)
                total += len(values)
        self.assertGreater(want, 0)
        self.assertEqual(report_value(r.stdout, "values compared"), str(total))
        self.assertEqual(report_value(r.stdout, "mismatches"), str(want))
        self.assertRegex(r.stdout, r"soak: golden model on 8 distinct good frames")
        self.assertRegex(r.stdout, r"(?m)^soak: total wall time [0-9.]+ s")
        with open(os.path.join(out, "soak.log")) as f:
            self.assertIn("values compared: %d" % total, f.read())
        r = subprocess.run([os.path.join(ROOT, "scripts", "soak.sh"), CONFIG, "--frames", "x"], capture_output=True,
                           text=True)
        self.assertEqual((r.returncode, r.stderr.strip()), (1, "soak.sh: --frames wants a positive integer, got 'x'"))

    # ---- the build script and bench ----

    def test_bench(self):
        r = subprocess.run([SIM, "bench", CONFIG, "--stub", "--left", self.path("a_L.pgm"), "--right",
                            self.path("a_R.pgm"), "--frames", "2"], capture_output=True, text=True)
        self.assertEqual(r.returncode, 0, r.stdout + r.stderr)
        # default stub timing L=2, C=3: 2*4000 + 3*100 + 3 cycles, 4 latency rows, c = 8303 - 8000 - 400
        self.assertRegex(r.stdout, r"\| no stalls \| 100x40 \| 2 \| 8303 \| 1\.038 \| 48175\.4 \| 4 \| -97 \| [0-9.]+ s, \d+ cycles/s \|")
        self.assertRegex(r.stdout, r"\| 10 % gaps, 10 % stalls \| 100x40 \| 2 \| \d+ \|")
        with open(os.path.join(ROOT, "build", "bench", "small-stub", "performance.md")) as f:
            self.assertIn("| no stalls | 100x40 | 2 | 8303 |", f.read())


    def test_build_is_cached(self):
        r = subprocess.run([SIM, "build", CONFIG, "--stub"], capture_output=True, text=True)
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertRegex(r.stdout, r"^sim build: up to date \(build/sim/stub-small/ielas_sim\)")

    def test_build_from_verilog_dir(self):
        # The non-stub path: every *.sv (and lint.vlt) in build/verilog/<config>/, rebuilt only when one changes.
        # The stub stands in for `make verilog` output under a configuration of its own (a copy of small).
        name = "harness-selftest"
        vdir = os.path.join(ROOT, "build", "verilog", name)
        os.makedirs(vdir, exist_ok=True)
        with open(os.path.join(ROOT, "src", "test", "cpp", "stub", "IElas.sv")) as f:
            stub = f.read()
        # keep the previous run's file when it holds the current stub, so a warm run builds once (for the change)
        top = os.path.join(vdir, "IElas.sv")
        if not os.path.isfile(top) or not open(top).read().startswith(stub):
            with open(top, "w") as f:
                f.write(stub)
        with open(os.path.join(vdir, "lint.vlt"), "w") as f:
            f.write("`verilator_config\nlint_off -rule UNUSEDSIGNAL\n")
        with open(os.path.join(ROOT, "golden", "configs", CONFIG + ".json")) as f:
            config = f.read()
        config_file = self.path(name + ".json")
        with open(config_file, "w") as f:
            f.write(config)
        builds = []
        for change in ("", "", "// changed %s\n" % time.time()):
            if change:
                with open(os.path.join(vdir, "IElas.sv"), "a") as f:
                    f.write(change)
            r = subprocess.run([SIM, "build", config_file], capture_output=True, text=True)
            self.assertEqual(r.returncode, 0, r.stdout + r.stderr)
            builds.append(r.stdout)
        rebuilt = [not re.search(r"^sim build: up to date", b, re.M) for b in builds]
        self.assertEqual(rebuilt[1:], [False, True], builds)
        self.assertRegex(builds[2], r"^sim build: \d+\.\d s \(build/sim/%s/ielas_sim\)" % name)
        r = subprocess.run([SIM, "run", config_file, "--left", self.path("a_L.pgm"), "--right", self.path("a_R.pgm"),
                            "--out", self.path("vdir-out"), "+stub_lat_rows=0", "+stub_extra=0"],
                           capture_output=True, text=True)
        self.assertEqual(r.returncode, 0, r.stdout + r.stderr)
        self.assertEqual(int(report_value(r.stdout, "cycles")), 100 * 40 + 100)
        # a top without the full ports (like the descriptor-only IElas): refused before Verilator runs
        old = "harness-selftest-old"
        os.makedirs(os.path.join(ROOT, "build", "verilog", old), exist_ok=True)
        with open(os.path.join(ROOT, "build", "verilog", old, "IElas.sv"), "w") as f:
            f.write(stub.replace("io_out_bits_data", "io_out_bits_data_left"))
        with open(self.path(old + ".json"), "w") as f:
            f.write(config)
        r = subprocess.run([SIM, "build", self.path(old + ".json")], capture_output=True, text=True)
        self.assertEqual(r.returncode, 1, r.stdout + r.stderr)
        self.assertIn("IElas.sv has no port io_out_bits_data: the harness needs the full top's ports", r.stderr)
        # a configuration (found through IELAS_CONFIG_DIR) without Verilog
        with open(self.path("no-verilog-here.json"), "w") as f:
            f.write(config)
        r = subprocess.run([SIM, "build", "no-verilog-here"], capture_output=True, text=True,
                           env=dict(os.environ, IELAS_CONFIG_DIR=self.dir))
        self.assertEqual(r.returncode, 1)
        self.assertIn("no Verilog in build/verilog/no-verilog-here (run make verilog", r.stderr)

    def test_build_script_errors(self):
        for args, pattern in [(["build", "no-such-config"], r"unknown configuration 'no-such-config'"),
                              (["frobnicate", CONFIG], r"unknown command 'frobnicate'")]:
            with self.subTest(args=args):
                r = subprocess.run([SIM] + args, capture_output=True, text=True)
                self.assertEqual(r.returncode, 1)
                self.assertRegex(r.stderr, pattern)


if __name__ == "__main__":
    unittest.main(verbosity=2)
