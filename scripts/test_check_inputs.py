#!/usr/bin/env python3
"""Tests of scripts/check_inputs.py, the Makefile's preflight: good inputs pass silently, every bad one gives exactly
one line on stderr, `check_inputs: ...` with its reason, and exit 2. The images are written here (a small PNG
encoder on zlib, PGM by hand). When golden/build/ielas-golden (or $IELAS_GOLDEN) exists, the bad stereo images are
also fed to it, which must refuse each with the same reason.

Run: python3 scripts/test_check_inputs.py   (a few seconds)
"""
import contextlib
import importlib.util
import io
import os
import struct
import subprocess
import sys
import tempfile
import unittest
import zlib

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CHECK = os.path.join(ROOT, "scripts", "check_inputs.py")
sys.dont_write_bytecode = True  # no __pycache__ beside the script
_spec = importlib.util.spec_from_file_location("check_inputs", CHECK)
check_inputs = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(check_inputs)
GOLDEN = os.environ.get("IELAS_GOLDEN", os.path.join(ROOT, "golden", "build", "ielas-golden"))


def chunk(ctype, data):
    return struct.pack(">I", len(data)) + ctype + data + struct.pack(">I", zlib.crc32(ctype + data))


def png_bytes(w, h, depth=8, colour=0, extra=b""):
    """A valid PNG of w x h (filter 0 rows of a pattern), any legal depth and colour type."""
    samples = {0: 1, 2: 3, 3: 1, 4: 2, 6: 4}[colour]
    row_bytes = (w * samples * depth + 7) // 8
    raw = b"".join(b"\0" + bytes((x * 7 + y * 3) % 256 for x in range(row_bytes)) for y in range(h))
    if colour == 3 and not extra:
        extra = chunk(b"PLTE", bytes(3 * (1 << depth)))  # a palette of 2^depth black entries
    ihdr = struct.pack(">IIBBBBB", w, h, depth, colour, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + extra + chunk(b"IDAT", zlib.compress(raw))
            + chunk(b"IEND", b""))


def pgm_bytes(w, h, maxval=255, comment=False, plain=False, pixels=None):
    n = w * h if pixels is None else pixels
    head = b"P2\n" if plain else b"P5\n"
    head += b"# written by test_check_inputs\n" if comment else b""
    head += b"%d %d\n%d\n" % (w, h, maxval)
    if plain:
        return head + b" ".join(b"%d" % (i % 256) for i in range(n)) + b"\n"
    return head + bytes(i % 256 for i in range(n * (2 if maxval > 255 else 1)))


def pfm_bytes(w, h, magic=b"Pf", pixels=None):
    n = w * h if pixels is None else pixels
    return magic + b"\n%d %d\n-1.0\n" % (w, h) + struct.pack("<%df" % n, *([1.5] * n))


class CheckInputsTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory(prefix="check_inputs_")
        d = cls.tmp.name
        good = png_bytes(64, 32)
        files = {
            "l.png": good, "r.png": png_bytes(64, 32),
            "rgb.png": png_bytes(64, 32, 8, 2), "rgba.png": png_bytes(64, 32, 8, 6),
            "palette.png": png_bytes(64, 32, 8, 3), "greyalpha.png": png_bytes(64, 32, 8, 4),
            "l.pgm": pgm_bytes(64, 32), "comment.pgm": pgm_bytes(64, 32, comment=True),
            "plain.pgm": pgm_bytes(64, 32, plain=True),
            "wide.png": png_bytes(65, 32), "small.png": png_bytes(31, 16), "big.png": png_bytes(129, 64),
            "notimage.png": b"hello, not an image\n", "empty.png": b"",
            "colour.ppm": b"P6\n64 32\n255\n" + bytes(64 * 32 * 3),
            "truncated.png": good[: len(good) // 2],
            "noiend.png": good[:-12],
            "noidat.png": good[:33] + chunk(b"IEND", b""),
            "noihdr.png": good[:8] + chunk(b"IEND", b""),
            "badihdr.png": png_bytes(64, 32)[:24] + bytes([3]) + good[25:],
            "bilevel.png": png_bytes(64, 32, 1, 0),
            "deep.png": png_bytes(64, 32, 16, 0),
            "deeprgb.png": png_bytes(64, 32, 16, 2),
            "palette4.png": png_bytes(64, 32, 4, 3),
            "truncated.pgm": pgm_bytes(64, 32, pixels=64 * 10),
            "deep.pgm": pgm_bytes(64, 32, maxval=65535),
            "badheader.pgm": b"P5\n64 x\n255\n" + bytes(64 * 32),
            "shortplain.pgm": pgm_bytes(64, 32, plain=True, pixels=3),
            "gt16.png": png_bytes(64, 32, 16, 0), "gt8.png": png_bytes(64, 32), "gt.pfm": pfm_bytes(64, 32),
            "gtwide.png": png_bytes(65, 32), "gt.pgm": pgm_bytes(64, 32),
            "gtcolour.pfm": pfm_bytes(64, 32, b"PF", pixels=64 * 32 * 3), "gtshort.pfm": pfm_bytes(64, 32, pixels=10),
            "cfg.json": b'{"name": "mine", "maxWidth": 64, "maxHeight": 32}',
            "broken.json": b'{"maxWidth": 128, ',
            "list.json": b"[1, 2]",
            "nowidth.json": b'{"maxHeight": 64}',
            "hugewidth.json": b'{"maxWidth": 10000, "maxHeight": 64}',
        }
        for name, data in files.items():
            with open(os.path.join(d, name), "wb") as f:
                f.write(data)

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def p(self, name):
        return os.path.join(self.tmp.name, name)

    def run_check(self, *args):
        """check_inputs.main in this process (fast); test_command_line runs the script itself."""
        out, err = io.StringIO(), io.StringIO()
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            code = check_inputs.main([CHECK, *args])
        return subprocess.CompletedProcess(args, code, out.getvalue(), err.getvalue())

    def ok(self, *args):
        r = self.run_check(*args)
        self.assertEqual((r.returncode, r.stdout, r.stderr), (0, "", ""), args)

    def bad(self, args, text):
        """Exit 2, exactly one line on stderr, `check_inputs: ` + a line that holds `text`; returns that line."""
        r = self.run_check(*args)
        self.assertEqual(r.returncode, 2, (args, r.stderr))
        self.assertEqual(r.stdout, "")
        lines = r.stderr.splitlines()
        self.assertEqual(len(lines), 1, r.stderr)
        self.assertTrue(lines[0].startswith("check_inputs: "), lines[0])
        self.assertIn(text, lines[0])
        return lines[0]

    def pair(self, left, right=None, config="small", *extra):
        return ["--left", self.p(left), "--right", self.p(right or left), "--config", config, *extra]

    # ---- good inputs: silent, exit 0 ----

    def test_good_inputs(self):
        self.ok(*self.pair("l.png", "r.png"))
        for name in ("rgb.png", "rgba.png", "palette.png", "greyalpha.png", "l.pgm", "comment.pgm", "plain.pgm"):
            with self.subTest(name=name):
                self.ok(*self.pair(name, "l.png"))
        self.ok(*self.pair("l.png", "r.png", "kitti", "--gt", self.p("gt16.png")))
        self.ok(*self.pair("l.png", "r.png", "kitti", "--gt", self.p("gt8.png")))
        self.ok(*self.pair("l.png", "r.png", self.p("cfg.json"), "--gt", self.p("gt.pfm")))
        self.ok("--config", "kitti")
        self.ok("--config=tsukuba", "--left=", "--right=", "--gt=")  # empty values count as not given
        self.ok("--left", "", "--right", "", "--gt", "", "--config", "", "--point", "")
        self.ok()

    def test_good_points(self):
        for grid in ("full", "quick"):
            names = subprocess.run([sys.executable, os.path.join(ROOT, "scripts", "sweep", "grid.py"), "names", grid],
                                   capture_output=True, text=True, check=True).stdout.split()
            self.assertTrue(names)
            self.ok("--point", names[0])

    # ---- images ----

    def test_unreadable(self):
        self.bad(self.pair("missing.png", "l.png"), f"LEFT={self.p('missing.png')}: cannot read image (No such file")
        self.bad(["--left", self.tmp.name, "--right", self.p("l.png")], "cannot read image (Is a directory)")
        self.bad(self.pair("l.png", "missing.pgm"), "RIGHT=")

    def test_not_png_or_pgm(self):
        self.bad(self.pair("notimage.png", "l.png"), "notimage.png: not a PNG or PGM image")
        self.bad(self.pair("empty.png", "l.png"), "empty.png: not a PNG or PGM image")
        self.bad(self.pair("colour.ppm", "l.png"), "colour.ppm: not a PNG or PGM image (a PPM)")

    def test_truncated_or_corrupt_png(self):
        self.bad(self.pair("truncated.png", "l.png"),
                 "truncated.png: truncated or corrupt PNG (a chunk runs past the end of the file)")
        self.bad(self.pair("l.png", "noiend.png"),
                 "RIGHT=" + self.p("noiend.png") + ": truncated or corrupt PNG (no IEND")
        self.bad(self.pair("noidat.png", "l.png"), "truncated or corrupt PNG (no IDAT chunk)")
        self.bad(self.pair("noihdr.png", "l.png"), "truncated or corrupt PNG (no IHDR chunk)")
        self.bad(self.pair("badihdr.png", "l.png"),
                 "truncated or corrupt PNG (IHDR: 64x32, bit depth 3, colour type 0)")

    def test_bit_depths(self):
        self.bad(self.pair("bilevel.png", "l.png"), "bilevel.png: 1-bit PNG (8-bit grey or colour expected)")
        self.bad(self.pair("deep.png", "l.png"), "deep.png: 16-bit PNG (8-bit grey or colour expected)")
        self.bad(self.pair("deeprgb.png", "l.png"), "deeprgb.png: 16-bit PNG (8-bit grey or colour expected)")
        self.bad(self.pair("palette4.png", "l.png"), "palette4.png: 4-bit palette PNG (8-bit grey or colour expected)")
        self.bad(self.pair("deep.pgm", "l.png"), "deep.pgm: 16-bit PGM (maxval 65535; 8-bit expected)")

    def test_bad_pgm(self):
        self.bad(self.pair("truncated.pgm", "l.png"),
                 "truncated.pgm: truncated PGM (64x32 needs 2048 bytes of pixels, the file has 640)")
        self.bad(self.pair("badheader.pgm", "l.png"),
                 "badheader.pgm: truncated or corrupt PGM (header: no valid height)")
        self.bad(self.pair("shortplain.pgm", "l.png"),
                 "shortplain.pgm: truncated or corrupt PGM (64x32 needs 2048 values, the file has 3)")

    def test_pair_and_sizes(self):
        self.bad(["--left", self.p("l.png")], "LEFT= given without RIGHT= (give both or neither)")
        self.bad(["--right", self.p("l.png")], "RIGHT= given without LEFT=")
        self.bad(["--left", self.p("missing.png")], "LEFT=" + self.p("missing.png") + ": cannot read image")
        self.bad(self.pair("l.png", "wide.png"), "LEFT and RIGHT differ in size: 64x32 (")
        self.bad(self.pair("big.png"), "size 129x64 is outside 32x16..128x64 (configuration small)")
        self.bad(self.pair("small.png"), "size 31x16 is outside 32x16..128x64 (configuration small)")
        self.bad(self.pair("l.png", "r.png", self.p("hugewidth.json")),
                 "maxWidth = 10000 is not an integer in 32..8192")
        self.ok(*self.pair("big.png", "big.png", "kitti"))
        self.bad(["--left", self.p("big.png"), "--right", self.p("big.png"), "--config", self.p("cfg.json")],
                 "outside 32x16..64x32 (configuration cfg)")

    def test_ground_truth(self):
        self.bad(self.pair("l.png", "r.png", "small", "--gt", self.p("gtwide.png")),
                 "GT=" + self.p("gtwide.png") + ": size 65x32, but LEFT is 64x32")
        self.bad(self.pair("l.png", "r.png", "small", "--gt", self.p("gt.pgm")),
                 "ground truth must be a .png or .pfm file")
        self.bad(self.pair("l.png", "r.png", "small", "--gt", self.p("missing.png")), "cannot read image")
        self.bad(self.pair("l.png", "r.png", "small", "--gt", self.p("deeprgb.png")), "16-bit colour PNG")
        self.bad(self.pair("l.png", "r.png", "small", "--gt", self.p("noiend.png")),
                 "truncated or corrupt PNG (no IEND")
        self.bad(self.pair("l.png", "r.png", "small", "--gt", self.p("gtcolour.pfm")), "colour PFM (grey Pf expected)")
        self.bad(self.pair("l.png", "r.png", "small", "--gt", self.p("gtshort.pfm")), "truncated PFM")
        self.ok("--gt", self.p("gt16.png"))  # alone: format only

    # ---- configurations, sweep points, options ----

    def test_configurations(self):
        legal = "legal: kitti, "
        line = self.bad(["--config", "missing"], "CONFIG=missing: unknown configuration (legal: ")
        for name in ("kitti", "small", "tsukuba"):
            self.assertIn(name, line)
        self.bad(["--config", "golden/configs/kitti"], "unknown configuration")
        self.bad(["--config", self.p("nothere.json")], "cannot read the configuration file (No such file")
        self.bad(["--config", self.p("broken.json")], "malformed JSON (")
        self.bad(["--config", self.p("list.json")], "not a JSON object")
        self.bad(["--config", self.p("nowidth.json")], "maxWidth = null is not an integer in 32..8192")
        for bad in ("missing", self.p("broken.json"), self.p("nowidth.json")):
            with self.subTest(config=bad):
                self.bad(["--config", bad], legal)
        # the configuration is checked before any image
        self.bad(self.pair("missing.png", "l.png", "missing"), "CONFIG=missing")

    def test_points(self):
        line = self.bad(["--point", "kitti-d999"], "POINT=kitti-d999: unknown sweep point (legal: ")
        self.assertIn("quick-", line)

    def test_command_line(self):
        """The script as the Makefile runs it: silent exit 0, or one line on stderr and exit 2."""
        r = subprocess.run([sys.executable, CHECK, "--config", "small", "--left", self.p("l.png"), "--right",
                            self.p("r.png")], capture_output=True, text=True, timeout=30)
        self.assertEqual((r.returncode, r.stdout, r.stderr), (0, "", ""))
        r = subprocess.run([sys.executable, CHECK, "--config", "small", "--left", self.p("truncated.png"), "--right",
                            self.p("r.png")], capture_output=True, text=True, timeout=30)
        self.assertEqual(r.returncode, 2)
        self.assertEqual(r.stderr, f"check_inputs: LEFT={self.p('truncated.png')}: truncated or corrupt PNG "
                                   "(a chunk runs past the end of the file)\n")

    def test_required(self):
        self.bad(["--require", "left,right", "--config", "small"], "set LEFT= and RIGHT= (a stereo pair, PNG or PGM)")
        self.bad(["--require", "left,right", "--left", self.p("l.png"), "--right", ""], "set LEFT= and RIGHT=")
        line = self.bad(["--require", "point", "--point", ""], "set POINT= (legal: ")
        self.assertIn("quick-", line)
        self.bad(["--require", "config"], "set CONFIG= (legal: kitti, ")
        self.bad(["--require", "gt"], "set GT=")
        self.bad(["--require", "colour"], "unknown key 'colour'")
        self.ok("--require", "left,right", "--left", self.p("l.png"), "--right", self.p("r.png"))

    def test_options(self):
        self.bad(["--bogus", "1"], "unknown option")
        self.bad(["--left"], "missing value")
        r = self.run_check("--help")
        self.assertEqual(r.returncode, 0)
        self.assertIn("check_inputs.py", r.stdout)

    # ---- the golden CLI refuses the same images for the same reason ----

    def test_same_reasons_as_golden(self):
        if not os.access(GOLDEN, os.X_OK):
            self.skipTest(f"no {GOLDEN} (make golden)")
        for name in ("notimage.png", "colour.ppm", "truncated.png", "noiend.png", "noidat.png", "bilevel.png",
                     "deep.png", "palette4.png", "truncated.pgm", "deep.pgm", "badheader.pgm"):
            with self.subTest(image=name):
                line = self.bad(self.pair(name, "l.png"), name)
                reason = line.split(f"{name}: ", 1)[1]
                r = subprocess.run([GOLDEN, "dump", "--mode", "ielas", "--config", "small", "--left", self.p(name),
                                    "--right", self.p("l.png"), "--out", self.p("dump")],
                                   capture_output=True, text=True, timeout=60)
                self.assertNotEqual(r.returncode, 0)
                self.assertEqual(len(r.stderr.splitlines()), 1, r.stderr)
                self.assertIn(f"{name}: {reason}", r.stderr)
        for name in ("l.png", "rgb.png", "palette.png", "greyalpha.png", "comment.pgm", "plain.pgm"):
            with self.subTest(good=name):
                r = subprocess.run([GOLDEN, "dump", "--mode", "ielas", "--config", "small", "--left", self.p(name),
                                    "--right", self.p("l.png"), "--out", self.p("dump")],
                                   capture_output=True, text=True, timeout=60)
                self.assertEqual((r.returncode, r.stderr), (0, ""))


if __name__ == "__main__":
    unittest.main()
