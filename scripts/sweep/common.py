"""Shared pieces of the sweep scripts: the results table, hashes, the cycle model, log parsing. Standard library only."""
import csv
import fcntl
import hashlib
import os
import re
import sys
import tempfile

sys.dont_write_bytecode = True

ROOT = os.path.abspath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))
CLOCK_HZ = 200e6  # the reference clock of the fps figures (docs/sweep.md)
BRAM36_BITS = 36 * 1024

# One row per point in docs/sweep/results.csv (build/sweep-quick/results.csv for SWEEP=quick).
COLUMNS = [
    "point", "grid", "resolution", "maxWidth", "maxHeight", "dispMax", "storedDisparities", "windowSize",
    "supportLanes", "denseLanes",
    "status", "reason",
    "config_hash", "design_hash", "generator_hash", "golden_hash", "top_stages",
    "LUT", "FF", "RAMB36E1", "RAMB18E1", "BRAM36eq", "DSP48E1", "LUTRAM_sites", "lut_levels", "bram_check",
    "yosys", "yosys_seconds", "lut_by_unit",
    "gen_memory_bits", "gen_memory_bram36",
    "cycles_per_frame", "cycles_per_pixel", "fps_200MHz", "latency_rows",
    "robotics_bad3", "robotics_d1", "robotics_density",
    "middlebury_bad3", "middlebury_d1", "middlebury_density", "accuracy_pairs",
    "wall_seconds", "date", "commit",
]


def sha256_file(path, h=None):
    own = h is None
    h = h or hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest() if own else h


def config_hash(path):
    """The configuration JSON's bytes (ElasParams writes it deterministically)."""
    return sha256_file(path)[:16]


def tree_hash(paths, base):
    """sha256 over (relative name, contents) of every file, in name order."""
    h = hashlib.sha256()
    for p in sorted(paths):
        h.update(os.path.relpath(p, base).encode() + b"\0")
        sha256_file(p, h)
        h.update(b"\0")
    return h.hexdigest()[:16]


def design_hash(verilog_dir):
    """The emitted design: every .sv/.v file of the Verilog directory (lint.vlt and the like excluded)."""
    files = [os.path.join(verilog_dir, f) for f in os.listdir(verilog_dir) if f.endswith((".sv", ".v"))]
    if not files:
        raise ValueError(f"no Verilog in {verilog_dir}")
    return tree_hash(files, verilog_dir)


def generator_hash(root=ROOT):
    """The generator's sources (Scala, build definition). Unchanged sources emit unchanged Verilog, so a rerun can
    skip a point without elaborating it; when they change, the point is elaborated and its Verilog hash decides."""
    files = [os.path.join(root, "build.sbt"), os.path.join(root, "project", "build.properties")]
    for d, _, fs in os.walk(os.path.join(root, "src", "main")):
        files += [os.path.join(d, f) for f in fs if f.endswith((".scala", ".java"))]
    return tree_hash([f for f in files if os.path.exists(f)], root)


def cycle_model(width, height, latency_rows, slack, clock_hz=CLOCK_HZ, cycles_per_pixel=1):
    """One frame of W x H pixels at one pixel every cyclesPerPixel clocks, no input gaps, no back-pressure: the
    no-stall bound cyclesPerPixel x (N + latencyRows * W + c) cycles with N = W * H (docs/sweep.md, "Cycle model")."""
    n = width * height
    cycles = cycles_per_pixel * (n + latency_rows * width + slack)
    return {"cycles_per_frame": cycles, "cycles_per_pixel": round(cycles / n, 4),
            "fps_200MHz": round(clock_hz / cycles, 1), "latency_rows": latency_rows}


def memory_bits_from_log(text):
    """The generator's memory summary, as `make verilog` prints it: '  total N bits (...)'."""
    m = re.findall(r"^\s*total (\d+) bits", text, re.M)
    return int(m[-1]) if m else None


def elaboration_error(text):
    """The reason an elaboration failed: the generator's `error: ...` line (a require message), else the last
    error-looking line."""
    for pattern in (r"^error: (.*)$", r"^\[error\] (?!\(|Total time|nonzero exit)(.*)$", r"^.*(?:Exception|Error)[: ].*$"):
        m = re.findall(pattern, text, re.M)
        if m:
            return m[0].strip() if isinstance(m[0], str) else m[0]
    lines = [l for l in text.strip().splitlines() if l.strip()]
    return lines[-1].strip() if lines else "no output"


class Results:
    """results.csv with one row per point, updated under a lock (points run in parallel under make -j)."""

    def __init__(self, path, order=None):
        self.path = path
        self.order = order or []

    def _lock(self):
        os.makedirs(os.path.dirname(os.path.abspath(self.path)), exist_ok=True)
        # The lock lives outside the (committed) results directory.
        locks = os.path.join(tempfile.gettempdir(), "ielas-sweep-locks")
        os.makedirs(locks, exist_ok=True)
        name = hashlib.sha256(os.path.abspath(self.path).encode()).hexdigest()[:24]
        fh = open(os.path.join(locks, name + ".lock"), "w")
        fcntl.flock(fh, fcntl.LOCK_EX)
        return fh

    def read(self):
        if not os.path.exists(self.path):
            return []
        with open(self.path, newline="") as fh:
            return list(csv.DictReader(fh))

    def find(self, point):
        for row in self.read():
            if row["point"] == point:
                return row
        return None

    def upsert(self, row):
        lock = self._lock()
        try:
            rows = [r for r in self.read() if r["point"] != row["point"]] + [row]
            rank = {n: i for i, n in enumerate(self.order)}
            rows.sort(key=lambda r: (rank.get(r["point"], len(rank)), r["point"]))
            tmp = f"{self.path}.{os.getpid()}.tmp"
            with open(tmp, "w", newline="") as fh:
                w = csv.DictWriter(fh, fieldnames=COLUMNS, extrasaction="ignore", lineterminator="\n")
                w.writeheader()
                for r in rows:
                    w.writerow({c: r.get(c, "") for c in COLUMNS})
            os.replace(tmp, self.path)
        finally:
            lock.close()


def up_to_date(row, cfg_hash, gen_hash=None, des_hash=None, gold_hash=None):
    """A recorded point needs no rerun when its configuration, its design (by Verilog hash, or by generator-source
    hash before elaborating) and the golden model that scored it are the ones recorded."""
    if not row or row.get("config_hash") != cfg_hash or row.get("golden_hash") != gold_hash:
        return False
    if des_hash is not None:
        return row.get("design_hash") == des_hash
    return gen_hash is not None and row.get("generator_hash") == gen_hash
