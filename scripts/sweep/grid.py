#!/usr/bin/env python3
"""The sweep grids (docs/sweep.md): which points exist, and the `Main config` specs that turn them into JSONs.

    grid.py names full|quick            point names, one per line (the Makefile's list)
    grid.py specs full|quick            NAME:BASE:KEY=VALUE,... specs for `sbt "run config DIR SPEC..."`

A point names its card parameters only; every other value, the SAD lanes among them, comes from ElasParams via
`Main config` (the base configuration's defaults, lanes re-derived), so nothing here is typed twice.
"""
import sys

sys.dont_write_bytecode = True

# resolution -> (base configuration in ElasParams.named, maxWidth, maxHeight); the sizes are for the report only
# (the JSON written by ElasParams is what counts).
RESOLUTIONS = {"kitti": ("kitti", 1242, 376), "tsukuba": ("tsukuba", 640, 480), "small": ("small", 128, 64)}
# The two named configurations, where the window size is varied.
NAMED = {"kitti": 255, "tsukuba": 127}
PARAMETER_SETS = ("robotics", "middlebury")


class Point:
    def __init__(self, grid, resolution, disp_max, stored, window, cycles_per_pixel=1):
        self.grid, self.resolution = grid, resolution
        self.disp_max, self.stored, self.window = disp_max, stored, window
        self.cycles_per_pixel = cycles_per_pixel
        prefix = "quick-" if grid == "quick" else ""
        rate = f"-c{cycles_per_pixel}" if cycles_per_pixel > 1 else ""
        self.name = f"{prefix}{resolution}-d{disp_max}-s{stored}-w{window}{rate}"

    @property
    def base(self):
        return RESOLUTIONS[self.resolution][0]

    def config_name(self, parameter_set="robotics"):
        """The hardware is the robotics configuration; the middlebury twin differs only in parameterSet and is
        used for accuracy (the parameter set changes post-processing, not the card parameters)."""
        return self.name if parameter_set == "robotics" else f"{self.name}-{parameter_set}"

    def spec(self, parameter_set="robotics"):
        kv = f"dispMax={self.disp_max},storedDisparities={self.stored},windowSize={self.window}"
        if self.cycles_per_pixel > 1:
            kv += f",cyclesPerPixel={self.cycles_per_pixel}"
        if parameter_set != "robotics":
            kv += f",parameterSet={parameter_set}"
        return f"{self.config_name(parameter_set)}:{self.base}:{kv}"

    def __repr__(self):
        return self.name


def full():
    """18 main points (resolution x dispMax x storedDisparities at windowSize 5), then windowSize 3 and 7 at the
    two named configurations (storedDisparities 20), then cyclesPerPixel 2, 4, 8 there: 28 points."""
    pts = [Point("full", r, d, s, 5) for r in ("kitti", "tsukuba") for d in (63, 127, 255) for s in (10, 20, 40)]
    pts += [Point("full", r, NAMED[r], 20, w) for r in ("kitti", "tsukuba") for w in (3, 7)]
    pts += [Point("full", r, NAMED[r], 20, 5, c) for r in ("kitti", "tsukuba") for c in (2, 4, 8)]
    return pts


def quick():
    """Small configurations (128x64, dispMax 15 so that Yosys on the whole top stays within minutes) for CI: the
    default window, and the two other window sizes."""
    return [Point("quick", "small", 15, 10, 5), Point("quick", "small", 15, 8, 3), Point("quick", "small", 15, 10, 7)]


def points(grid):
    if grid == "full":
        return full()
    if grid == "quick":
        return quick()
    raise ValueError(f"SWEEP must be full or quick, not '{grid}'")


def by_name(name):
    for g in ("full", "quick"):
        for p in points(g):
            if p.name == name:
                return p
    raise ValueError(f"unknown sweep point '{name}' (see scripts/sweep/grid.py names full|quick)")


def main(argv):
    if len(argv) != 3 or argv[1] not in ("names", "specs"):
        print(__doc__.strip().splitlines()[2], file=sys.stderr)
        return 2
    pts = points(argv[2])
    if argv[1] == "names":
        print("\n".join(p.name for p in pts))
    else:
        print(" ".join(p.spec(s) for p in pts for s in PARAMETER_SETS))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
