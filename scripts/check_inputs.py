#!/usr/bin/env python3
"""Preflight of the Makefile's inputs, run before anything is built or elaborated (Python standard library only).

    check_inputs.py [--left L] [--right R] [--gt G] [--config NAME|FILE.json] [--point NAME] [--require KEYS]

An empty value counts as not given, so the Makefile can pass its variables as they are; --require left,right (or
point, config, gt) makes those keys mandatory. Checks, in this order:
  --config  a name of golden/configs/<name>.json, or a .json file: readable JSON with integer maxWidth (32..8192)
            and maxHeight (16..8192)
  --point   one of `scripts/sweep/grid.py names full` or `names quick`
  --left, --right
            PNG or PGM with 8 bits per sample (grey, or colour that the golden model converts to grey; 1-, 2-, 4- and
            16-bit images are refused, as ielas-golden refuses them), a PNG complete up to its IEND chunk, a binary
            PGM holding all its pixels; both given, both the same size, within 32x16 .. maxWidth x maxHeight of the
            configuration (8192x8192 without one)
  --gt      ground truth as ielas-eval reads it: a .png (8-bit, or 16-bit grey as KITTI) or a grey .pfm, the size of
            the left image
Only headers are read (and a PNG's chunk lengths; a plain P2 PGM is read whole), so a check takes milliseconds.
The first problem is one line on stderr, `check_inputs: ...`, and exit 2; success prints nothing.
"""
import json
import os
import struct
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CONFIG_DIR = os.path.join(ROOT, "golden", "configs")
GRID = os.path.join(ROOT, "scripts", "sweep", "grid.py")
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
MAX_SIDE = 8192  # the largest maxWidth / maxHeight any configuration may have
MIN_W, MIN_H = 32, 16


class Bad(Exception):
    """One input problem; its text is the error line."""


# ---------------------------------------------------------------- configurations and sweep points

def config_names():
    try:
        return sorted(f[:-5] for f in os.listdir(CONFIG_DIR) if f.endswith(".json"))
    except OSError:
        return []


def legal_configs():
    return "legal: " + ", ".join(config_names()) + ", or a .json file"


def config_size(config):
    """(name, maxWidth, maxHeight) of a configuration name or .json file."""
    if config.endswith(".json"):
        path = config
    elif "/" in config or config not in config_names():
        raise Bad(f"CONFIG={config}: unknown configuration ({legal_configs()})")
    else:
        path = os.path.join(CONFIG_DIR, config + ".json")
    try:
        with open(path, encoding="utf-8") as f:
            text = f.read()
    except (OSError, UnicodeDecodeError) as e:
        reason = e.strerror if isinstance(e, OSError) and e.strerror else str(e)
        raise Bad(f"CONFIG={config}: cannot read the configuration file ({reason}; {legal_configs()})")
    try:
        card = json.loads(text)
    except ValueError as e:
        raise Bad(f"CONFIG={config}: malformed JSON ({e}; {legal_configs()})")
    if not isinstance(card, dict):
        raise Bad(f"CONFIG={config}: malformed configuration (not a JSON object; {legal_configs()})")
    size = []
    for key, lo in (("maxWidth", MIN_W), ("maxHeight", MIN_H)):
        v = card.get(key)
        if isinstance(v, bool) or not isinstance(v, int) or not lo <= v <= MAX_SIDE:
            raise Bad(f"CONFIG={config}: malformed configuration ({key} = {json.dumps(v)} is not an integer in "
                      f"{lo}..{MAX_SIDE}; {legal_configs()})")
        size.append(v)
    name = os.path.basename(config)[:-5] if config.endswith(".json") else config
    return name, size[0], size[1]


def point_names():
    """The sweep points, as the Makefile lists them (scripts/sweep/grid.py names full, then quick)."""
    names = []
    for grid in ("full", "quick"):
        r = subprocess.run([sys.executable, GRID, "names", grid], capture_output=True, text=True)
        if r.returncode != 0:
            raise Bad(f"cannot list the sweep points (scripts/sweep/grid.py names {grid} failed)")
        names += r.stdout.split()
    return names


def check_point(point):
    names = point_names()
    if point not in names:
        raise Bad(f"POINT={point}: unknown sweep point (legal: {', '.join(names)})")


# ---------------------------------------------------------------- image headers

def png_header(f):
    """(width, height, bit depth, colour type) from IHDR, after a walk over the chunk lengths that must reach IEND
    (so a truncated file is found without decoding). The reasons are ielas-golden's."""
    corrupt = "truncated or corrupt PNG"
    f.seek(0)
    head = f.read(33)
    if len(head) < 33 or head[12:16] != b"IHDR" or struct.unpack(">I", head[8:12])[0] != 13:
        raise Bad(corrupt + " (no IHDR chunk)")
    w, h, depth, colour = struct.unpack(">IIBB", head[16:26])
    legal = {0: (1, 2, 4, 8, 16), 2: (8, 16), 3: (1, 2, 4, 8), 4: (8, 16), 6: (8, 16)}
    if w == 0 or h == 0 or w > 0x7FFFFFFF or h > 0x7FFFFFFF or depth not in legal.get(colour, ()):
        raise Bad(f"{corrupt} (IHDR: {w}x{h}, bit depth {depth}, colour type {colour})")
    return w, h, depth, colour


def png_walk(f, size):
    corrupt = "truncated or corrupt PNG"
    at, idat = 8, False
    while True:
        if size - at < 12:
            raise Bad(corrupt + " (no IEND chunk)")
        f.seek(at)
        length, ctype = struct.unpack(">I4s", f.read(8))
        if length > 0x7FFFFFFF or size - at - 12 < length:
            raise Bad(corrupt + " (a chunk runs past the end of the file)")
        if ctype == b"IEND":
            break
        idat = idat or ctype == b"IDAT"
        at += 12 + length
    if not idat:
        raise Bad(corrupt + " (no IDAT chunk)")


def pgm_header(f, size, plain):
    """(width, height, maxval, offset of the pixels) of a P5 or P2 file."""
    corrupt = "truncated or corrupt PGM"
    data = f.read(min(size, 1 << 16))
    at = 2
    values = []
    for what in ("width", "height", "maxval"):
        while at < len(data):
            if data[at:at + 1] == b"#":
                while at < len(data) and data[at:at + 1] not in (b"\n", b"\r"):
                    at += 1
            elif data[at:at + 1].isspace():
                at += 1
            else:
                break
        start = at
        while at < len(data) and data[at:at + 1].isdigit() and at - start < 10:
            at += 1
        if at == start or (at < len(data) and not data[at:at + 1].isspace()):
            raise Bad(f"{corrupt} (header: no valid {what})")
        values.append(int(data[start:at]))
    w, h, maxval = values
    if at >= len(data):
        raise Bad(corrupt + " (no pixels)")
    at += 1  # the single whitespace character after maxval
    if w == 0 or h == 0 or maxval == 0 or maxval > 65535:
        raise Bad(f"{corrupt} (header: {w}x{h}, maxval {maxval})")
    if maxval > 255:
        raise Bad(f"16-bit PGM (maxval {maxval}; 8-bit expected)")
    if not plain and size - at < w * h:
        raise Bad(f"truncated PGM ({w}x{h} needs {w * h} bytes of pixels, the file has {size - at})")
    if plain:
        f.seek(at)
        count = len(f.read().split())
        if count < w * h:
            raise Bad(f"truncated or corrupt PGM ({w}x{h} needs {w * h} values, the file has {count})")
    return w, h


def open_image(label, path):
    try:
        f = open(path, "rb")
    except OSError as e:
        raise Bad(f"{label}={path}: cannot read image ({e.strerror})")
    if os.path.isdir(path):
        f.close()
        raise Bad(f"{label}={path}: cannot read image (is a directory)")
    return f


def input_image(label, path):
    """(width, height) of a stereo view that ielas-golden and the harness accept."""
    with open_image(label, path) as f:
        size = os.fstat(f.fileno()).st_size
        magic = f.read(8)
        f.seek(0)
        try:
            if magic == PNG_SIGNATURE:
                w, h, depth, colour = png_header(f)
                if depth != 8:
                    raise Bad(f"{depth}-bit {'palette ' if colour == 3 else ''}PNG (8-bit grey or colour expected)")
                png_walk(f, size)
                return w, h
            if magic[:2] in (b"P2", b"P5"):
                return pgm_header(f, size, magic[:2] == b"P2")
            kind = {b"P1": "a 1-bit PBM", b"P4": "a 1-bit PBM", b"P3": "a PPM", b"P6": "a PPM", b"Pf": "a PFM",
                    b"PF": "a PFM"}.get(magic[:2])
            raise Bad("not a PNG or PGM image" + (f" ({kind})" if kind else ""))
        except Bad as e:
            raise Bad(f"{label}={path}: {e}")


def ground_truth(path):
    """(width, height) of a ground-truth map that ielas-eval reads (by its extension, as ielas-eval does)."""
    ext = os.path.splitext(path)[1].lower()
    if ext not in (".png", ".pfm"):
        raise Bad(f"GT={path}: ground truth must be a .png or .pfm file")
    with open_image("GT", path) as f:
        size = os.fstat(f.fileno()).st_size
        try:
            if ext == ".png":
                if f.read(8) != PNG_SIGNATURE:
                    raise Bad("not a PNG image")
                w, h, depth, colour = png_header(f)
                if depth == 16 and colour != 0:
                    raise Bad("16-bit colour PNG (ground truth: 8-bit, or 16-bit grey)")
                png_walk(f, size)
                return w, h
            head = f.read(256).split(maxsplit=4)
            if head[:1] == [b"PF"]:
                raise Bad("colour PFM (grey Pf expected)")
            try:
                if head[0] != b"Pf" or len(head) < 5:
                    raise ValueError
                w, h, scale = int(head[1]), int(head[2]), float(head[3])
            except ValueError:
                raise Bad("not a grey PFM (Pf) file")
            if w <= 0 or h <= 0 or scale == 0:
                raise Bad(f"corrupt PFM (header: {w}x{h}, scale {scale})")
            if size < 4 * w * h:
                raise Bad(f"truncated PFM ({w}x{h} needs {4 * w * h} bytes of pixels, the file has {size} in all)")
            return w, h
        except Bad as e:
            raise Bad(f"GT={path}: {e}")


# ---------------------------------------------------------------- main

def check_required(require, given):
    for key in [k for k in require.split(",") if k]:
        if key not in ("left", "right", "gt", "config", "point"):
            raise Bad(f"--require {require}: unknown key '{key}' (legal: left, right, gt, config, point)")
        if given.get(key):
            continue
        if key in ("left", "right"):
            raise Bad("set LEFT= and RIGHT= (a stereo pair, PNG or PGM)")
        if key == "config":
            raise Bad(f"set CONFIG= ({legal_configs()})")
        if key == "point":
            raise Bad(f"set POINT= (legal: {', '.join(point_names())})")
        raise Bad("set GT= (a .png or .pfm ground truth)")


def check(left="", right="", gt="", config="", point="", require=""):
    check_required(require, {"left": left, "right": right, "gt": gt, "config": config, "point": point})
    limit, where = (MAX_SIDE, MAX_SIDE), ""
    if config:
        name, max_w, max_h = config_size(config)
        limit, where = (max_w, max_h), f" (configuration {name})"
    if point:
        check_point(point)
    lw, lh = input_image("LEFT", left) if left else (0, 0)
    rw, rh = input_image("RIGHT", right) if right else (0, 0)
    if bool(left) != bool(right):
        raise Bad(f"{'LEFT' if left else 'RIGHT'}= given without {'RIGHT' if left else 'LEFT'}= (give both or neither)")
    if left:
        if (lw, lh) != (rw, rh):
            raise Bad(f"LEFT and RIGHT differ in size: {lw}x{lh} ({left}) vs {rw}x{rh} ({right})")
        if not (MIN_W <= lw <= limit[0] and MIN_H <= lh <= limit[1]):
            raise Bad(f"LEFT={left}: size {lw}x{lh} is outside {MIN_W}x{MIN_H}..{limit[0]}x{limit[1]}{where}")
    if gt:
        gw, gh = ground_truth(gt)
        if left and (gw, gh) != (lw, lh):
            raise Bad(f"GT={gt}: size {gw}x{gh}, but LEFT is {lw}x{lh} (the same size expected)")


def main(argv):
    options = {"--left": "left", "--right": "right", "--gt": "gt", "--config": "config", "--point": "point",
               "--require": "require"}
    values = {}
    args = list(argv[1:])
    while args:
        a = args.pop(0)
        if a in ("-h", "--help"):
            print(__doc__.strip())
            return 0
        key, eq, val = a.partition("=")
        if key not in options or (not eq and not args):
            print(f"check_inputs: unknown option or missing value '{a}' (see --help)", file=sys.stderr)
            return 2
        values[options[key]] = val if eq else args.pop(0)
    try:
        check(**values)
    except Bad as e:
        print(f"check_inputs: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
